"""Sampling plans: where to send the robot to collect calibration or test data.

Cartesian plans (:func:`latin_hypercube_box`, :func:`grid`, :func:`liu2022_plan`) choose TCP
positions in a box of the world frame, all with one orientation, and command them with the
nominal inverse kinematics on *one* branch for every point: mixing branches (shoulder,
elbow, wrist flip) would mix error patterns that a smooth error model cannot share.
:func:`uniform_joints` samples joint space directly.  :func:`socket_plan` places a fixture
in the workspace and seats a ball on the tool in each of its sockets in varied orientations,
for the constraint calibration.

Joint values are controller joints in rad (mm for prismatic joints); positions are mm.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..io.observations import Observations
from ..io.tables import Measurements
from ..kinematics.ik import closed_form, ik_all, solve_ik
from ..spatial import make_transform, rot_z, so3_exp
from . import liu2022
from .true_robot import TrueRobot

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
    from scipy.stats import qmc  # loaded when used: the command line starts faster
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
        raise InputError(f"prismatic joint {j} of robot {chain.name!r} has no limits to sample "
                         "between; give it min and max")
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


# ------------------------------------------------------------------------ sockets
# Where a fixture may be placed, in the robot's base frame: horizontal distance from the
# joint-1 axis and height above the base as fractions of the reach (measured from the
# shoulder), in front of the robot (azimuth from +x).
PLACEMENT_RADIUS = (0.35, 0.7)
PLACEMENT_AZIMUTH_DEG = 75.0
PLACEMENT_HEIGHT = (0.0, 0.3)  # base level .. shoulder height + this fraction of the reach
PLACEMENT_TILT_DEG = 10.0
# Orientations tried per configuration wanted, and fixture poses tried per placement, before
# a placement (or the whole plan) is given up as out of reach.
CANDIDATES_PER_CONFIGURATION = 3
ATTEMPTS_PER_PLACEMENT = 20
HINT_POOL = 4096
# Joint readings that make a compliant / backlashed robot's ball reach the socket are found
# by fixed-point iteration; the deflections are ~1e-4 rad, so a few rounds reach rounding.
READING_ITERATIONS = 8


@dataclass(frozen=True, eq=False)
class SocketPlan:
    """Ball-in-socket data of a simulated robot.

    joints: (N, n) joint readings (rad, mm), with their noise; fixture_ids and socket_ids:
    (N,) strings; ball: (N, 3) true ball centres in the world frame (mm: socket centre plus
    seating error); placements: (K, 4, 4) fixture poses in the world frame (fixture ids are
    ``"P1"`` ... ``"PK"``).
    """

    joints: np.ndarray
    fixture_ids: np.ndarray
    socket_ids: np.ndarray
    ball: np.ndarray
    placements: np.ndarray

    def observations(self, fixture):
        """The plan as :class:`~robocal.io.observations.Observations` of ``fixture``'s sockets."""
        return Observations.of(self.joints, placement=self.fixture_ids, socket=self.socket_ids, fixture=fixture)

    def measurements(self, chain):
        """The plan as a measurement table (joints in file units, fixture and socket columns)."""
        return Measurements(path="", joints=chain.joints_to_file(self.joints),
                            fixture=self.fixture_ids, socket=self.socket_ids)


# Each configuration is chosen from a pool of candidate postures (~100 kB of work arrays
# apiece), so a plan this size already needs about a gigabyte.
MAX_SOCKET_CONFIGURATIONS = 10_000


