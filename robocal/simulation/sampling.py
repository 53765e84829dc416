"""Sampling plans: where to send the robot to collect calibration or test data.

Cartesian plans (:func:`latin_hypercube_box`, :func:`grid`, :func:`liu2022_plan`) choose TCP
positions in a box of the world frame, all with one orientation, and command them with the
nominal inverse kinematics on *one* branch for every point: mixing branches (shoulder,
elbow, wrist flip) would mix error patterns that a smooth error model cannot share.
:func:`uniform_joints` samples joint space directly.

Joint values are controller joints in rad (mm for prismatic joints); positions are mm.
"""
import numpy as np
from scipy.stats import qmc

from ..errors import InputError
from ..kinematics.ik import closed_form, ik_all, solve_ik
from . import liu2022

# A hint is on its branch when that branch reproduces it to this (rad); two branches this
# close to it mean it sits on a singularity where they meet.
BRANCH_TOL = 1e-6


def latin_hypercube_box(chain, n, low, high, orientation, seed=0, hint=None):
    """``n`` Latin-hypercube points in a box, each commanded with nominal IK on one branch.

    The points are ``scipy.stats.qmc.LatinHypercube(d=3, seed=seed)`` scaled to the box
    ``low``..``high`` (x, y, z in mm, world frame); every target has the TCP orientation
    ``orientation`` (3x3).  hint: a posture (controller joints, rad) whose IK branch is used
    for every point; without one, the branch that reaches the most points.

    Returns q (n, n_joints) and targets (n, 4, 4).  Raises InputError if some points have
    no solution on that branch within the joint limits.
    """
    n = _count(n)
    low, high = _box(low, high)
    unit = qmc.LatinHypercube(d=3, seed=seed).random(n)
    targets = _targets(low + unit * (high - low), orientation)
    return _solve_on_one_branch(chain, targets, hint, low, high), targets


def grid(chain, low, high, counts, orientation, hint=None):
    """A regular grid of ``counts`` = (nx, ny, nz) points spanning the box ``low``..``high``
    (mm; a count of 1 puts that layer at ``low``), x varying slowest; otherwise as
    :func:`latin_hypercube_box`.  Returns q (nx·ny·nz, n_joints) and targets."""
    low, high = _box(low, high)
    counts = np.asarray(counts)
    if counts.shape != (3,) or not np.all(counts == np.round(counts)) or np.any(counts < 1):
        raise InputError(f"grid counts must be three whole numbers >= 1 (nx, ny, nz), got {np.ravel(counts).tolist()}")
    axes = [np.linspace(lo, hi, int(k)) for lo, hi, k in zip(low, high, counts)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    targets = _targets(points, orientation)
    return _solve_on_one_branch(chain, targets, hint, low, high), targets


def uniform_joints(chain, n, rng):
    """``n`` joint vectors uniform within the limits: q_m = min_m + rand · (max_m - min_m).

    Unlimited revolute joints use -pi..pi.  rng: a numpy Generator or a seed.
    """
    n = _count(n)
    lower, upper = chain.lower.copy(), chain.upper.copy()
    unlimited = ~(np.isfinite(lower) & np.isfinite(upper))
    if np.any(unlimited & ~chain.revolute):
        j = int(np.argmax(unlimited & ~chain.revolute)) + 1
        raise InputError(f"prismatic joint {j} of robot {chain.name!r} has no limits to sample between; give it min and max")
    lower[unlimited], upper[unlimited] = -np.pi, np.pi
    return lower + np.random.default_rng(rng).random((n, chain.n_joints)) * (upper - lower)


def liu2022_plan(chain):
    """The published KR 150-2 experiment's 150 targets (see :mod:`robocal.simulation.liu2022`).

    Returns q (150, 6) rad, targets (150, 4, 4), and the indices of the 50 training points
    (the first 50) and of the 100 test points (the rest).  The published errors before
    compensation (mean 1.690 mm) are statistics over all 150 points, not the test points.
    """
    liu2022.require_kr150(chain, "the liu2022 sampling plan")
    posture = np.radians(liu2022.POSTURE_DEG)
    q, targets = latin_hypercube_box(
        chain, liu2022.N_POINTS, liu2022.BOX_LOW, liu2022.BOX_HIGH,
        chain.fk(posture)[:3, :3], seed=liu2022.SEED, hint=posture,
    )
    return q, targets, np.arange(liu2022.N_TRAIN), np.arange(liu2022.N_TRAIN, liu2022.N_POINTS)


# ----------------------------------------------------------------------------- helpers
def _count(n):
    if not float(n).is_integer() or n < 1:
        raise InputError(f"the number of points must be a whole number >= 1, got {n}")
    return int(n)


def _box(low, high):
    low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
    if low.shape != (3,) or high.shape != (3,) or not np.all(np.isfinite(low) & np.isfinite(high)):
        raise InputError("a box needs finite low = (x, y, z) and high = (x, y, z) in mm")
    if np.any(low > high):
        raise InputError(f"box low {low.tolist()} must not exceed high {high.tolist()} in any coordinate")
    return low, high


def _targets(points, orientation):
    """(N, 4, 4) poses at ``points`` (N, 3) with the rotation ``orientation``."""
    rotation = np.asarray(orientation, dtype=float)
    if rotation.shape != (3, 3) or not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-9) \
            or np.linalg.det(rotation) < 0:
        raise InputError("the TCP orientation must be a 3x3 rotation matrix")
    targets = np.zeros((points.shape[0], 4, 4))
    targets[:, :3, :3] = rotation
    targets[:, :3, 3] = points
    targets[:, 3, 3] = 1.0
    return targets


