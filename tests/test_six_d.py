"""6-D data as first-class (issue 28): the weights of positions and orientations are settings
(--position-sigma, --orientation-sigma), and evaluate reports the held-out orientation error
beside the nominal robot's.  Real data: ipa UR10 series B (positions and orientations)."""
import json

import numpy as np
import pytest

from refusals import assert_refused, copy_inputs, run_ok
from robocal.io import datasets
from robocal.methods import make_method
from robocal.methods.evaluation import orientation_stats, position_scores


@pytest.fixture(scope="module")
def series_b():
    dataset = datasets.ipa_ur10("B")
    chain, obs = dataset.chain, dataset.observations
    order = np.random.default_rng(0).permutation(obs.n_poses)
    return chain, obs.subset(np.sort(order[:300])), obs.subset(np.sort(order[300:700]))


@pytest.mark.filterwarnings("ignore")
def test_an_orientation_weighted_calibration_reports_its_held_out_orientation_error(series_b):
    chain, train, test = series_b
    fitted = make_method("kinematic", orientation_sigma=0.01).fit(chain, train)
    _, _, stats = position_scores(fitted, test, chain.name)
    assert {"rot_mean_deg", "rot_rms_deg", "rot_max_deg"} <= set(stats)
    assert stats["rot_rms_deg"] < stats["nominal"]["rot_rms_deg"]
    assert stats["rot_mean_deg"] <= stats["rot_rms_deg"] <= stats["rot_max_deg"]


def test_orientation_stats_measure_the_angle_between_the_frames():
    from scipy.spatial.transform import Rotation

    measured = Rotation.random(50, random_state=1)
    turned = measured * Rotation.from_rotvec(np.tile([0.0, 0.0, np.radians(0.5)], (50, 1)))
    poses = np.tile(np.eye(4), (50, 1, 1))
    poses[:, :3, :3] = turned.as_matrix()
    stats = orientation_stats(poses, measured.as_matrix())
    assert abs(stats["rot_mean_deg"] - 0.5) < 1e-9 and abs(stats["rot_max_deg"] - 0.5) < 1e-9


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("sixd")
    run_ok("simulate", "ur5", "--n", "40", "--orientation", "--out", root / "meas.csv")
    return root


def test_the_weights_are_options_of_calibrate_and_evaluate_reports_orientations(folder, tmp_path):
    run_ok("calibrate", "ur5", folder / "meas.csv", "--position-sigma", "0.05", "--orientation-sigma", "0.02",
           "--out", tmp_path / "m.json")
    result = json.loads(run_ok("evaluate", tmp_path / "m.json", folder / "meas.csv", "--json").output)
    assert "rot_rms_deg" in result and "rot_rms_deg" in result["nominal"]


@pytest.mark.parametrize("args, says", [
    ("calibrate ur5 meas.csv --orientation-sigma 0 --out m.json", "--orientation-sigma"),
    ("calibrate ur5 meas.csv --position-sigma -1 --out m.json", "--position-sigma"),
])
def test_weights_that_are_not_standard_deviations_are_refused(args, says, folder, tmp_path, monkeypatch):
    before = copy_inputs(folder, tmp_path, monkeypatch)
    assert_refused(args.split(), says, tmp_path, before)
