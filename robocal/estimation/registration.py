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
from ..spatial.transforms import kabsch  # noqa: F401  (imported from here by callers)
from .identification import BASE, TOOL_POSITION
from .least_squares import levenberg_marquardt


@dataclass(frozen=True)
class FitReport:
    """How a registration ended."""

    names: tuple
    iterations: int
    converged: bool
    rms_start_mm: float
    rms_after_mm: float


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
    rms = lambda c: float(np.sqrt(np.mean(np.sum((positions - c.fk_positions(q)) ** 2, axis=1))))  # noqa: E731
    start = rms(chain)
    fit = levenberg_marquardt(chain, q, positions, names, max_iterations=max_iterations)
    return fit.chain, FitReport(tuple(names), fit.iterations, fit.converged, start, rms(fit.chain))
