"""The parameter space of a chain: every identifiable parameter as a record, built once.

A parameter's name is what model files, truth files and reports show (``theta3``,
``base_rz``, ``gain2``, ``compliance4`` ...); everything an algorithm needs to know about it
(which joint, which kind of quantity, its unit, its factor to file units) is read from its
:class:`Parameter` record, never parsed out of the name.  The space maps names to indices
and back; algorithms work with the records.

Groups and kinds:

* ``"link"``: per joint, kinds ``theta, d, a, alpha, beta`` (DH, MDH) or
  ``theta, ux, uy, wx, wy`` (POE);
* ``"base"``, ``"tool"``, ``"home"`` (POE only): kinds ``x, y, z`` (mm) and ``rx, ry, rz``
  (rad) of that frame;
* ``"gains"``: per joint, kind ``gain``, the log of the scale of the joint's reading (a
  fraction: 1e-4 is 100 ppm);
* ``"compliance"``: per joint, kind ``compliance`` (rad/(N·m); mm/N on a prismatic joint),
  only in the space of a :class:`~robocal.kinematics.compliant.CompliantChain`.
"""
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import InputError

LINK_KINDS = {
    "dh": ("theta", "d", "a", "alpha", "beta"),
    "mdh": ("theta", "d", "a", "alpha", "beta"),
    # POE axis placement: shift along the joint frame's x / y, tilt about its x / y.
    "poe": ("theta", "ux", "uy", "wx", "wy"),
}
FRAME_KINDS = ("x", "y", "z", "rx", "ry", "rz")
FRAME_GROUPS = ("base", "tool", "home")
GAIN = "gain"
COMPLIANCE = "compliance"
# Joint gains and compliances are shown in millionths: ppm, and µrad/(N·m) (a 150 kg-class
# joint is about 0.01 rad/(N·m) x 1e-6).
FILE_UNIT = 1e6
_ANGULAR_LINK = ("alpha", "beta", "wx", "wy")


@dataclass(frozen=True)
class Parameter:
    """One model parameter.

    name: as files and reports show it; index: its position in the space; group: 'link',
    'base', 'tool', 'home', 'gains' or 'compliance'; joint: 1-based joint number, or None
    for a frame parameter; kind: see the module notes; unit: 'mm', 'rad', 'rad/(N*m)',
    'mm/N' or 'fraction'; angular: True for parameters in radians (shown in degrees).
    """

    name: str
    index: int
    group: str
    joint: int | None
    kind: str
    unit: str
    angular: bool

    @property
    def file_unit(self):
        """The unit files and reports show: 'mm', 'deg', 'ppm' (gains), 'µrad/(N·m)' or
        'nm/N' (compliances, in millionths)."""
        return {"rad": "deg", "mm": "mm", "fraction": "ppm", "rad/(N*m)": "µrad/(N·m)", "mm/N": "nm/N"}[self.unit]

    @property
    def file_factor(self):
        """Internal unit -> file unit: degrees for angles, millionths for gains and
        compliances, 1 for lengths."""
        if self.group in ("gains", COMPLIANCE):
            return FILE_UNIT
        return float(np.degrees(1.0)) if self.angular else 1.0


def _link_record(convention, kind, joint, revolute):
    if kind == "theta":
        # A joint offset turns a revolute joint; it slides a POE prismatic joint along its
        # axis, while in (M)DH a prismatic joint's theta still turns about z.
        angular = revolute or convention != "poe"
    else:
        angular = kind in _ANGULAR_LINK
    return ("link", joint, kind, "rad" if angular else "mm", angular)


def _frame_records(group):
    return [(group, None, kind, "mm" if k < 3 else "rad", k >= 3) for k, kind in enumerate(FRAME_KINDS)]


class ParameterSpace:
    """The named parameters of one chain, in a fixed order, with name <-> index lookups.

    Build it with :meth:`of_chain` (or read ``chain.parameters``); a space is immutable.
    """

    def __init__(self, records):
        self._records = tuple(records)
        self._index = {p.name: p.index for p in self._records}
        if len(self._index) != len(self._records):
            raise InputError("parameter names must be unique")

    @classmethod
    def of_chain(cls, convention, joint_types, compliance=False):
        """The space of a chain of ``joint_types`` in ``convention``: links, gains, base,
        tool, home (POE), and the joint compliances when ``compliance``.

        Spaces are immutable and depend on nothing else, so one is built per kind of chain:
        a fit makes a new chain at every step and would otherwise rebuild it each time.
        """
        return _space(cls, convention, tuple(joint_types), bool(compliance))

    @classmethod
    def _build(cls, convention, joint_types, compliance):
        rows = []
        n = len(joint_types)
        for j, kind_of_joint in enumerate(joint_types, start=1):
            rows += [_link_record(convention, kind, j, kind_of_joint == "revolute")
                     for kind in LINK_KINDS[convention]]
        rows += [("gains", j, GAIN, "fraction", False) for j in range(1, n + 1)]
        for group in FRAME_GROUPS:
            if group != "home" or convention == "poe":
                rows += _frame_records(group)
        if compliance:
            rows += [(COMPLIANCE, j, COMPLIANCE, "rad/(N*m)" if t == "revolute" else "mm/N", False)
                     for j, t in enumerate(joint_types, start=1)]
        records = []
        for group, joint, kind, unit, angular in rows:
            name = f"{group}_{kind}" if joint is None else f"{kind}{joint}"
            records.append(Parameter(name, len(records), group, joint, kind, unit, angular))
        return cls(records)

    # ------------------------------------------------------------------ lookups
    def __len__(self):
        return len(self._records)

    def __iter__(self):
        return iter(self._records)

    def __contains__(self, name):
        return name in self._index

    def __getitem__(self, name):
        """The record of ``name``; InputError if the chain has no such parameter."""
        try:
            return self._records[self._index[name]]
        except (KeyError, TypeError):
            raise InputError(f"parameter {name!r} does not exist in this model; "
                             f"known: {', '.join(self.names)}") from None

    def get(self, name):
        """The record of ``name``, or None."""
        k = self._index.get(name)
        return None if k is None else self._records[k]

    @property
    def names(self):
        """All names, in the space's order."""
        return tuple(p.name for p in self._records)

    def index(self, name):
        """Position of ``name`` in the space."""
        return self[name].index

    def records(self, names):
        """The records of ``names`` (a list of Parameter)."""
        return [self[name] for name in names]

    def of_group(self, group):
        """Names of one group, in order."""
        return [p.name for p in self._records if p.group == group]

    def file_units(self, names):
        """(P,) factors from internal units to the ones files and reports show."""
        return np.array([self[name].file_factor for name in names])


@lru_cache(maxsize=64)
def _space(cls, convention, joint_types, compliance):
    return cls._build(convention, joint_types, compliance)