def socket_plan(robot, fixture, placements, per_socket, rng=None, *, max_tilt_deg=30.0,
                joint_noise_deg=0.0, seating_mm=0.0):
    """Place ``fixture`` ``placements`` times in front of the robot and seat the ball (the
    tool origin) in each socket in ``per_socket`` configurations.

    robot: a Chain (the ball reaches the sockets on it exactly) or a TrueRobot (on its actual
    geometry, through its compliance and backlash: the readings are the joint values that
    put the real ball in the socket, in the order visited).  Each placement is a random
    fixture pose (yaw uniform, tilt up to 10 deg) within reach in front of the robot; each
    configuration approaches its socket from above, the tool z axis tilted from the fixture
    normal by up to ``max_tilt_deg`` and turned at random about itself; inverse kinematics
    from the nearest of a pool of random postures gives varied arm configurations.
    joint_noise_deg: Gaussian noise on the readings (deg; mm on prismatic joints);
    seating_mm: Gaussian error of the ball centre about the socket centre, per coordinate.
    rng: a numpy Generator or a seed.  Returns a :class:`SocketPlan`.
    """
    truth = robot if isinstance(robot, TrueRobot) else None
    chain = robot.actual if truth is not None else robot
    placements, per_socket = _count(placements), _count(per_socket)
    total = placements * per_socket * len(fixture.ids)
    if total > MAX_SOCKET_CONFIGURATIONS:
        raise InputError(f"{placements} placements x {len(fixture.ids)} sockets x {per_socket} per socket is {total:,} "
                         f"configurations, more than the {MAX_SOCKET_CONFIGURATIONS:,} a plan is made for (a real "
                         "session records tens per socket): ask for fewer placements or configurations per socket")
    options = {"max_tilt_deg": max_tilt_deg, "joint_noise_deg": joint_noise_deg, "seating_mm": seating_mm}
    for name, value in options.items():
        if not np.isfinite(value) or value < 0:
            raise InputError(f"{name} must be a finite value >= 0, got {value}")
    if max_tilt_deg >= 90.0:
        raise InputError(f"max_tilt_deg must be below 90 (the ball comes from above the socket), got {max_tilt_deg}")
    rng = np.random.default_rng(rng)
    sockets = np.array([fixture.sockets[s] for s in fixture.ids])
    workspace = _Workspace(chain)
    joints, fixture_ids, socket_ids, ball, poses = [], [], [], [], []
    for k in range(placements):
        for _ in range(ATTEMPTS_PER_PLACEMENT):
            pose = workspace.fixture_pose(sockets, rng)
            found = _seat(chain, workspace, pose, sockets, per_socket, max_tilt_deg, seating_mm, rng)
            if found is not None:
                break
        else:
            raise InputError(
                f"could not place fixture '{fixture.name}' so that robot {chain.name!r} reaches all its sockets "
                f"in {per_socket} orientations (tried {ATTEMPTS_PER_PLACEMENT} poses for placement {k + 1}): "
                "use a smaller fixture, fewer configurations per socket or a smaller max tilt"
            )
        q, centres, index = found
        joints.append(q)
        ball.append(centres)
        socket_ids.append(np.array(fixture.ids)[index])
        fixture_ids.append(np.full(len(q), f"P{k + 1}"))
        poses.append(pose)
    q_link = np.concatenate(joints)
    readings = q_link if truth is None else _readings(truth, q_link)
    noise = np.where(chain.revolute, np.radians(joint_noise_deg), joint_noise_deg)
    readings = readings + rng.normal(size=readings.shape) * noise
    return SocketPlan(readings, np.concatenate(fixture_ids), np.concatenate(socket_ids),
                      np.concatenate(ball), np.array(poses))


