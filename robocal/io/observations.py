"""Observations: what a method fits and is scored on, in internal units.

A measurement file is read in file units (mm, degrees; :class:`~robocal.io.tables.Measurements`);
:func:`observations` converts it once, here at the edge, for a given robot: joint readings to
rad (mm for prismatic joints), orientations to rotation matrices, and, for ball-in-socket
data, the fixture file to a :class:`~robocal.io.fixtures.Fixture`.  Nothing below this layer
sees degrees.

It is also where data meet their robot, so it refuses what no calibration of that robot can
use, with one line each: joint values beyond the robot's limits, measured positions whose
scale does not fit the robot's (metres, inches, cm, micrometres), and a robot file whose
lengths look like metres.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..spatial import compose_pose, pose_to_xyz_rpy, rpy_to_matrix
from .fixtures import Fixture, fixture_from_dict, fixture_to_dict, read_fixture
from .library import load_robot
from .tables import Measurements, read_measurements, read_targets, write_commands
from .units import beyond_limits, check_measurement_units, check_target_units
# The flange of an industrial robot reaches hundreds of mm from its base; a model that stays
# within this over every pose has its lengths in metres.
SMALLEST_REACH_MM = 10.0
# Configurations over the joint range that judge a robot without data (simulation).
SIZE_SAMPLE = 64


@dataclass(frozen=True, eq=False)
class Observations:
    """Measured data of one robot, in internal units.

    Attributes
    ----------
    path : str
        The file the data came from ("" for data made in memory).
    joints : (N, n) array
        Joint readings of the controller in rad (mm for prismatic joints).
    positions : (N, 3) array or None
        Measured TCP positions in mm, in the measurement frame; None for ball-in-socket data.
    rotations : (N, 3, 3) array or None
        Measured TCP orientations as rotation matrices, or None.
    sigmas : (N, 3) array or None
        Standard deviations of the positions in mm, or None.
    placement, socket : (N,) arrays of str or None
        Ball-in-socket data: the fixture placement and the socket of each configuration.
    fixture : Fixture or None
        The fixture whose sockets ``socket`` names (ball-in-socket data).
    rows : (N,) array of int
        The line of each row in its file (header = line 1), for messages.
    kind : str
        "pose", "position" or "constraint", as :attr:`Measurements.kind`.
    times : (N,) array or None
        When each row was measured (seconds, or any increasing number), from a ``timestamp``
        or ``time`` column; None when the file has neither.
    """

    path: str
    joints: np.ndarray
    positions: np.ndarray | None
    rotations: np.ndarray | None
    sigmas: np.ndarray | None
    placement: np.ndarray | None
    socket: np.ndarray | None
    fixture: Fixture | None
    rows: np.ndarray
    kind: str
    times: np.ndarray | None = None

    @classmethod
    def of(cls, joints, positions=None, *, rotations=None, sigmas=None, placement=None, socket=None,
           fixture=None, path="") -> Observations:
        """Observations made in memory (a simulation, a script), already in internal units:
        joints (N, n) rad; positions (N, 3) mm; rotations (N, 3, 3); sigmas (N, 3) mm;
        placement and socket (N,) ids with their ``fixture`` for ball-in-socket data."""
        joints = np.atleast_2d(cls._numbers(joints, "joints", "(N, n) rad (mm for prismatic joints)"))
        if joints.ndim != 2:
            raise InputError(f"joints must be (N, n): one row of joint values (rad; mm for prismatic joints) per "
                             f"pose, got shape {joints.shape}")
        count = len(joints)

        def array(values, shape, name, dtype=float):
            if values is None:
                return None
            values = np.asarray(values, dtype=dtype) if dtype is str else cls._numbers(values, name, f"{shape}")
            if values.shape != shape:
                raise InputError(f"{name} must have shape {shape} for {count} poses, got {values.shape}")
            return values

        positions = array(positions, (count, 3), "positions")
        placement = array(placement, (count,), "placement", str)
        kind = ("pose" if rotations is not None else "position") if positions is not None else "constraint"
        if positions is None and placement is None:
            raise InputError("observations need measured positions or ball-in-socket ids (placement, socket)")
        return cls(path=str(path), joints=joints, positions=positions,
                   rotations=array(rotations, (count, 3, 3), "rotations"), sigmas=array(sigmas, (count, 3), "sigmas"),
                   placement=placement, socket=array(socket, (count,), "socket", str), fixture=fixture,
                   rows=np.arange(2, count + 2), kind=kind)

    @staticmethod
    def _numbers(values, name, shape):
        """``values`` as a float array, or an InputError saying what they must be."""
        try:
            return np.asarray(values, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{name} must be numbers, {shape}; got {type(values).__name__} with "
                             "values that are not numbers") from None

    @property
    def n_poses(self) -> int:
        """Number of observed configurations."""
        return len(self.joints)

    def to_plain(self) -> dict:
        """The observations as plain data (arrays, text, a dict for the fixture): what crosses
        to another process (:mod:`robocal.parallel`); :meth:`from_plain` reads it back exactly."""
        arrays = ("joints", "positions", "rotations", "sigmas", "placement", "socket", "rows", "times")
        plain = {name: getattr(self, name) for name in arrays}
        return {**plain, "path": self.path, "kind": self.kind,
                "fixture": None if self.fixture is None else fixture_to_dict(self.fixture)}

    @classmethod
    def from_plain(cls, plain) -> Observations:
        """The observations :meth:`to_plain` made."""
        fixture = plain["fixture"]
        return cls(**{**plain, "fixture": None if fixture is None else fixture_from_dict(fixture, plain["path"])})

    def subset(self, index) -> Observations:
        """The observations selected by ``index`` (integer indices or a boolean mask)."""
        index = np.asarray(index)
        if index.size == 0:
            index = index.astype(int)

        def take(values):
            return None if values is None else values[index]

        return replace(self, joints=self.joints[index], positions=take(self.positions),
                       rotations=take(self.rotations), sigmas=take(self.sigmas),
                       placement=take(self.placement), socket=take(self.socket), rows=self.rows[index],
                       times=take(self.times))


def observations(chain, data: Measurements, fixture: Fixture | None = None, *, beyond_limits=False) -> Observations:
    """``data`` (file units) as :class:`Observations` of ``chain`` (internal units).

    ``fixture`` is required for ball-in-socket data and refused for instrument data.
    InputError, naming the file rows, for joint values beyond the robot's limits (by more than
    robocal.io.units.LIMIT_TOLERANCE_DEG / _MM; ``beyond_limits=True`` accepts them), for measured positions
    whose spread does not fit the robot's (another length unit), and for a robot whose
    lengths look like metres.
    """
    if fixture is not None and data.fixture is None:
        raise InputError(f"{data.path or 'the data'} has no fixture and socket columns: a fixture "
                         "(--fixture) applies to ball-in-socket data only")
    joints = chain.joints_from_file(data.joints)
    if not beyond_limits:
        _check_limits(chain, data, joints)
    check_robot_in_mm(chain, joints)
    if data.positions is not None:
        check_measurement_units(chain, data.joints, data.positions, data.path)
    return Observations(
        path=data.path, joints=joints, positions=data.positions,
        rotations=None if data.orientations is None else rpy_to_matrix(np.radians(data.orientations)),
        sigmas=data.sigmas, placement=data.fixture, socket=data.socket, fixture=fixture,
        rows=data.rows, kind=data.kind, times=_times(data))


# Columns that say when a row was measured (the measurement file keeps other columns as text).
TIME_COLUMNS = ("timestamp", "time")


def _times(data: Measurements):
    """The rows' measurement times from the first TIME_COLUMNS column present, as numbers;
    an InputError naming the row of a value that is not one."""
    for name in TIME_COLUMNS:
        if name in data.extra:
            values = np.asarray(data.extra[name])
            try:
                times = values.astype(float)
            except ValueError:
                times = None
            if times is None or not np.isfinite(times).all():
                bad = next(i for i, v in enumerate(values) if not _is_number(v))
                raise InputError(f"{data.path or 'the data'} row {int(data.rows[bad])}: {name} = '{values[bad]}' is "
                                 f"not a number; give the {name} column as numbers (e.g. seconds or "
                                 "YYYYMMDDhhmmss), or remove it")
            return times
    return None


def _is_number(text):
    try:
        return np.isfinite(float(text))
    except ValueError:
        return False


def read_observations(path, chain, fixture_path=None, *, beyond_limits=False) -> Observations:
    """Read a measurement CSV (and a fixture file for ball-in-socket data) for ``chain`` (a
    Chain, or a built-in name or robot file as :func:`~robocal.io.library.load_robot` takes);
    ``beyond_limits`` as in :func:`observations`."""
    if isinstance(chain, (str, os.PathLike)):
        chain = load_robot(chain)
    if not hasattr(chain, "joints_from_file"):
        raise InputError(f"the robot must be a Chain, a built-in name or a robot file, got {type(chain).__name__}")
    data = read_measurements(path, n_joints=chain.n_joints, joint_names=chain.joint_names, robot_judges_units=True)
    fixture = None if fixture_path is None else read_fixture(fixture_path)
    return observations(chain, data, fixture, beyond_limits=beyond_limits)


def _check_limits(chain, data: Measurements, joints):
    """InputError naming the rows whose joint values lie beyond the robot's limits."""
    beyond = beyond_limits(chain, joints)
    if not beyond.any():
        return
    rows = np.flatnonzero(beyond.any(axis=1))
    first = rows[0]
    joint = int(np.flatnonzero(beyond[first])[0])
    unit = "deg" if chain.revolute[joint] else "mm"
    low, high = chain.joints_to_file(np.vstack([chain.lower, chain.upper]))[:, joint]
    lines = [str(int(line)) for line in np.asarray(data.rows)[rows[:5]]]
    if len(rows) > 5:
        named = f"rows {', '.join(lines)} and {len(rows) - 5} more"
    else:
        named = f"row {lines[0]}" if len(lines) == 1 else f"rows {', '.join(lines[:-1])} and {lines[-1]}"
    others = " (and others)" if len(rows) > 1 or beyond[first].sum() > 1 else ""
    fix = "those rows" if len(rows) > 1 else "the row"
    raise InputError(
        f"{data.path or 'the data'} {named}: q{joint + 1} = {data.joints[first, joint]:.6g} {unit}{others} lies "
        f"beyond joint {joint + 1}'s limits {low:.6g} to {high:.6g} {unit} of the robot '{chain.name}': fix {fix} "
        "or the robot file's min and max, or accept values beyond the limits "
        "(--beyond-limits; beyond_limits=True in Python)")


