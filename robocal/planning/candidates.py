"""Candidate configurations a design chooses from.

* :func:`joint_candidates`: uniform or Latin-hypercube joint vectors within the joint limits
  less a margin;
* :func:`box_candidates`: Latin-hypercube TCP positions in a Cartesian box, all with one TCP
  orientation, each solved by the nominal inverse kinematics on one arm branch (as
  :func:`robocal.simulation.latin_hypercube_box`, but positions out of reach are dropped
  rather than refused);
* :func:`usable`: the candidates away from joint limits and singularities.

Joint values are controller joints in rad (mm for prismatic joints).
"""
import numpy as np

from ..errors import InputError
from ..kinematics.ik import closed_form, ik_all, solve_ik

SAMPLINGS = ("uniform", "lhs")
# The default margin from joint limits and from singularities (deg): a pose at a limit is
# where a robot stops with an error, and one near a singularity is where small joint errors
# are amplified and IK branches meet.
MARGIN_DEG = 5.0
# How many candidates a design draws by default.
DEFAULT_COUNT = 10_000
# A Cartesian box must leave at least this share of its candidates reachable (after the
# margins) for the design to stand for the box.
REACHABLE_SHARE = 0.05
# Rounds of draws that replace the configurations near a singularity before giving up.
DRAWS = 20
# Configurations that set the typical distance from singularities (a fixed draw).
SINGULARITY_REFERENCE = 2000


def _limits(chain, margin):
    """(lower, upper) sampling limits: the joint limits less ``margin`` rad on revolute
    joints; an unlimited revolute joint spans -pi..pi."""
    lower, upper = chain.lower.copy(), chain.upper.copy()
    unlimited = ~(np.isfinite(lower) & np.isfinite(upper))
    if np.any(unlimited & ~chain.revolute):
        j = int(np.argmax(unlimited & ~chain.revolute)) + 1
        raise InputError(f"prismatic joint {j} of robot {chain.name!r} has no limits to sample between; "
                         "give it min and max in the robot file")
    lower[unlimited], upper[unlimited] = -np.pi, np.pi
    shrink = np.where(chain.revolute & ~unlimited, margin, 0.0)
    lower, upper = lower + shrink, upper - shrink
    if np.any(lower >= upper):
        j = int(np.argmax(lower >= upper)) + 1
        raise InputError(f"a margin of {np.degrees(margin):g} deg leaves nothing of joint {j}'s range: "
                         "give a smaller --margin")
    return lower, upper


def joint_candidates(chain, count, seed=0, *, sampling="uniform", margin_deg=MARGIN_DEG, volume=None):
    """``count`` joint vectors (count, n) rad drawn ``uniform`` or as a Latin hypercube
    (``lhs``) within the limits less ``margin_deg``, those near a singularity (see
    :func:`usable`) or, with ``volume`` (a :class:`~robocal.planning.workspace.WorkingVolume`),
    outside the working volume replaced by further draws; reproducible for ``seed``."""
    from scipy.stats import qmc  # loaded when used: the command line starts faster
    if sampling not in SAMPLINGS:
        raise InputError(f"sampling must be one of {', '.join(SAMPLINGS)}, got {sampling!r}")
    lower, upper = _limits(chain, np.radians(margin_deg))
    rng = np.random.default_rng(seed)
    kept = []
    for _ in range(DRAWS):
        if sampling == "lhs":
            unit = qmc.LatinHypercube(d=chain.n_joints, seed=rng).random(count)
        else:
            unit = rng.random((count, chain.n_joints))
        q = lower + unit * (upper - lower)
        q = q[usable(chain, q, margin_deg)]
        kept.append(q if volume is None else q[volume.inside(chain, q)])
        if sum(len(k) for k in kept) >= count:
            return np.concatenate(kept)[:count]
    if volume is not None:
        raise InputError(f"hardly any configuration of robot {chain.name!r} keeps the arm in the working volume "
                         f"({volume.describe()}) {margin_deg:g} deg from its singularities: check --floor and --walls "
                         "(mm, robot base frame)")
    raise InputError(f"hardly any configuration of robot {chain.name!r} lies {margin_deg:g} deg from its "
                     "singularities: give a smaller --margin")


