"""Measurement, target and command CSV files (docs/ARCHITECTURE.md, "File formats").

Values stay in file units here: millimetres and degrees.  The kinematics layer converts.

Row numbers in messages and in :attr:`Measurements.rows` are line numbers of the file
with the header on line 1, which is also the row number a spreadsheet shows.
"""

from __future__ import annotations

import csv
import dataclasses
import difflib
import io
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.errors import FileFormatError, InputError, RobocalWarning
from robocal.io.atomic import write_text_atomic
from robocal.io.file_kinds import KIND_COLUMN, check_kind, marked
from robocal.io.reading import read_text

POSITION_COLUMNS = ("x", "y", "z")
ORIENTATION_COLUMNS = ("rx", "ry", "rz")
SIGMA_COLUMNS = ("sx", "sy", "sz")
CONSTRAINT_COLUMNS = ("fixture", "socket")
_NAMED_COLUMNS = POSITION_COLUMNS + ORIENTATION_COLUMNS + SIGMA_COLUMNS + CONSTRAINT_COLUMNS + (KIND_COLUMN,)
_JOINT_COLUMN = re.compile(r"q([1-9][0-9]*)")
# Joint names offered as spelling suggestions even when the file has fewer joints.
_SUGGESTED_JOINT_COUNT = 12

# Radian detection: every joint value inside one turn in radians, on enough varied data
# that a few small moves in degrees near the zero position are not mistaken for radians.
_RADIAN_BOUND = 6.3
_RADIAN_MIN_ROWS = 5
_RADIAN_MIN_SPREAD = 0.5

# No measured or commanded value of a robot comes near this (mm for positions and prismatic
# joints, degrees for joints and orientations: a kilometre, ~2800 turns); beyond it a cell is
# a slip (an exponent, a pasted id) and would only show up later as a meaningless spread.
_LARGEST_VALUE = 1e6

# Target orientations in radians: every rx, ry, rz within one half-turn in radians, and one
# that a degree file would hardly hold within that bound — either a fraction beyond
# RADIAN_TARGET_LARGE (a tool within 3 deg of the base's axes, tilted 1.x deg or more), or within
# RADIAN_TARGET_SNAP of a non-zero multiple of 45 deg in radians (pi, pi/2: the tool down or
# sideways, as radians write it).  Degree targets (rx = 180; small tilts near zero) pass.
_RADIAN_TARGET_BOUND = np.pi + 1e-3
_RADIAN_TARGET_LARGE = 1.0
_RADIAN_TARGET_SNAP = 2e-3

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
        extra = {str(name): _optional_strings(f"extra column {name!r}", values, count) for name, values in self.extra.items()}
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


def read_measurements(path: str | os.PathLike, n_joints: int | None = None) -> Measurements:
    """Read and validate a measurement CSV file.

    Args:
        path: the CSV file: ``q1`` … ``qN`` and either ``x, y, z`` (optionally with
            ``rx, ry, rz`` and ``sx, sy, sz``) or ``fixture, socket``.
        n_joints: the robot's number of joints, when known; the file must match it.

    Raises:
        FileFormatError: the file is missing, malformed or inconsistent; the message names
            the file, and the row and column where there is one.

    Warns:
        RobocalWarning: joint values that look like radians; identical rows.
    """
    table = _read_table(path)
    # A design's poses file becomes a measurement file when the measured x, y, z (or the
    # sockets) are added to it.
    kind = check_kind(table.path, table.header, _kind_cells(table), ("measurements", "poses"), "a measurement file",
                      "measured data: q1..qN with the x, y, z the instrument measured")
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
        extra={name: table.column(name) for name in table.header if name not in _NAMED_COLUMNS and name not in joint_names},
    )
    _warn_if_radians(measurements)
    _warn_about_identical_rows(measurements)
    return measurements


def read_targets(path: str | os.PathLike, n_joints: int | None = None) -> Targets:
    """Read and validate a targets CSV file: ``x, y, z, rx, ry, rz``, optionally ``q1`` … ``qN``.

    Raises:
        FileFormatError: as for :func:`read_measurements`.

    Warns:
        RobocalWarning: orientations that look like radians.
    """
    table = _read_table(path)
    check_kind(table.path, table.header, _kind_cells(table), ("measurements",), "a targets file",
               "the targets themselves (x, y, z, rx, ry, rz)")
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
    _warn_if_radian_orientations(targets)
    return targets


def _kind_cells(table):
    """The cells of the column that says which robocal file this is (None: it has none)."""
    return table.column(KIND_COLUMN) if KIND_COLUMN in table.header else None