def check_robot_in_mm(chain, joints=None):
    """InputError when the robot's flange stays within SMALLEST_REACH_MM of its base over
    ``joints`` (N, n) rad, or over its joint range when None: its file gives lengths in
    metres.  Wherever a robot meets data (reading measurements, simulating them)."""
    where = "over these poses"
    if joints is None:
        # Seeded: the same robot is judged the same way every time.
        joints, where = chain.random_configurations(SIZE_SAMPLE, rng=0), "over its joint range"
    if len(joints) == 0:
        return
    rigid = chain.rigid
    reach = float(np.linalg.norm(rigid.replace(base=np.eye(4), tool=np.eye(4)).fk_positions(joints), axis=1).max())
    if reach < SMALLEST_REACH_MM:
        raise InputError(
            f"the robot '{chain.name}' reaches at most {reach:.3g} from its base {where}, where an "
            "industrial robot reaches hundreds of mm: its robot file looks like metres; give its lengths in mm")


@dataclass(frozen=True, eq=False)
class TargetPoses:
    """A targets file in internal units: ``poses`` (N, 4, 4) (mm) in the measurement frame,
    ``hints`` (N, n) rad posture hints or None, ``rows`` (N,) file lines."""

    path: str
    poses: np.ndarray
    hints: np.ndarray | None
    rows: np.ndarray


