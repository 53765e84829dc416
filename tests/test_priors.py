"""Tolerance priors (maximum a posteriori calibration) and the one data check every method
meets: a parameter the poses cannot see is held by its prior instead of sliding or being
refused; another robot's data, or data in other units, are refused by every method in one
line with nothing written; the real data robocal ships are not."""
import warnings

import numpy as np
import pytest

from robocal.errors import InputError
from robocal.estimation import ConstraintCalibration, KinematicCalibration
from robocal.io.datasets import ipa_ur10, mukca, ur5_tsinghua
from robocal.io.library import builtin
from robocal.io.robot_file import chain_from_dict, chain_to_dict
from robocal.kinematics.tolerances import default_tolerances, tolerances_of
from robocal.simulation import make_true_robot, uniform_joints
from robocal.spatial import compose_pose
from refusals import assert_refused, copy_inputs

SIX_AXIS = ("ur5", "ur10", "kr150-2", "irb120", "fanuc-r2000ic-165f")
SEVEN_AXIS = ("panda", "iiwa14")


def _measured(name, count=60, seed=1):
    chain = builtin(name)
    truth = make_true_robot(chain, "typical", seed=seed)
    q = uniform_joints(chain, count, np.random.default_rng(seed))
    return chain, q, truth.measure(q, np.random.default_rng(seed + 1))


def test_tolerances_scale_with_the_robot_and_read_from_the_robot_file():
    small, large = default_tolerances(builtin("ur5")), default_tolerances(builtin("kr150-2"))
    assert large.length == pytest.approx(1.0, rel=1e-3) and small.length < 0.5 * large.length
    assert small.joint_zero == large.joint_zero
    doc = chain_to_dict(builtin("ur5"))
    doc["tolerances"] = {"length_mm": 2.0, "joint_zero_deg": 0.5}
    chain = chain_from_dict(doc)
    told = tolerances_of(chain)
    assert told.length == 2.0 and told.joint_zero == pytest.approx(np.radians(0.5))
    assert told.axis_angle == small.axis_angle  # the keys not given keep their defaults
    assert tolerances_of(chain, 3.0).length == 6.0
    assert chain_from_dict(chain_to_dict(chain)).tolerances == chain.tolerances
    doc["tolerances"] = {"length": 2.0}
    with pytest.raises(InputError, match="unknown key 'length'"):
        chain_from_dict(doc)


def test_tolerances_are_the_arms_whatever_tool_a_registration_gives_it():
    # Registration gives the start of a calibration the tool the data ask for: another robot's
    # data (a UR10's ISO cubes fitted as a UR5's) asked for a 121 m one.
    ur5 = builtin("ur5")
    for tool in ([0.0, 0.0, 150.0], [-25.9, -100.2, 121121.1]):
        assert default_tolerances(ur5.replace(tool=compose_pose(tool, np.zeros(3)))) == default_tolerances(ur5)


def test_another_real_robots_data_that_register_with_a_long_tool_are_refused():
    dataset = ipa_ur10("D")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(InputError, match="not this robot's"):
            KinematicCalibration("full").fit(builtin("ur5"), dataset.observations.joints,
                                             dataset.observations.positions)


def test_a_parameter_the_poses_barely_see_is_held_by_its_prior_not_refused():
    # Position-only data with the TCP 2 mm off the last axis: the last joint's offset and the
    # angles about it barely move the TCP.  Plain least squares lets them take up noise; under
    # the tolerances they stay within their prior's spread and the fit is accepted.
    chain = builtin("kr150-2").replace(tool=compose_pose([2.0, 0.0, 150.0], np.zeros(3)))
    truth = make_true_robot(chain, "typical", seed=3)
    rng = np.random.default_rng(3)
    q = uniform_joints(chain, 40, rng)
    measured = truth.measure(q, rng)
    result = KinematicCalibration("full").fit(chain, q, measured).result_
    assert result.held_by_prior, "some parameter should be barely seen by these poses"
    for name in result.held_by_prior:
        k = result.names.index(name)
        assert abs(result.values[k]) <= result.prior_std[k], (name, result.values[k], result.prior_std[k])
        assert result.std_errors[k] <= result.prior_std[k]
    # Where the data do see a parameter, its share is high and the prior changes nothing visible.
    assert max(result.data_share) > 0.99


def test_a_compliance_gravity_barely_loads_stays_within_its_prior():
    chain, q, measured = _measured("kr150-2", count=80, seed=4)
    result = KinematicCalibration("full+compliance").fit(chain, q, measured).result_
    for name in (n for n in result.names if n.startswith("compliance")):
        k = result.names.index(name)
        assert abs(result.values[k]) <= 3 * result.prior_std[k], name


@pytest.mark.parametrize("data", SIX_AXIS + SEVEN_AXIS)
def test_every_builtin_robots_data_are_refused_as_any_other_builtin_robot(data):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, q, measured = _measured(data)
        for other in (SIX_AXIS if data in SIX_AXIS else SEVEN_AXIS):
            chain = builtin(other)
            if other == data:
                KinematicCalibration("full").fit(chain, q, measured)
                continue
            with pytest.raises(InputError, match="not this robot's"):
                KinematicCalibration("full").fit(chain, q, measured)