@dataclass(frozen=True)
class _Table:
    """The cells of a CSV file as strings, before any interpretation."""

    path: str
    header: list[str]
    cells: np.ndarray  # (N, number of columns) str
    lines: np.ndarray  # (N,) line number of each row
    # Column name -> the factor that brings its numbers to robocal's units (its header's
    # unit tag, see _unit_tags); columns without a tag are not in it.
    scales: dict = dataclasses.field(default_factory=dict)

    def column(self, name: str) -> np.ndarray:
        """The raw cells of one column."""
        return self.cells[:, self.header.index(name)]

    def numbers(self, names) -> np.ndarray:
        """The named columns as an (N, k) float array in robocal's units (deg, mm); every
        cell a finite number."""
        values = np.empty((len(self.lines), len(names)))
        for position, name in enumerate(names):
            values[:, position] = self._number_column(name) * self.scales.get(name, 1.0)
        return values

    def texts(self, name: str) -> np.ndarray:
        """A text column (ids), stripped; every cell non-empty."""
        texts = np.char.strip(self.column(name))
        empty = np.flatnonzero(texts == "")
        if empty.size:
            raise FileFormatError(f"{self.where(empty[0], name)} is empty: every row needs a {name} id")
        return texts

    def check_positive(self, names, values: np.ndarray, problem: str) -> None:
        """Fail at the first cell of ``values`` (columns ``names``) that is not > 0."""
        bad_rows, bad_columns = np.nonzero(values <= 0)
        if bad_rows.size:
            row, column = bad_rows[0], bad_columns[0]
            raise FileFormatError(
                f"{self.where(row, names[column])}: {problem}, got {self.column(names[column])[row].strip()}"
            )

    def where(self, row_index: int, name: str) -> str:
        """``"file, row R, column 'c'"`` for messages."""
        return f"{self.path}, row {self.lines[row_index]}, column '{name}'"

    def _number_column(self, name: str) -> np.ndarray:
        cells = self.column(name)
        try:
            values = cells.astype(float)
        except ValueError:
            values = self._parse_cell_by_cell(name, cells)
        not_finite = np.flatnonzero(~np.isfinite(values))
        if not_finite.size:
            row = not_finite[0]
            raise FileFormatError(
                f"{self.where(row, name)}: '{cells[row].strip()}' is not a finite number: "
                f"replace it with a measured value or delete the row"
            )
        absurd = np.flatnonzero(np.abs(values) > _LARGEST_VALUE)
        if absurd.size:
            row = absurd[0]
            raise FileFormatError(
                f"{self.where(row, name)}: {cells[row].strip()} is beyond ±{_LARGEST_VALUE:.0e}, more than any "
                f"robot measures (mm, degrees): fix the cell or delete the row"
            )
        return values

    def _parse_cell_by_cell(self, name: str, cells: np.ndarray) -> np.ndarray:
        """Find the offending cell after the fast vectorised parse failed."""
        values = np.empty(len(cells))
        for row, cell in enumerate(cells):
            try:
                values[row] = float(cell)
            except ValueError:
                raise FileFormatError(f"{self.where(row, name)}: {_describe_bad_number(cell)}") from None
        return values


def _describe_bad_number(cell: str) -> str:
    text = cell.strip()
    if not text:
        return "the cell is empty: every row needs a value; fill it in or delete the row"
    if re.fullmatch(r"[+-]?[0-9]*,[0-9]+", text):
        return f"'{text}' is not a number: use '.' as the decimal point, not ','"
    return f"'{text}' is not a number: fix the cell or delete the row"


def _read_table(path: str | os.PathLike) -> _Table:
    """Read a comma-separated file with a header into strings, checking its shape."""
    name = str(path)
    records = list(_records(name))
    if not records:
        raise FileFormatError(f"{name} is empty: expected a header line such as q1,q2,…,x,y,z and one row per measurement")
    header_line, header = records[0]
    header, scales = _unit_tags(name, [cell.strip() for cell in header])
    _check_header_line(name, header)
    data = records[1:]
    if not data:
        raise FileFormatError(f"{name} has a header but no data rows")
    lengths = np.fromiter((len(cells) for _, cells in data), dtype=int, count=len(data))
    wrong = np.flatnonzero(lengths != len(header))
    if wrong.size:
        line, cells = data[wrong[0]]
        hint = " (a decimal comma such as 1,5 splits a number in two: use '.')" if len(cells) > len(header) else ""
        raise FileFormatError(
            f"{name}, row {line}: {len(cells)} cells but the header has {len(header)} columns{hint}: "
            f"every row needs one value per header column"
        )
    table = _Table(
        path=name,
        header=header,
        cells=np.array([cells for _, cells in data], dtype=str).reshape(len(data), len(header)),
        lines=np.array([line for line, _ in data], dtype=int),
        scales=scales,
    )
    return _without_blank_unnamed_columns(table)


