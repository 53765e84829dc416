"""A "true" robot: the hidden reality a calibration is scored against.

A :class:`TrueRobot` couples a nominal chain (what the controller believes) with the
actual geometry (every parameter, base and tool included, off by known deviations), joint
compliance under gravity, gear backlash and measurement noise.  Its truth file (JSON)
records all of it, so a test can compare an identified model with what was simulated.

The defining numbers are kept in file units (mm, degrees; N·m/rad and kg) both here and in
the file: a truth file read back then describes bit for bit the same robot.
"""
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ..errors import FileFormatError, InputError
from ..io.atomic import write_text_atomic
from ..io import schema
from ..io.reading import load_json
from ..io.robot_file import chain_from_dict, robot_to_toml, tomllib
from ..io.observations import Observations, check_robot_in_mm
from ..io.tables import Measurements
from ..kinematics import Chain
from ..spatial import matrix_to_rpy, so3_exp
from .joint_effects import Compliance, backlash_offsets, to_controller

TRUTH_FORMAT = "robocal-truth"
TRUTH_VERSION = 1
_UNITS = {
    "lengths": "mm",
    "angles": "deg",
    "stiffness": "N*m/rad (N/mm for prismatic joints); null = rigid",
    "masses": "kg",
}
# The units entry a truth file may carry (robocal.io.schema.stated_units): what robocal
# writes, and the spellings of the same units a person editing the file might use.
_UNIT_SPELLINGS = {
    "lengths": ("mm", "millimetre", "millimetres", "millimeter", "millimeters"),
    "angles": ("deg", "degree", "degrees"),
    "stiffness": (_UNITS["stiffness"], "N*m/rad", "Nm/rad", "N.m/rad"),
    "masses": ("kg", "kilogram", "kilograms"),
}
# Every entry of a truth file (to_dict): any other is refused, not ignored.
_TRUTH_KEYS = ("format", "version", "units", "preset", "seed", "robot", "deviations", "compliance", "backlash",
               "noise", "noise_orientation")


def _file_to_internal(chain, name, value):
    """A deviation in file units (mm, deg, ppm for joint gains) -> the chain's internal units
    (an unknown name passes unchanged: ``Chain.perturbed`` refuses it)."""
    parameter = chain.parameters.get(name)
    if parameter is None:
        return float(value)
    return np.radians(value) if parameter.angular else float(value) / parameter.file_factor


