"""Measurement, target and command CSV files (docs/ARCHITECTURE.md, "File formats").

Values stay in file units here: millimetres and degrees.  The kinematics layer converts.

Row numbers in messages and in :attr:`Measurements.rows` are line numbers of the file
with the header on line 1, which is also the row number a spreadsheet shows.
"""

from __future__ import annotations

import dataclasses
import difflib
import os
import warnings
from dataclasses import dataclass, field

import numpy as np

from robocal.errors import FileFormatError, InputError, RobocalWarning
from robocal.io.csv_table import (  # noqa: F401  (the column names are this module's vocabulary too)
    CONSTRAINT_COLUMNS,
    JOINT_COLUMN as _JOINT_COLUMN,
    ORIENTATION_COLUMNS,
    POSITION_COLUMNS,
    SIGMA_COLUMNS,
    _Table,
    _read_table,
)
from robocal.io.csv_writing import write_commands, write_measurements  # noqa: F401  (re-exported)
from robocal.io.file_kinds import KIND_COLUMN, check
from robocal.io.units import JOINT_RADIAN_BOUND, check_angles, joint_values_look_like_radians

_NAMED_COLUMNS = POSITION_COLUMNS + ORIENTATION_COLUMNS + SIGMA_COLUMNS + CONSTRAINT_COLUMNS + (KIND_COLUMN,)
# Joint names offered as spelling suggestions even when the file has fewer joints.
_SUGGESTED_JOINT_COUNT = 12

# How many groups of identical rows a warning spells out before summarising the rest.
_DUPLICATES_SHOWN = 3


# --------------------------------------------------------------------------- data types


@dataclass(frozen=True, eq=False)
class Measurements:
    """The content of a measurement file, in file units (mm, degrees).

    Attributes:
        path: the file the data came from (``""`` for data made in memory).
        joints: (N, n) joint positions in degrees (mm for prismatic joints).
        positions: (N, 3) measured x, y, z in mm, or None for constraint data.
        orientations: (N, 3) measured rx, ry, rz in degrees, or None.
        sigmas: (N, 3) standard deviations of x, y, z in mm, or None.
        fixture: (N,) fixture placement ids as strings, or None.
        socket: (N,) socket ids as strings, or None.
        rows: (N,) line number of each row in its file (header = line 1); defaults to
            2..N+1, the lines the rows would occupy when written.
        extra: other columns, by name, as (N,) string arrays.
    """

    path: str
    joints: np.ndarray
    positions: np.ndarray | None = None
    orientations: np.ndarray | None = None
    sigmas: np.ndarray | None = None
    fixture: np.ndarray | None = None
    socket: np.ndarray | None = None
    rows: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        joints = np.asarray(self.joints, dtype=float)
        if joints.ndim != 2 or joints.shape[1] == 0:
            raise InputError(f"joints must be an (N, n) array with n >= 1, got shape {joints.shape}")
        count = joints.shape[0]
        object.__setattr__(self, "path", str(self.path))
        object.__setattr__(self, "joints", joints)
        for name in ("positions", "orientations", "sigmas"):
            object.__setattr__(self, name, _optional_triples(name, getattr(self, name), count))
        for name in CONSTRAINT_COLUMNS:
            object.__setattr__(self, name, _optional_strings(name, getattr(self, name), count))
        rows = np.arange(2, count + 2) if self.rows is None else np.asarray(self.rows, dtype=int)
        if rows.shape != (count,):
            raise InputError(f"rows must have shape ({count},), got {rows.shape}")
        object.__setattr__(self, "rows", rows)
        extra = {str(name): _optional_strings(f"extra column {name!r}", values, count)
                 for name, values in self.extra.items()}
        object.__setattr__(self, "extra", extra)
        self._check_columns_fit_together()

    def _check_columns_fit_together(self) -> None:
        if (self.fixture is None) != (self.socket is None):
            raise InputError("fixture and socket go together: give both or neither")
        if self.positions is None and self.fixture is None:
            raise InputError("measurements need positions (x, y, z) or constraint ids (fixture, socket)")
        if self.positions is None and (self.orientations is not None or self.sigmas is not None):
            raise InputError("orientations and sigmas describe measured positions: they need positions too")
        if self.sigmas is not None and not np.all(self.sigmas > 0):
            raise InputError("sigmas (standard deviations) must all be > 0")
        clashes = sorted(set(self.extra) & (set(_NAMED_COLUMNS) | set(self.joint_names)))
        if clashes:
            raise InputError(f"extra columns {clashes} clash with measurement columns: rename them")

    @property
    def n_poses(self) -> int:
        """Number of measured configurations (rows)."""
        return self.joints.shape[0]

    @property
    def n_joints(self) -> int:
        """Number of joint columns."""
        return self.joints.shape[1]

    @property
    def joint_names(self) -> list[str]:
        """The joint column names, ``q1`` … ``qn``."""
        return [f"q{i}" for i in range(1, self.n_joints + 1)]

    @property
    def kind(self) -> str:
        """``"pose"`` (positions and orientations), ``"position"`` or ``"constraint"``.

        A file with both x, y, z and fixture, socket counts as position data: it carries
        more information; the constraint ids remain available.
        """
        if self.orientations is not None:
            return "pose"
        if self.positions is not None:
            return "position"
        return "constraint"

    def subset(self, index: np.ndarray) -> Measurements:
        """The rows selected by ``index`` (integer indices or a boolean mask of length N)."""
        index = np.asarray(index)
        if index.size == 0:
            index = index.astype(int)  # np.asarray([]) is float, which cannot index
        if index.dtype == bool and index.shape != (self.n_poses,):
            raise InputError(f"a boolean mask must have {self.n_poses} entries, got shape {index.shape}")

        def take(values):
            return None if values is None else values[index]

        return dataclasses.replace(
            self,
            joints=self.joints[index],
            positions=take(self.positions),
            orientations=take(self.orientations),
            sigmas=take(self.sigmas),
            fixture=take(self.fixture),
            socket=take(self.socket),
            rows=self.rows[index],
            extra={name: values[index] for name, values in self.extra.items()},
        )


