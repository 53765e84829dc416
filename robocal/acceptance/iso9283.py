"""ISO 9283 pose characteristics: what a robot's buyer and integrator state its accuracy in.

A measurement campaign of the standard visits the same commanded poses (P1..P5 on the
diagonal plane of a cube in the working range) for n cycles (30), and an instrument measures
each visit.  Per commanded pose (positions in mm, orientations a, b, c in deg, about x, y, z):

* pose accuracy: the barycentre of the attained positions against the command,
  ``APx = x̄ - x_c`` (and y, z), ``AP = sqrt(APx² + APy² + APz²)``; orientations
  ``APa = ā - a_c`` (and b, c);
* pose repeatability: ``RP = l̄ + 3 S_l``, where ``l_j`` is the distance of visit j from the
  barycentre and ``S_l = sqrt(Σ (l_j - l̄)² / (n - 1))``; orientations ``RPa = 3 S_a``,
  ``S_a = sqrt(Σ (a_j - ā)² / (n - 1))``;

and between two commanded poses (the standard takes P2 and P4), distance accuracy
``AD = D̄ - D_c`` (attained distances ``D_j = |P1_j - P2_j|`` of the same cycle, commanded
``D_c``) and distance repeatability ``RD = 3 S_D``.

Real controllers never command a repeat visit bit for bit (UR10 series D wanders by up to
0.88 mm between cycles), so visits are grouped by a pose name when the file has one, else by
commanded position within a stated tolerance (:func:`group_visits`), and the commands' own
spread is reported beside the figures.  Angles are differenced on the circle, so that a
pose near ±180 deg is not split in two.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError

CYCLES = 30
# The standard's five poses lie on the cube's diagonal plane, P2..P5 at this share of the
# plane's diagonal from its corners.
CORNER_SHARE = 0.1
# Commanded positions of one pose's visits are grouped when they lie within this (mm).
DEFAULT_MATCH_MM = 2.0


def _wrapped(degrees):
    """Angles (deg) wrapped into [-180, 180)."""
    return (np.asarray(degrees, dtype=float) + 180.0) % 360.0 - 180.0


def _circular_mean(degrees, around):
    """The mean (deg) of ``degrees`` (n,) differenced from ``around`` on the circle."""
    return around + np.mean(_wrapped(np.asarray(degrees) - around))


@dataclass(frozen=True)
class PoseCharacteristics:
    """ISO 9283 figures of one commanded pose (mm, deg): ``n`` visits; accuracy ``AP``,
    ``APx/y/z``; repeatability ``RP``; with orientations ``APa/b/c`` and ``RPa/b/c`` (else
    None); ``command_spread_mm``: the largest distance of a visit's command from their mean
    (0 for commands repeated exactly)."""

    pose: str
    n: int
    AP: float
    APx: float
    APy: float
    APz: float
    RP: float
    command_spread_mm: float
    APa: float | None = None
    APb: float | None = None
    APc: float | None = None
    RPa: float | None = None
    RPb: float | None = None
    RPc: float | None = None

    def to_dict(self):
        out = {"pose": self.pose, "n": self.n, "AP_mm": self.AP, "APx_mm": self.APx, "APy_mm": self.APy,
               "APz_mm": self.APz, "RP_mm": self.RP}
        for name in ("APa", "APb", "APc", "RPa", "RPb", "RPc"):
            out[f"{name}_deg"] = getattr(self, name)
        out["command_spread_mm"] = self.command_spread_mm
        return out


def pose_characteristics(name, commanded, attained, commanded_angles=None, attained_angles=None):
    """:class:`PoseCharacteristics` of one pose from its ``n`` visits: ``commanded`` and
    ``attained`` (n, 3) mm, optionally orientations (n, 3) deg (a, b, c about x, y, z).

    Raises:
        InputError: fewer than two visits (repeatability needs n - 1 >= 1).
    """
    commanded = np.asarray(commanded, dtype=float)
    attained = np.asarray(attained, dtype=float)
    n = len(attained)
    if n < 2:
        raise InputError(f"pose {name} has {n} visit: ISO 9283 repeatability needs at least two cycles (30 by the "
                         "standard)")
    command = commanded.mean(axis=0)
    barycentre = attained.mean(axis=0)
    bias = barycentre - command
    distances = np.linalg.norm(attained - barycentre, axis=1)
    repeatability = distances.mean() + 3.0 * distances.std(ddof=1)
    spread = float(np.linalg.norm(commanded - command, axis=1).max())
    angles = {}
    if commanded_angles is not None and attained_angles is not None:
        commanded_angles = np.asarray(commanded_angles, dtype=float)
        attained_angles = np.asarray(attained_angles, dtype=float)
        for k, axis in enumerate("abc"):
            command_angle = _circular_mean(commanded_angles[:, k], commanded_angles[0, k])
            mean = _circular_mean(attained_angles[:, k], command_angle)
            angles[f"AP{axis}"] = float(_wrapped(mean - command_angle))
            angles[f"RP{axis}"] = float(3.0 * np.std(_wrapped(attained_angles[:, k] - mean), ddof=1))
    return PoseCharacteristics(str(name), n, float(np.linalg.norm(bias)), *map(float, bias), float(repeatability),
                               spread, **angles)


@dataclass(frozen=True)
class DistanceCharacteristics:
    """ISO 9283 distance figures between two poses (mm): ``AD``, ``RD``, the commanded
    distance ``commanded_mm`` and the ``n`` cycles both poses were visited in."""

    between: tuple
    n: int
    commanded_mm: float
    AD: float
    RD: float

    def to_dict(self):
        return {"between": list(self.between), "n": self.n, "commanded_mm": self.commanded_mm, "AD_mm": self.AD,
                "RD_mm": self.RD}


def distance_characteristics(between, commanded_1, commanded_2, attained_1, attained_2):
    """:class:`DistanceCharacteristics` of poses ``between`` = (name 1, name 2) from their
    visits in the same cycles: commanded and attained positions (n, 3) mm each."""
    n = len(attained_1)
    if n < 2 or len(attained_2) != n:
        raise InputError(f"distance {between[0]}-{between[1]} needs the two poses visited in the same two or more "
                         "cycles")
    commanded = float(np.linalg.norm(np.mean(commanded_1, axis=0) - np.mean(commanded_2, axis=0)))
    attained = np.linalg.norm(np.asarray(attained_1, float) - np.asarray(attained_2, float), axis=1)
    return DistanceCharacteristics(tuple(between), n, commanded, float(attained.mean() - commanded),
                                   float(3.0 * attained.std(ddof=1)))


def group_visits(commanded, names=None, tolerance_mm=DEFAULT_MATCH_MM):
    """(labels (N,) int, pose names): which commanded pose each row visits.  By ``names``
    ((N,) text) when given; else rows whose commanded positions (N, 3) mm lie within
    ``tolerance_mm`` of a pose's first visit are that pose's (in order of first visit,
    named P1, P2, ...).

    Raises:
        InputError: two poses' commands nearer than ``tolerance_mm`` to each other's (the
            grouping would be ambiguous: give a pose column or a smaller tolerance).
    """
    commanded = np.asarray(commanded, dtype=float)
    if names is not None:
        unique, first = np.unique(np.asarray(names).astype(str), return_index=True)
        order = unique[np.argsort(first)]
        index = {name: k for k, name in enumerate(order)}
        return np.array([index[str(v)] for v in names]), [str(v) for v in order]
    centres, labels = [], np.empty(len(commanded), dtype=int)
    for row, point in enumerate(commanded):
        near = [k for k, c in enumerate(centres) if np.linalg.norm(point - c) <= tolerance_mm]
        if len(near) > 1:
            raise InputError(f"row {row + 1}'s command lies within {tolerance_mm:g} mm of poses "
                             f"P{near[0] + 1} and P{near[1] + 1}: give a pose column, or a smaller --match-mm")
        if near:
            labels[row] = near[0]
        else:
            labels[row] = len(centres)
            centres.append(point)
    return labels, [f"P{k + 1}" for k in range(len(centres))]


def cycles_of(labels):
    """(N,) cycle number of each row: the how-many-th visit of its pose it is."""
    labels = np.asarray(labels)
    cycle = np.zeros(len(labels), dtype=int)
    seen = {}
    for row, label in enumerate(labels):
        cycle[row] = seen.get(label, 0)
        seen[label] = cycle[row] + 1
    return cycle


def cube_poses(centre, edge_mm):
    """(5, 3) mm: the standard's P1..P5 in a cube of ``edge_mm`` about ``centre``: P1 its
    centre, P2..P5 on the diagonal plane through two opposite edges, CORNER_SHARE of the
    plane's diagonal in from its corners."""
    centre = np.asarray(centre, dtype=float)
    half = edge_mm / 2.0
    # The plane through the bottom edge at -y and the top edge at +y (C1-C2-C7-C8).
    corners = np.array([[-half, -half, -half], [half, -half, -half], [half, half, half], [-half, half, half]])
    inward = (0.0 - corners) * (2.0 * CORNER_SHARE)  # towards the plane's centre, a share of the diagonal
    return np.vstack([centre, centre + corners + inward])


