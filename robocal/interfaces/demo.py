"""``robocal demo``: a real job on the built-in KUKA KR 150-2, with measured figures only.

Forward kinematics of random configurations within the joint limits; every closed-form IK
branch of those poses with its round-trip error; numerical IK on a "calibrated" model
(random 1 mm / 0.1 deg deviations of every link parameter) seeded from the nominal closed
form.  Every number printed is measured in this run.
"""
import time

import numpy as np
from rich.table import Table

from ..io.library import load_robot
from ..kinematics.ik import ik_all, solve_ik
from ..spatial import so3_log


def _timed(func):
    t0 = time.perf_counter()
    value = func()
    return value, time.perf_counter() - t0


def _round_trip(chain, q, targets):
    """Position (mm) and orientation (rad) errors of FK(q) against the targets."""
    poses = chain.fk(q)
    dp = np.linalg.norm(poses[:, :3, 3] - targets[:, :3, 3], axis=1)
    dw = np.linalg.norm(so3_log(poses[:, :3, :3] @ np.swapaxes(targets[:, :3, :3], 1, 2)), axis=1)
    return dp, dw


def run_demo(n=10000, seed=0, robot="kr150-2"):
    """Run the job and return its measurements as a JSON-ready dict."""
    chain = load_robot(robot)
    rng = np.random.default_rng(seed)
    q = chain.random_configurations(n, rng)
    poses, t_fk = _timed(lambda: chain.fk(q))

    (branches, valid), t_ik = _timed(lambda: ik_all(chain, poses))
    flat_q, flat_valid = branches.reshape(-1, chain.n_joints), valid.reshape(-1)
    dp, dw = _round_trip(chain, flat_q[flat_valid], np.repeat(poses, branches.shape[1], axis=0)[flat_valid])
    wrapped = np.angle(np.exp(1j * (branches - q[:, None, :])))
    original_found = np.any(valid & np.all(np.abs(wrapped) < 1e-6, axis=2), axis=1)

    names = chain.parameter_names(("links",))
    scale = np.array([np.radians(0.1) if chain.is_angular(p) else 1.0 for p in names])
    calibrated = chain.perturbed(names, rng.normal(size=len(names)) * scale)
    targets = calibrated.fk(q)
    nominal_gap = np.linalg.norm(poses[:, :3, 3] - targets[:, :3, 3], axis=1)
    result, t_num = _timed(lambda: solve_ik(calibrated, targets, hint=q, nominal=chain))
    cal_dp, cal_dw = _round_trip(calibrated, result.q[result.success], targets[result.success])

    return {
        "robot": chain.name,
        "configurations": n,
        "seed": seed,
        "forward_kinematics": {"seconds": t_fk, "per_second": n / t_fk},
        "closed_form_ik": {
            "seconds": t_ik,
            "per_second": n / t_ik,
            "branches_per_target_mean": float(valid.sum(axis=1).mean()),
            "original_configuration_found": float(original_found.mean()),
            "max_position_error_mm": float(dp.max()),
            "max_orientation_error_rad": float(dw.max()),
        },
        "numerical_ik_calibrated_model": {
            "seconds": t_num,
            "per_second": n / t_num,
            "nominal_vs_calibrated_mean_mm": float(nominal_gap.mean()),
            "nominal_vs_calibrated_max_mm": float(nominal_gap.max()),
            "success_rate": float(result.success.mean()),
            "max_position_error_mm": float(cal_dp.max()) if cal_dp.size else None,
            "max_orientation_error_rad": float(cal_dw.max()) if cal_dw.size else None,
        },
    }


def demo_tables(result):
    """Rich renderables of :func:`run_demo`'s result."""
    n = result["configurations"]
    cf, num = result["closed_form_ik"], result["numerical_ik_calibrated_model"]
    table = Table(title=f"{result['robot']}: {n} random configurations within the joint limits (seed {result['seed']})")
    table.add_column("step")
    table.add_column("time", justify="right")
    table.add_column("rate", justify="right")
    table.add_column("result")
    table.add_row("forward kinematics", f"{result['forward_kinematics']['seconds'] * 1e3:.1f} ms",
                  f"{result['forward_kinematics']['per_second'] / 1e6:.2f} M/s", "(N, 4, 4) poses")
    table.add_row(
        "closed-form IK, all branches", f"{cf['seconds'] * 1e3:.1f} ms", f"{cf['per_second'] / 1e3:.0f} k/s",
        f"{cf['branches_per_target_mean']:.2f} branches/target within limits; original found "
        f"{100 * cf['original_configuration_found']:.2f} %; round trip max "
        f"{cf['max_position_error_mm']:.1e} mm, {cf['max_orientation_error_rad']:.1e} rad",
    )
    table.add_row(
        "numerical IK, perturbed model", f"{num['seconds'] * 1e3:.1f} ms", f"{num['per_second'] / 1e3:.0f} k/s",
        f"model differs from nominal by {num['nominal_vs_calibrated_mean_mm']:.2f} mm mean / "
        f"{num['nominal_vs_calibrated_max_mm']:.2f} mm max; success {100 * num['success_rate']:.2f} %; "
        f"residual max {num['max_position_error_mm']:.1e} mm, {num['max_orientation_error_rad']:.1e} rad",
    )
    return [table]
