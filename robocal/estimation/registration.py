"""Base and tool registration: put measurements taken in an instrument's frame into the
robot's, with the nominal geometry.

A closed-form rigid fit (Kabsch) of nominal FK positions onto the measurements gives the base
frame from any tracker placement; Levenberg–Marquardt on the chain itself (the analytic
identification Jacobian, steps applied with :meth:`Chain.perturbed`) then refines base and
tool together.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..spatial import make_transform

TOOL_POSITION = ("tool_x", "tool_y", "tool_z")
BASE = ("base_x", "base_y", "base_z", "base_rx", "base_ry", "base_rz")


def kabsch(source, target, weights=None):
    """Rotation R and translation t minimising sum w |R source_i + t - target_i|^2."""
    source = np.asarray(source, dtype=float)
    target = np.asarray(target, dtype=float)
    w = np.ones(len(source)) if weights is None else np.asarray(weights, dtype=float)
    w = w / w.sum()
    mu_s, mu_t = w @ source, w @ target
    cov = (target - mu_t).T @ ((source - mu_s) * w[:, None])
    u, s, vt = np.linalg.svd(cov)
    if s[1] < 1e-9 * max(s[0], 1e-300):
        raise InputError("the measured points are (nearly) collinear: a rigid frame cannot be fitted; "
                         "measure poses spread over the workspace")
    fix = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    rot = u @ fix @ vt
    return rot, mu_t - rot @ mu_s


@dataclass(frozen=True)
class FitReport:
    """How a Levenberg–Marquardt fit of chain parameters ended."""

    names: tuple
    iterations: int
    converged: bool
    rms_before_mm: float
    rms_after_mm: float


def fit_chain(chain, joints, positions, names, *, max_iterations=100, tolerance=1e-10):
    """Levenberg–Marquardt over the named parameters so that FK(joints) meets ``positions``.

    joints (N, n) rad; positions (N, 3) mm.  Returns (fitted chain, FitReport).  Steps are
    solved with column scaling and a least-squares solver, so parameters the data cannot
    determine stay where they are instead of running away.
    """
    names = list(names)
    q = np.asarray(joints, dtype=float)
    target = np.asarray(positions, dtype=float)
    residual = (target - chain.fk_positions(q)).reshape(-1)
    cost = residual @ residual
    rms_before = np.sqrt(cost / len(q))
    damping = 1e-3
    converged = False
    iteration = 0
    for iteration in range(1, max_iterations + 1):
        jac = chain.identification_jacobian(q, names)[:, :3, :].reshape(-1, len(names))
        scale = np.linalg.norm(jac, axis=0)
        scale[scale == 0.0] = 1.0
        js = jac / scale
        normal = js.T @ js
        gradient = js.T @ residual
        while True:
            lhs = normal + damping * np.diag(np.diag(normal) + 1e-12)
            step = np.linalg.lstsq(lhs, gradient, rcond=1e-12)[0] / scale
            candidate = chain.perturbed(names, step)
            new_residual = (target - candidate.fk_positions(q)).reshape(-1)
            new_cost = new_residual @ new_residual
            if new_cost <= cost or damping > 1e12:
                break
            damping *= 10.0
        if new_cost > cost:
            break
        improvement = cost - new_cost
        chain, residual, cost = candidate, new_residual, new_cost
        damping = max(damping / 10.0, 1e-12)
        if improvement <= tolerance * max(cost, 1e-30) or np.max(np.abs(step)) < 1e-13:
            converged = True
            break
    report = FitReport(tuple(names), iteration, converged, float(rms_before), float(np.sqrt(cost / len(q))))
    return chain, report


def register_base_and_tool(chain, joints, positions, *, tool=True, max_iterations=100):
    """Fit the base frame (and the TCP position in the flange frame) to measured positions.

    Starts from a Kabsch fit of nominal FK positions onto the measurements, so it converges
    from any instrument placement.  Returns (registered chain, FitReport).
    """
    q = np.asarray(joints, dtype=float)
    if len(q) < 4:
        raise InputError(f"registration needs at least 4 poses spread over the workspace, got {len(q)}")
    nominal = chain.fk_positions(q)
    rot, shift = kabsch(nominal, positions)
    chain = chain.replace(base=make_transform(rot, shift) @ chain.base)
    names = list(BASE) + (list(TOOL_POSITION) if tool else [])
    return fit_chain(chain, q, positions, names, max_iterations=max_iterations)