def _records(path: str):
    """Yield (line number, cells) of every non-blank line of a CSV file."""
    text = _read_text(path)
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        for cells in reader:
            if cells:
                yield reader.line_num, cells
    except csv.Error as error:
        raise FileFormatError(f"{path}, row {reader.line_num}: {error}: check the quoting of that line") from None


def _read_text(path: str) -> str:
    return read_text(path, "CSV file", "table", form="CSV")


# A header cell may carry its unit: "x[m]", "q2[rad]", "rz[deg]".  Factors to deg and mm.
_UNIT_TAG = re.compile(r"(.+?)\s*\[\s*([^\]]+?)\s*\]")
_ANGLE_TAGS = {"deg": 1.0, "degree": 1.0, "degrees": 1.0, "rad": 180.0 / np.pi, "radian": 180.0 / np.pi,
               "radians": 180.0 / np.pi}
_LENGTH_TAGS = {"mm": 1.0, "m": 1000.0, "cm": 10.0, "in": 25.4, "inch": 25.4, "um": 1e-3, "µm": 1e-3}
# Columns whose unit is an angle, a length, or either (a joint: revolute or prismatic).
_ANGLE_NAMES = ORIENTATION_COLUMNS
_LENGTH_NAMES = POSITION_COLUMNS + SIGMA_COLUMNS


def _unit_tags(path: str, header: list[str]) -> tuple[list[str], dict]:
    """(header without unit tags, {column: factor to deg or mm}) of a header whose cells may
    end in a unit in brackets; an unknown unit, or a length unit on an angle (and the
    reverse), is refused."""
    names, scales = [], {}
    for cell in header:
        match = _UNIT_TAG.fullmatch(cell)
        if match is None:
            names.append(cell)
            continue
        name, unit = match.group(1).strip(), match.group(2).strip()
        unit_key = unit.lower() if unit != "µm" else unit
        angle, length = _ANGLE_TAGS.get(unit_key), _LENGTH_TAGS.get(unit_key)
        is_joint = _JOINT_COLUMN.fullmatch(name) is not None
        if angle is None and length is None:
            raise FileFormatError(f"{path}: column {cell!r} has the unit {unit!r}, which robocal does not know: use "
                                  "deg or rad for angles, mm, m, cm, in or um for lengths")
        if (name in _ANGLE_NAMES and angle is None) or (name in _LENGTH_NAMES and length is None):
            raise FileFormatError(f"{path}: column {cell!r}: {name} is {'an angle' if angle is None else 'a length'}, "
                                  f"not in {unit}")
        if name in _ANGLE_NAMES or name in _LENGTH_NAMES or is_joint:
            scales[name] = angle if angle is not None else length
        names.append(name)
    return names, scales


def _check_header_line(path: str, header: list[str]) -> None:
    if not any(header):
        raise FileFormatError(f"{path} has no header: the first line must name the columns (q1,q2,…,x,y,z)")
    if header[0].lstrip().startswith("#"):
        raise FileFormatError(f"{path}: line 1 is a comment ('#'); comment lines are not read: delete them so that "
                              "the first line names the columns (q1,q2,…,x,y,z)")
    if len(header) == 1 and re.search(r"[;\t]", header[0]):
        raise FileFormatError(
            f"{path} is not comma-separated: export it with ',' between fields and '.' as the decimal point"
        )
    if all(_is_number(cell) for cell in header):
        raise FileFormatError(
            f"{path}: the first line holds numbers, not column names: add a header line such as q1,q2,…,x,y,z"
        )
    seen: dict[str, int] = {}
    for column, name in enumerate(header, start=1):
        if name and name in seen:
            raise FileFormatError(f"{path}: column '{name}' appears twice (columns {seen[name]} and {column}): rename or delete one")
        seen[name] = column


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _without_blank_unnamed_columns(table: _Table) -> _Table:
    """Drop columns without a name and without content (trailing commas from spreadsheets)."""
    unnamed = [column for column, name in enumerate(table.header) if not name]
    if not unnamed:
        return table
    for column in unnamed:
        filled = np.flatnonzero(np.char.strip(table.cells[:, column]) != "")
        if filled.size:
            raise FileFormatError(
                f"{table.path}, row {table.lines[filled[0]]}: column {column + 1} has values but no name in the header: "
                f"name it or delete it"
            )
    kept = [column for column in range(len(table.header)) if table.header[column]]
    return dataclasses.replace(table, header=[table.header[c] for c in kept], cells=table.cells[:, kept])


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
    joints = measurements.joints
    if len(joints) < _RADIAN_MIN_ROWS:
        return
    inside_one_turn = np.abs(joints).max() < _RADIAN_BOUND
    varied = np.ptp(joints, axis=0).max() >= _RADIAN_MIN_SPREAD
    if inside_one_turn and varied:
        warnings.warn(
            RobocalWarning(
                f"all joint values of {measurements.path} lie within ±{_RADIAN_BOUND}: they look like radians, "
                f"but robocal expects degrees; convert with numpy.degrees() or check the export"
            ),
            stacklevel=3,
        )