# The pair of poses the standard measures distance characteristics between.
DISTANCE_POSES = ("P2", "P4")


@dataclass(frozen=True)
class Iso9283Result:
    """The ISO 9283 figures of a campaign: ``poses`` (:class:`PoseCharacteristics`, in order
    of first visit), ``distance`` (:class:`DistanceCharacteristics` or None when the
    campaign has no P2 and P4), how visits were matched (``matched_by``), the file, and the
    poses ``visited_once`` (no repeatability: left out of the figures)."""

    path: str
    poses: tuple
    distance: DistanceCharacteristics | None
    matched_by: str
    visited_once: tuple = ()

    def to_dict(self):
        return {"file": self.path, "matched_by": self.matched_by, "poses": [p.to_dict() for p in self.poses],
                "distance": None if self.distance is None else self.distance.to_dict(),
                "visited_once": list(self.visited_once)}


def characteristics(campaign, *, match_mm=DEFAULT_MATCH_MM, positions=None):
    """:class:`Iso9283Result` of ``campaign`` (:class:`~robocal.io.iso_campaign.IsoCampaign`);
    ``positions`` (N, 3) mm replaces the measured positions (the compensated robot's)."""
    attained = campaign.attained if positions is None else np.asarray(positions, dtype=float)
    labels, names = group_visits(campaign.commanded, campaign.pose, match_mm)
    matched = "the pose column" if campaign.pose is not None else f"commanded position within {match_mm:g} mm"
    with_angles = campaign.commanded_angles is not None
    counts = np.bincount(labels, minlength=len(names))
    once = tuple(name for name, count in zip(names, counts) if count < 2)
    if len(once) == len(names):
        raise InputError(f"{campaign.path}: every commanded pose is visited once: ISO 9283 repeatability needs each "
                         "pose visited in at least two cycles (30 by the standard); give a pose column, or a larger "
                         "--match-mm if the commands wander")
    poses = []
    for k, name in enumerate(names):
        rows = labels == k
        if counts[k] < 2:
            continue  # a pose visited once has no repeatability: listed in visited_once
        poses.append(pose_characteristics(
            name, campaign.commanded[rows], attained[rows],
            campaign.commanded_angles[rows] if with_angles else None,
            campaign.attained_angles[rows] if with_angles else None))
    distance = None
    if all(p in names for p in DISTANCE_POSES):
        cycle = cycles_of(labels) if campaign.cycle is None else np.asarray(campaign.cycle)
        first, second = (labels == names.index(p) for p in DISTANCE_POSES)
        common = np.intersect1d(cycle[first], cycle[second])
        # The first visit of each pose in every cycle both were visited in.
        pick = [np.array([np.flatnonzero(side & (cycle == c))[0] for c in common], dtype=int)
                for side in (first, second)]
        if len(common) >= 2:
            distance = distance_characteristics(DISTANCE_POSES, campaign.commanded[pick[0]],
                                                campaign.commanded[pick[1]], attained[pick[0]], attained[pick[1]])
    return Iso9283Result(campaign.path, tuple(poses), distance, matched, once)