def _branch_of(chain, hint):
    """The index of the closed-form IK branch (see ``ik_all``) that the posture ``hint`` lies on."""
    q, valid = ik_all(chain, chain.fk(hint)[None])
    difference = q[0] - hint
    # A revolute joint's branch value may be the hint's plus whole turns.
    difference[:, chain.revolute] = np.angle(np.exp(1j * difference[:, chain.revolute]))
    distance = np.where(valid[0], np.linalg.norm(difference, axis=1), np.inf)
    first, second = np.argsort(distance)[:2]
    if distance[first] > BRANCH_TOL or distance[second] <= BRANCH_TOL:
        raise InputError(
            f"the posture hint {np.round(np.degrees(hint), 3).tolist()} deg is not a regular posture "
            "within the joint limits (it is beyond a limit or on a singularity where IK branches meet, "
            "such as a wrist axis at 0): give a hint inside the limits and away from singularities"
        )
    return int(first)


def _solve_on_one_branch(chain, targets, hint, low, high):
    """Nominal IK of every target on one branch; InputError naming the points that fail."""
    if hint is not None:
        hint = np.asarray(hint, dtype=float)
        if hint.shape != (chain.n_joints,):
            raise InputError(f"the posture hint needs {chain.n_joints} joint values, got shape {hint.shape}")
    try:
        closed_form(chain)
    except InputError:
        # No branches to choose from: the numerical solver starts every point from the hint
        # (or the zero configuration), which keeps them near its posture.
        branch = None
    else:
        if hint is None:
            branch = int(np.argmax(ik_all(chain, targets)[1].sum(axis=0)))
        else:
            branch = _branch_of(chain, hint)
    result = solve_ik(chain, targets, hint, branch=branch)
    failed = np.flatnonzero(~result.success)
    if failed.size:
        where = "" if branch is None else f" on IK branch {branch}"
        raise InputError(
            f"{failed.size} of {targets.shape[0]} points in the box x {low[0]:g}..{high[0]:g}, "
            f"y {low[1]:g}..{high[1]:g}, z {low[2]:g}..{high[2]:g} mm cannot be reached by robot "
            f"{chain.name!r}{where} within its joint limits with the requested orientation "
            f"(first: {np.round(targets[failed[0], :3, 3], 1).tolist()} mm); "
            "use a smaller box, or move it to where the robot reaches in that posture"
        )
    return result.q