def _warn_if_radian_orientations(targets: Targets) -> None:
    """RobocalWarning when rx, ry, rz look like radians (see _RADIAN_TARGET_BOUND)."""
    angles = np.abs(targets.orientations)
    if angles.max() > _RADIAN_TARGET_BOUND:
        return
    eighths = angles / (np.pi / 4)
    snapped = (np.round(eighths) >= 1) & (np.abs(eighths - np.round(eighths)) * (np.pi / 4) <= _RADIAN_TARGET_SNAP)
    # Hand-written degree tilts are whole numbers; radians (other than 0) almost never are.
    large = (angles > _RADIAN_TARGET_LARGE) & (angles != np.round(angles))
    if large.any() or snapped.any():
        warnings.warn(
            RobocalWarning(
                f"all rx, ry, rz of {targets.path} lie within ±3.1416 and look like radians (largest "
                f"{angles.max():.6g}), but robocal expects degrees: convert with numpy.degrees() or check the export"
            ),
            stacklevel=3,
        )


def _warn_about_identical_rows(measurements: Measurements) -> None:
    groups = _identical_row_groups(measurements)
    if not groups:
        return
    described = [_describe_rows(measurements.rows[group]) for group in groups[:_DUPLICATES_SHOWN]]
    if len(groups) == 1:
        finding = f"{described[0]} are identical"
    else:
        more = f"; and {len(groups) - _DUPLICATES_SHOWN} more" if len(groups) > _DUPLICATES_SHOWN else ""
        finding = f"{len(groups)} groups of rows are identical ({'; '.join(described)}{more})"
    warnings.warn(
        RobocalWarning(
            f"{measurements.path}: {finding}: a repeated export? "
            f"The rows are kept; delete them if they are not genuine repeats"
        ),
        stacklevel=3,
    )


def _identical_row_groups(measurements: Measurements) -> list[np.ndarray]:
    """Indices of rows with the same joints and measured values, one array per group."""
    parts = [measurements.joints]
    parts += [values for values in (measurements.positions, measurements.orientations) if values is not None]
    for ids in (measurements.fixture, measurements.socket):
        if ids is not None:
            parts.append(np.unique(ids, return_inverse=True)[1].reshape(-1, 1).astype(float))
    keys = np.hstack(parts)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    if counts.max() == 1:
        return []
    order = np.argsort(inverse, kind="stable")
    groups = np.split(order, np.cumsum(counts)[:-1])
    repeated = [group for group in groups if len(group) > 1]
    return sorted(repeated, key=lambda group: group[0])


def _describe_rows(lines: np.ndarray) -> str:
    numbers = [str(line) for line in lines]
    return f"rows {', '.join(numbers[:-1])} and {numbers[-1]}"


# --------------------------------------------------------------------------- writing


def write_measurements(path: str | os.PathLike, data: Measurements) -> Path:
    """Write ``data`` as a measurement CSV file, atomically, and return the path.

    Columns: q1 … qn, then x, y, z / rx, ry, rz / sx, sy, sz / fixture, socket where
    present, then the extra columns.  Floats are written exactly (shortest repr), so
    :func:`read_measurements` gives back the same numbers; ``rows`` become the lines of
    the new file.
    """
    columns: dict[str, list[str]] = {}
    _add_number_columns(columns, data.joint_names, data.joints)
    for names, values in ((POSITION_COLUMNS, data.positions), (ORIENTATION_COLUMNS, data.orientations), (SIGMA_COLUMNS, data.sigmas)):
        if values is not None:
            _add_number_columns(columns, names, values)
    if data.fixture is not None:
        columns["fixture"] = data.fixture.tolist()
        columns["socket"] = data.socket.tolist()
    for name, values in data.extra.items():
        columns[name] = values.tolist()
    # Not marked: a simulated measurement file is what a user's is, and is read as one.
    return _write_csv(path, columns)