@dataclass(frozen=True, eq=False)
class Targets:
    """The content of a targets file: desired TCP poses in the measurement frame.

    Attributes:
        path: the file the targets came from.
        positions: (N, 3) x, y, z in mm.
        orientations: (N, 3) rx, ry, rz in degrees.
        hints: (N, n) posture hints q1 … qn in degrees, or None.
        rows: (N,) line number of each target in its file (header = line 1).
    """

    path: str
    positions: np.ndarray
    orientations: np.ndarray
    hints: np.ndarray | None = None
    rows: np.ndarray | None = None

    def __post_init__(self) -> None:
        positions = np.asarray(self.positions, dtype=float)
        if positions.ndim != 2 or positions.shape[1] != 3:
            raise InputError(f"target positions must be an (N, 3) array, got shape {positions.shape}")
        count = positions.shape[0]
        object.__setattr__(self, "path", str(self.path))
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "orientations", _triples("orientations", self.orientations, count))
        if self.hints is not None:
            hints = np.asarray(self.hints, dtype=float)
            if hints.ndim != 2 or hints.shape[0] != count:
                raise InputError(f"posture hints must be an ({count}, n) array, got shape {hints.shape}")
            object.__setattr__(self, "hints", hints)
        rows = np.arange(2, count + 2) if self.rows is None else np.asarray(self.rows, dtype=int)
        if rows.shape != (count,):
            raise InputError(f"rows must have shape ({count},), got {rows.shape}")
        object.__setattr__(self, "rows", rows)

    @property
    def n_targets(self) -> int:
        """Number of targets (rows)."""
        return self.positions.shape[0]


def _triples(name: str, values, count: int) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    if array.shape != (count, 3):
        raise InputError(f"{name} must have shape ({count}, 3), got {array.shape}")
    return array


def _optional_triples(name: str, values, count: int) -> np.ndarray | None:
    return None if values is None else _triples(name, values, count)


def _optional_strings(name: str, values, count: int) -> np.ndarray | None:
    if values is None:
        return None
    array = np.asarray(values).astype(str)
    if array.shape != (count,):
        raise InputError(f"{name} must have shape ({count},), got {array.shape}")
    return array


