"""Inverse kinematics: closed forms, the numerical solver and solve_ik's choices."""
import numpy as np
import pytest

from robocal.errors import InputError
from robocal.io.library import load_robot
from robocal.kinematics import Chain, to_mdh, to_poe
from robocal.kinematics.ik import (
    OffsetWrist,
    SphericalWrist,
    closed_form,
    ik_all,
    solve_ik,
    solve_numeric,
)
from robocal.spatial import make_transform, rpy_to_matrix, so3_log

SIX_AXIS = ["kr150-2", "irb120", "fanuc-r2000ic-165f", "ur5", "ur10"]


def wrapped(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


def pose_errors(chain, q, targets):
    """Position (mm) and orientation (rad) distance of FK(q) from targets."""
    poses = chain.fk(q)
    position = np.linalg.norm(poses[:, :3, 3] - targets[:, :3, 3], axis=1)
    rotation = so3_log(poses[:, :3, :3] @ np.swapaxes(targets[:, :3, :3], 1, 2))
    return position, np.linalg.norm(rotation, axis=1)


def perturbed(chain, seed):
    """The chain with random 1 mm / 0.1 deg deviations (1 sigma) of every link parameter."""
    rng = np.random.default_rng(seed)
    names = chain.parameter_names(("links",))
    sigma = np.array([np.radians(0.1) if chain.is_angular(name) else 1.0 for name in names])
    return chain.perturbed(names, rng.normal(0.0, sigma))


def assert_all_branches_exact(chain, count, seed):
    q = chain.random_configurations(count, seed)
    targets = chain.fk(q)
    branches, valid = ik_all(chain, targets)
    assert branches.shape == (count, 8, chain.n_joints) and valid.shape == (count, 8)
    assert np.all(np.isnan(branches[~valid]))
    assert chain.within_limits(branches[valid]).all()
    position, orientation = pose_errors(chain, branches[valid], np.repeat(targets, 8, axis=0)[valid.ravel()])
    assert position.max() < 1e-6 and orientation.max() < 1e-8
    # The configuration the target came from is one of the branches (up to whole turns).
    distance = np.abs(wrapped(branches - q[:, None, :])).max(axis=2)
    assert np.all(np.nanmin(np.where(valid, distance, np.inf), axis=1) < 1e-6)


# --------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("name", SIX_AXIS)
def test_closed_form_reproduces_every_branch(name):
    chain = load_robot(name)
    solver = closed_form(chain)
    assert solver.exact
    assert isinstance(solver, OffsetWrist if name.startswith("ur") else SphericalWrist)
    assert_all_branches_exact(chain, 10_000, seed=1)


def test_closed_form_does_not_depend_on_conventions_frames_or_joint_map():
    """The same KR150-2 as MDH and POE, with a base, a tool, flipped joint signs and a
    J2/J3 coupling, is solved exactly: the closed form works from the geometry alone."""
    kr = load_robot("kr150-2")
    base = make_transform(rpy_to_matrix([0.1, -0.2, 0.3]), [100.0, -50.0, 400.0])
    tool = make_transform(rpy_to_matrix([0.3, 0.2, -0.1]), [10.0, 20.0, 150.0])
    coupling = np.diag([1.0, -1.0, 1.0, 1.0, -1.0, 1.0])
    coupling[2, 1] = 1.0  # q_model3 = q3 + q2, as FANUC's J3
    for chain in (to_mdh(kr), to_poe(kr)):
        chain = chain.replace(base=base, tool=tool, joint_map=chain.joint_map @ coupling,
                              lower=np.full(6, -np.pi), upper=np.full(6, np.pi))
        assert closed_form(chain).exact
        assert_all_branches_exact(chain, 2000, seed=2)


def test_closed_form_with_oblique_axes():
    """Axis 1 not perpendicular to axis 2 and a non-orthogonal wrist (the general wrist
    solution, not the mirror shortcut of orthogonal wrists)."""
    tilt = np.radians(10.0)
    axis2 = np.array([0.0, np.cos(tilt), np.sin(tilt)])
    centre = np.array([900.0, 40.0, 1600.0])
    w4 = np.array([1.0, 0.0, 0.0])
    w5 = np.array([np.cos(np.radians(65.0)), np.sin(np.radians(65.0)), 0.0])  # 65 deg from w4
    w6 = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    chain = Chain(
        "oblique", "poe", ("revolute",) * 6, theta=np.radians([5, -10, 20, 0, 30, -40]),
        axes=[[0.0, 0.0, 1.0], axis2, -axis2, w4, w5, w6],
        points=[[0.0, 0.0, 0.0], [300.0, 0.0, 700.0], [300.0, 0.0, 1800.0], centre, centre, centre],
        home=make_transform(rpy_to_matrix([0.2, 0.4, -0.3]), centre + [200.0, 30.0, -50.0]),
    )
    solver = closed_form(chain)
    assert isinstance(solver, SphericalWrist) and solver.exact and not solver.orthogonal
    assert_all_branches_exact(chain, 2000, seed=3)


def test_closed_form_ur_with_frames_and_signs():
    ur = load_robot("ur10")
    chain = ur.replace(
        base=make_transform(rpy_to_matrix([np.pi, 0.0, 0.5]), [0.0, 0.0, 1200.0]),
        tool=make_transform(rpy_to_matrix([0.0, 0.5, 0.0]), [0.0, 40.0, 120.0]),
        joint_map=np.diag([-1.0, 1.0, -1.0, 1.0, 1.0, -1.0]),
        theta=ur.theta + np.radians([10, -20, 30, 0, 15, 90]),
    )
    assert isinstance(closed_form(chain), OffsetWrist)
    assert_all_branches_exact(chain, 2000, seed=4)


def test_no_closed_form_says_why():
    with pytest.raises(InputError, match="6 revolute joints"):
        closed_form(load_robot("panda"))
    # A KR150-2 with its wrist offset by 60 mm fits neither structure.
    kr = load_robot("kr150-2")
    bent = kr.replace(a=kr.a + np.array([0.0, 0.0, 0.0, 60.0, 0.0, 0.0]))
    with pytest.raises(InputError, match="axes 4, 5 and 6 do not meet") as error:
        closed_form(bent)
    assert "numerical solver" in str(error.value)


# ---------------------------------------------------------------------- numerical solver
@pytest.mark.parametrize("name", SIX_AXIS)
def test_numerical_ik_on_a_perturbed_robot(name):
    nominal = load_robot(name)
    chain = perturbed(nominal, seed=10)
    q = chain.random_configurations(2000, 11)
    targets = chain.fk(q)
    result = solve_ik(chain, targets, hint=q, nominal=nominal)
    assert result.success.all()
    assert result.position_error.max() < 1e-6 and result.orientation_error.max() < 1e-8
    position, orientation = pose_errors(chain, result.q, targets)
    assert position.max() < 1e-6 and orientation.max() < 1e-8
    assert chain.within_limits(result.q).all()


def test_calibrated_chain_alone_uses_its_idealised_closed_form():
    """Without the nominal chain the calibrated one's own near-closed-form geometry seeds the
    solver, and ik_all refines every branch on it."""
    chain = perturbed(load_robot("kr150-2"), seed=12)
    solver = closed_form(chain)
    assert not solver.exact
    q = chain.random_configurations(500, 13)
    targets = chain.fk(q)
    result = solve_ik(chain, targets)
    assert result.success.all()
    branches, valid = ik_all(chain, targets)
    assert valid.any(axis=1).all()
    position, orientation = pose_errors(chain, branches[valid], np.repeat(targets, 8, axis=0)[valid.ravel()])
    assert position.max() < 1e-6 and orientation.max() < 1e-8


def test_seven_axis_arm_with_a_hint():
    panda = load_robot("panda")
    rng = np.random.default_rng(14)
    q = panda.random_configurations(300, 15)
    targets = panda.fk(q)
    hint = np.clip(q + rng.normal(0.0, 0.02, q.shape), panda.lower, panda.upper)
    result = solve_ik(panda, targets, hint)
    assert result.success.all()
    position, orientation = pose_errors(panda, result.q, targets)
    assert position.max() < 1e-6 and orientation.max() < 1e-8
    assert panda.within_limits(result.q).all()


def test_solve_numeric_from_seeds_and_position_only():
    panda = load_robot("panda")
    q = panda.random_configurations(100, 16)
    targets = panda.fk(q)
    result = solve_numeric(panda, targets, q + 0.01)
    assert result.success.all() and result.position_error.max() < 1e-9
    # Position only: any orientation will do.
    targets[:, :3, :3] = np.eye(3)
    result = solve_ik(panda, targets, q, position_only=True)
    assert result.success.all()
    assert pose_errors(panda, result.q, targets)[0].max() < 1e-6


def test_position_only_with_a_closed_form():
    kr = load_robot("kr150-2")
    q = kr.random_configurations(500, 22)
    targets = kr.fk(q)
    targets[:, :3, :3] = np.eye(3)  # mostly out of reach as poses, not as positions
    rng = np.random.default_rng(23)
    result = solve_ik(kr, targets, q + rng.normal(0.0, 0.3, q.shape), position_only=True)
    assert result.success.all()
    assert pose_errors(kr, result.q, targets)[0].max() < 1e-6
    # Without a hint the seeds are the zero posture's tool directions turned to face each
    # target; a few awkward positions may still be missed.
    assert solve_ik(kr, targets, position_only=True).success.mean() > 0.99


# ------------------------------------------------------------------------- failures
@pytest.mark.parametrize("name", ["kr150-2", "ur5", "panda"])
def test_unreachable_target_fails_with_nan(name):
    chain = load_robot(name)
    q = chain.random_configurations(3, 17)
    targets = chain.fk(q)
    far = targets[1, :3, 3] / np.linalg.norm(targets[1, :3, 3])
    targets[1, :3, 3] += 3000.0 * far + [0.0, 0.0, 3000.0]
    result = solve_ik(chain, targets, hint=q)
    assert result.success.tolist() == [True, False, True]
    assert np.isnan(result.q[1]).all() and np.isfinite(result.q[[0, 2]]).all()
    assert result.position_error[1] > 1000.0


def test_target_needing_joints_beyond_limits_fails():
    kr = load_robot("kr150-2")
    q = np.radians([[60.0, -60.0, 30.0, 20.0, 40.0, 10.0]])
    targets = kr.fk(q)
    # Joint 1 may only turn +-10 deg: both shoulder solutions (60 and about -120 deg) are out.
    narrow = kr.replace(lower=np.maximum(kr.lower, -np.radians(10.0)), upper=np.minimum(kr.upper, np.radians(10.0)))
    result = solve_ik(narrow, targets, hint=q)
    assert not result.success[0] and np.isnan(result.q).all()
    assert not ik_all(narrow, targets)[1].any()
    assert not solve_numeric(narrow, targets, q).success[0]
    # The same solver on a perturbed copy (numerical path) agrees.
    assert not solve_ik(perturbed(narrow, seed=18), targets, hint=q).success[0]


# ------------------------------------------------------------------------ branch choice
def test_branch_nearest_the_hint_is_returned():
    kr = load_robot("kr150-2")
    q = kr.random_configurations(200, 19)
    targets = kr.fk(q)
    branches, valid = ik_all(kr, targets)
    rng = np.random.default_rng(20)
    # Branch k's distance to the nearest other branch (near a singularity two coincide).
    apart = np.abs(wrapped(branches[:, :, None] - branches[:, None, :])).max(axis=3)
    apart[:, np.arange(8), np.arange(8)] = np.inf
    apart = np.nanmin(np.where(valid[:, None, :], apart, np.inf), axis=2)
    for k in range(8):
        rows = np.flatnonzero(valid[:, k] & (apart[:, k] > 0.2))
        hint = branches[rows, k] + rng.normal(0.0, 0.02, (rows.size, 6))
        result = solve_ik(kr, targets[rows], hint)
        assert result.success.all()
        assert np.abs(result.q - branches[rows, k]).max() < 1e-6
        # Asking for the branch by index gives the same.
        by_index = solve_ik(kr, targets[rows], branch=k)
        assert np.abs(by_index.q - branches[rows, k]).max() < 1e-6
    # Without a hint: the branch nearest zero.
    nearest = np.argmin(np.where(valid, np.sum(branches ** 2, axis=2), np.inf), axis=1)
    result = solve_ik(kr, targets)
    assert np.abs(result.q - branches[np.arange(200), nearest]).max() < 1e-6


def test_whole_turns_follow_the_hint():
    ur = load_robot("ur5")  # every joint +-360 deg
    q = ur.random_configurations(100, 21)
    targets = ur.fk(q)
    shifted = q + 2 * np.pi * np.where(q < 0, 1.0, -1.0)  # the other equivalent, still in limits
    result = solve_ik(ur, targets, hint=shifted)
    assert result.success.all()
    assert np.abs(result.q - shifted).max() < 1e-6
    result = solve_ik(ur, targets, hint=q)
    assert np.abs(result.q - q).max() < 1e-6


def test_single_pose_and_bad_shapes():
    kr = load_robot("kr150-2")
    q = np.radians([10.0, -70.0, 40.0, 20.0, 30.0, -50.0])
    result = solve_ik(kr, kr.fk(q), hint=q)
    assert result.q.shape == (1, 6) and np.allclose(result.q[0], q, atol=1e-9)
    with pytest.raises(InputError, match="4x4"):
        solve_ik(kr, np.eye(3))
    with pytest.raises(InputError, match="hint"):
        solve_ik(kr, kr.fk(q), hint=np.zeros(5))
    with pytest.raises(InputError, match="branch"):
        solve_ik(kr, kr.fk(q), branch=8)