def write_commands(
    path: str | os.PathLike,
    joints: np.ndarray,
    positions: np.ndarray,
    orientations: np.ndarray,
    *,
    joint_ok: np.ndarray | None = None,
    frame: str | None = None,
    extra: dict[str, list[str]] | None = None,
) -> Path:
    """Write a commands CSV file (docs/ARCHITECTURE.md, "File formats"), atomically.

    Args:
        joints: (N, n) joint commands in degrees.
        positions: (N, 3) corrected Cartesian targets in mm.
        orientations: (N, 3) corrected rx, ry, rz in degrees.
        joint_ok: optional (N,) bool, False for targets the robot cannot reach.  Adds a
            ``reachable`` column (1/0); unreachable rows get empty joint cells, and empty
            Cartesian cells where those are not finite.
        frame: optional text naming the frame of x, y, z, rx, ry, rz; adds a ``frame``
            column that says it on every row (a file read alone still says what it holds).
        extra: optional further columns, by name, each N cells of text (e.g. whether a
            target lies in the model's domain of validity).

    Raises:
        InputError: shapes that do not match, or non-finite values in a row that is
            reachable (a wrong command must never be written).
    """
    joints = np.asarray(joints, dtype=float)
    positions = np.asarray(positions, dtype=float)
    orientations = np.asarray(orientations, dtype=float)
    if joints.ndim != 2:
        raise InputError(f"joint commands must be an (N, n) array, got shape {joints.shape}")
    count = len(joints)
    if positions.shape != (count, 3) or orientations.shape != (count, 3):
        raise InputError(
            f"commands need ({count}, 3) positions and orientations for {count} joint vectors, "
            f"got {positions.shape} and {orientations.shape}"
        )
    reachable = np.ones(count, dtype=bool) if joint_ok is None else np.asarray(joint_ok, dtype=bool)
    if reachable.shape != (count,):
        raise InputError(f"joint_ok must have shape ({count},), got {reachable.shape}")
    columns: dict[str, list[str]] = {}
    _add_number_columns(columns, [f"q{i}" for i in range(1, joints.shape[1] + 1)], joints, blank=~reachable)
    _add_number_columns(columns, POSITION_COLUMNS, positions, blank=~reachable)
    _add_number_columns(columns, ORIENTATION_COLUMNS, orientations, blank=~reachable)
    if joint_ok is not None:
        columns["reachable"] = reachable.astype(int).astype(str).tolist()
    if frame is not None:
        columns["frame"] = [frame] * count
    for name, cells in (extra or {}).items():
        if name in columns or len(cells) != count:
            raise InputError(f"extra column {name!r} clashes with a command column or does not have {count} cells")
        columns[name] = [str(cell) for cell in cells]
    return _write_csv(path, marked(columns, "commands"))


def _add_number_columns(columns: dict[str, list[str]], names, values: np.ndarray, blank: np.ndarray | None = None) -> None:
    """Format ``values`` column by column into ``columns``.

    Rows flagged in ``blank`` may hold non-finite values, which become empty cells (joint
    cells of such rows are always empty); any other non-finite value is refused.
    """
    values = np.asarray(values, dtype=float)
    blank = np.zeros(len(values), dtype=bool) if blank is None else blank
    is_joint = [bool(_JOINT_COLUMN.fullmatch(name)) for name in names]
    bad_rows, bad_columns = np.nonzero(~np.isfinite(values) & ~blank[:, None])
    if bad_rows.size:
        raise InputError(
            f"entry {bad_rows[0]} (counting from 0) of column '{names[bad_columns[0]]}' is "
            f"{values[bad_rows[0], bad_columns[0]]}: only finite values can be written "
            f"(mark unreachable targets with joint_ok)"
        )
    for column, name in enumerate(names):
        empty = blank & (is_joint[column] | ~np.isfinite(values[:, column]))
        columns[name] = ["" if skip else _number_text(value) for value, skip in zip(values[:, column].tolist(), empty.tolist())]


# Below this a value is rounding noise of a zero (a joint at 0 deg read back as 2.6e-16),
# far under any instrument's resolution in mm or degrees.
_ZERO_NOISE = 1e-12


def _number_text(value: float) -> str:
    """The shortest text that reads back as ``value`` (repr), with rounding noise of a zero
    and a negative zero written as 0.0."""
    return "0.0" if abs(value) < _ZERO_NOISE else repr(value)


def _write_csv(path: str | os.PathLike, columns: dict[str, list[str]]) -> Path:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(list(columns))
    writer.writerows(zip(*columns.values()))
    return write_text_atomic(path, buffer.getvalue())
