"""Loaders for three public measured datasets (MIT licence; sources and papers in
``robocal/io/data/README.md``).

Each loader returns a :class:`Dataset`: the robot model the data were taken against, the data
in internal units (:class:`~robocal.io.observations.Observations`: rad, mm, rotation matrices),
converted once by :func:`~robocal.io.observations.observations` as a user's own CSV is, and
the same data in file units (:class:`~robocal.io.tables.Measurements`: deg, mm), which
``robocal dataset`` writes.

The data ship inside the package (``robocal/io/data``, CSVs gzip-compressed).  A folder with
the uncompressed originals in the same layout can be read instead: pass ``root=`` or set
$ROBOCAL_SHARED_DATA.
"""
from __future__ import annotations

import csv
import gzip
import os
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import FileFormatError, InputError
from ..kinematics import Chain
from ..spatial import compose_pose, matrix_to_rpy
from .fixtures import Fixture
from .library import builtin
from .observations import Observations, observations
from .tables import Measurements

_ENV = "ROBOCAL_SHARED_DATA"
# Beside this module, so an installed wheel finds it from any working directory.
PACKAGED_DATA = Path(__file__).resolve().with_name("data")


class _Source(NamedTuple):
    folder: Path
    origin: str  # where the folder came from, for error messages
    suffix: str  # ".gz" for the packaged copy, "" for uncompressed originals


def _source(root=None):
    """The folder to read: ``root``, else $ROBOCAL_SHARED_DATA, else the packaged copy."""
    if root:
        return _Source(Path(root), "given as root", "")
    if os.environ.get(_ENV):
        return _Source(Path(os.environ[_ENV]), f"from ${_ENV}", "")
    return _Source(PACKAGED_DATA, "packaged with robocal: reinstall it", ".gz")


@dataclass(frozen=True, eq=False)
class Dataset:
    """A measured dataset shipped with robocal, as every loader returns it.

    Attributes
    ----------
    name : str
        Its name for ``robocal dataset NAME`` (e.g. "ur5-tsinghua", "mukca-panda-1").
    chain : Chain
        The robot model the data were taken against.
    observations : Observations
        The data in internal units, what every method fits: joints (N, n) rad; positions
        (N, 3) mm and rotations (N, 3, 3), or None for ball-in-socket data, which carry
        placement and socket (N,) ids and their ``fixture`` instead.
    measurements : Measurements
        The same data in file units: joints (N, n) deg, positions (N, 3) mm, orientations
        (N, 3) rpy deg; the file ``robocal dataset`` writes.
    fixture : Fixture or None
        The socket fixture (mm) of ball-in-socket data; None for instrument data.
    description : str
        Robot, instrument and poses, in one line.
    citation : str
        The paper to cite when the data are used.

    A dataset is not a tuple: unpacking or indexing it raises a TypeError that names the
    attributes to use.
    """

    name: str
    chain: Chain
    observations: Observations
    measurements: Measurements
    fixture: Fixture | None
    description: str
    citation: str

    def _not_a_tuple(self):
        return TypeError(f"the loaders return a Dataset, not a tuple: use dataset.chain, dataset.observations "
                         f"(rad, mm), dataset.measurements (file units: deg, mm) and dataset.fixture "
                         f"(dataset '{self.name}')")

    def __iter__(self):
        raise self._not_a_tuple()

    def __getitem__(self, index):
        raise self._not_a_tuple()

    def __repr__(self):
        return (f"Dataset({self.name!r}: {self.chain.name}, {self.observations.n_poses} "
                f"{self.observations.kind} observations)")


def _dataset(name, chain, data, description, citation, fixture=None):
    """The :class:`Dataset` of ``data`` (file units), converted as a user's own file is."""
    return Dataset(name=name, chain=chain, observations=observations(chain, data, fixture), measurements=data,
                   fixture=fixture, description=description, citation=citation)


def dataset_dir(root=None):
    """The folder the loaders read: ``root``, else $ROBOCAL_SHARED_DATA, else the packaged
    copy.  Files other than the CSVs, such as ``mukca/panda.urdf``, are uncompressed in all."""
    return _source(root).folder


def _data_file(source, relative):
    """Path of ``relative`` (an original file name, e.g. ``ur5_tsinghua/x.csv``) in ``source``."""
    path = source.folder / (relative + source.suffix)
    if not path.is_file():
        raise InputError(f"dataset folder {source.folder} ({source.origin}) has no {relative}")
    return path


def _open_text(path):
    # newline="" keeps the CRLF line ends of the ipa files for the csv module, as open() did.
    if path.suffix == ".gz":
        return gzip.open(path, "rt", newline="", encoding="utf-8")
    return open(path, newline="", encoding="utf-8")


def _read_rows(path, delimiter):
    with _open_text(path) as handle:
        rows = list(csv.reader(handle, delimiter=delimiter))
    if not rows:
        raise FileFormatError(f"{path} is empty")
    return rows[0], rows[1:]