# What the predicted figures of the compensated robot are, said wherever they are shown.
PREDICTED_NOTE = ("predicted, not measured: each visit's measured position less the model's predicted systematic "
                  "error at its joint command (where the model says the TCP goes less where the controller's nominal "
                  "robot puts it: what compensation would have removed); RP is unchanged by "
                  "construction where a pose's commands repeat (the prediction is then one vector per pose), "
                  "and orientations are not predicted")


def predicted_compensated(campaign, systematic, *, match_mm=DEFAULT_MATCH_MM):
    """:class:`Iso9283Result` the compensated robot is predicted to reach on ``campaign``:
    the attained positions less ``systematic`` (N, 3) mm, a model's predicted systematic
    error at each visit's joint command in the campaign's frame (:data:`PREDICTED_NOTE`).
    Position figures only: the orientation ones are None."""
    systematic = np.asarray(systematic, dtype=float)
    if systematic.shape != campaign.attained.shape:
        raise InputError(f"the systematic error must be one (x, y, z) per visit, {campaign.attained.shape}, got "
                         f"{systematic.shape}")
    positions_only = replace(campaign, commanded_angles=None, attained_angles=None)
    return characteristics(positions_only, match_mm=match_mm, positions=campaign.attained - systematic)


# Cube edges tried by plan_campaign, as shares of the robot's reach, largest first: the
# standard asks for the largest cube in the part of the working range used most.
EDGE_SHARES = (0.5, 0.4, 0.3, 0.25, 0.2, 0.15, 0.1)


