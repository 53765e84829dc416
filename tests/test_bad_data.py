"""Data that used to give a silent wrong answer: each is refused with one line that names the
cause, or (gross outliers) handled by the robust loss that lists them."""
import warnings
from dataclasses import replace

import numpy as np
import pytest

from robocal.errors import FileFormatError, InputError
from robocal.estimation.calibration import KinematicCalibration, OutlierError, OutlierWarning
from robocal.io.datasets import ipa_ur10, mukca, ur5_tsinghua
from robocal.io.fixtures import Fixture, read_fixture
from robocal.io.library import builtin
from robocal.io.observations import observations, read_observations
from robocal.io.tables import Measurements, write_measurements
from robocal.methods import KinematicMethod


# ----------------------------------------------------------------------- gross outliers
@pytest.fixture(scope="module")
def ur5_split():
    """The real UR5 data (mm, deg) as observations, split into 500 training and 500 test poses,
    and the held-out mean error of the clean plain fit."""
    dataset = ur5_tsinghua()
    chain, obs = dataset.chain, dataset.observations
    order = np.random.default_rng(0).permutation(obs.n_poses)
    train, test = obs.subset(np.sort(order[:500])), obs.subset(np.sort(order[500:]))
    clean = KinematicCalibration().fit(chain, train.joints, train.positions)
    return chain, train, test, _held_out(clean, test)


def _held_out(calibration, test):
    return float(np.mean(np.linalg.norm(test.positions - calibration.predict(test.joints), axis=1)))


def _corrupted(positions, count, seed):
    """``count`` rows with x shifted by 50-500 mm either way; returns (positions, sorted rows)."""
    rng = np.random.default_rng(seed)
    bad = np.sort(rng.choice(len(positions), count, replace=False))
    positions = positions.copy()
    positions[bad, 0] += rng.uniform(50.0, 500.0, count) * rng.choice([-1.0, 1.0], count)
    return positions, bad


@pytest.mark.parametrize("count", [1, 5, 25])  # 25 of 500: 5 % of the rows
def test_robust_fit_gets_past_gross_outliers_and_lists_them(ur5_split, count):
    chain, train, test, clean_error = ur5_split
    positions, bad = _corrupted(train.positions, count, seed=count)
    for loss in ("huber", "soft_l1"):
        robust = KinematicCalibration(loss=loss).fit(chain, train.joints, positions)
        assert robust.result_.outliers == tuple(bad)
        assert _held_out(robust, test) < 1.1 * clean_error


@pytest.mark.parametrize("count", [1, 5, 25])
def test_plain_fit_names_the_outliers(ur5_split, count):
    chain, train, _, _ = ur5_split
    positions, bad = _corrupted(train.positions, count, seed=count)
    with pytest.raises(OutlierError, match="--loss huber") as caught:
        KinematicCalibration().fit(chain, train.joints, positions)
    assert sorted(caught.value.poses) == list(bad)
    assert caught.value.inlier_rms < 0.2
    shown = sorted(caught.value.poses[:10])
    assert f"{shown[0]}" in str(caught.value) and "0-based" in str(caught.value)


def test_methods_name_the_outliers_as_file_rows(ur5_split):
    chain, train, _, _ = ur5_split
    positions, bad = _corrupted(train.positions, 5, seed=5)
    data = replace(train, positions=positions, path="ur5.csv")
    with pytest.raises(OutlierError) as caught:
        KinematicMethod().fit(chain, data)
    message = str(caught.value)
    assert "of ur5.csv" in message and "0-based" not in message
    for row in train.rows[bad]:
        assert str(row) in message
    # The robust loss goes through and records the same rows.
    method = KinematicMethod(loss="huber").fit(chain, data)
    assert method.record_.calibration.outlier_rows == tuple(int(r) for r in train.rows[bad])


def test_wrong_robot_is_still_refused_with_a_robust_loss(ur5_split):
    _, train, _, _ = ur5_split
    other = builtin("kr150-2")
    with pytest.raises(InputError) as caught:
        KinematicCalibration(loss="huber").fit(other, train.joints, train.positions)
    assert not isinstance(caught.value, OutlierError)


# ------------------------------------------------------------------ Python API: joint width
def test_joint_conversions_refuse_the_wrong_width():
    from robocal.kinematics.compliant import with_compliance

    robot = builtin("ur5")
    compliant, _ = with_compliance(robot, np.zeros((3, 6)), None)
    for chain in (robot, compliant):
        for convert in (chain.joints_from_file, chain.joints_to_file):
            with pytest.raises(InputError, match=f"7 joint values for the 6-joint robot '{robot.name}'"):
                convert([[0] * 7])
            with pytest.raises(InputError, match="5 joint values"):
                convert([0] * 5)
            with pytest.raises(InputError, match="one number"):
                convert(3.0)
            assert convert(np.zeros((2, 4, 6))).shape == (2, 4, 6)
            assert convert(np.zeros((0, 6))).shape == (0, 6)
    assert np.allclose(robot.joints_from_file([180.0] * 6), np.pi)


# ------------------------------------------------------------- units and joint limits
@pytest.mark.parametrize("factor, unit", [(1e-3, "metres"), (1 / 25.4, "inches"), (0.1, "cm"), (1e3, "micrometres")])
def test_positions_in_another_length_unit_are_refused(tmp_path, factor, unit):
    dataset = ur5_tsinghua()
    chain, data = dataset.chain, dataset.measurements  # written back as a file: file units
    scaled = replace(data, positions=data.positions * factor, extra={})
    path = write_measurements(tmp_path / "ur5.csv", scaled)
    with pytest.raises(InputError, match=f"spread .* where the model of .* spreads 259 mm: they look like {unit}; "
                                         "give x, y, z in mm"):
        read_observations(path, chain)