def _columns(path, header, rows, names, decimal_comma=False):
    index = {name: i for i, name in enumerate(header)}
    missing = [n for n in names if n not in index]
    if missing:
        raise FileFormatError(f"{path}: columns {', '.join(missing)} are missing")
    text = np.array([[row[index[n]] for n in names] for row in rows])
    if decimal_comma:
        text = np.char.replace(text, ",", ".")
    return text.astype(float)


def ur5_tsinghua(root=None):
    """UR5 with a GTS3800 tracker, positions in the robot base frame (1,000 grid poses).

    The targets are nominal FK of the authors' UR5 model (their d5 = 94.56 mm, not UR's
    94.65) plus a 31 mm tool along the flange z axis; measured = target + dif.
    Returns a :class:`Dataset` ("ur5-tsinghua"); its measurements keep the targets as the
    x_t, y_t, z_t columns.
    """
    path = _data_file(_source(root), "ur5_tsinghua/3D_UR5_uncalibrated_grid_cleaned.csv")
    header, rows = _read_rows(path, ",")
    joints = _columns(path, header, rows, [f"joint_{i}" for i in range(1, 7)])
    target = _columns(path, header, rows, ["x_t", "y_t", "z_t"])
    dif = _columns(path, header, rows, ["x_dif", "y_dif", "z_dif"])
    ur5 = builtin("ur5")
    d = ur5.d.copy()
    d[4] = 94.56
    chain = ur5.replace(name="UR5 (Tsinghua dataset model)", d=d, tool=compose_pose([0.0, 0.0, 31.0], np.zeros(3)))
    data = Measurements(path=str(path), joints=joints, positions=target + dif,
                        extra={"x_t": target[:, 0], "y_t": target[:, 1], "z_t": target[:, 2]})
    return _dataset("ur5-tsinghua", chain, data,
                    f"UR5, GTS3800 laser tracker, {data.n_poses} grid poses in the robot base frame",
                    "Yao, Jacobi, Shao, Kibireva, Applied Soft Computing 203 (2026) 116099")


def ipa_ur10(series="B", root=None):
    """UR10 with a Leica tracker and 6-DoF probe (ipa): Series 'A' (grid, 11,911 poses),
    'B' (joint configurations, 1,495 poses, with per-reading standard deviations) or 'D'
    (ISO cubes, 632 visits, with standard deviations; :mod:`robocal.io.ipa_iso` makes an ISO
    9283 campaign of it).

    Positions and orientations are in the tracker frame; base (tracker <- robot) and tool
    (flange -> probe) are not given.  The chain's tool starts at the probe offset the
    dataset README quotes, (0, 0.3, 93) mm, for registration to refine; for series D at the
    TCP its commanded poses are of, 109 mm along the flange z axis.
    Returns a :class:`Dataset` ("ipa-ur10-a", "-b" or "-d") with the measured orientations
    (robocal rpy in its measurements, in deg) and, for series A, the acquisition times.
    """
    from scipy.spatial.transform import Rotation  # loaded when used: the command line starts faster
    series = str(series).upper()
    files = {"A": "Series_A/measurements_grid.csv", "B": "Series_B/measurements_joint_configurations.csv",
             "D": "Series_D/measurements_iso_cubes.csv"}
    if series not in files:
        raise InputError(f"ipa UR10 series must be 'A', 'B' or 'D', got {series!r}")
    path = _data_file(_source(root), "ipa_ur10/" + files[series])
    header, rows = _read_rows(path, ";")
    joint_names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                   "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
    joints = np.degrees(_columns(path, header, rows, joint_names, decimal_comma=True))
    xyz = _columns(path, header, rows, ["measurement_x", "measurement_y", "measurement_z"], decimal_comma=True)
    euler = _columns(path, header, rows, ["measurement_rx", "measurement_ry", "measurement_rz"], decimal_comma=True)
    # The tracker reports intrinsic X-Y-Z Euler angles; robocal's rpy is fixed-axis x, y, z.
    rpy = np.degrees(matrix_to_rpy(Rotation.from_euler("XYZ", euler, degrees=True).as_matrix()))
    sigmas = None
    if series in ("B", "D"):
        sigmas = _columns(path, header, rows, ["measurement_std_x", "measurement_std_y", "measurement_std_z"],
                          decimal_comma=True)
        sigmas = np.maximum(sigmas, 1e-4)  # a reported 0 would mean infinite weight
    probe = [0.0, 0.0, 109.0] if series == "D" else [0.0, 0.3, 93.0]
    chain = builtin("ur10").replace(name=f"UR10 (ipa series {series})", tool=compose_pose(probe, np.zeros(3)))
    # The acquisition time (YYYYMMDDhhmmss) orders the rows for a split that holds out the
    # last poses measured.  Series B's were rounded to 6 digits by a spreadsheet (2,02011E+13):
    # its rows are in acquisition order, but its stamps say nothing and are left out.
    stamps = _columns(path, header, rows, ["Timestamp"], decimal_comma=True)[:, 0] if "Timestamp" in header else None
    distinct = stamps is not None and len(np.unique(stamps)) > len(stamps) // 2
    extra = {"timestamp": np.asarray([f"{t:.0f}" for t in stamps])} if distinct else {}
    data = Measurements(path=str(path), joints=joints, positions=xyz, orientations=rpy, sigmas=sigmas, extra=extra)
    return _dataset(f"ipa-ur10-{series.lower()}", chain, data,
                    f"UR10, Leica laser tracker with a 6-DoF probe, series {series}: {data.n_poses} poses "
                    "in the tracker frame",
                    "Landgraf et al., A Hybrid Neural Network Approach for Increasing the Absolute Accuracy "
                    "of Industrial Robots, IEEE CASE 2021")


