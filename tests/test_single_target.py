"""One target at a time: the point program's FK, the point IK solver and
Compensator.command give what the batch paths give for the same target."""
import numpy as np
import pytest

from robocal.compensation import Compensator
from robocal.errors import InputError
from robocal.io.library import load_robot
from robocal.io.observations import Observations
from robocal.kinematics import to_mdh, to_poe
from robocal.kinematics.ik import PointSolver, closed_form, solve_ik
from robocal.kinematics.program import PointProgram
from robocal.methods import KrigingMethod, make_method
from robocal.simulation import make_true_robot

ROBOTS = ["kr150-2", "irb120", "ur5", "ur10"]


def perturbed(chain, seed):
    rng = np.random.default_rng(seed)
    names = chain.parameter_names(("links",))
    sigma = np.array([np.radians(0.1) if chain.is_angular(name) else 1.0 for name in names])
    return chain.perturbed(names, rng.normal(0.0, sigma))


def program_of(chain):
    return PointProgram(chain._compiled[0], chain.joint_map, chain.revolute)


@pytest.mark.parametrize("name", ROBOTS)
def test_point_program_equals_batched_fk_and_jacobian(name):
    nominal = load_robot(name)
    for chain in (nominal, perturbed(nominal, 1), to_mdh(nominal), to_poe(nominal),
                  nominal.replace(joint_map=np.diag([1.0, -1.0, 1.0, 1.0, -1.0, 1.0]))):
        program = program_of(chain)
        q = chain.random_configurations(20, np.random.default_rng(2))
        for row in q:
            np.testing.assert_allclose(program.matrix(row.tolist()), chain.fk(row), atol=1e-9)
            _, columns = program.pose_jacobian(row.tolist())
            np.testing.assert_allclose(np.array(columns).reshape(-1, 6).T, chain.jacobian(row), atol=1e-9)


@pytest.mark.parametrize("name", ROBOTS)
def test_point_solver_equals_solve_ik_target_by_target(name):
    nominal = load_robot(name)
    rng = np.random.default_rng(3)
    for chain, seed_from in ((nominal, None), (perturbed(nominal, 4), nominal)):
        solver = PointSolver(chain, seed_from)
        q = chain.random_configurations(40, rng)
        targets = chain.fk(q)
        hints = q + rng.normal(0.0, 0.2, q.shape)
        # A few unreachable targets: far away, and a posture hint that is absurd.
        targets[:3, :3, 3] *= 10.0
        batch = solve_ik(chain, targets, hint=hints, nominal=seed_from)
        for i in range(len(q)):
            one, ok = solver.solve(targets[i], hints[i])
            assert ok == batch.success[i]
            if ok:
                np.testing.assert_allclose(one, batch.q[i], atol=1e-8)
            else:
                assert np.all(np.isnan(one))
        # Without a hint: the branch nearest zero, as in the batch.
        batch = solve_ik(chain, targets[3:8], nominal=seed_from)
        for i in range(5):
            one, ok = solver.solve(targets[3 + i])
            assert ok == batch.success[i]
            np.testing.assert_allclose(one, batch.q[i], atol=1e-8)


@pytest.mark.parametrize("name", ["kr150-2", "irb120", "fanuc-r2000ic-165f", "ur5", "ur10"])
def test_closed_form_of_one_target_equals_the_batch(name):
    """One target goes through the float path (ik/one.py); its branches, masks and seeds
    are the batch's, including targets out of reach and far off the idealised geometry."""
    nominal = load_robot(name)
    solver = closed_form(nominal)
    rng = np.random.default_rng(7)
    q = nominal.random_configurations(60, rng)
    targets = perturbed(nominal, 8).fk(q)
    targets[:4, :3, 3] *= 3.0
    for mode in ("solve", "seeds"):
        batch = getattr(solver, mode)(targets, q)
        for i in range(len(q)):
            alone = getattr(solver, mode)(targets[i:i + 1], q[i])
            np.testing.assert_allclose(alone[0][0], batch[0][i], atol=1e-9, equal_nan=True)
            for mask_alone, mask_batch in zip(alone[1:], batch[1:]):
                np.testing.assert_array_equal(mask_alone[0], mask_batch[i])


