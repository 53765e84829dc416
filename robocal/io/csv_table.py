"""A CSV file as robocal reads it, before any meaning is given to its columns.

:func:`_read_table` reads a comma-separated file with a header through the one bounded
reader (:mod:`robocal.io.reading`) into a :class:`_Table` of strings, checking its shape (a
header, one cell per column in every row, no unnamed column with values).  Every CSV reader
of robocal gets its rows from :func:`_records`: a file of another format is named (a report, a
model file), a first line ``sep=,`` or ``sep=;`` (Excel's way of stating the separator) is
honoured, and columns separated by semicolons, tabs or spaces without it are refused in one
line saying so (DESIGN.md: CSV files are comma-separated).  A header cell may
carry its unit in brackets (``x[m]``, ``q2[rad]``); :class:`_Table` gives numbers in
robocal's units (degrees, mm).  :mod:`robocal.io.tables` gives the columns their meaning.
"""
from __future__ import annotations

import csv
import dataclasses
import io
import os
import re
from dataclasses import dataclass

import numpy as np

from robocal.errors import FileFormatError
from robocal.io.reading import read_table_text

POSITION_COLUMNS = ("x", "y", "z")
ORIENTATION_COLUMNS = ("rx", "ry", "rz")
SIGMA_COLUMNS = ("sx", "sy", "sz")
CONSTRAINT_COLUMNS = ("fixture", "socket")
JOINT_COLUMN = re.compile(r"q([1-9][0-9]*)")
_JOINT_COLUMN = JOINT_COLUMN

# No measured or commanded value of a robot comes near this (mm for positions and prismatic
# joints, degrees for joints and orientations: a kilometre, ~2800 turns); beyond it a cell is
# a slip (an exponent, a pasted id) and would only show up later as a meaningless spread.
_LARGEST_VALUE = 1e6


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
        raise FileFormatError(f"{name} is empty: expected a header line such as q1,q2,…,x,y,z "
                              "and one row per measurement")
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


def _records(path: str, what: str = "CSV file"):
    """Yield (line number, cells) of every non-blank line of a CSV file (``what`` names it in
    messages: "candidates file")."""
    text = read_table_text(path, what)
    text, delimiter = _stated_separator(path, text)
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter)
    try:
        for cells in reader:
            if cells:
                yield reader.line_num, cells
    except csv.Error as error:
        raise FileFormatError(f"{path}, row {reader.line_num}: {error}: check the quoting of that line") from None


# Excel writes the separator it used as a first line "sep=;" (and reads it back so).
_SEPARATOR_LINE = re.compile(r'\A\ufeff?[ \t]*"?sep=(.?)"?[ \t]*(\r\n|\r|\n|\Z)', re.I)
# The separators a first line sep= may state: the comma robocal's files use, and the
# semicolon of spreadsheets whose decimal mark is a comma (the numbers must still use '.').
_STATED_SEPARATORS = (",", ";")


def _stated_separator(path: str, text: str) -> tuple[str, str]:
    """(text, separator): a first line ``sep=X`` is read and blanked (the rows keep their
    line numbers); without one the separator is the comma."""
    match = _SEPARATOR_LINE.match(text)
    if match is None:
        return text, ","
    separator = match.group(1)
    if separator not in _STATED_SEPARATORS:
        shown = {"\t": "a tab", " ": "a space", "": "nothing"}.get(separator, repr(separator))
        raise FileFormatError(f"{path}: its first line (sep=) says the columns are separated by {shown}: "
                              "robocal reads ',' (or ';' after a first line sep=;): export it with ','")
    return match.group(2) + text[match.end():], separator


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
        if angle is None and length is None:
            raise FileFormatError(f"{path}: column {cell!r} has the unit {unit!r}, which robocal does not know: use "
                                  "deg or rad for angles, mm, m, cm, in or um for lengths")
        if (name in _ANGLE_NAMES and angle is None) or (name in _LENGTH_NAMES and length is None):
            raise FileFormatError(f"{path}: column {cell!r}: {name} is {'an angle' if angle is None else 'a length'}, "
                                  f"not in {unit}")
        # Every tagged column is scaled (a joint may be named by the robot's joint names).
        scales[name] = angle if angle is not None else length
        names.append(name)
    return names, scales


def _check_header_line(path: str, header: list[str]) -> None:
    if not any(header):
        raise FileFormatError(f"{path} has no header: the first line must name the columns (q1,q2,…,x,y,z)")
    if header[0].lstrip().startswith("#"):
        raise FileFormatError(f"{path}: line 1 is a comment ('#'); comment lines are not read: delete them so that "
                              "the first line names the columns (q1,q2,…,x,y,z)")
    if len(header) == 1:
        found = _other_separator(header[0])
        if found:
            raise FileFormatError(
                f"{path} is not comma-separated: its columns are separated by {found}; robocal reads ',' between "
                "fields (or ';' after a first line sep=;) and '.' as the decimal point: export it so"
            )
    if all(_is_number(cell) for cell in header):
        raise FileFormatError(
            f"{path}: the first line holds numbers, not column names: add a header line such as q1,q2,…,x,y,z"
        )
    seen: dict[str, int] = {}
    for column, name in enumerate(header, start=1):
        if name and name in seen:
            raise FileFormatError(f"{path}: column '{name}' appears twice "
                                  f"(columns {seen[name]} and {column}): rename or delete one")
        seen[name] = column


def _other_separator(line: str) -> str:
    """What separates the names of a header line read as one column ("tabs", "spaces"), or
    "" when it is one name."""
    for mark, name in ((";", "semicolons"), ("\t", "tabs"), ("|", "vertical bars (a Markdown table?)")):
        if mark in line:
            return name
    return "spaces" if len(line.split()) > 1 else ""


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
                f"{table.path}, row {table.lines[filled[0]]}: column {column + 1} has values "
                "but no name in the header: "
                f"name it or delete it"
            )
    kept = [column for column in range(len(table.header)) if table.header[column]]
    return dataclasses.replace(table, header=[table.header[c] for c in kept], cells=table.cells[:, kept])
