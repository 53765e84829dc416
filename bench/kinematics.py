"""Kinematics throughput of robocal beside the peers that are installed.

Prints, for N = 1, 1e3, 1e5 configurations of the KUKA KR 150-2 on one core: batched forward
kinematics (full pose and positions only), the geometric and identification Jacobians,
closed-form IK (every branch) and numerical IK on a perturbed ("calibrated") model; then the
same operations with pinocchio and robotics-toolbox-python when they import.

    python bench/kinematics.py            # add --quick for a shorter run
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets are stated
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from robocal.io.library import load_robot  # noqa: E402

SIZES = (1, 1000, 100000)


def rate(func, n_items, budget=1.0):
    """Items per second of ``func()``, repeated for about ``budget`` seconds (best of runs)."""
    func()
    best = np.inf
    spent, runs = 0.0, 0
    while spent < budget or runs < 3:
        t0 = time.perf_counter()
        func()
        dt = time.perf_counter() - t0
        best = min(best, dt)
        spent += dt
        runs += 1
    return n_items / best


def fmt_rate(value):
    if value is None:
        return "-"
    if value >= 1e6:
        return f"{value / 1e6:.2f} M/s"
    return f"{value / 1e3:.1f} k/s"


def perturbed_model(chain, rng):
    """Random 1 mm / 0.1 deg deviations of every link parameter: a calibrated model."""
    names = chain.parameter_names(("links",))
    scale = np.array([np.radians(0.1) if chain.is_angular(n) else 1.0 for n in names])
    return chain.perturbed(names, rng.normal(size=len(names)) * scale)


def robocal_rows(robot, budget):
    rng = np.random.default_rng(0)
    calibrated = perturbed_model(robot, rng)
    rows = []
    try:
        from robocal.kinematics.ik import ik_all, solve_ik
    except ImportError:
        ik_all = solve_ik = None
    for n in SIZES:
        q = robot.random_configurations(n, rng)
        targets = robot.fk(q)
        targets_cal = calibrated.fk(q)
        row = {
            "N": n,
            "fk": rate(lambda: robot.fk(q), n, budget),
            "fk positions": rate(lambda: robot.fk_positions(q), n, budget),
            "jacobian": rate(lambda: robot.jacobian(q), n, budget),
            "id. jacobian": rate(lambda: robot.identification_jacobian(q), n, budget),
        }
        if ik_all is not None:
            row["IK closed form"] = rate(lambda: ik_all(robot, targets), n, budget)
            result = solve_ik(calibrated, targets_cal, hint=q, nominal=robot)
            row["IK numeric"] = rate(lambda: solve_ik(calibrated, targets_cal, hint=q, nominal=robot), n, budget)
            row["IK success"] = f"{100.0 * np.mean(result.success):.2f} %"
        rows.append(row)
    return rows


def pinocchio_rows(robot, budget):
    try:
        import pinocchio as pin
        from robocal.io.urdf import write_urdf
    except ImportError:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "robot.urdf")
        write_urdf(robot, path)
        model = pin.buildModelFromUrdf(path)
    data = model.createData()
    frame = model.getFrameId("tcp")
    rows = []
    for n in SIZES[:2]:  # a Python loop over 1e5 poses is 1e3 poses timed 100 times longer
        q = robot.random_configurations(n, 1)

        def fk():
            for qi in q:
                pin.framesForwardKinematics(model, data, qi)
                data.oMf[frame]

        def jac():
            for qi in q:
                pin.computeFrameJacobian(model, data, qi, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)

        rows.append({"N": n, "fk": rate(fk, n, budget), "jacobian": rate(jac, n, budget)})
    return rows


def rtb_rows(robot, budget):
    try:
        import roboticstoolbox as rtb
    except ImportError:
        return None
    links = [
        rtb.RevoluteDH(d=robot.d[i] / 1000, a=robot.a[i] / 1000, alpha=robot.alpha[i], offset=robot.theta[i])
        for i in range(robot.n_joints)
    ]
    # The ETS form runs fkine and ik_LM in C/C++; DHRobot.fkine itself is pure Python.
    model = rtb.DHRobot(links).ets()
    rows = []
    rng = np.random.default_rng(2)
    for n in SIZES:
        q = robot.model_joints(robot.random_configurations(n, rng))
        row = {"N": n, "fk": rate(lambda: model.fkine(q), n, budget)}
        if n <= 1000:
            poses = [model.fkine(qi).A for qi in q]
            seeds = q + rng.normal(size=q.shape) * 0.05

            def ik():
                for pose, seed in zip(poses, seeds):
                    model.ik_LM(pose, q0=seed)

            row["IK numeric"] = rate(ik, n, budget)
        rows.append(row)
    return rows


def print_table(title, rows, columns):
    print(f"\n{title}")
    widths = [max(len(c), 12) for c in columns]
    print("  ".join(c.rjust(w) for c, w in zip(columns, widths)))
    for row in rows:
        cells = []
        for c, w in zip(columns, widths):
            v = row.get(c)
            cells.append((str(v) if c in ("N", "IK success") or isinstance(v, str) else fmt_rate(v)).rjust(w))
        print("  ".join(cells))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter timing budget")
    args = parser.parse_args()
    budget = 0.2 if args.quick else 1.0
    robot = load_robot("kr150-2")
    print(f"robot: {robot.name}, {robot.n_joints} joints; one core (OMP_NUM_THREADS=1)")
    columns = ["N", "fk", "fk positions", "jacobian", "id. jacobian", "IK closed form", "IK numeric", "IK success"]
    print_table("robocal (configurations or solves per second)", robocal_rows(robot, budget), columns)
    pin_rows = pinocchio_rows(robot, budget)
    if pin_rows is None:
        print("\npinocchio: not installed (pip install pin)")
    else:
        print_table("pinocchio, called per configuration from Python", pin_rows, ["N", "fk", "jacobian"])
    rows = rtb_rows(robot, budget)
    if rows is None:
        print("\nrobotics-toolbox-python: not installed (pip install roboticstoolbox-python)")
    else:
        print_table("robotics-toolbox-python (ETS fkine batch in C; C++ ik_LM per pose)", rows, ["N", "fk", "IK numeric"])
    print("\nTargets: FK >= 3 M/s at N = 1e5; closed-form IK >= 0.5 M/s; numerical IK >= 50 k/s, 100 % success.")


if __name__ == "__main__":
    main()
