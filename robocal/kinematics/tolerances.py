"""Manufacturing tolerances: how far a real robot may lie from its drawing, by kind of parameter.

They are the priors of every calibration (maximum a posteriori: the weighted residual plus
each deviation over its tolerance, squared) and the yardstick of the data check: a fit that
needs many tolerances to explain the data is not this robot's.

Kinds, in file units (mm, deg, ppm) where a robot file's ``[tolerances]`` table gives them:

* ``length_mm``: link lengths and offsets (DH/MDH ``a``, ``d``; POE axis shifts and home
  position);
* ``joint_zero_deg``: joint offsets (``theta``);
* ``axis_angle_deg``: axis angles (``alpha``, Hayati's ``beta``; POE axis tilts and home
  rotation);
* ``gain_ppm``: a joint reading's scale error;
* ``compliance_bend_deg``: how far gravity may bend a joint through its compliance, at the
  largest gravity torque of the poses; a compliance is also never negative.

Base and tool carry no prior: the tracker may stand anywhere and the tool is what the user
mounted, so registration and the data place them.

The defaults are one standard deviation of what calibrations of real arms find, lengths
scaled with the robot's size (its total link length to the flange, without the tool, over a
KR 150-2's, see :func:`~robocal.kinematics.gravity.size_factor`): full calibrations of the three real
arms robocal ships moved link lengths by up to 1.3 mm (UR10 series B, a2; size 0.49),
joint zeros by up to 0.11 deg and axis angles by up to 0.67 deg (UR5, alpha3), joint gains
by a few hundred ppm, and bent joints through compliance by at most 0.08 deg.
"""
from dataclasses import dataclass, fields, replace

import numpy as np

from ..errors import InputError

# Per unit of size (a KR 150-2 is 1; a UR10 0.49, a UR5 0.34): a length tolerance of 1 mm,
# never below LENGTH_FLOOR_MM (assembly errors do not shrink with the arm).
LENGTH_PER_SIZE_MM = 1.0
LENGTH_FLOOR_MM = 0.2
JOINT_ZERO_DEG = 0.1
AXIS_ANGLE_DEG = 0.25
GAIN_PPM = 1000.0
COMPLIANCE_BEND_DEG = 0.1

_KIND_OF = {"theta": "joint_zero", "d": "length", "a": "length", "ux": "length", "uy": "length",
            "alpha": "axis_angle", "beta": "axis_angle", "wx": "axis_angle", "wy": "axis_angle"}


@dataclass(frozen=True)
class Tolerances:
    """One standard deviation of each kind of deviation, in internal units.

    length: mm; joint_zero, axis_angle, compliance_bend: rad; gain: fraction.
    """

    length: float
    joint_zero: float
    axis_angle: float
    gain: float
    compliance_bend: float

    # File keys with their factor from internal units.
    FILE_KEYS = {"length": ("length_mm", 1.0), "joint_zero": ("joint_zero_deg", float(np.degrees(1.0))),
                 "axis_angle": ("axis_angle_deg", float(np.degrees(1.0))), "gain": ("gain_ppm", 1e6),
                 "compliance_bend": ("compliance_bend_deg", float(np.degrees(1.0)))}

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
                    or not np.isfinite(value) or value <= 0:
                key = self.FILE_KEYS[f.name][0]
                raise InputError(f"tolerance {key} must be a number > 0, got {value!r}")
            object.__setattr__(self, f.name, float(value))

    def scaled(self, factor):
        """Every tolerance times ``factor`` (> 0)."""
        if isinstance(factor, bool) or not isinstance(factor, (int, float)) or not np.isfinite(factor) \
                or factor <= 0:
            raise InputError(f"tolerance scale must be a number > 0, got {factor!r}")
        return Tolerances(**{f.name: getattr(self, f.name) * factor for f in fields(self)})

    def to_file(self):
        """{file key: value in file units}, as a robot file's ``[tolerances]`` holds them."""
        return {key: getattr(self, name) * factor for name, (key, factor) in self.FILE_KEYS.items()}

    def with_file_values(self, table, where="[tolerances]"):
        """These tolerances with the keys of a robot file's ``[tolerances]`` table (file units)
        replacing theirs; InputError naming an unknown key or a bad value."""
        if not isinstance(table, dict):
            raise InputError(f"{where} must be a table of {', '.join(k for k, _ in self.FILE_KEYS.values())}")
        known = {key: (name, factor) for name, (key, factor) in self.FILE_KEYS.items()}
        changes = {}
        for key, value in table.items():
            if key not in known:
                raise InputError(f"{where}: unknown key {key!r}; known: {', '.join(known)}")
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
                raise InputError(f"{where}: {key} must be a number > 0, got {value!r}")
            name, factor = known[key]
            changes[name] = float(value) / factor
        return replace(self, **changes)