class _Workspace:
    """Reach and IK seeds of a chain, computed once per plan."""

    def __init__(self, chain):
        self.chain = chain
        zero = np.zeros(chain.n_joints)
        _, origins, _ = chain.joint_frames(zero)
        self.base = chain.base
        shoulder = origins[0, min(1, chain.n_joints - 1)]
        # A fixed seed: the pool is part of the method, not of the user's random draw.
        pool = chain.random_configurations(HINT_POOL, np.random.default_rng(0))
        pool_poses = chain.fk(pool)
        self.pool, self.pool_poses = pool, pool_poses
        local = _to_base(chain.base, np.concatenate([pool_poses[:, :3, 3], shoulder[None]]))
        self.shoulder = local[-1]
        self.reach = float(np.max(np.linalg.norm(local[:-1] - self.shoulder, axis=1)))

    def fixture_pose(self, sockets, rng):
        """A random fixture pose (world frame) with the sockets' centroid in the placement region."""
        radius = self.reach * rng.uniform(*PLACEMENT_RADIUS)
        azimuth = np.radians(rng.uniform(-PLACEMENT_AZIMUTH_DEG, PLACEMENT_AZIMUTH_DEG))
        height = rng.uniform(0.0, self.shoulder[2] + PLACEMENT_HEIGHT[1] * self.reach)
        centre = np.array([radius * np.cos(azimuth), radius * np.sin(azimuth), height])
        tilt_axis = np.array([*_unit_circle(rng), 0.0])
        tilt = so3_exp(tilt_axis * np.radians(rng.uniform(0.0, PLACEMENT_TILT_DEG)))
        rotation = tilt @ rot_z(rng.uniform(-np.pi, np.pi))
        local = make_transform(rotation, centre - rotation @ sockets.mean(axis=0))
        return self.base @ local

    def hints(self, targets, lever):
        """The pool posture nearest to each target (position, and orientation at ``lever`` mm)."""
        position = np.linalg.norm(self.pool_poses[None, :, :3, 3] - targets[:, None, :3, 3], axis=2)
        # 3 - trace(R_a^T R_b) grows with the angle between the orientations.
        trace = np.einsum("pij,tij->tp", self.pool_poses[:, :3, :3], targets[:, :3, :3])
        return self.pool[np.argmin(position + lever * (3.0 - trace), axis=1)]


def _seat(chain, workspace, pose, sockets, per_socket, max_tilt_deg, seating_mm, rng):
    """Configurations seating the ball in every socket of a fixture at ``pose``, or None if
    some socket has fewer than ``per_socket`` reachable orientations."""
    count = len(sockets) * per_socket * CANDIDATES_PER_CONFIGURATION
    index = np.repeat(np.arange(len(sockets)), per_socket * CANDIDATES_PER_CONFIGURATION)
    centres = sockets[index] @ pose[:3, :3].T + pose[:3, 3]
    centres = centres + rng.normal(size=centres.shape) * seating_mm
    # Tool z against the fixture normal, tilted about a random horizontal axis of the
    # fixture, turned about itself at random.
    down = pose[:3, :3] @ np.diag([1.0, -1.0, -1.0])
    tilt = np.column_stack([*_unit_circle(rng, count), np.zeros(count)])
    tilt *= np.radians(rng.uniform(0.0, max_tilt_deg, count))[:, None]
    spin = np.column_stack([np.zeros((count, 2)), rng.uniform(-np.pi, np.pi, count)])
    rotations = so3_exp(tilt @ pose[:3, :3].T) @ down @ so3_exp(spin)
    targets = np.zeros((count, 4, 4))
    targets[:, :3, :3], targets[:, :3, 3], targets[:, 3, 3] = rotations, centres, 1.0
    result = solve_ik(chain, targets, workspace.hints(targets, workspace.reach))
    chosen = []
    for s in range(len(sockets)):
        ok = np.flatnonzero(result.success & (index == s))
        if ok.size < per_socket:
            return None
        chosen.append(ok[:per_socket])
    chosen = np.concatenate(chosen)
    return result.q[chosen], centres[chosen], index[chosen]


def _readings(truth, q_link):
    """Joint readings whose real link values (compliance, backlash) are ``q_link``."""
    readings = q_link.copy()
    for _ in range(READING_ITERATIONS):
        readings = readings - (truth.joints(readings) - q_link)
    return readings


def _unit_circle(rng, count=None):
    angle = rng.uniform(-np.pi, np.pi, count)
    return np.cos(angle), np.sin(angle)


def _to_base(base, points):
    return (points - base[:3, 3]) @ base[:3, :3]
