"""Joining a tracker's named points to the robot's joint log: ``robocal import``.

Every calibration starts with a join that used to be spreadsheet work: the tracker software
exports points (:mod:`robocal.io.tracker_points`), the controller logs joints.  Here the two
are joined and checked:

* by point name (the log has a ``name``/``point``/``id`` column), or by the nearest
  timestamp within ``max_dt`` seconds (both have a ``time``/``timestamp`` column: seconds,
  or ISO 8601 date-times), each point used once;
* a joint row with no point, or a point with no joint row, is reported, never guessed;
* points measured more than once under one name are averaged, with their spread reported;
  one name logged twice with different joints is refused;
* the point's uncertainty becomes ``sx, sy, sz``; temperature and time are kept.

The log's joint columns are ``q1..qN`` in degrees, or tagged with their unit (``q1[rad]``).
"""
from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass

import numpy as np

from ..errors import FileFormatError, InputError
from .csv_table import JOINT_COLUMN, _read_table
from .file_kinds import check
from .tables import Measurements
from .units import check_joint_table

NAME_COLUMNS = ("name", "point", "id", "label", "target")
TIME_COLUMNS = ("time", "timestamp")
# Default largest gap (s) between a joint row's and its point's timestamps.
MAX_DT = 0.5
# One name logged twice is one pose when its joints agree to this (deg or mm).
SAME_JOINTS = 1e-6


@dataclass(frozen=True)
class JoinReport:
    """How the join went: ``matched`` poses, ``by`` what, the joint rows with no point
    (their lines and keys), the points with no joint row, and the ``duplicates`` averaged
    ((name, count, spread mm))."""

    matched: int
    by: str
    joints_without_point: tuple
    points_without_joints: tuple
    duplicates: tuple

    def to_dict(self):
        return {"matched": self.matched, "by": self.by,
                "joint_rows_without_point": [{"line": int(n), "key": k} for n, k in self.joints_without_point],
                "points_without_joint_row": [{"line": int(n), "name": k} for n, k in self.points_without_joints],
                "averaged": [{"name": n, "count": c, "spread_mm": s} for n, c, s in self.duplicates]}


def _column(table, choices):
    found = [name for name in table.header if name.strip().lower() in choices]
    return found[0] if found else None


def _seconds(texts, path, what):
    """(N,) seconds of timestamps given as numbers or ISO 8601 date-times."""
    out = np.empty(len(texts))
    for k, text in enumerate(texts):
        try:
            out[k] = float(text)
        except ValueError:
            try:
                out[k] = _dt.datetime.fromisoformat(str(text).strip()).timestamp()
            except ValueError:
                raise FileFormatError(f"{path}: {what} {text!r} is neither seconds nor an ISO 8601 date-time") \
                    from None
    return out


def _averaged(points):
    """(names, positions, uncertainty, first index per name, duplicates) with repeated
    names averaged."""
    # Whole-array operations only: a name at a time was quadratic (3 million points ran for
    # minutes).
    names, first, index = np.unique(points.names, return_index=True, return_inverse=True)
    index = index.reshape(-1)
    positions = np.stack([np.bincount(index, weights=points.positions[:, c]) for c in range(3)], axis=1)
    counts = np.bincount(index)
    positions /= counts[:, None]
    spreads = np.zeros(len(names))
    np.maximum.at(spreads, index, np.linalg.norm(points.positions - positions[index], axis=1))
    duplicates = [(str(names[k]), int(counts[k]), float(spreads[k])) for k in np.flatnonzero(counts > 1)]
    uncertainty = None
    if points.uncertainty is not None:
        # The mean of c readings: the single reading's uncertainty over sqrt(c).
        uncertainty = np.bincount(index, weights=points.uncertainty) / counts / np.sqrt(counts)
    return names, positions, uncertainty, first, tuple(duplicates)


def _joint_log(joints_path):
    """The joint log's table, refused first when it is one of robocal's own files of another
    kind (:func:`robocal.io.file_kinds.check`)."""
    table = _read_table(joints_path)
    check(table.path, "joint-log", header=table.header, column=table.column)
    return table


def join(points, joints_path, *, by=None, max_dt=MAX_DT):
    """(:class:`~robocal.io.tables.Measurements`, :class:`JoinReport`): the points
    (:class:`~robocal.io.tracker_points.TrackerPoints`) joined to the joint log at
    ``joints_path``, ``by`` "name" or "time" (default: name when the log has a name column).

    Raises:
        FileFormatError: a log without joint columns or without the key to join by, or a
            name logged twice with different joints.
        InputError: no row could be joined.
    """
    table = joints_path if hasattr(joints_path, "header") else _joint_log(joints_path)
    indices = sorted(int(m.group(1)) for name in table.header if (m := JOINT_COLUMN.fullmatch(name)))
    if not indices or indices != list(range(1, len(indices) + 1)):
        raise FileFormatError(f"{table.path}: a joint log needs the columns q1..qN (deg, or tagged such as q1[rad])")
    joint_names = [f"q{k}" for k in indices]
    joints = table.numbers(joint_names)
    # Untagged columns in radians, by the one test of joint values without a robot to judge
    # them (robocal.io.units), as a file of configurations: refused here, before the
    # measurement file carries them as degrees.  (The log cannot say which joints are
    # prismatic; a column in mm beyond one turn clears the file.)
    check_joint_table(joints[:, [k for k, name in enumerate(joint_names) if name not in table.scales]], table.path)
    name_column, time_column = _column(table, NAME_COLUMNS), _column(table, TIME_COLUMNS)
    if by is None and name_column is None and time_column is None:
        raise FileFormatError(f"{table.path} has no name column ({', '.join(NAME_COLUMNS)}) and no time column "
                              f"({', '.join(TIME_COLUMNS)}): add the point's name to every joint row")
    by = by or ("name" if name_column is not None else "time")
    if by == "name":
        if name_column is None:
            raise FileFormatError(f"{table.path} has no name column ({', '.join(NAME_COLUMNS)}) to join the points "
                                  "by: add one, or join by time")
        return _by_name(points, table, joints, joint_names, name_column)
    if by != "time":
        raise InputError(f"--by {by}: join by name or by time")
    if time_column is None or points.time is None:
        lacking = table.path if time_column is None else points.path
        raise FileFormatError(f"{lacking} has no time column ({', '.join(TIME_COLUMNS)}) to join by time")
    return _by_time(points, table, joints, joint_names, time_column, max_dt)


