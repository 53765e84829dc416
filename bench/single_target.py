"""One target at a time, in process: robocal's single-call paths beside pinocchio's FK, eaik's
closed-form IK and the Robotics Toolbox's ik_LM (each when it imports), and beside robocal's
own batch figures per target, in one run.

    python bench/single_target.py            # --quick: shorter timing budget

UR5 (the built-in model); the "calibrated" robot is the nominal one with 1 mm / 0.1 deg
deviations of every link parameter; the kinematic, Kriging and hybrid models are fitted to
300 simulated poses of a UR5 with the 'typical' errors.  Times are the median of repeated
calls over 200 different targets (us per call); one core.
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from robocal.io.library import load_robot  # noqa: E402
from robocal.io.observations import Observations  # noqa: E402
from robocal.kinematics.ik import PointSolver, closed_form, ik_all, solve_ik  # noqa: E402
from robocal.kinematics.program import PointProgram  # noqa: E402
from robocal.methods import make_method  # noqa: E402
from robocal.simulation import make_true_robot  # noqa: E402

TARGETS = 200


def per_call(func, items, budget):
    """Median time (us) of func(item) over the items, repeated for about ``budget`` s."""
    for item in items[:5]:
        func(item)
    times = []
    spent = 0.0
    while spent < budget or len(times) < len(items):
        for item in items:
            t0 = time.perf_counter()
            func(item)
            dt = time.perf_counter() - t0
            times.append(dt)
            spent += dt
        if len(times) > 20 * len(items):
            break
    return 1e6 * float(np.median(times))


def batch_per_target(func, count, budget):
    """Time (us) per target of one batch call over ``count`` targets (best of runs)."""
    func()
    best, spent = np.inf, 0.0
    while spent < budget or best == np.inf:
        t0 = time.perf_counter()
        func()
        dt = time.perf_counter() - t0
        best, spent = min(best, dt), spent + dt
    return 1e6 * best / count


def perturbed(chain, rng):
    names = chain.parameter_names(("links",))
    scale = np.array([np.radians(0.1) if chain.is_angular(n) else 1.0 for n in names])
    return chain.perturbed(names, rng.normal(size=len(names)) * scale)


def row(label, value, note=""):
    text = "-" if value is None else f"{value:10.1f} us"
    print(f"  {label:<58s} {text:>14s}  {note}")


def robocal_kinematics(robot, calibrated, q, budget):
    print("robocal, one call")
    program = PointProgram.of(robot)
    rows = [r.tolist() for r in q]
    row("FK, one configuration (PointProgram)", per_call(program.matrix, rows, budget), "goal <= 10 us")
    row("FK, one configuration through Chain.fk (batch API)", per_call(robot.fk, list(q), budget))
    targets = robot.fk(q)
    solver = closed_form(robot)
    row("closed-form IK, all 8 branches, one target", per_call(lambda t: solver.solve(t[None]), list(targets), budget),
        "goal <= 50 us")
    point = PointSolver(calibrated, robot)
    cal_targets = calibrated.fk(q)
    items = list(zip(cal_targets, q))
    row("IK on the calibrated model, one target (PointSolver)", per_call(lambda i: point.solve(*i), items, budget),
        "nominal closed form + Newton")
    row("IK on the calibrated model, one target (solve_ik, batch of one)",
        per_call(lambda i: solve_ik(calibrated, i[0][None], hint=i[1][None], nominal=robot), items[:40], budget / 2))
    print("robocal, batch of 1,000 (per target)")
    many = robot.random_configurations(1000, np.random.default_rng(9))
    row("FK", batch_per_target(lambda: robot.fk(many), 1000, budget))
    row("closed-form IK, all branches (ik_all)", batch_per_target(lambda: ik_all(robot, robot.fk(many)), 1000, budget))
    row("IK on the calibrated model (solve_ik)",
        batch_per_target(lambda: solve_ik(calibrated, calibrated.fk(many), hint=many, nominal=robot), 1000, budget))


def robocal_compensation(robot, q, budget):
    truth = make_true_robot(robot, "typical", seed=0)
    rng = np.random.default_rng(3)
    train = robot.random_configurations(300, rng)
    observations = Observations.of(train, truth.positions(train))
    print("robocal, Compensator: one target (command) and per target in a batch of 1,000 (commands)")
    many = np.vstack([q] * 5)
    fitted = {}
    for method in ("kinematic", "kriging", "hybrid"):
        settings = {} if method == "kinematic" else {"random_state": 0}
        model = make_method(method, **settings).fit(robot, observations)
        compensator = model.compensator_
        targets = compensator.chain.fk(q)
        batch_targets = compensator.chain.fk(many)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            one = per_call(lambda i: compensator.command(targets[i], q[i]), list(range(len(q))), budget)
            batch = batch_per_target(lambda: compensator.commands(batch_targets, hint=many), len(many), budget)
            of_one = per_call(lambda i: compensator.commands(targets[i:i + 1], hint=q[i:i + 1]),
                              list(range(20)), budget / 4)
        goal = "goal <= 100 us" if method == "kinematic" else "goal <= 300 us"
        row(f"{method}: command, one target", one, goal)
        row(f"{method}: commands, a batch of one", of_one)
        row(f"{method}: commands, per target in a batch of {len(many):,}", batch)
        fitted[method] = model
    return fitted, observations


def robocal_domain_and_bound(robot, fitted, observations, q, budget):
    """What robocal serve asks beside the command: the domain check and the 95 % bound of the
    commanded configuration, on the one-configuration paths and as a batch of one."""
    from robocal.methods.bound import fit_bound

    print("robocal, serve's checks of one configuration: one-row path and a batch of one")
    positions = robot.fk_positions(q)
    items = list(range(len(q)))
    for method in ("kinematic", "kriging"):
        model = fitted[method]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            bound = fit_bound(model, robot, observations)
            domain = model.domain_
            inside = domain.check(q, positions).inside
            one = per_call(lambda i, d=domain: d.inside_one(q[i], positions[i]), items, budget)
            of_one = per_call(lambda i, d=domain: d._check(q[i:i + 1], np.ones(1, bool), positions[i:i + 1], None,
                                                           None, "targets"), items[:40], budget / 4)
            row(f"{method}: domain, inside_one", one)
            row(f"{method}: domain, check of a batch of one", of_one)
            one = per_call(lambda i, b=bound, s=inside: b.predict_one(q[i], s[i]), items, budget)
            of_one = per_call(lambda i, b=bound, s=inside: b.predict(q[i:i + 1], inside=s[i:i + 1]), items[:40],
                              budget / 4)
            row(f"{method}: 95 % bound, predict_one", one, f"{int(inside.sum())} of {len(q)} inside")
            row(f"{method}: 95 % bound, predict of a batch of one", of_one)


def kriging_variance(budget):
    from robocal.estimation.kriging import Kriging

    rng = np.random.default_rng(4)
    x = rng.uniform(-500.0, 500.0, (500, 3))
    y = np.column_stack([np.sin(x[:, 0] / 300.0), np.cos(x[:, 1] / 400.0), x[:, 2] / 1000.0])
    y += rng.normal(0.0, 0.01, y.shape)
    model = Kriging(nugget="estimate", random_state=0).fit(x, y)
    points = rng.uniform(-500.0, 500.0, (100_000, 3))
    t0 = time.perf_counter()
    model.predict(points)
    mean = time.perf_counter() - t0
    t0 = time.perf_counter()
    model.predict(points, return_mse=True)
    both = time.perf_counter() - t0
    print(f"Kriging (500 training points, 3 outputs), 100,000 predictions: mean {mean:.2f} s, "
          f"mean and variance {both:.2f} s ({both / mean:.1f} x; goal <= 2 x)")
    # Both already share the cross-correlations of a block of 1,000 points; the variance adds
    # one blocked triangular solve with them, n^2 flops per point and output against the
    # mean's n: the ratio grows with n, whatever the code around it.
    n = len(x)
    print(f"  the variance's triangular solve: {n * n:,} flops per point and output, the mean's product {n:,}")


def pinocchio_fk(robot, q, budget):
    try:
        import pinocchio as pin

        from robocal.io.urdf import write_urdf
    except ImportError:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "robot.urdf")
        write_urdf(robot.replace(masses=None), path)  # kinematics only
        model = pin.buildModelFromUrdf(path)
    data = model.createData()
    frame = model.getFrameId("tcp")

    def fk(qi):
        pin.framesForwardKinematics(model, data, qi)
        return data.oMf[frame]

    return per_call(fk, list(robot.model_joints(q)), budget)


def eaik_ik(robot, q, budget):
    try:
        from eaik.IK_DH import DhRobot
    except ImportError:
        return None
    bot = DhRobot(np.asarray(robot.alpha), np.asarray(robot.a) / 1000.0, np.asarray(robot.d) / 1000.0)
    poses = [bot.fwdKin(qi) for qi in robot.model_joints(q)]
    return per_call(bot.IK, poses, budget)


def rtb_ik(robot, q, budget):
    try:
        import roboticstoolbox as rtb
    except ImportError:
        return None
    links = [rtb.RevoluteDH(d=robot.d[i] / 1000, a=robot.a[i] / 1000, alpha=robot.alpha[i], offset=robot.theta[i])
             for i in range(robot.n_joints)]
    model = rtb.DHRobot(links).ets()
    qm = robot.model_joints(q)
    rng = np.random.default_rng(5)
    items = [(model.fkine(qi).A, qi + rng.normal(size=qi.shape) * 0.05) for qi in qm]
    # A tolerance that reaches about 1 um at the TCP (its residual is in m and rad).
    return per_call(lambda i: model.ik_LM(i[0], q0=i[1], tol=1e-12), items, budget)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter timing budget")
    args = parser.parse_args()
    budget = 0.3 if args.quick else 1.5
    robot = load_robot("ur5")
    rng = np.random.default_rng(0)
    calibrated = perturbed(robot, rng)
    q = robot.random_configurations(TARGETS, rng)
    q[:, 1] = np.clip(q[:, 1], -2.8, -0.3)  # arm above the base, as in use
    print(f"robot: {robot.name}; {TARGETS} different targets; median us per call; one core")
    robocal_kinematics(robot, calibrated, q, budget)
    fitted, observations = robocal_compensation(robot, q, budget)
    robocal_domain_and_bound(robot, fitted, observations, q, budget)
    kriging_variance(budget)
    print("peers, one call")
    value = pinocchio_fk(robot, q, budget)
    row("pinocchio FK (framesForwardKinematics + oMf)", value, "" if value is not None else "not installed (pip install pin)")
    value = eaik_ik(robot, q, budget)
    row("eaik closed-form IK, all branches", value, "" if value is not None else "not installed (pip install eaik)")
    value = rtb_ik(robot, q, budget)
    row("Robotics Toolbox ik_LM (ETS, C++), tol 1e-12", value,
        "" if value is not None else "not installed (pip install roboticstoolbox-python)")


if __name__ == "__main__":
    main()