@pytest.mark.slow
@pytest.mark.parametrize("group", [SIX_AXIS, SEVEN_AXIS], ids=["six axes", "seven axes"])
def test_every_builtin_robots_socket_data_are_refused_as_any_other_builtin_robot(group):
    from robocal.io.fixtures import read_fixture
    from robocal.simulation.sampling import socket_plan

    plate = read_fixture(__import__("pathlib").Path(__file__).resolve().parents[1] / "examples" / "plate-fixture.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for data in group:
            plan = socket_plan(make_true_robot(builtin(data), "typical", seed=1), plate, 3, 8, rng=1)
            for other in group:
                fit = lambda other=other, plan=plan: ConstraintCalibration().fit(  # noqa: E731
                    builtin(other), plan.joints, plan.fixture_ids, plan.socket_ids, plate)
                if other == data:
                    fit()
                    continue
                with pytest.raises(InputError):  # not this robot's, or its socket distances cannot be
                    fit()


@pytest.mark.slow
def test_the_shipped_real_data_pass_the_check_and_map_keeps_their_held_out_error():
    # Random halves; the MAP fit's held-out mean within 1 % of plain least squares.
    for dataset in (ur5_tsinghua(), ipa_ur10("A"), ipa_ur10("B")):
        chain, q, p = dataset.chain, dataset.observations.joints, dataset.observations.positions
        order = np.random.default_rng(0).permutation(len(q))[:1200]
        train, test = order[:600], order[600:]
        errors = []
        for prior in ("tolerances", "none"):
            cal = KinematicCalibration("full", prior=prior).fit(chain, q[train], p[train])
            errors.append(np.linalg.norm(p[test] - cal.predict(q[test]), axis=1).mean())
        assert errors[0] <= 1.01 * errors[1], (chain.name, errors)
    for unit in ("panda_1", "panda_2", "panda_3"):
        dataset = mukca(unit)
        sockets = dataset.observations
        ConstraintCalibration(gains=True).fit(dataset.chain, sockets.joints, sockets.placement, sockets.socket,
                                              sockets.fixture)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    root = tmp_path_factory.mktemp("priors")
    runner = CliRunner()
    plate = str(__import__("pathlib").Path(__file__).resolve().parents[1] / "examples" / "plate-fixture.toml")
    for args in (["simulate", "ur10", "--n", "60", "--out", str(root / "ur10.csv")],
                 ["simulate", "kr150-2", "--sampling", "sockets", "--fixture", plate, "--placements", "3",
                  "--per-socket", "8", "--out", str(root / "kr_sockets.csv")],
                 ["simulate", "ur5", "--n", "60", "--out", str(root / "ur5.csv")]):
        assert runner.invoke(app, args).exit_code == 0
    lines = (root / "ur5.csv").read_text().splitlines()
    header = lines[0].split(",")
    columns = [header.index(c) for c in ("x", "y", "z")]
    for k in range(3, 8):  # five rows in metres among millimetres
        cells = lines[k].split(",")
        for c in columns:
            cells[c] = repr(float(cells[c]) / 1000.0)
        lines[k] = ",".join(cells)
    (root / "ur5_five_in_metres.csv").write_text("\n".join(lines) + "\n")
    return root, plate


@pytest.mark.parametrize("method", ["kinematic", "kriging", "hybrid", "ann"])
def test_every_method_refuses_another_robots_data_in_one_line(inputs, tmp_path, monkeypatch, method):
    root, _ = inputs
    before = copy_inputs(root, tmp_path, monkeypatch)
    extra = ["--generations", "5"] if method == "ann" else []
    assert_refused(["calibrate", "ur5", str(tmp_path / "ur10.csv"), "--method", method, "--out",
                    str(tmp_path / "model.json"), *extra], "not this robot's", tmp_path, before)


def test_the_constraint_method_refuses_another_robots_sockets_in_one_line(inputs, tmp_path, monkeypatch):
    root, plate = inputs
    before = copy_inputs(root, tmp_path, monkeypatch)
    assert_refused(["calibrate", "ur5", str(tmp_path / "kr_sockets.csv"), "--method", "constraint", "--fixture",
                    plate, "--out", str(tmp_path / "model.json")], "not this robot's", tmp_path, before)


def test_kriging_refuses_rows_in_metres_naming_them(inputs, tmp_path, monkeypatch):
    root, _ = inputs
    before = copy_inputs(root, tmp_path, monkeypatch)
    assert_refused(["calibrate", "ur5", str(tmp_path / "ur5_five_in_metres.csv"), "--method", "kriging", "--out",
                    str(tmp_path / "model.json")], "not this robot's positions in mm", tmp_path, before)


@pytest.mark.slow
def test_a_model_predicted_worse_than_the_nominal_robot_is_refused_unless_accepted(inputs, tmp_path, monkeypatch):
    # Kriging over the TCP position from 60 poses spread over a UR5's whole joint space.
    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    root, _ = inputs
    before = copy_inputs(root, tmp_path, monkeypatch)
    args = ["calibrate", "ur5", str(tmp_path / "ur5.csv"), "--method", "kriging", "--out", str(tmp_path / "model.json")]
    assert_refused(args, "--accept-extrapolation", tmp_path, before)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        done = CliRunner().invoke(app, args + ["--accept-extrapolation", "--json"])
    assert done.exit_code == 0, done.output
    predicted = __import__("json").loads(done.stdout)["predicted_error"]
    assert predicted["mean_mm"] > predicted["nominal_mean_mm"]


def test_re_registration_refuses_another_robots_poses_in_one_line(inputs, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    root, _ = inputs
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert CliRunner().invoke(app, ["calibrate", "ur5", str(root / "ur5.csv"), "--out",
                                        str(root / "ur5_model.json")]).exit_code == 0
    before = copy_inputs(root, tmp_path, monkeypatch)
    assert_refused(["calibrate", str(tmp_path / "ur5_model.json"), str(tmp_path / "ur10.csv"), "--method", "frames",
                    "--out", str(tmp_path / "moved.json")], "not this robot's", tmp_path, before)