def _by_name(points, table, joints, joint_names, name_column):
    names, positions, uncertainty, first, duplicates = _averaged(points)
    logged = np.array([cell.strip() for cell in table.column(name_column)])
    keep, seen, missing = [], {}, []
    for row, key in enumerate(logged):
        if key in seen:
            if np.abs(joints[seen[key]] - joints[row]).max() > SAME_JOINTS:
                raise FileFormatError(f"{table.path}, line {table.lines[row]}: point {key} is logged twice with "
                                      f"different joints (first on line {table.lines[seen[key]]}): one name per pose")
            continue
        seen[key] = row
        where = np.searchsorted(names, key)
        if where < len(names) and names[where] == key:
            keep.append((row, where))
        else:
            missing.append((table.lines[row], key))
    unused = [(int(points.lines[first[k]]), str(names[k])) for k in np.flatnonzero(~np.isin(names, list(seen)))]
    rows, found = (np.array(v, dtype=int) for v in zip(*keep)) if keep else (np.zeros(0, int), np.zeros(0, int))
    return _result(points, table, joints, joint_names, rows, positions[found],
                   None if uncertainty is None else uncertainty[found], first[found], "point name", missing,
                   unused, duplicates)


def _by_time(points, table, joints, joint_names, time_column, max_dt):
    logged = _seconds(table.column(time_column), table.path, "time")
    measured = _seconds(points.time, points.path, "time")
    order = np.argsort(measured)
    in_order = measured[order]
    used = np.zeros(len(measured), dtype=bool)
    keep, missing = [], []
    for row, when in enumerate(logged):
        at = np.searchsorted(in_order, when)
        near = [order[k] for k in (at - 1, at) if 0 <= k < len(order) and not used[order[k]]]
        best = min(near, key=lambda k: abs(measured[k] - when), default=None)
        if best is None or abs(measured[best] - when) > max_dt:
            missing.append((table.lines[row], f"t = {table.column(time_column)[row]}"))
            continue
        used[best] = True
        keep.append((row, best))
    unused = [(points.lines[k], str(points.names[k])) for k in np.flatnonzero(~used)]
    rows, found = (np.array(v, dtype=int) for v in zip(*keep)) if keep else (np.zeros(0, int), np.zeros(0, int))
    return _result(points, table, joints, joint_names, rows, points.positions[found],
                   None if points.uncertainty is None else points.uncertainty[found], found,
                   f"nearest timestamp within {max_dt:g} s", missing, unused, ())


def _result(points, table, joints, joint_names, rows, positions, uncertainty, point_index, by, missing, unused,
            duplicates):
    if len(rows) == 0:
        raise InputError(f"no joint row of {table.path} could be joined to a point of {points.path} by {by}: check "
                         "that the names (or clocks) of the two files agree")
    extra = {"point": points.names[point_index]}
    for name, values in (("temperature", points.temperature), ("time", points.time)):
        if values is not None:
            extra[name] = values[point_index]
    sigmas = None if uncertainty is None else np.repeat(np.asarray(uncertainty)[:, None], 3, axis=1)
    data = Measurements(path="", joints=joints[rows], positions=positions, sigmas=sigmas, extra=extra)
    report = JoinReport(len(rows), by, tuple(missing), tuple(unused), tuple(duplicates))
    return data, report


def import_points(points_path, joints_path, out, *, units=None, by=None, max_dt=MAX_DT):
    """``robocal import``: join ``points_path`` to ``joints_path`` and write the
    measurement file ``out`` (atomically); returns the :class:`JoinReport` as a dict with
    the unit the points were read in and where the file went."""
    from .atomic import check_outputs
    from .csv_writing import write_measurements
    from .tracker_points import read_points

    check_outputs([out], [points_path, joints_path])
    # Both files' kinds before either's content: robocal's commands given as the joint log is
    # named as such, whatever the points hold.
    log = _joint_log(joints_path)
    points = read_points(points_path, units=units)
    data, report = join(points, log, by=by, max_dt=max_dt)
    write_measurements(out, data)
    return {"out": str(out), "points_unit": points.unit, **report.to_dict()}
