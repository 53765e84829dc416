"""Named points as laser-tracker software exports them.

SpatialAnalyzer-style ASCII and its cousins: ``//`` or ``#`` comment lines, fields separated
by semicolons, tabs, commas or spaces, decimal commas, a header or none, lengths in mm,
metres or inches.  :func:`read_points` reads any of them into :class:`TrackerPoints`:

* the delimiter is the one that splits every data line into the same number of fields
  (at least three numbers);
* a decimal comma is read as a point where commas do not separate fields;
* columns are found by name (``name``/``point``/``id``, ``x``, ``y``, ``z``,
  ``uncertainty``/``sigma``/``u``, ``temperature``/``temp``, ``time``/``timestamp``; case and
  a unit in brackets or parentheses ignored); without a header the first non-numeric field
  is the name and the next three numbers are x, y, z;
* the unit is the one the header's columns or a comment states (``Units: Meters``), or
  ``units`` when given (which must not contradict the file); none stated means mm, and the
  measurement file's unit evidence (:mod:`robocal.io.units`) judges it with the robot.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..errors import FileFormatError, InputError
from .reading import read_table_text
from .units import check_point_lengths

LENGTHS = {"mm": 1.0, "millimeters": 1.0, "millimetres": 1.0, "m": 1000.0, "meters": 1000.0, "metres": 1000.0,
           "cm": 10.0, "in": 25.4, "inch": 25.4, "inches": 25.4, "um": 1e-3, "µm": 1e-3}
_DELIMITERS = (";", "\t", ",", None)  # None: runs of white space
_NAMES = {"name": ("name", "point", "pointname", "point name", "id", "label", "target"),
          "x": ("x",), "y": ("y",), "z": ("z",),
          "uncertainty": ("uncertainty", "sigma", "u", "unc", "std"),
          "temperature": ("temperature", "temp", "t_air", "air temperature"),
          "time": ("time", "timestamp", "date time", "datetime")}
_UNIT_IN_NAME = re.compile(r"^(.*?)\s*[\[(]\s*([^\])]+?)\s*[\])]\s*$")
_UNIT_IN_COMMENT = re.compile(r"units?\s*[:=]\s*([a-zµ]+)", re.IGNORECASE)


@dataclass(frozen=True)
class TrackerPoints:
    """Points of a tracker export: ``names`` (N,), ``positions`` (N, 3) mm, optionally
    ``uncertainty`` (N,) mm, ``temperature`` (N,) and ``time`` (N,) text, the ``unit`` the
    file was read in and the file ``lines`` (N,)."""

    path: str
    names: np.ndarray
    positions: np.ndarray
    uncertainty: np.ndarray | None
    temperature: np.ndarray | None
    time: np.ndarray | None
    unit: str
    lines: np.ndarray


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True


def _split(line, delimiter):
    fields = line.split(delimiter) if delimiter is not None else line.split()
    return [f.strip().strip('"') for f in fields]


def _delimiter(lines):
    """The delimiter that splits every line into one count of at least four fields."""
    for delimiter in _DELIMITERS:
        counts = {len(_split(line, delimiter)) for line in lines}
        if len(counts) == 1 and counts.pop() >= 4:
            return delimiter
    for delimiter in _DELIMITERS:  # three fields: x, y, z without names
        counts = {len(_split(line, delimiter)) for line in lines}
        if len(counts) == 1 and counts.pop() == 3:
            return delimiter
    raise FileFormatError("its lines do not split into the same number of fields with any of ; tab , or spaces: "
                          "export one point per line, name then x, y, z")


def _header_columns(cells, path):
    """{role: column} and the unit stated in the header's column names (or None)."""
    roles, units = {}, set()
    for column, cell in enumerate(cells):
        match = _UNIT_IN_NAME.match(cell)
        name, unit = (match.group(1), match.group(2)) if match else (cell, None)
        key = re.sub(r"[\s_]+", " ", name.strip().lower())
        for role, spellings in _NAMES.items():
            if key in spellings and role not in roles:
                roles[role] = column
                if unit is not None and role in ("x", "y", "z", "uncertainty"):
                    units.add(unit.lower())
    missing = [axis for axis in "xyz" if axis not in roles]
    if missing:
        raise FileFormatError(f"{path}: its header {', '.join(cells)} names no {', '.join(missing)} column: name the "
                              "columns x, y, z (and name, uncertainty, temperature, time)")
    if len(units) > 1:
        raise FileFormatError(f"{path}: its columns are in different units ({', '.join(sorted(units))}): export "
                              "them in one")
    return roles, units.pop() if units else None


