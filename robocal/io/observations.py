"""Observations: what a method fits and is scored on, in internal units.

A measurement file is read in file units (mm, degrees; :class:`~robocal.io.tables.Measurements`);
:func:`observations` converts it once, here at the edge, for a given robot: joint readings to
rad (mm for prismatic joints), orientations to rotation matrices, and, for ball-in-socket
data, the fixture file to a :class:`~robocal.io.fixtures.Fixture`.  Nothing below this layer
sees degrees.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..spatial import compose_pose, pose_to_xyz_rpy, rpy_to_matrix
from .fixtures import Fixture, read_fixture
from .tables import Measurements, read_measurements, read_targets, write_commands


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

    @classmethod
    def of(cls, joints, positions=None, *, rotations=None, sigmas=None, placement=None, socket=None,
           fixture=None, path="") -> Observations:
        """Observations made in memory (a simulation, a script), already in internal units:
        joints (N, n) rad; positions (N, 3) mm; rotations (N, 3, 3); sigmas (N, 3) mm;
        placement and socket (N,) ids with their ``fixture`` for ball-in-socket data."""
        joints = np.atleast_2d(np.asarray(joints, dtype=float))
        count = len(joints)

        def array(values, shape, name, dtype=float):
            if values is None:
                return None
            values = np.asarray(values, dtype=dtype)
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

    @property
    def n_poses(self) -> int:
        """Number of observed configurations."""
        return len(self.joints)

    def subset(self, index) -> Observations:
        """The observations selected by ``index`` (integer indices or a boolean mask)."""
        index = np.asarray(index)
        if index.size == 0:
            index = index.astype(int)

        def take(values):
            return None if values is None else values[index]

        return replace(self, joints=self.joints[index], positions=take(self.positions),
                       rotations=take(self.rotations), sigmas=take(self.sigmas),
                       placement=take(self.placement), socket=take(self.socket), rows=self.rows[index])


def observations(chain, data: Measurements, fixture: Fixture | None = None) -> Observations:
    """``data`` (file units) as :class:`Observations` of ``chain`` (internal units).

    ``fixture`` is required for ball-in-socket data and refused for instrument data.
    """
    if fixture is not None and data.fixture is None:
        raise InputError(f"{data.path or 'the data'} has no fixture and socket columns: a fixture "
                         "(--fixture) applies to ball-in-socket data only")
    return Observations(
        path=data.path, joints=chain.joints_from_file(data.joints), positions=data.positions,
        rotations=None if data.orientations is None else rpy_to_matrix(np.radians(data.orientations)),
        sigmas=data.sigmas, placement=data.fixture, socket=data.socket, fixture=fixture,
        rows=data.rows, kind=data.kind)


def read_observations(path, chain, fixture_path=None) -> Observations:
    """Read a measurement CSV (and a fixture file for ball-in-socket data) for ``chain``."""
    data = read_measurements(path, n_joints=chain.n_joints)
    fixture = None if fixture_path is None else read_fixture(fixture_path)
    return observations(chain, data, fixture)


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
    targets = read_targets(path, n_joints=chain.n_joints)
    hints = None if targets.hints is None else chain.joints_from_file(targets.hints)
    return TargetPoses(targets.path, compose_pose(targets.positions, np.radians(targets.orientations)), hints,
                       np.asarray(targets.rows))


def write_joint_commands(path, chain, joints, poses, reachable):
    """Write a commands CSV: ``joints`` (N, n) rad (ignored where not ``reachable``), the
    Cartesian ``poses`` (N, 4, 4) sent, and the ``reachable`` (N,) column; in file units."""
    reachable = np.asarray(reachable, dtype=bool)
    xyz, rpy = pose_to_xyz_rpy(poses)
    file_joints = chain.joints_to_file(np.where(reachable[:, None], joints, 0.0))
    return write_commands(path, file_joints, xyz, np.degrees(rpy), joint_ok=reachable)