def read_target_poses(path, chain) -> TargetPoses:
    """Read a targets CSV (x, y, z mm; rx, ry, rz deg; optional q1..qN deg) for ``chain``."""
    targets = read_targets(path, n_joints=chain.n_joints, joint_names=chain.joint_names)
    check_target_units(chain, targets.hints, targets.positions, targets.path)
    hints = None if targets.hints is None else chain.joints_from_file(targets.hints)
    return TargetPoses(targets.path, compose_pose(targets.positions, np.radians(targets.orientations)), hints,
                       np.asarray(targets.rows))


# What the Cartesian columns of a commands file are, said in the file itself.
COMMANDS_FRAME = "robot base frame; robot-file tool; controller FK of q"


def write_joint_commands(path, chain, joints, poses, reachable, extra=None):
    """Write a commands CSV: ``joints`` (N, n) rad (ignored where not ``reachable``), the
    Cartesian ``poses`` (N, 4, 4) sent, the ``reachable`` (N,) column, the ``frame`` column
    (COMMANDS_FRAME) and the ``extra`` columns ({name: N cells}); in file units."""
    reachable = np.asarray(reachable, dtype=bool)
    xyz, rpy = pose_to_xyz_rpy(poses)
    file_joints = chain.joints_to_file(np.where(reachable[:, None], joints, 0.0))
    return write_commands(path, file_joints, xyz, np.degrees(rpy), joint_ok=reachable, frame=COMMANDS_FRAME,
                          extra=extra)