# --------------------------------------------------------------------------- reading


def _named_joints(table: _Table, joint_names) -> _Table:
    """``table`` with columns named by the robot's ``joint_names`` renamed q1..qN (the k-th
    name is qk); a file with both kinds of joint column is refused."""
    if not joint_names:
        return table
    rename = {name: f"q{k}" for k, name in enumerate(joint_names, start=1)}
    named = [name for name in table.header if name in rename]
    if not named:
        return table
    numbered = [name for name in table.header if _JOINT_COLUMN.fullmatch(name)]
    if numbered:
        raise FileFormatError(f"{table.path} names joint columns both by the robot's joint names ({named[0]}) and "
                              f"as {numbered[0]}: keep one kind")
    missing = [name for name in joint_names if name not in table.header]
    if missing:
        raise FileFormatError(f"{table.path} names its joint columns by the robot's joints but lacks "
                              f"{', '.join(missing)}: the robot's joints are {', '.join(joint_names)}")
    return dataclasses.replace(table, header=[rename.get(name, name) for name in table.header],
                               scales={rename.get(name, name): v for name, v in table.scales.items()})


def read_measurements(path: str | os.PathLike, n_joints: int | None = None, joint_names=None, *,
                      robot_judges_units: bool = False) -> Measurements:
    """Read and validate a measurement CSV file.

    Args:
        path: the CSV file: ``q1`` … ``qN`` and either ``x, y, z`` (optionally with
            ``rx, ry, rz`` and ``sx, sy, sz``) or ``fixture, socket``.
        n_joints: the robot's number of joints, when known; the file must match it.
        joint_names: the robot's joint names, when it has them: the joint columns may
            carry them instead of q1 … qN.
        robot_judges_units: the caller has the robot judge the units of position data
            (:mod:`robocal.io.units`, as ``read_observations`` does): no warning here from
            the joint values alone, which would say the same thing twice.

    Raises:
        FileFormatError: the file is missing, malformed or inconsistent; the message names
            the file, and the row and column where there is one.
        InputError: measured orientations rx, ry, rz that look like radians.

    Warns:
        RobocalWarning: joint values that look like radians; identical rows.
    """
    table = _named_joints(_read_table(path), joint_names)
    # A design's poses file becomes a measurement file when the measured x, y, z (or the
    # sockets) are added to it.
    kind = check(table.path, "measurements", header=table.header, column=table.column)
    joint_names = _check_header(table, n_joints)
    has_positions = _column_group_present(table, POSITION_COLUMNS, "measured positions")
    has_orientations = _column_group_present(table, ORIENTATION_COLUMNS, "measured orientations")
    has_sigmas = _column_group_present(table, SIGMA_COLUMNS, "standard deviations")
    has_constraints = _column_group_present(table, CONSTRAINT_COLUMNS, "constraint data")
    if kind == "poses" and not (has_positions or has_constraints):
        raise FileFormatError(f"{table.path} is robocal's planned poses, written by 'robocal design': measure them "
                              "and add the measured x, y, z (mm) to each row, then calibrate on it")
    if not (has_positions or has_constraints):
        raise FileFormatError(
            f"{table.path} has neither measured positions nor constraint data: add columns x, y, z "
            f"(measured TCP position, mm) or fixture, socket (which fixture socket the ball sat in)"
        )
    if not has_positions and (has_orientations or has_sigmas):
        raise FileFormatError(
            f"{table.path} has {'rx, ry, rz' if has_orientations else 'sx, sy, sz'} but no x, y, z: "
            f"orientations and standard deviations belong to measured positions; add x, y, z"
        )
    sigmas = table.numbers(SIGMA_COLUMNS) if has_sigmas else None
    if sigmas is not None:
        table.check_positive(SIGMA_COLUMNS, sigmas, "a standard deviation must be > 0")
    measurements = Measurements(
        path=table.path,
        joints=table.numbers(joint_names),
        positions=table.numbers(POSITION_COLUMNS) if has_positions else None,
        orientations=table.numbers(ORIENTATION_COLUMNS) if has_orientations else None,
        sigmas=sigmas,
        fixture=table.texts("fixture") if has_constraints else None,
        socket=table.texts("socket") if has_constraints else None,
        rows=table.lines,
        extra={name: table.column(name) for name in table.header
               if name not in _NAMED_COLUMNS and name not in joint_names},
    )
    if measurements.orientations is not None:
        # The one test of typed angles (robocal.io.units), as a targets file's rx, ry, rz meet it.
        check_angles(measurements.orientations, f"the measured rx, ry, rz of {measurements.path}")
    if not (robot_judges_units and measurements.positions is not None):
        # Ball-in-socket data have no positions for the robot to judge their units by.
        _warn_if_radians(measurements)
    _warn_about_identical_rows(measurements)
    return measurements