def _branch(chain, targets, hint):
    """The closed-form branch to solve every target on: the hint's (nearest to it), else the
    one that reaches the most targets; None when the chain has no closed form."""
    try:
        closed_form(chain)
    except InputError:
        return None
    valid = ik_all(chain, targets)[1]
    if hint is None:
        return int(np.argmax(valid.sum(axis=0)))
    q, ok = ik_all(chain, chain.fk(hint)[None])
    difference = q[0] - hint
    difference[:, chain.revolute] = np.angle(np.exp(1j * difference[:, chain.revolute]))
    return int(np.argmin(np.where(ok[0], np.linalg.norm(difference, axis=1), np.inf)))


def box_candidates(chain, count, low, high, orientation, seed=0, *, hint=None, margin_deg=MARGIN_DEG, volume=None):
    """Joint vectors putting the TCP at ``count`` Latin-hypercube points of the box
    ``low``..``high`` (x, y, z mm, robot base frame) with the rotation ``orientation`` (3x3),
    on one IK branch (the ``hint`` posture's, rad, else the one reaching most points), kept
    where they are reachable, ``margin_deg`` inside the joint limits and away from
    singularities.  InputError when too little of the box is reachable so."""
    from scipy.stats import qmc  # loaded when used: the command line starts faster

    low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
    if np.any(low > high):
        raise InputError(f"box low {low.tolist()} must not exceed high {high.tolist()} in any coordinate (mm)")
    rotation = np.asarray(orientation, dtype=float)
    unit = qmc.LatinHypercube(d=3, seed=np.random.default_rng(seed)).random(count)
    targets = np.zeros((count, 4, 4))
    targets[:, :3, :3], targets[:, :3, 3], targets[:, 3, 3] = rotation, low + unit * (high - low), 1.0
    if hint is not None:
        hint = chain.joint_batch(hint)[0]
    result = solve_ik(chain, targets, hint, branch=_branch(chain, targets, hint) if hint is None else None)
    q = result.q[result.success]
    q = q[usable(chain, q, margin_deg)] if len(q) else q
    if volume is not None and len(q):
        q = q[volume.inside(chain, q)]
    if len(q) < max(REACHABLE_SHARE * count, 1):
        raise InputError(
            f"only {len(q)} of {count} points of the box x {low[0]:g}..{high[0]:g}, y {low[1]:g}..{high[1]:g}, "
            f"z {low[2]:g}..{high[2]:g} mm are reachable by robot {chain.name!r} with that orientation, "
            f"{margin_deg:g} deg from its joint limits and singularities"
            + ("" if volume is None else f", with {volume.describe()}") + ": move the box to where the robot reaches "
            "in that posture (robot base frame, mm), or change --rpy or --margin")
    return q


def _smallest_singular_value(chain, joints, reach):
    rigid = chain.rigid
    jac = rigid.jacobian(joints)
    scaled = np.concatenate([jac[:, :3, :] / reach, jac[:, 3:, :]], axis=1)
    return np.linalg.svd(scaled, compute_uv=False)[:, -1]


def singularity_measure(chain, joints):
    """(N,) how far each configuration is from a singularity: the smallest singular value of
    the geometric Jacobian (position rows divided by the reach), over its median across
    configurations uniform in the limits: a typical configuration scores 1, a singular one 0
    (the KR 150-2's wrist scores 0.39, 0.16 and 0.04 at 5, 2 and 0.5 deg from q5 = 0)."""
    rigid = chain.rigid
    reference = rigid.random_configurations(SINGULARITY_REFERENCE, np.random.default_rng(0))
    reach = max(float(np.max(np.linalg.norm(rigid.replace(base=np.eye(4)).fk_positions(reference), axis=1))), 1.0)
    typical = float(np.median(_smallest_singular_value(rigid, reference, reach)))
    return _smallest_singular_value(rigid, np.asarray(joints, dtype=float), reach) / max(typical, 1e-300)


def usable(chain, joints, margin_deg=MARGIN_DEG):
    """(N,) mask of configurations ``margin_deg`` inside the joint limits of revolute joints
    and with :func:`singularity_measure` at least sin(margin_deg) (5 deg: 0.087, which leaves
    out the 2-5 % of uniform configurations of the built-in robots closest to a singularity)."""
    q = np.asarray(joints, dtype=float)
    margin = np.radians(margin_deg)
    shrink = np.where(chain.revolute, margin, 0.0)
    inside = np.all((q >= chain.lower + shrink) & (q <= chain.upper - shrink), axis=1)
    return inside & (singularity_measure(chain, q) >= np.sin(margin))