def test_a_robot_file_in_metres_is_refused():
    dataset = ur5_tsinghua()
    chain, data = dataset.chain, dataset.measurements
    in_metres = chain.replace(a=chain.a / 1000, d=chain.d / 1000)
    with pytest.raises(InputError, match="reaches at most 0.8.* robot file looks like metres"):
        observations(in_metres, data)


def test_a_fixture_in_metres_is_refused(tmp_path):
    path = tmp_path / "plate.toml"
    path.write_text('[sockets]\nA = [0.0, 0.0, 0.0]\nB = [0.15, 0.0, 0.0]\nC = [0.0, 0.12, 0.0]\n')
    with pytest.raises(FileFormatError, match="plate.toml: .* socket spacing: largest 0.192, .* look like metres; "
                                              "give them in mm"):
        read_fixture(path)
    Fixture("mm", {"A": [0, 0, 0], "B": [1.5, 0, 0]})  # a small fixture in mm is still one


def test_joint_values_beyond_the_limits_are_refused_unless_accepted(tmp_path):
    chain = builtin("kr150-2")  # A1 within +-185 deg
    rng = np.random.default_rng(0)
    q = chain.joints_to_file(chain.random_configurations(60, rng))
    q[16, 0] = 500.0
    data = Measurements(path="kr.csv", joints=q, positions=chain.fk_positions(chain.joints_from_file(q)))
    with pytest.raises(InputError, match=r"kr.csv row 18: q1 = 500 deg lies beyond joint 1's limits -185 to 185 deg "
                                         r"of the robot .*beyond_limits=True"):
        observations(chain, data)
    assert observations(chain, data, beyond_limits=True).n_poses == 60
    # A reading a little past a limit is a rounded data sheet, not a wrong row.
    q[16, 0], q[20, 2] = 185.4, chain.joints_to_file(chain.lower)[2] - 0.4
    assert observations(chain, replace(data, joints=q)).n_poses == 60
    q[[3, 40], 5] = chain.joints_to_file(chain.upper)[5] + 0.6
    with pytest.raises(InputError, match="rows 5 and 42: q6 = .* \\(and others\\) lies beyond joint 6's"):
        observations(chain, replace(data, joints=q))
    path = write_measurements(tmp_path / "kr.csv", replace(data, joints=q))
    with pytest.raises(InputError, match="kr.csv rows 5 and 42: q6"):
        read_observations(path, chain)
    assert read_observations(path, chain, beyond_limits=True).n_poses == 60


def test_the_packaged_real_data_pass_every_check():
    # The loaders convert through observations(), which runs every check.
    for dataset in (ur5_tsinghua(), ipa_ur10("A"), ipa_ur10("B")):
        assert dataset.observations.n_poses == dataset.measurements.n_poses
    for unit in ("panda_1", "panda_2", "panda_3"):
        dataset = mukca(unit)
        assert dataset.observations.kind == "constraint"
        assert observations(dataset.chain, dataset.measurements, dataset.fixture).kind == "constraint"


def test_a_plain_fit_that_goes_through_warns_about_a_pose_far_off(ur5_split):
    chain, train, _, _ = ur5_split
    positions = train.positions.copy()
    positions[7, 0] += 20.0  # the fit passes every check, but the held-out error goes 0.104 -> 0.178 mm
    with pytest.warns(OutlierWarning, match=r"pose 7 \(0-based\) misses by 1\d\.\d mm .*--loss huber"):
        KinematicCalibration().fit(chain, train.joints, positions)
    data = replace(train, positions=positions, path="ur5.csv")
    with pytest.warns(OutlierWarning, match=f"row {train.rows[7]} of ur5.csv misses by"):
        KinematicMethod().fit(chain, data)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        KinematicMethod().fit(chain, train)  # the clean data: no warning
        KinematicMethod(loss="huber").fit(chain, data)  # the robust fit lists the pose instead


def test_estimator_settings_and_shapes_are_refused():
    """Settings that returned the start unfitted or were taken as truthy, arrays of the wrong
    shape that raised numpy errors, and a missing fixture: each an InputError naming it."""
    from robocal.estimation import ConstraintCalibration

    chain = builtin("ur5")
    q = chain.random_configurations(60, rng=0)
    p = chain.fk_positions(q)
    for settings, arrays, message in (({"max_iterations": 0}, {}, "max_iterations"),
                                      ({"loss": "huber", "f_scale": -1}, {}, "f_scale"),
                                      ({"register": "maybe"}, {}, "register"),
                                      ({}, {"orientations": np.zeros((60, 3))}, r"\(N, 3, 3\)"),
                                      ({}, {"sigmas": np.ones(60)}, "sigmas")):
        with pytest.raises(InputError, match=message):
            KinematicCalibration(**settings).fit(chain, q, p, **arrays)
    with pytest.raises(InputError, match="max_iterations"):
        ConstraintCalibration(max_iterations=-1).fit(chain, q, ["P"] * 60, ["A"] * 60, None)
    with pytest.raises(InputError, match="fixture must be a Fixture"):
        ConstraintCalibration().fit(chain, q, ["P"] * 60, ["A"] * 60, None)


def test_read_observations_takes_a_robot_name_and_refuses_what_is_no_robot(tmp_path):
    chain = builtin("ur5")
    q = chain.random_configurations(30, rng=1)
    path = write_measurements(tmp_path / "m.csv",
                              Measurements("", chain.joints_to_file(q), positions=chain.fk_positions(q)))
    assert read_observations(path, "ur5").n_poses == 30
    with pytest.raises(InputError, match="must be a Chain"):
        read_observations(path, None)