@pytest.mark.parametrize("name", ["kr150-2", "irb120", "ur5", "ur10"])
def test_nearest_branch_of_one_target_is_the_batch_ranking_first(name):
    """ClosedForm.nearest_one skips a shoulder root that joint 1 alone rules out: what it
    returns is still the first of all eight branches as solve_ik ranks them, also for
    references far from the target (the other shoulder then often wins) and for a joint map
    that mixes joints (no skipping)."""
    nominal = load_robot(name)
    mixed = nominal.replace(joint_map=np.eye(6) + 0.01 * np.eye(6, k=1))
    rng = np.random.default_rng(11)
    for chain, seeds in ((nominal, False), (perturbed(nominal, 12), True), (mixed, False)):
        solver = closed_form(nominal if seeds else chain)
        q = chain.random_configurations(30, rng)
        targets = chain.fk(q)
        # Every other reference near the target's own configuration, the others anywhere.
        references = np.where((np.arange(30) % 2 == 0)[:, None], q + rng.normal(0.0, 0.1, q.shape),
                              chain.random_configurations(30, rng))
        for target, reference in zip(targets, references):
            reference = reference.tolist()
            joints, usable, preferred = solver.branches_one(target, reference, seeds)
            distance = [np.inf if not ok else float(np.sum((np.array(b) - reference) ** 2)) + (0.0 if p else 1e6)
                        for b, ok, p in zip(joints, usable, preferred)]
            found = solver.nearest_one(target, reference, seeds, 1e6)
            if not np.isfinite(min(distance)):
                assert found is None
                continue
            best = int(np.argmin(distance))
            np.testing.assert_array_equal(found[0], joints[best])
            assert found[1] == preferred[best]


def test_closed_form_is_fitted_once_per_chain():
    chain = load_robot("ur5")
    assert closed_form(chain) is closed_form(chain)


def test_no_closed_form_is_solved_as_the_batch_does():
    chain = load_robot("ur5")
    # Joint 2 made prismatic: no closed form; the numerical solver from the hint.
    odd = chain.replace(joint_types=("revolute", "prismatic") + chain.joint_types[2:])
    solver = PointSolver(odd)
    q = odd.random_configurations(3, np.random.default_rng(5))
    for row in q:
        one, ok = solver.solve(odd.fk(row), row + 0.01)
        batch = solve_ik(odd, odd.fk(row)[None], hint=(row + 0.01)[None])
        assert ok == batch.success[0]
        np.testing.assert_allclose(one, batch.q[0], atol=1e-8, equal_nan=True)


def _compare(compensator, targets, hints, iterate=False):
    batch = compensator.commands(targets, hint=hints, iterate=iterate)
    for i in range(len(targets)):
        one = compensator.command(targets[i], hints[i], iterate=iterate)
        assert one.success[0] == batch.success[i]
        np.testing.assert_allclose(one.q[0], batch.q[i], atol=1e-8, equal_nan=True)
        # The corrected targets (mm) to 1e-9 mm: Newton and the batch's Levenberg–Marquardt
        # both stop within 1e-9 mm of the same solution.
        np.testing.assert_allclose(one.corrected[0], batch.corrected[i], rtol=0.0, atol=1e-9, equal_nan=True)
    return batch


@pytest.fixture(scope="module")
def ur5_data():
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=0)
    rng = np.random.default_rng(6)
    q = chain.random_configurations(80, rng)
    q[:, 1] = np.clip(q[:, 1], -2.6, -0.5)
    observations = Observations.of(q[:50], truth.positions(q[:50]))
    targets = chain.fk(q[50:])
    hints = q[50:] + rng.normal(0.0, 0.05, (30, 6))
    return chain, observations, targets, hints


@pytest.mark.filterwarnings("ignore:.*extrapolates")
@pytest.mark.parametrize("method", ["kinematic", "kriging", "hybrid", "kriging-joints"])
def test_command_of_one_target_equals_the_batch(ur5_data, method):
    chain, observations, targets, hints = ur5_data
    if method == "kriging-joints":
        fitted = KrigingMethod(register="no", inputs="joints", random_state=0).fit(chain, observations)
    else:
        fitted = make_method(method, **({"random_state": 0} if method != "kinematic" else {})).fit(chain, observations)
    compensator = fitted.compensator_
    batch = _compare(compensator, targets, hints)
    assert batch.success.sum() > 20
    if method == "kriging":
        _compare(compensator, targets[:5], hints[:5], iterate=True)


def test_command_refuses_a_batch_and_a_bad_hint():
    chain = load_robot("ur5")
    with pytest.raises(InputError, match="one"):
        Compensator(chain).command(chain.fk(np.zeros((2, 6))))
    with pytest.raises(InputError, match="hint"):
        Compensator(chain).command(chain.fk(np.zeros(6)), np.zeros(5))
    with pytest.raises(InputError, match="hint"):
        PointSolver(chain).solve(chain.fk(np.zeros(6)), ["a"] * 6)
