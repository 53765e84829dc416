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


# ik_LM stops when E = ½eᵀe ≤ tol, e the pose error in m and rad: its default 1e-6 accepts
# |e| up to 1.4 mm.  This tol stops it at |e| ≤ 0.45 µm; VERIFY_* judge every answer by
# robocal's forward kinematics of the same model.
RTB_TOL = 1e-13
VERIFY_POSITION = 1e-3  # mm: 1 µm
VERIFY_ORIENTATION = 1e-6  # rad: 1 µm at a 1 m lever arm


def rtb_rows(robot, budget):
    try:
        import roboticstoolbox as rtb
    except ImportError:
        return None
    links = [
        rtb.RevoluteDH(d=robot.d[i] / 1000, a=robot.a[i] / 1000, alpha=robot.alpha[i], offset=robot.theta[i])
        for i in range(robot.n_joints)
    ]
    # The ETS form evaluates in C (``eval``: a batch of configurations to an (N, 4, 4) array;
    # ``fkine`` wraps each pose in an SE3 object) and runs ik_LM in C++.
    model = rtb.DHRobot(links).ets()
    rows = []
    rng = np.random.default_rng(2)
    for n in SIZES:
        q_robocal = robot.random_configurations(n, rng)
        q = robot.model_joints(q_robocal)
        poses = model.eval(q).reshape(n, 4, 4)
        mine = robot.fk(q_robocal)
        row = {"N": n, "fk": rate(lambda: model.eval(q), n, budget), "fk SE3": rate(lambda: model.fkine(q), n, budget),
               "FK agreement": f"{np.abs(poses[:, :3, 3] * 1000 - mine[:, :3, 3]).max():.1e} mm"}
        if n <= 1000:
            seeds = q + rng.normal(size=q.shape) * 0.05
            for name, tol in (("IK numeric", RTB_TOL), ("IK default tol", 1e-6)):
                def ik():
                    return [model.ik_LM(pose, q0=seed, tol=tol) for pose, seed in zip(poses, seeds)]

                row[name] = rate(ik, n, budget)
                row[name + " verified"] = verified_share(robot, poses, ik())
        rows.append(row)
    return rows


def verified_share(robot, poses, solutions):
    """The share of ik_LM's answers that reach ``poses`` (N, 4, 4; m) within VERIFY_POSITION
    and VERIFY_ORIENTATION by robocal's forward kinematics, whatever its success flag said."""
    found = np.array([s.q for s in solutions])  # model variables: back to controller joints
    T = robot.fk(np.linalg.solve(robot.joint_map, found.T).T)
    position = np.linalg.norm(T[:, :3, 3] - poses[:, :3, 3] * 1000, axis=1)
    relative = np.einsum("nji,njk->nik", poses[:, :3, :3], T[:, :3, :3])
    angle = np.arccos(np.clip((np.trace(relative, axis1=1, axis2=2) - 1) / 2, -1, 1))
    ok = (position <= VERIFY_POSITION) & (angle <= VERIFY_ORIENTATION)
    return f"{100.0 * ok.mean():.1f} %"


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
    try:  # one BLAS thread for robocal and the peers alike, held after the libraries load
        from threadpoolctl import threadpool_limits
        threadpool_limits(1)
    except ImportError:
        pass
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
        print_table(f"robotics-toolbox-python (ETS eval: C batch FK; fkine: SE3 objects; C++ ik_LM per pose, "
                    f"tol {RTB_TOL:g} and its default 1e-6; verified: within {VERIFY_POSITION * 1000:g} µm and "
                    f"{VERIFY_ORIENTATION:g} rad by robocal's FK)", rows,
                    ["N", "fk", "fk SE3", "FK agreement", "IK numeric", "IK numeric verified", "IK default tol",
                     "IK default tol verified"])
    print("\nTargets: FK >= 3 M/s at N = 1e5; closed-form IK >= 0.5 M/s; numerical IK >= 50 k/s, 100 % success.")


if __name__ == "__main__":
    main()