def default_tolerances(chain):
    """The default :class:`Tolerances` of ``chain``: lengths scaled to its arm's size (module
    notes), to the flange.  The tool is not the arm's: a calibration registers one to the data
    before its prior is built, and another robot's data registered to this one can take a tool
    of any length (a UR10's ISO cubes fitted as a UR5's: 121 m), which would loosen every
    length tolerance a hundredfold and let the data check pass them."""
    size = _flange_size(chain.rigid)
    return Tolerances(length=max(LENGTH_FLOOR_MM, LENGTH_PER_SIZE_MM * size), joint_zero=np.radians(JOINT_ZERO_DEG),
                      axis_angle=np.radians(AXIS_ANGLE_DEG), gain=GAIN_PPM * 1e-6,
                      compliance_bend=np.radians(COMPLIANCE_BEND_DEG))


# Sizes by arm geometry: every fit measures the size of its registered start, a new chain that
# differs from the user's only in base and tool, which do not change the size.  It is measured
# without them, so that its last bits do not depend on which base the cache first saw (a Dask
# worker's cross-validation printed figures 1e-16 apart from the same run here).
_SIZES = {}
_SIZES_KEPT = 64
_NOT_THE_ARM = {"name", "base", "tool", "masses", "tolerances", "joint_names", "lower", "upper"}


def _flange_size(rigid):
    """The arm's size (:func:`~robocal.kinematics.gravity.size_factor`) to the flange."""
    from .gravity import size_factor

    key = tuple(value.tobytes() if isinstance(value, np.ndarray) else value
                for f in fields(rigid) if f.name not in _NOT_THE_ARM for value in (getattr(rigid, f.name),))
    size = _SIZES.get(key)
    if size is None:
        if len(_SIZES) >= _SIZES_KEPT:
            _SIZES.clear()
        size = _SIZES[key] = float(size_factor(rigid.replace(base=np.eye(4), tool=np.eye(4))))
    return size


def tolerances_of(chain, scale=1.0):
    """The chain's tolerances (its robot file's ``[tolerances]`` over the defaults), times
    ``scale``."""
    own = getattr(chain.rigid, "tolerances", None)
    base = default_tolerances(chain)
    if own:
        base = replace(base, **own)
    return base if scale == 1.0 else base.scaled(scale)


def prior_sigmas(chain, names, tolerances, joints=None):
    """(P,) one standard deviation of each named parameter's deviation, internal units;
    ``inf`` for a parameter without a prior (base, tool, and any name outside the chain's
    space such as the constraint calibration's scale).

    A compliance's comes from ``tolerances.compliance_bend`` over the largest gravity torque
    of its joint at ``joints`` (N, n) rad (without them, or without torque, it has none).
    """
    space = chain.parameters
    torque = None
    out = np.full(len(names), np.inf)
    for k, name in enumerate(names):
        record = space.get(name)
        if record is None or record.group in ("base", "tool"):
            continue
        if record.group == "gains":
            out[k] = tolerances.gain
        elif record.group == "compliance":
            if joints is None:
                continue
            if torque is None:
                torque = np.abs(chain.gravity_torque(np.asarray(joints, dtype=float))).max(axis=0)
            load = torque[record.joint - 1]
            if load > 0:
                bend = tolerances.compliance_bend if chain.revolute[record.joint - 1] else tolerances.length
                out[k] = bend / load
        elif record.group == "home":
            out[k] = tolerances.length if record.unit == "mm" else tolerances.axis_angle
        elif record.kind == "theta" and record.unit == "mm":
            out[k] = tolerances.length  # a POE prismatic joint's offset slides along its axis
        else:
            out[k] = getattr(tolerances, _KIND_OF[record.kind])
    return out