def read_targets(path: str | os.PathLike, n_joints: int | None = None, joint_names=None) -> Targets:
    """Read and validate a targets CSV file: ``x, y, z, rx, ry, rz``, optionally ``q1`` … ``qN``.

    Raises:
        FileFormatError: as for :func:`read_measurements`.
        InputError: orientations that look like radians.
    """
    table = _named_joints(_read_table(path), joint_names)
    check(table.path, "targets", header=table.header, column=table.column)
    joint_names = _check_header(table, n_joints, joints_required=False)
    missing = [name for name in POSITION_COLUMNS + ORIENTATION_COLUMNS if name not in table.header]
    if missing:
        raise FileFormatError(
            f"{table.path} lacks column{'s' if len(missing) > 1 else ''} {', '.join(missing)}: "
            f"a targets file needs x, y, z (mm) and rx, ry, rz (deg) for every target"
        )
    targets = Targets(
        path=table.path,
        positions=table.numbers(POSITION_COLUMNS),
        orientations=table.numbers(ORIENTATION_COLUMNS),
        hints=table.numbers(joint_names) if joint_names else None,
        rows=table.lines,
    )
    # The one test of typed angles (robocal.io.units): a file of radians is refused.
    check_angles(targets.orientations, f"the rx, ry, rz of {targets.path}")
    return targets


def _check_header(table: _Table, n_joints: int | None, joints_required: bool = True) -> list[str]:
    """Check the column names and return the joint columns in order q1 … qN."""
    indices = sorted(int(match.group(1)) for name in table.header if (match := _JOINT_COLUMN.fullmatch(name)))
    if "q0" in table.header:
        raise FileFormatError(
            f"{table.path} has a column q0: joint columns are numbered from q1; rename q0…q{max(indices, default=0)} "
            f"to q1…q{max(indices, default=0) + 1}"
        )
    _check_spelling(table, indices, n_joints)
    if not indices:
        if joints_required:
            raise FileFormatError(f"{table.path} has no joint columns: add q1, q2, … (joint positions in degrees)")
        return []
    missing = sorted(set(range(1, indices[-1] + 1)) - set(indices))
    if missing:
        present = ", ".join(f"q{i}" for i in indices)
        raise FileFormatError(
            f"{table.path} has joint columns {present} but no q{missing[0]}: joint columns must run from q1 to qN "
            f"without gaps"
        )
    if n_joints is not None and indices[-1] != n_joints:
        raise FileFormatError(
            f"{table.path} has {indices[-1]} joint column{'s' if indices[-1] > 1 else ''} (q1..q{indices[-1]}) "
            f"but the robot has {n_joints} joints: "
            f"check that the file belongs to this robot"
        )
    return [f"q{i}" for i in indices]


def _check_spelling(table: _Table, joint_indices: list[int], n_joints: int | None) -> None:
    """Reject an unknown column that looks like a misspelt known one which is missing.

    Unknown columns are kept as extra data, so a typo would otherwise silently lose a
    coordinate.  A column is only taken for a typo when the name it resembles most is not
    in the file: ``dx`` next to ``x`` is extra data, ``xx`` without ``x`` is a typo.
    """
    joint_count = max([_SUGGESTED_JOINT_COUNT, n_joints or 0, *joint_indices]) + 1
    known = list(_NAMED_COLUMNS) + [f"q{i}" for i in range(1, joint_count + 1)]
    present = set(table.header)
    for name in table.header:
        if name in known:
            continue
        closest = difflib.get_close_matches(name.lower(), known, n=1)
        if closest and closest[0] not in present:
            raise FileFormatError(
                f"{table.path}: column '{name}' is not known: did you mean '{closest[0]}'? "
                f"Column names are lower case: q1…qN, x, y, z, rx, ry, rz, sx, sy, sz, fixture, socket"
            )


