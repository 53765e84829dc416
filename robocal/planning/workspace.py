"""Where a planned pose may put the arm: the working volume of a design.

A pose drawn uniformly in the joint limits is often one the robot cannot take: half of a
UR5's put the wrist or the TCP below its own base, through the table it stands on.  A
design (``robocal design``) therefore keeps only candidates whose arm stays in the working
volume:

* above a floor, by default the robot's mounting plane (z = 0 of the robot base frame: a
  table- or floor-mounted arm); ``--floor`` sets another height, ``--floor none`` lifts it
  (a wall or ceiling mount, where the walls or a box say where the cell is);
* within walls (``--walls xmin,xmax,ymin,ymax``), when given;

and says which volume it assumed.  The arm is checked at the origin of every joint the
arm's motion carries (not a shoulder that sits on the first axis) and at the TCP: where the
links and the tool are, to first order.  Positions are in mm in the robot base frame (the robot file's base
transform is not applied: the mounting is the robot's own).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class WorkingVolume:
    """``floor_mm``: the lowest z any point of the arm may take (None: no floor);
    ``walls_mm``: (xmin, xmax, ymin, ymax) or None."""

    floor_mm: float | None = 0.0
    walls_mm: tuple | None = None

    def __post_init__(self):
        if self.walls_mm is not None:
            walls = tuple(float(v) for v in self.walls_mm)
            if len(walls) != 4 or walls[0] >= walls[1] or walls[2] >= walls[3]:
                raise InputError(f"--walls must be xmin,xmax,ymin,ymax (mm) with each min below its max, got "
                                 f"{','.join(f'{v:g}' for v in walls)}")
            object.__setattr__(self, "walls_mm", walls)

    def points(self, chain, joints):
        """(N, m, 3) mm: the origins of the joints that move with the arm (beyond the first,
        those the joints' motion carries: a shoulder on the first axis stays where it is
        mounted) and the TCP, robot base frame."""
        mounted = chain.replace(base=np.eye(4))
        _, origins, tcp = mounted.joint_frames(np.asarray(joints, dtype=float))
        points = np.concatenate([origins[:, 1:, :], tcp[:, None, :3, 3]], axis=1)
        return points[:, _moving(mounted)]

    def inside(self, chain, joints):
        """(N,) bool: the configurations ``joints`` (N, n) rad whose arm stays in the volume."""
        joints = np.asarray(joints, dtype=float)
        if len(joints) == 0:
            return np.zeros(0, dtype=bool)
        points = self.points(chain, joints)
        keep = np.ones(len(joints), dtype=bool)
        if self.floor_mm is not None:
            keep &= points[:, :, 2].min(axis=1) >= self.floor_mm
        if self.walls_mm is not None:
            x, y = points[:, :, 0], points[:, :, 1]
            xmin, xmax, ymin, ymax = self.walls_mm
            keep &= (
                (x.min(axis=1) >= xmin) & (x.max(axis=1) <= xmax) & (y.min(axis=1) >= ymin) & (y.max(axis=1) <= ymax)
            )
        return keep

    def check_given(self, chain, joints, rows, path, what):
        """Refuse, in one line naming the first rows (``rows`` (N,) file lines) of ``path``,
        configurations ``joints`` (N, n) rad a user gave (``what``: "candidates", "targets")
        that put the arm outside the volume: the volume binds the poses a user gives as it
        binds those robocal draws, and a plan holding them would send the arm through the
        table."""
        outside = np.flatnonzero(~self.inside(chain, joints))
        if not outside.size:
            return
        first = self.points(chain, np.asarray(joints, dtype=float)[outside[:1]])[0]
        if self.floor_mm is not None and first[:, 2].min() < self.floor_mm:
            why = f"the arm reaches z = {first[:, 2].min():.1f} mm"
        else:
            why = f"the arm reaches x {first[:, 0].min():.1f}..{first[:, 0].max():.1f}, " \
                  f"y {first[:, 1].min():.1f}..{first[:, 1].max():.1f} mm"
        lines = [str(int(line)) for line in np.asarray(rows)[outside[:3]]]
        named = ", ".join(lines) + (f" and {outside.size - 3} more" if outside.size > 3 else "")
        raise InputError(f"{path} row{'s' if outside.size > 1 else ''} {named}: {len(outside)} of the {what} put the "
                         f"arm outside the working volume ({self.describe()}; {why} in row {lines[0]}): remove "
                         "them, or give the robot's real cell with --floor and --walls")

    def describe(self):
        """One line: what the design assumed."""
        parts = []
        if self.floor_mm is None:
            parts.append("no floor (a wall or ceiling mount)")
        elif self.floor_mm == 0.0:
            parts.append("above the mounting plane, z >= 0 mm (a table or floor mount; --floor to change)")
        else:
            parts.append(f"above z = {self.floor_mm:g} mm (--floor)")
        if self.walls_mm is not None:
            parts.append("within x {:g}..{:g}, y {:g}..{:g} mm (--walls)".format(*self.walls_mm))
        return ", ".join(parts)

    def to_dict(self):
        return {
            "floor_mm": self.floor_mm,
            "walls_mm": None if self.walls_mm is None else list(self.walls_mm),
            "assumed": self.describe(),
        }


def _moving(mounted):
    """(n,) bool over the points of :meth:`WorkingVolume.points`: those whose position some
    joint motion changes (judged on a fixed draw of configurations)."""
    q = mounted.random_configurations(16, np.random.default_rng(0))
    _, origins, tcp = mounted.joint_frames(q)
    points = np.concatenate([origins[:, 1:, :], tcp[:, None, :3, 3]], axis=1)
    return np.ptp(points, axis=0).max(axis=1) > 1e-6


def parse_floor(text):
    """``--floor``: a height in mm, or ``none``."""
    if text is None:
        return 0.0
    if str(text).strip().lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"--floor takes a height in mm (robot base frame) or none, got {text!r}") from None
    if not np.isfinite(value):
        raise InputError(f"--floor must be a finite height in mm, got {text!r}")
    return value