@dataclass(frozen=True)
class CampaignPlan:
    """The commanded poses of an ISO 9283 campaign: ``names`` (5,), ``positions`` (5, 3) mm
    and ``rpy_deg`` (3,) of every pose (robot base frame), ``joints`` (5, n) rad on one arm
    branch, the cube's ``centre`` and ``edge_mm``, and ``cycles``."""

    names: tuple
    positions: np.ndarray
    rpy_deg: np.ndarray
    joints: np.ndarray
    centre: np.ndarray
    edge_mm: float
    cycles: int


def plan_campaign(chain, *, centre=None, edge_mm=None, rpy_deg=(180.0, 0.0, 0.0), cycles=CYCLES, volume=None):
    """The standard's five poses in a cube of ``chain``'s working range, TCP orientation
    ``rpy_deg`` everywhere, all solved on one arm branch inside the limits and the working
    ``volume`` (:class:`~robocal.planning.workspace.WorkingVolume`, default above the mounting
    plane).  Without ``centre`` (mm, robot base frame) the cube is centred where the robot's
    reachable configurations put the TCP most often; without ``edge_mm`` it is the largest
    of EDGE_SHARES of the reach whose poses are all reachable so.

    Raises:
        InputError: no cube of the given (or any tried) size is reachable.
    """
    from ..kinematics.ik import solve_ik
    from ..planning.workspace import WorkingVolume
    from ..spatial import compose_pose

    volume = WorkingVolume() if volume is None else volume
    mounted = chain.replace(base=np.eye(4))
    sample = mounted.random_configurations(4000, np.random.default_rng(0))
    sample = sample[volume.inside(mounted, sample)]
    tcp = mounted.fk_positions(sample)
    reach = float(np.linalg.norm(tcp, axis=1).max())
    if centre is None:
        # In front of the robot (along +x, then the other sides), at the height and radius
        # where its reachable configurations put the TCP most often: where it works.
        radius = np.median(np.linalg.norm(tcp[:, :2], axis=1))
        height = float(np.median(tcp[:, 2]))
        centres = [np.array([c * r * radius, s * r * radius, height]) for r in (1.0, 0.8, 1.2)
                   for c, s in ((1, 0), (0, -1), (-1, 0), (0, 1))]
    else:
        centres = [np.asarray(centre, dtype=float)]
    rpy = np.asarray(rpy_deg, dtype=float)
    edges = [edge_mm] if edge_mm is not None else [share * reach for share in EDGE_SHARES]
    for edge in edges:
        for middle in centres:
            points = cube_poses(middle, edge)
            targets = compose_pose(points, np.radians(np.broadcast_to(rpy, points.shape)))
            solved = solve_ik(mounted, targets, hint=sample[np.argmin(np.linalg.norm(tcp - middle, axis=1))])
            if solved.success.all() and volume.inside(mounted, solved.q).all():
                return CampaignPlan(("P1", "P2", "P3", "P4", "P5"), points, rpy, solved.q, middle, float(edge), cycles)
    # The numbers as given (a centre or an edge typed to the tenth is not shown rounded to
    # another one), the edges tried to the mm.
    shown = ", ".join(f"{e:g}" for e in edges) if edge_mm is not None else ", ".join(f"{e:.0f}" for e in edges)
    raise InputError(f"no ISO 9283 cube of edge {shown} mm "
                     + ("" if centre is None else f"about {', '.join(f'{v:g}' for v in centres[0])} mm ")
                     + f"is reachable by '{chain.name}' with the TCP at "
                     f"rx, ry, rz = {', '.join(f'{v:g}' for v in rpy)} deg on one arm branch: give --centre, --edge "
                     "or --rpy")