@dataclass(frozen=True, eq=False)
class TrueRobot:
    """The real robot behind a nominal model.

    nominal: the chain the controller uses.
    deviations: parameter name (``Chain.parameter_names``) -> deviation in mm or deg (ppm
        for a joint gain); the actual chain is ``nominal.perturbed`` by them.
    compliance: joint stiffness and mass model, or None for rigid joints.
    backlash: (n,) half-width of each model joint's play in deg (mm for prismatic joints),
        or None.
    noise: standard deviation of measured positions, mm, per coordinate.
    noise_orientation: standard deviation of measured orientations, deg, about each axis.
    seed: the seed the deviations were drawn with (a record; None if not drawn).
    preset: the preset name this robot was made from, or "custom".
    actual: derived, the nominal chain with the deviations applied.
    """

    nominal: Chain
    deviations: Mapping = field(default_factory=dict)
    compliance: Compliance | None = None
    backlash: np.ndarray | None = None
    noise: float = 0.0
    noise_orientation: float = 0.0
    seed: int | None = None
    preset: str = "custom"
    actual: Chain = field(init=False)

    def __post_init__(self):
        set_ = object.__setattr__
        chain = self.nominal
        # Simulated data of a robot file in metres would look fine and be 1000x off.
        check_robot_in_mm(chain)
        deviations = {str(k): float(v) for k, v in dict(self.deviations).items()}
        set_(self, "deviations", MappingProxyType(deviations))
        set_(self, "actual", chain.perturbed(
            {name: _file_to_internal(chain, name, value) for name, value in deviations.items()}))
        if self.compliance is not None:
            self.compliance.check_robot(chain)
        if self.backlash is not None:
            backlash = np.array(self.backlash, dtype=float).reshape(-1)
            if backlash.shape != (chain.n_joints,) or not np.all(np.isfinite(backlash)) or np.any(backlash < 0):
                raise InputError(
                    f"backlash needs {chain.n_joints} finite half-widths >= 0 (deg), got "
                    f"{np.ravel(self.backlash).tolist()}"
                )
            set_(self, "backlash", backlash)
        for name in ("noise", "noise_orientation"):
            value = float(getattr(self, name))
            if not np.isfinite(value) or value < 0:
                raise InputError(f"{name} must be a standard deviation >= 0, got {getattr(self, name)}")
            set_(self, name, value)
        if self.seed is not None:
            set_(self, "seed", int(self.seed))

    # ------------------------------------------------------------------- physics
    def joints(self, q, previous=None):
        """The controller joint values the links really take when ``q`` (N, n) is commanded
        row by row: the command, plus backlash, plus the gravity deflection.

        previous: (n,) the configuration the robot comes from before the first row
        (default: the zero configuration); it sets the first row's direction of motion.
        """
        chain = self.actual
        q2 = chain.joint_batch(q)
        offset = np.zeros_like(q2)
        if self.backlash is not None:
            start = np.zeros(chain.n_joints) if previous is None else np.asarray(previous, dtype=float)
            if start.shape != (chain.n_joints,):
                raise InputError(f"previous must be one configuration of {chain.n_joints} "
                                 f"joints, got shape {start.shape}")
            half_width = chain.joints_from_file(self.backlash)
            offset += backlash_offsets(chain.model_joints(q2), half_width, chain.model_joints(start)[0])
        real = q2 + to_controller(chain, offset)
        if self.compliance is not None:
            # The torque is taken where the links are before they give way: the deflection is
            # ~1e-4 rad, and the torque it would change is smaller by that much again.
            real = real + to_controller(chain, self.compliance.deflection(chain, real))
        return real

    def pose(self, q, previous=None):
        """True TCP poses (N, 4, 4) in the world frame for commands ``q`` (N, n), no noise.

        See :meth:`joints` for ``previous``.
        """
        q = np.asarray(q, dtype=float)
        poses = self.actual.fk(self.joints(np.atleast_2d(q), previous))
        return poses[0] if q.ndim == 1 else poses

    def positions(self, q, previous=None):
        """True TCP positions (N, 3) mm, no noise: :meth:`pose` without the orientations, faster."""
        q = np.asarray(q, dtype=float)
        positions = self.actual.fk_positions(self.joints(np.atleast_2d(q), previous))
        return positions[0] if q.ndim == 1 else positions

    def error(self, q, previous=None):
        """True minus nominal TCP positions (N, 3) mm for commands ``q``."""
        return self.positions(q, previous) - self.nominal.fk_positions(q)

    def measure(self, q, rng, previous=None, orientation=False):
        """What an instrument reads: true TCP positions (N, 3) mm with Gaussian noise.

        With ``orientation`` also the orientations as rotation matrices (N, 3, 3), each
        turned by a small random rotation (``noise_orientation`` deg about each world axis)
        so that the noise stays isotropic near gimbal lock; returns (positions, rotations)
        then.  rng: a numpy Generator or a seed.
        """
        rng = np.random.default_rng(rng)
        q = self.nominal.joint_batch(q)
        if orientation:
            poses = self.pose(q, previous)
            positions = poses[:, :3, 3]
        else:
            positions = self.positions(q, previous)
        positions = positions + rng.normal(scale=self.noise, size=positions.shape)
        if not orientation:
            return positions
        turn = so3_exp(rng.normal(scale=np.radians(self.noise_orientation), size=positions.shape))
        return positions, turn @ poses[:, :3, :3]

    def observations(self, q, rng, previous=None, orientation=False):
        """:meth:`measure` as :class:`~robocal.io.observations.Observations` (internal units),
        what every method fits; the position noise is each row's sigma when there is any."""
        q = self.nominal.joint_batch(q)
        measured = self.measure(q, rng, previous, orientation)
        positions, rotations = measured if orientation else (measured, None)
        sigmas = np.full_like(positions, self.noise) if self.noise > 0 else None
        return Observations.of(q, positions, rotations=rotations, sigmas=sigmas)

    def measurements(self, q, rng, previous=None, orientation=False):
        """The same as a :class:`~robocal.io.tables.Measurements` table (file units: deg)."""
        obs = self.observations(q, rng, previous, orientation)
        rpy = None if obs.rotations is None else np.degrees(matrix_to_rpy(obs.rotations))
        return Measurements(path="", joints=self.nominal.joints_to_file(obs.joints), positions=obs.positions,
                            orientations=rpy, sigmas=obs.sigmas)

    # ------------------------------------------------------------------ truth file
    def to_dict(self):
        """A JSON-safe record (lists, floats, strings, null) of everything that was simulated."""
        compliance = None
        if self.compliance is not None:
            c = self.compliance
            compliance = {
                "stiffness": [None if np.isinf(k) else float(k) for k in c.stiffness],
                "link_masses": c.link_masses.tolist(),
                "payload": c.payload,
            }
        return {
            "format": TRUTH_FORMAT,
            "version": TRUTH_VERSION,
            "units": dict(_UNITS),
            "preset": self.preset,
            "seed": self.seed,
            "robot": robot_to_toml(self.nominal),
            "deviations": dict(self.deviations),
            "compliance": compliance,
            "backlash": None if self.backlash is None else self.backlash.tolist(),
            "noise": self.noise,
            "noise_orientation": self.noise_orientation,
        }

    @classmethod
    def from_dict(cls, doc, where="<truth>"):
        """The robot a :meth:`to_dict` record describes."""
        if not isinstance(doc, dict) or doc.get("format") != TRUTH_FORMAT:
            raise FileFormatError(f"{where}: not a robocal truth file (no \"format\": \"{TRUTH_FORMAT}\")")
        if doc.get("version") != TRUTH_VERSION:
            raise FileFormatError(
                f"{where}: truth file version {doc.get('version')!r}; this robocal reads version {TRUTH_VERSION}"
            )
        try:
            # Every entry through the one schema helper: a value of the wrong type is one line
            # naming it (robocal.io.schema), never Python's own message; an entry robocal does
            # not read, or units it does not read the numbers in, is refused, not ignored.
            schema.keys(doc, where, _TRUTH_KEYS, required=("robot",))
            if "units" in doc:
                schema.stated_units(doc["units"], f"{where}: units", _UNIT_SPELLINGS)
            robot = schema.text(doc["robot"], f"{where}: robot")
            try:
                nominal = chain_from_dict(tomllib.loads(robot), f"{where} (robot)")
            except tomllib.TOMLDecodeError as why:
                raise FileFormatError(f"{where}: robot must be a robot file's TOML text ({why}); write the truth "
                                      "file again with robocal simulate --truth") from None
            compliance = doc.get("compliance")
            if compliance is not None:
                compliance = schema.table(compliance, f"{where}: compliance")
                compliance = Compliance(
                    stiffness=[np.inf if k is None else schema.number(k, f"{where}: compliance stiffness")
                               for k in _listed(compliance, "stiffness", where)],
                    link_masses=schema.numbers(compliance.get("link_masses"), f"{where}: compliance link_masses"),
                    payload=schema.number(compliance.get("payload"), f"{where}: compliance payload"),
                )
            deviations = schema.table(doc.get("deviations", {}), f"{where}: deviations")
            seed = doc.get("seed")
            if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
                raise FileFormatError(f"{where}: seed must be a whole number or null, got {schema.shown(seed)}")
            backlash = doc.get("backlash")
            return cls(
                nominal=nominal,
                deviations={str(k): schema.number(v, f"{where}: deviations {k}") for k, v in deviations.items()},
                compliance=compliance,
                backlash=None if backlash is None else schema.numbers(backlash, f"{where}: backlash"),
                noise=schema.number(doc.get("noise", 0.0), f"{where}: noise"),
                noise_orientation=schema.number(doc.get("noise_orientation", 0.0), f"{where}: noise_orientation"),
                seed=seed,
                preset=schema.text(doc.get("preset", "custom"), f"{where}: preset"),
            )
        except FileFormatError:
            raise
        except KeyError as missing:
            raise FileFormatError(f"{where}: missing entry {missing}") from None
        except (TypeError, ValueError, OverflowError, tomllib.TOMLDecodeError) as why:
            raise FileFormatError(f"{where}: {why}") from None


def _listed(table, key, where):
    """``table[key]`` if it is a list (a compliance's stiffness: numbers, or null for a rigid
    joint), else a one-line refusal."""
    value = table.get(key)
    if not isinstance(value, list):
        raise FileFormatError(f"{where}: compliance {key} must be a list of numbers (null: rigid), "
                              f"got {schema.shown(value)}")
    return value


def write_truth(path, truth):
    """Write ``truth`` (a :class:`TrueRobot`) as a JSON truth file, atomically."""
    return write_text_atomic(path, json.dumps(truth.to_dict(), indent=2) + "\n")


def read_truth(path):
    """Read a truth file written by :func:`write_truth`."""
    doc = load_json(path, "truth file", "settings", reader="truth")
    return TrueRobot.from_dict(doc, str(path))