def read_points(path, units=None) -> TrackerPoints:
    """Read a tracker's point export (module notes); ``units`` (a key of LENGTHS) states
    the file's length unit.

    Raises:
        FileFormatError: no consistent delimiter, a cell that is not a number, a unit the
            file states differently from ``units``, or no points.
    """
    if units is not None and units.lower() not in LENGTHS:
        raise InputError(f"--units {units}: give one of mm, m, cm, in, um")
    text = read_table_text(path, "point file", reader="points", kind="points")
    stated, data = set(), []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith(("//", "#")):
            found = _UNIT_IN_COMMENT.search(line)
            if found:
                stated.add(found.group(1).lower())
            continue
        data.append((number, line))
    if not data:
        raise FileFormatError(f"{path} holds no points: one line per point, name then x, y, z")
    try:
        delimiter = _delimiter([line for _, line in data])
    except FileFormatError as error:
        raise FileFormatError(f"{path}: {error}") from None
    decimal_comma = delimiter != "," and any(re.search(r"\d,\d", line) for _, line in data)
    rows = [(n, _split(line.replace(",", ".") if decimal_comma else line, delimiter)) for n, line in data]
    first = rows[0][1]
    if sum(_is_number(cell) for cell in first) < 3:  # a header
        roles, header_unit = _header_columns(first, path)
        rows = rows[1:]
        if header_unit is not None:
            stated.add(header_unit)
    else:
        numeric = [k for k, cell in enumerate(first) if _is_number(cell)]
        names = [k for k, cell in enumerate(first) if not _is_number(cell)]
        roles = {"x": numeric[0], "y": numeric[1], "z": numeric[2]}
        if names:
            roles["name"] = names[0]
    if not rows:
        raise FileFormatError(f"{path} has a header but no points")
    unit = _unit(path, stated, units)
    lines = np.array([n for n, _ in rows])

    def numbers(role):
        out = np.empty(len(rows))
        for k, (n, cells) in enumerate(rows):
            try:
                out[k] = float(cells[roles[role]])
            except (ValueError, IndexError):
                raise FileFormatError(f"{path}, line {n}: {role} is {cells[roles[role]]!r}, not a number") from None
        if not np.isfinite(out).all():
            raise FileFormatError(f"{path}, line {lines[~np.isfinite(out)][0]}: {role} is not a finite number")
        return out

    def texts(role):
        return np.array([cells[roles[role]] for _, cells in rows]) if role in roles else None

    factor = LENGTHS[unit]
    positions = np.stack([numbers(axis) for axis in "xyz"], axis=1) * factor
    if not stated and units is None:
        # None stated: mm, unless the numbers are no robot's poses in mm (robocal.io.units).
        check_point_lengths(positions, f"the x, y, z of {path} (no unit stated, read as mm)",
                            "state the unit (--units m, or a 'Units: m' line in the file) or export in mm")
    names = texts("name")
    if names is None:
        names = np.array([str(n) for n in lines])
    return TrackerPoints(path=str(path), names=names, positions=positions,
                         uncertainty=numbers("uncertainty") * factor if "uncertainty" in roles else None,
                         temperature=texts("temperature"), time=texts("time"), unit=unit, lines=lines)


def _unit(path, stated, given):
    """The file's length unit: what it states, which ``given`` must agree with."""
    stated = {u for u in stated}
    unknown = [u for u in stated if u not in LENGTHS]
    if unknown:
        raise FileFormatError(f"{path} states the unit {unknown[0]!r}, which robocal does not know: give --units "
                              "mm, m, cm, in or um")
    factors = {LENGTHS[u] for u in stated}
    if len(factors) > 1:
        raise FileFormatError(f"{path} states two units ({', '.join(sorted(stated))}): export it in one")
    if given is not None:
        if factors and LENGTHS[given.lower()] not in factors:
            raise InputError(f"--units {given} contradicts {path}, which states {sorted(stated)[0]}: leave --units "
                             "out or fix the export")
        return given.lower()
    return sorted(stated)[0] if stated else "mm"
