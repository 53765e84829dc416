"""The domain of validity of a fitted method: where its training data were.

A calibration is a fit to the configurations it was trained on; a Kriging or network error
model, and even a kinematic model that absorbed compliance into its geometry, may be far off
outside them.  :class:`Domain` records, from the training data:

* the range of every joint seen (rad; mm for prismatic joints);
* the arm branches seen (shoulder, elbow, wrist flip), as the closed-form inverse kinematics
  of 6R arms numbers them (:func:`robocal.kinematics.ik.ik_all`), when the robot has one;
* the box of the measured TCP positions (mm, measurement frame), for position data;
* the fixture placements, for ball-in-socket data (reported, not judged: an id names a
  place in one session only);
* the training configurations themselves, scaled by each joint's range, so that a
  configuration far from all of them is caught although each joint lies inside its range.

:meth:`Domain.check` says for each configuration whether it lies inside, and why not.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from ..errors import FileFormatError, InputError
from ..kinematics.ik import closed_form
from ..kinematics.ik.one import Degenerate
from ..kinematics.program import PointProgram

# A joint may pass its training range by this fraction of the range, or by the minimum below,
# whichever is larger, and still count as inside.  Measured on 20 random 50/50 splits: of the
# held-out poses, 1.9 % pass some training range at all and 0.9 % by more than 2 % (UR5
# Tsinghua); 1.6 % and 0.4 % (UR10 B).  Trained on the lower half of q2 on a compliant
# KR 150-2 (tests/test_domain.py), every held-out pose whose error exceeds three times the
# in-domain error lies beyond this margin, for the kinematic and the Kriging model alike.
RANGE_MARGIN_FRACTION = 0.02
RANGE_MARGIN_MIN_DEG = 1.0
RANGE_MARGIN_MIN_MM = 1.0  # prismatic joints
# The measured positions' box: the same fraction of its extent, at least this much (mm).
BOX_MARGIN_FRACTION = 0.02
BOX_MARGIN_MIN_MM = 5.0
# Which bit of a branch index is which, and the joint (0-based) whose two values tell the two
# sides apart, for each closed form (see robocal/kinematics/ik/opw.py and ur.py).
BRANCH_BITS = {
    "spherical-wrist": (("shoulder", 4, 0), ("elbow", 2, 2), ("wrist", 1, 4)),
    "UR-type": (("shoulder", 4, 0), ("wrist", 2, 4), ("elbow", 1, 2)),
}
# Within this of the singularity that separates a side from the other (the defining joint
# differing by less than twice this from its value on the other side), a configuration
# belongs to both sides: it is not judged by its branch.  5 deg leaves out 1 % of the UR10 B
# wrist flips and none of the UR5 (Tsinghua) poses.
BRANCH_SINGULAR = np.radians(5.0)
# A configuration that matches none of the closed form's branches within this (rad, joint
# space norm) lies beyond the limits the closed form keeps; its branch is not judged.
BRANCH_MATCH = 1e-4
# Nearest training configuration, in joint space scaled by each joint's training range: a
# configuration counts as inside when its nearest training configuration is within
# NEIGHBOUR_FACTOR times the 95th percentile of the training configurations' own
# nearest-neighbour distances.  On random 50/50 splits the held-out poses' distance is at
# most 0.5 of that radius (99th percentile) on the UR5 and UR10 B data; on the UR10 A grid
# 2 to 8 of 5,956 held-out poses pass it.
NEIGHBOUR_FACTOR = 3.0
NEIGHBOUR_PERCENTILE = 95.0
# Training configurations kept for the nearest-neighbour criterion (a random subset beyond:
# the file stays below 200 kB, and the radius is measured on the same subset).
NEIGHBOUR_KEEP = 2000
# Pairwise distances are computed in blocks of this many rows (memory, not speed).
BLOCK = 1024


def arm_branches(chain, joints):
    """The arm branch of each configuration, as the closed form numbers them.

    Parameters
    ----------
    chain : Chain
        The robot (its nominal model: the branches are those of its closed form).
    joints : (N, n) array
        Controller joints, rad (mm for prismatic joints).

    Returns
    -------
    (kind, sides) : (str, dict) or None
        ``kind`` names the closed form ("spherical-wrist", "UR-type"); ``sides`` maps
        "shoulder", "elbow" and "wrist" to an (N,) int array: 0 or 1 for the side of that
        choice, -1 where the configuration is too near the singularity between them (or
        beyond the closed form's limits) to say.  None when the robot has no closed form.
    """
    try:
        solver = closed_form(chain)
    except InputError:
        return None
    q = np.asarray(joints, dtype=float)
    poses = chain.fk(q)
    branches, valid = solver.solve(poses, reference=q) if solver.exact else solver.seeds(poses, reference=q)[:2]
    distance = np.where(valid, np.linalg.norm(branches - q[:, None, :], axis=2), np.inf)
    own = np.argmin(distance, axis=1)
    matched = distance[np.arange(len(q)), own] <= BRANCH_MATCH
    sides = {}
    for name, bit, joint in BRANCH_BITS[solver.kind]:
        other = branches[np.arange(len(q)), own ^ bit, joint]
        with np.errstate(invalid="ignore"):
            # The other side's solution beyond the limits (NaN) is as good as far away.
            near = np.abs(np.angle(np.exp(1j * (other - q[:, joint])))) < 2.0 * BRANCH_SINGULAR
        sides[name] = np.where(matched & ~near, (own & bit) // bit, -1)
    return solver.kind, sides


@dataclass(frozen=True)
class DomainCheck:
    """Where a set of configurations lies with respect to a :class:`Domain`.

    inside : (N,) bool
        True for the configurations inside the training domain.
    reasons : tuple of str
        Per configuration, why it lies outside ("" when inside); several reasons are joined
        with "; ".
    counts : dict
        Reason category ("q2 beyond its training range", "another elbow branch", ...) ->
        how many configurations it applies to.
    summary : str
        One line for the user.
    """

    inside: np.ndarray
    reasons: tuple
    counts: dict
    summary: str

    @property
    def n_outside(self):
        return int(np.count_nonzero(~self.inside))


@dataclass(frozen=True)
class Domain:
    """The training data's domain (see the module docstring); build it with :meth:`of`.

    chain : Chain
        The nominal robot (its joint units and arm branches); not part of the document.
    joint_min, joint_max, joint_margin : (n,) arrays
        Training range of each joint and how far beyond it still counts as inside (rad; mm
        for prismatic joints).
    branch_kind : str or None
        The closed form whose branches ``branches`` names; None when the robot has none.
    branches : dict
        "shoulder" / "elbow" / "wrist" -> tuple of the sides (0, 1) the training data saw.
    box_min, box_max : (3,) arrays or None
        The training TCP positions' box in the measurement frame, mm (position data).
    box_margin : float
        mm beyond the box that still count as inside.
    placements : tuple of str or None
        The fixture placements of ball-in-socket training data.
    neighbours : (M, n) array or None
        Training configurations (a subset of at most NEIGHBOUR_KEEP), rad / mm.
    neighbour_radius : float
        Nearest-neighbour distance beyond which a configuration is outside, in joint space
        scaled by each joint's training range (dimensionless).
    n_poses : int
        The training poses the domain was computed from.
    frames : tuple or None
        A re-registered model's (names, (P, P) covariance in mm and rad, limit mm): the
        posterior of the base and tool its few poses gave; a configuration where that
        uncertainty moves the TCP by more than the limit (the model's own error) lies outside,
        since there the re-registration, not the model, decides the error.
    """

    chain: object = field(repr=False, compare=False)
    joint_min: np.ndarray
    joint_max: np.ndarray
    joint_margin: np.ndarray
    branch_kind: str | None = None
    branches: dict = field(default_factory=dict)
    box_min: np.ndarray | None = None
    box_max: np.ndarray | None = None
    box_margin: float = 0.0
    placements: tuple | None = None
    neighbours: np.ndarray | None = None
    neighbour_radius: float = np.inf
    n_poses: int = 0
    frames: tuple | None = None

    # ------------------------------------------------------------------ building
    @classmethod
    def of(cls, chain, observations, random_state=0):
        """The domain of ``observations`` (:class:`~robocal.io.observations.Observations`)
        of robot ``chain`` (the nominal model)."""
        q = np.asarray(observations.joints, dtype=float)
        low, high = q.min(axis=0), q.max(axis=0)
        floor = np.where(chain.revolute, np.radians(RANGE_MARGIN_MIN_DEG), RANGE_MARGIN_MIN_MM)
        margin = np.maximum(RANGE_MARGIN_FRACTION * (high - low), floor)
        found = arm_branches(chain, q)
        kind, branches = None, {}
        if found is not None:
            kind = found[0]
            branches = {name: tuple(int(s) for s in np.unique(side[side >= 0])) for name, side in found[1].items()}
        box = {}
        if observations.positions is not None:
            p = observations.positions
            box = {"box_min": p.min(axis=0), "box_max": p.max(axis=0),
                   "box_margin": float(max(BOX_MARGIN_FRACTION * np.max(np.ptp(p, axis=0)), BOX_MARGIN_MIN_MM))}
        placements = None if observations.placement is None else tuple(sorted({str(p) for p in observations.placement}))
        domain = cls(chain=chain, joint_min=low, joint_max=high, joint_margin=margin, branch_kind=kind,
                     branches=branches, placements=placements, n_poses=len(q), **box)
        # Repeated configurations (repeatability runs, ball-in-socket groups) would make the
        # spacing zero: the criterion works on the distinct ones.
        kept = np.unique(q, axis=0)
        if len(kept) < 2:
            return domain
        if len(kept) > NEIGHBOUR_KEEP:
            kept = kept[np.sort(np.random.default_rng(random_state).choice(len(kept), NEIGHBOUR_KEEP, replace=False))]
        nearest = replace(domain, neighbours=kept)._nearest(kept, leave_one_out=True)
        spacing = np.percentile(nearest, NEIGHBOUR_PERCENTILE)
        return replace(domain, neighbours=kept, neighbour_radius=float(NEIGHBOUR_FACTOR * spacing))

    # ------------------------------------------------------------------ checking
    def _scale(self):
        """Per joint, the length that scaled joint space divides by: the training range, or
        the range margin for a joint the training held still (its range check covers it)."""
        return np.maximum(self.joint_max - self.joint_min, self.joint_margin)

    @cached_property
    def _scaled_neighbours(self):
        """(scale (n,), training configurations scaled (M, n), their squared norms (M,)):
        what every nearest-neighbour distance needs, computed once per domain."""
        scale = self._scale()
        train = self.neighbours / scale
        return scale, train, np.sum(train ** 2, axis=1)

    def _nearest(self, q, leave_one_out=False):
        """(N,) scaled distance of each configuration to its nearest training configuration
        (to the nearest other one with ``leave_one_out``, ``q`` being the training set)."""
        scale, train, train_squared = self._scaled_neighbours
        out = np.empty(len(q))
        for start in range(0, len(q), BLOCK):
            block = q[start:start + BLOCK] / scale
            d2 = np.sum(block ** 2, axis=1)[:, None] + train_squared[None, :] - 2.0 * block @ train.T
            if leave_one_out:
                rows = np.arange(len(block))
                d2[rows, start + rows] = np.inf
            out[start:start + BLOCK] = np.sqrt(np.maximum(d2.min(axis=1), 0.0))
        return out

    # ------------------------------------------------------------ one configuration
    @cached_property
    def _point(self):
        """What :meth:`inside_one` prepares once: each criterion's limits as floats, the
        closed form and the nominal robot's forward kinematics of one configuration."""
        return _PointDomain(self)

    def inside_one(self, joints, position=None):
        """Whether one configuration lies inside the training domain: ``check`` of that row
        alone, ``check(joints[None], position[None]).inside[0]``, without the batch machinery
        (some 250 us for a batch of one) nor the reasons.

        joints : (n,) controller joints, rad (mm for prismatic joints); a NaN configuration
            counts as inside, as ``check`` counts it.
        position : (3,) TCP position (mm, measurement frame) for the training box, or None.

        Built for a controller asking point by point (``robocal serve``); about 50 us.
        """
        return self._point.inside(joints, position)

    def check(self, joints, positions=None, placement=None, uncertainty=None, what="targets"):
        """Which configurations lie inside the training domain, and why the others do not.

        Parameters
        ----------
        joints : (N, n) array
            Controller joints, rad (mm for prismatic joints); rows with NaN (an unreachable
            target) are neither inside nor outside: they count as inside with no reason.
        positions : (N, 3) array, optional
            TCP positions (mm, measurement frame) to check against the training box.
        placement : (N,) array of str, optional
            Fixture placements of ball-in-socket data; those the training did not have are
            named in the summary, not flagged (see the comment below).
        uncertainty : (N,) array, optional
            The error model's predicted standard deviation (mm), quoted in the summary.
        what : str
            What the rows are, plural, for the summary ("targets", "poses").

        Returns
        -------
        DomainCheck
        """
        q = np.atleast_2d(np.asarray(joints, dtype=float))
        count = len(q)
        if q.shape[1] != len(self.joint_min):
            raise InputError(f"the domain is of a robot with {len(self.joint_min)} joints, got {q.shape[1]}")
        known = np.all(np.isfinite(q), axis=1)
        if count == 1 and placement is None and uncertainty is None:
            # One configuration (a compensator asked target by target): the point path says
            # whether it is inside; only one outside needs the reasons below.
            position = None if positions is None else np.asarray(positions, dtype=float).reshape(-1)
            if self.inside_one(q[0], position):
                return DomainCheck(inside=np.ones(1, dtype=bool), reasons=("",), counts={},
                                   summary=self._summary(np.ones(1, dtype=bool), known, {}, None, what))
        return self._check(q, known, positions, placement, uncertainty, what)

    def _check(self, q, known, positions, placement, uncertainty, what):
        """:meth:`check` of configurations ``q`` (N, n), ``known`` (N,) where finite: the
        batch, which gives the reasons."""
        count = len(q)
        qk = np.where(known[:, None], q, self.joint_min)
        reasons = [[] for _ in range(count)]
        categories = [[] for _ in range(count)]

        def flag(mask, category, texts):
            for i in np.flatnonzero(mask & known):
                reasons[i].append(texts(i))
                categories[i].append(category)

        file_q = self.chain.joints_to_file(qk)
        file_low, file_high = self.chain.joints_to_file(self.joint_min), self.chain.joints_to_file(self.joint_max)
        for j in range(len(self.joint_min)):
            unit = "deg" if self.chain.revolute[j] else "mm"
            beyond = ((qk[:, j] < self.joint_min[j] - self.joint_margin[j])
                      | (qk[:, j] > self.joint_max[j] + self.joint_margin[j]))
            flag(beyond, f"q{j + 1} beyond its training range",
                 lambda i, j=j, unit=unit: (f"q{j + 1} = {file_q[i, j]:.1f} {unit} beyond the training range "
                                            f"{file_low[j]:.1f}..{file_high[j]:.1f} {unit}"))
        if self.branch_kind is not None:
            found = arm_branches(self.chain, qk)
            sides = {} if found is None else found[1]
            for name, side in sides.items():
                seen = self.branches.get(name, ())
                other = (side >= 0) & ~np.isin(side, seen)
                saw = " or ".join(f"{name} {s + 1}" for s in seen) or f"no clear {name} side"
                flag(other, f"another {name} branch",
                     lambda i, name=name, side=side, saw=saw: f"{name} {side[i] + 1}: training saw {saw} only")
        if positions is not None and self.box_min is not None:
            p = np.asarray(positions, dtype=float)
            for a, axis in enumerate("xyz"):
                with np.errstate(invalid="ignore"):
                    beyond = ((p[:, a] < self.box_min[a] - self.box_margin)
                              | (p[:, a] > self.box_max[a] + self.box_margin))
                flag(beyond, f"{axis} beyond the training box",
                     lambda i, a=a, axis=axis: (f"{axis} = {p[i, a]:.1f} mm beyond the training box "
                                                f"{self.box_min[a]:.1f}..{self.box_max[a]:.1f} mm"))
        if self.frames is not None:
            names, covariance, limit = self.frames
            jac = self.chain.identification_jacobian(qk, list(names))[:, :3, :]
            spread = np.sqrt(np.maximum(np.einsum("nip,pq,niq->n", jac, covariance, jac), 0.0))
            flag(spread > limit, "base and tool pinned too loosely here",
                 lambda i: (f"the re-registration's poses pin base and tool to {spread[i]:.2g} mm RMS here, more than "
                            f"the model's own {limit:.2g} mm"))
        if self.neighbours is not None:
            # Only where nothing else was found: the gap is then the one reason left to give.
            unexplained = np.array([not r for r in reasons]) & known
            distance = np.zeros(count)
            distance[unexplained] = self._nearest(qk[unexplained]) if unexplained.any() else 0.0
            flag(unexplained & (distance > self.neighbour_radius), "far from every training configuration",
                 lambda i: (f"far from every training configuration ({distance[i] / self.neighbour_radius:.1f} "
                            "times the training poses' spacing)"))
        inside = np.array([not r for r in reasons])
        counts = dict(Counter(c for cs in categories for c in cs).most_common())
        summary = self._summary(inside, known, counts, uncertainty, what)
        if placement is not None and self.placements is not None:
            # A placement id names where a fixture stood in one session only: the same id in
            # another file may be another place, and another id the same one.  Where the ball
            # went is what the joint criteria judge; the ids are only reported.
            new = sorted(set(np.asarray(placement).astype(str)) - set(self.placements))
            if new:
                summary += (f"; fixture placements not in the training data: {', '.join(new)} "
                            "(judged by their joint configurations)")
        return DomainCheck(inside=inside, reasons=tuple("; ".join(r) for r in reasons), counts=counts,
                           summary=summary)

    def coverage(self, joints, positions=None):
        """The arguments of :func:`robocal.interfaces.plots.domain_coverage` for the
        configurations ``joints`` (N, n) rad / mm (and their TCP ``positions``, (N, 3) mm, if
        known), in file units: the training configurations kept, each joint's range and
        margin, the evaluated joints and which of them lie inside."""
        to_file = self.chain.joints_to_file
        training = self.neighbours if self.neighbours is not None else np.vstack([self.joint_min, self.joint_max])
        return {"training": to_file(training), "low": to_file(self.joint_min), "high": to_file(self.joint_max),
                "margin": to_file(self.joint_margin), "joints": to_file(joints),
                "inside": self.check(joints, positions).inside,
                "units": ["deg" if r else "mm" for r in self.chain.revolute]}

    @staticmethod
    def _summary(inside, known, counts, uncertainty, what):
        n, outside = int(np.count_nonzero(known)), int(np.count_nonzero(~inside))
        if not outside:
            line = f"all {n} {what} lie inside the training domain"
        else:
            line = (f"{outside} of {n} {what} lie outside the training domain: "
                    + ", ".join(f"{c} ({k})" for c, k in counts.items()))
        if uncertainty is not None:
            u = np.asarray(uncertainty, dtype=float)
            parts = [f"{label} {np.nanmedian(u[mask]):.3g} mm" for label, mask in
                     (("inside", inside & known), ("outside", ~inside)) if np.any(mask & np.isfinite(u))]
            if parts:
                line += "; the error model's predicted uncertainty (median): " + ", ".join(parts)
        return line

    # -------------------------------------------------------------- file document
    def to_dict(self):
        """The domain as the model file's ``domain`` entry (file units: deg and mm)."""
        to_file = self.chain.joints_to_file
        doc = {
            "n_poses": int(self.n_poses),
            "joints": {"min": to_file(self.joint_min).tolist(), "max": to_file(self.joint_max).tolist(),
                       "margin": to_file(self.joint_margin).tolist()},
            "branches": None if self.branch_kind is None else {
                "kind": self.branch_kind, "seen": {k: [s + 1 for s in v] for k, v in self.branches.items()}},
            "box": None if self.box_min is None else {
                "min": self.box_min.tolist(), "max": self.box_max.tolist(), "margin": self.box_margin},
            "placements": None if self.placements is None else list(self.placements),
            "neighbours": None if self.neighbours is None else {
                "joints": to_file(self.neighbours).tolist(), "radius": self.neighbour_radius},
        }
        if self.frames is not None:
            names, covariance, limit = self.frames
            doc["frames"] = {"names": list(names), "covariance_mm_rad": np.asarray(covariance).tolist(),
                             "limit_mm": float(limit)}
        return doc

    @classmethod
    def from_dict(cls, document, chain, path="<domain>"):
        """A domain from :meth:`to_dict`'s document, for robot ``chain`` (the nominal model);
        FileFormatError when it is damaged."""
        def damaged(why):
            return FileFormatError(f"{path}: the domain of validity is damaged ({why}); "
                                   "regenerate the file with 'robocal calibrate'")

        n = chain.n_joints

        def vector(values, size, what):
            array = np.asarray(values, dtype=float)
            if array.shape != (size,) or not np.all(np.isfinite(array)):
                raise damaged(f"{what} must be {size} finite numbers")
            return array

        try:
            joints = document["joints"]
            low = chain.joints_from_file(vector(joints["min"], n, "joints.min"))
            high = chain.joints_from_file(vector(joints["max"], n, "joints.max"))
            margin = chain.joints_from_file(vector(joints["margin"], n, "joints.margin"))
            if np.any(high < low) or np.any(margin < 0):
                raise damaged("a joint range is reversed or a margin negative")
            fields = {"chain": chain, "joint_min": low, "joint_max": high, "joint_margin": margin,
                      "n_poses": int(document["n_poses"])}
            branches = document["branches"]
            if branches is not None:
                kind = branches["kind"]
                if kind not in BRANCH_BITS:
                    raise damaged(f"unknown arm branch kind {kind!r}")
                seen = {str(k): tuple(int(s) - 1 for s in v) for k, v in branches["seen"].items()}
                if any(s not in (0, 1) for v in seen.values() for s in v):
                    raise damaged("arm branch sides must be 1 or 2")
                fields.update(branch_kind=kind, branches=seen)
            box = document["box"]
            if box is not None:
                fields.update(box_min=vector(box["min"], 3, "box.min"), box_max=vector(box["max"], 3, "box.max"),
                              box_margin=float(box["margin"]))
            if document["placements"] is not None:
                fields["placements"] = tuple(str(p) for p in document["placements"])
            neighbours = document["neighbours"]
            if neighbours is not None:
                kept = np.asarray(neighbours["joints"], dtype=float)
                if kept.ndim != 2 or kept.shape[1] != n or len(kept) == 0 or not np.all(np.isfinite(kept)):
                    raise damaged(f"neighbours.joints must be rows of {n} finite numbers")
                fields.update(neighbours=chain.joints_from_file(kept), neighbour_radius=float(neighbours["radius"]))
            frames = document.get("frames")
            if frames is not None:
                names = tuple(str(n) for n in frames["names"])
                covariance = np.asarray(frames["covariance_mm_rad"], dtype=float)
                if covariance.shape != (len(names), len(names)) or not np.all(np.isfinite(covariance)) \
                        or any(n not in chain.parameters for n in names):
                    raise damaged("frames must name the model's parameters with a square finite covariance")
                fields["frames"] = (names, covariance, float(frames["limit_mm"]))
        except FileFormatError:
            raise
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise damaged(f"{type(exc).__name__}: {exc}") from None
        return cls(**fields)


class _PointDomain:
    """:meth:`Domain.check` of one configuration, inside or not (see
    :meth:`Domain.inside_one`): the same criteria in the same order of operations, on
    floats, prepared once per domain.  A domain with the re-registration criterion
    (``frames``), and a configuration whose branches only the batch closed form can follow,
    are checked by the batch."""

    def __init__(self, domain):
        self.domain = domain
        self.n = len(domain.joint_min)
        # Each joint's range with its margin, as check computes it.
        self.low = (domain.joint_min - domain.joint_margin).tolist()
        self.high = (domain.joint_max + domain.joint_margin).tolist()
        self.box = None
        if domain.box_min is not None:
            self.box = ((domain.box_min - domain.box_margin).tolist(), (domain.box_max + domain.box_margin).tolist())
        self.branches = None
        if domain.branch_kind is not None:
            try:
                solver = closed_form(domain.chain)
            except InputError:
                solver = None  # check finds no sides either
            if solver is not None:
                seen = [(bit, joint, domain.branches.get(name, ())) for name, bit, joint in BRANCH_BITS[solver.kind]]
                self.branches = (solver, not solver.exact, PointProgram.of(domain.chain), seen)
        self.batch_only = domain.frames is not None

    def inside(self, joints, position=None):
        """Whether ``joints`` (n,) rad (and ``position`` (3,) mm, or None) lie inside."""
        q = np.asarray(joints, dtype=float).reshape(-1)
        if q.shape != (self.n,):
            raise InputError(f"the domain is of a robot with {self.n} joints, got {q.shape[0]}")
        values = q.tolist()
        if not math.isfinite(sum(values)):
            return True  # unreachable: neither inside nor outside, counted inside
        if self.batch_only:
            return self._batch(q, position)
        for value, low, high in zip(values, self.low, self.high):
            if value < low or value > high:
                return False
        if self.branches is not None:
            found = self._other_branch(values)
            if found is None:
                return self._batch(q, position)
            if found:
                return False
        if position is not None and self.box is not None:
            for value, low, high in zip(np.asarray(position, dtype=float).tolist(), *self.box):
                if value < low or value > high:
                    return False
        domain = self.domain
        if domain.neighbours is not None:
            scale, train, train_squared = domain._scaled_neighbours
            block = q[None] / scale
            d2 = np.sum(block ** 2, axis=1)[:, None] + train_squared[None, :] - 2.0 * block @ train.T
            if math.sqrt(max(float(d2.min()), 0.0)) > domain.neighbour_radius:
                return False
        return True

    def _other_branch(self, values):
        """Whether the configuration lies on an arm branch the training did not see, as
        :func:`arm_branches` decides for one row; None where only the batch can say."""
        solver, seeds, program, seen = self.branches
        try:
            joints, usable, _ = solver.branches_one(program.matrix(values), values, seeds)
        except Degenerate:
            return None
        best, own = math.inf, 0
        for k, (branch, ok) in enumerate(zip(joints, usable)):
            if ok:
                distance = math.sqrt(sum([(b - v) * (b - v) for b, v in zip(branch, values)]))
                if distance < best:
                    best, own = distance, k
        if not best <= BRANCH_MATCH:
            return False  # no branch matches: not judged
        for bit, joint, sides in seen:
            difference = joints[own ^ bit][joint] - values[joint]
            # The other side's solution beyond the limits (NaN) is as good as far away.
            if abs(math.atan2(math.sin(difference), math.cos(difference))) < 2.0 * BRANCH_SINGULAR:
                continue
            if (own & bit) // bit not in sides:
                return True
        return False

    def _batch(self, q, position):
        positions = None if position is None else np.asarray(position, dtype=float).reshape(1, 3)
        return bool(self.domain._check(q[None], np.ones(1, dtype=bool), positions, None, None, "targets").inside[0])