def _column_group_present(table: _Table, group: tuple[str, ...], meaning: str) -> bool:
    """True if all columns of ``group`` are present, False if none; an error if only some."""
    present = [name for name in group if name in table.header]
    if present and len(present) < len(group):
        missing = [name for name in group if name not in present]
        raise FileFormatError(
            f"{table.path} has column{'s' if len(present) > 1 else ''} {', '.join(present)} but not "
            f"{', '.join(missing)}: {meaning} need all of {', '.join(group)}"
        )
    return bool(present)


def _warn_if_radians(measurements: Measurements) -> None:
    # The one test of joint values without a robot to judge them (robocal.io.units).
    if joint_values_look_like_radians(measurements.joints):
        warnings.warn(
            RobocalWarning(
                f"all joint values of {measurements.path} lie within ±{JOINT_RADIAN_BOUND}: they look like radians, "
                f"but robocal expects degrees; convert with numpy.degrees() or check the export"
            ),
            stacklevel=3,
        )


def _warn_about_identical_rows(measurements: Measurements) -> None:
    parts = [values for values in (measurements.joints, measurements.positions, measurements.orientations,
                                   measurements.fixture, measurements.socket) if values is not None]
    warn_about_identical_rows(measurements.path, measurements.rows, parts)


def warn_about_identical_rows(path, lines, parts) -> None:
    """The one warning, for every reader of rows of measured values, of rows repeated verbatim
    (a repeated export): ``parts``, the columns the reader takes, (N,) or (N, k) arrays of
    numbers or texts; ``lines`` (N,) the rows' file lines."""
    groups = _identical_row_groups(parts)
    if not groups:
        return
    lines = np.asarray(lines)
    described = [_describe_rows(lines[group]) for group in groups[:_DUPLICATES_SHOWN]]
    if len(groups) == 1:
        finding = f"{described[0]} are identical"
    else:
        more = f"; and {len(groups) - _DUPLICATES_SHOWN} more" if len(groups) > _DUPLICATES_SHOWN else ""
        finding = f"{len(groups)} groups of rows are identical ({'; '.join(described)}{more})"
    warnings.warn(
        RobocalWarning(
            f"{path}: {finding}: a repeated export? "
            f"The rows are kept; delete them if they are not genuine repeats"
        ),
        stacklevel=4,
    )


def _identical_row_groups(parts) -> list[np.ndarray]:
    """Indices of rows equal in every one of ``parts`` (as :func:`warn_about_identical_rows`),
    one array per group of two or more, in the order of their first row."""
    columns = []
    for values in parts:
        values = np.asarray(values)
        if values.dtype.kind in "US" or values.dtype == object:
            values = np.unique(values.astype(str), return_inverse=True)[1].reshape(values.shape).astype(float)
        columns.append(values.reshape(len(values), -1).astype(float))
    keys = np.hstack(columns)
    if len(keys) == 0:
        return []
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    if counts.max() == 1:
        return []
    order = np.argsort(inverse, kind="stable")
    groups = np.split(order, np.cumsum(counts)[:-1])
    repeated = [group for group in groups if len(group) > 1]
    return sorted(repeated, key=lambda group: group[0])


# A group of identical rows is named by at most this many of its row numbers: the warning
# stays a line, however often an export repeated a row.
_ROWS_NAMED = 5


def _describe_rows(lines: np.ndarray) -> str:
    numbers = [str(line) for line in lines]
    if len(numbers) > _ROWS_NAMED:
        return f"rows {', '.join(numbers[:_ROWS_NAMED])} and {len(numbers) - _ROWS_NAMED} more"
    return f"rows {', '.join(numbers[:-1])} and {numbers[-1]}"


# --------------------------------------------------------------------------- writing