# The MUKCa fixture: two sockets 50 mm apart; the files name them hole_0 and hole_1.
MUKCA_SOCKET_DISTANCE_MM = 50.0
# Ball centre on the flange axis, a first guess for the calibration to refine: Franka's hand
# TCP (103.4 mm beyond the flange) plus about 30 mm to the ball centre.
MUKCA_BALL_MM = 103.4 + 30.0


def mukca(unit="panda_1", root=None):
    """Ball-in-socket data of a Franka Panda (MUKCa): joint angles only, no instrument.

    unit: 'panda_1', 'panda_2' or 'panda_3'.  Placements are the unit's folders (sorted);
    each row of ``<placement>/hole_k.csv`` (7 joint angles in rad, no header) is a
    configuration with the ball in socket ``k``.
    Returns a :class:`Dataset` ("mukca-panda-N"): the built-in Panda with the ball as its
    tool (a guess, on the flange z axis), the two-socket fixture, and constraint observations
    with the placement in ``placement`` and ``"0"`` / ``"1"`` in ``socket`` (in its
    measurements, file units, the placement is the ``fixture`` column).
    """
    source = _source(root)
    folder = source.folder / "mukca" / str(unit)
    if not folder.is_dir():
        units = sorted(p.name for p in folder.parent.glob("panda_*")) if folder.parent.is_dir() else []
        known = f"; units: {', '.join(units)}" if units else ""
        raise InputError(f"no MUKCa unit {unit!r} in {folder.parent} ({source.origin}){known}")
    joints, placements, sockets = [], [], []
    for placement in sorted(p for p in folder.iterdir() if p.is_dir()):
        for path in sorted(placement.glob("hole_[0-9].csv" + source.suffix)):
            try:
                with _open_text(path) as handle:
                    q = np.loadtxt(handle, delimiter=",", ndmin=2)
            except ValueError as why:
                raise FileFormatError(f"{path}: {why}") from None
            if q.shape[1] != 7:
                raise FileFormatError(f"{path}: expected 7 joint columns, got {q.shape[1]}")
            joints.append(np.degrees(q))
            placements += [placement.name] * len(q)
            sockets += [path.name.split(".")[0].split("_")[1]] * len(q)  # hole_<k>.csv[.gz]
    if not joints:
        raise FileFormatError(f"{folder} ({source.origin}) holds no <placement>/hole_k.csv files")
    fixture = Fixture(name="MUKCa two-socket fixture",
                      sockets={"0": [0.0, 0.0, 0.0], "1": [MUKCA_SOCKET_DISTANCE_MM, 0.0, 0.0]})
    chain = builtin("panda").replace(name=f"Franka Panda (MUKCa {unit}, ball tool)",
                                     tool=compose_pose([0.0, 0.0, MUKCA_BALL_MM], np.zeros(3)))
    data = Measurements(path=str(folder), joints=np.concatenate(joints), fixture=placements, socket=sockets)
    return _dataset(f"mukca-{str(unit).replace('_', '-')}", chain, data,
                    f"Franka Panda, ball in a two-socket fixture, joint angles only: {data.n_poses} "
                    f"configurations in {len(set(placements))} placements",
                    "Franzese, Spahn, Kober, Della Santina, arXiv:2503.12584 (2025)", fixture)


def split_indices(data, split, seed=0):
    """Training rows of a random split of ``data`` (:class:`Measurements`) with ``split`` the
    training fraction, and the training placements (sorted names) for ball-in-socket data,
    which are split by whole fixture placements so that the test placements are unseen;
    None for other data."""
    if not 0.0 < split < 1.0:
        raise InputError(f"--split is the training fraction and must lie between 0 and 1, got {split}")
    rng = np.random.default_rng(seed)
    if data.fixture is None:
        count = int(round(split * data.n_poses))
        if not 0 < count < data.n_poses:
            raise InputError(f"--split {split} of {data.n_poses} poses leaves "
                             f"{'no training' if count == 0 else 'no test'} "
                             f"pose: give a training fraction between {1 / data.n_poses:.3g} and "
                             f"{1 - 1 / data.n_poses:.4g}")
        return np.sort(rng.permutation(data.n_poses)[:count]), None
    placements = np.unique(data.fixture)
    if len(placements) < 2:
        raise InputError(f"{data.path} has one fixture placement: nothing to hold out")
    cut = min(max(int(round(split * len(placements))), 1), len(placements) - 1)
    chosen = rng.permutation(placements)[:cut]
    return np.flatnonzero(np.isin(data.fixture, chosen)), sorted(str(p) for p in chosen)
