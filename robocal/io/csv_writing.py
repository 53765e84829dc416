"""Writing robocal's CSV files: measurements (``simulate``) and commands (``compensate``),
atomically, every number with all its digits (and no rounding noise around zero)."""
from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np

from robocal.errors import InputError
from robocal.io.atomic import write_text_atomic
from robocal.io.csv_table import JOINT_COLUMN, ORIENTATION_COLUMNS, POSITION_COLUMNS, SIGMA_COLUMNS
from robocal.io.file_kinds import marked, marked_rows


def write_measurements(path: str | os.PathLike, data) -> Path:
    """Write ``data`` (a :class:`~robocal.io.tables.Measurements`) as a measurement CSV file, atomically, and
    return the path.

    Columns: q1 … qn, then x, y, z / rx, ry, rz / sx, sy, sz / fixture, socket where
    present, then the extra columns.  Floats are written exactly (shortest repr), so
    :func:`read_measurements` gives back the same numbers; ``rows`` become the lines of
    the new file.
    """
    columns: dict[str, list[str]] = {}
    _add_number_columns(columns, data.joint_names, data.joints)
    for names, values in (
        (POSITION_COLUMNS, data.positions),
        (ORIENTATION_COLUMNS, data.orientations),
        (SIGMA_COLUMNS, data.sigmas),
    ):
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


def _add_number_columns(
    columns: dict[str, list[str]], names, values: np.ndarray, blank: np.ndarray | None = None
) -> None:
    """Format ``values`` column by column into ``columns``.

    Rows flagged in ``blank`` may hold non-finite values, which become empty cells (joint
    cells of such rows are always empty); any other non-finite value is refused.
    """
    values = np.asarray(values, dtype=float)
    blank = np.zeros(len(values), dtype=bool) if blank is None else blank
    is_joint = [bool(JOINT_COLUMN.fullmatch(name)) for name in names]
    bad_rows, bad_columns = np.nonzero(~np.isfinite(values) & ~blank[:, None])
    if bad_rows.size:
        raise InputError(
            f"entry {bad_rows[0]} (counting from 0) of column '{names[bad_columns[0]]}' is "
            f"{values[bad_rows[0], bad_columns[0]]}: only finite values can be written "
            f"(mark unreachable targets with joint_ok)"
        )
    for column, name in enumerate(names):
        empty = blank & (is_joint[column] | ~np.isfinite(values[:, column]))
        columns[name] = [
            "" if skip else _number_text(value) for value, skip in zip(values[:, column].tolist(), empty.tolist())
        ]


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


# The columns of evaluate --per-pose.
PER_POSE_COLUMNS = ("row", "x_measured", "y_measured", "z_measured", "x_model", "y_model", "z_model", "error_mm",
                    "bound95_mm", "in_domain")


def write_per_pose(path, rows, measured, predicted, error, bound, inside) -> Path:
    """evaluate --per-pose: one line per pose (PER_POSE_COLUMNS: the pose's line in its file,
    measured and model x, y, z in mm, the error's length and 95 % bound in mm, 1/0 inside
    the domain), marked as robocal's evaluation, atomically; ``bound`` None (no bound in the
    model file) and ``inside`` None (no domain) leave their cells empty."""
    count = len(rows)
    columns = {"row": [str(int(r)) for r in rows]}
    for k, axis in enumerate("xyz"):
        columns[f"{axis}_measured"] = [repr(float(v)) for v in measured[:, k]]
    for k, axis in enumerate("xyz"):
        columns[f"{axis}_model"] = [repr(float(v)) for v in predicted[:, k]]
    columns["error_mm"] = [f"{e:.6g}" for e in error]
    columns["bound95_mm"] = [""] * count if bound is None else [f"{b:.6g}" for b in bound]
    columns["in_domain"] = [""] * count if inside is None else [str(int(i)) for i in inside]
    return _write_csv(path, marked(columns, "evaluation"))


def csv_text(header, rows, kind: str | None = None) -> str:
    """The CSV text of ``header`` (column names) and ``rows`` (sequences of cells, written as
    they are), one line each with "\n" line ends: for summaries written beside other outputs;
    with ``kind`` (robocal.io.file_kinds) ending in the column that says which file it is."""
    if kind is not None:
        header, rows = marked_rows(header, rows, kind)
    stream = io.StringIO()
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return stream.getvalue()
