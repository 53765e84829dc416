"""The files of a measurement plan (``robocal design``): configurations and candidate
placements read, the poses CSV written.

Configurations (a design's candidates, joint targets, measured poses) are read by the reader
of measurement files (:mod:`robocal.io.csv_table`, :func:`robocal.io.tables._named_joints`): a
column tagged with its unit (``q2[rad]``) or named by the robot's joints is read as there.

The poses CSV is the joint part of a measurement file: ``pose`` (the order to measure in),
``q1`` … ``qN`` in the controller's degrees (mm for prismatic joints) and ``x_nominal,
y_nominal, z_nominal``, where the nominal model puts the TCP (mm, robot base frame; a check
for the operator, which ``calibrate`` ignores), and the ``robocal_file`` column saying it is
robocal's poses; a ball-in-socket design adds ``fixture, socket``.  Add the measured ``x, y,
z`` and it is a measurement file.  A placements CSV gives candidate fixture frames: ``x, y,
z, rx, ry, rz`` (mm; deg) in the robot base frame and optionally a ``fixture`` column naming
them.
"""
import csv
import io
from dataclasses import replace

import numpy as np

from ..errors import FileFormatError, InputError
from ..spatial import compose_pose
from .atomic import write_text_atomic
from .file_kinds import READERS, check, marked
from .tables import _named_joints
from .csv_table import _check_header_line, _read_table, _records
from .units import check_angles, check_joint_table

# Joint values this far beyond a limit (deg, mm) are refused, as measurement files' are.
LIMIT_TOLERANCE = 0.5


def table(path):
    """(header, rows of text) of a CSV file, read by the one CSV reader (robocal.io.csv_table:
    other formats named, sep= honoured, other separators refused); FileFormatError for an
    empty one."""
    rows = [cells for _, cells in _records(str(path)) if any(cell.strip() for cell in cells)]
    if not rows:
        raise FileFormatError(f"{path} is empty: give a CSV with columns q1 ... qN (deg)")
    header = [name.strip() for name in rows[0]]
    _check_header_line(str(path), header)
    return header, rows[1:]


def _cells(header, rows):
    """column(name) -> the cells of that column in the rows as long as the header."""
    body = [row for row in rows if len(row) == len(header)]
    return lambda name: [row[header.index(name)] for row in body]


def numbers(path, header, rows, names, unit=""):
    """(len(rows), len(names)) values of the named columns; FileFormatError naming the first
    cell that is empty, not a number, NaN or infinite."""
    index = [header.index(name) for name in names]
    values = np.empty((len(rows), len(names)))
    for r, row in enumerate(rows):
        for c, k in enumerate(index):
            cell = row[k].strip() if k < len(row) else ""
            try:
                values[r, c] = float(cell)
            except ValueError:
                values[r, c] = np.nan
            if not np.isfinite(values[r, c]):
                shown = repr(cell) if cell else "empty"
                raise FileFormatError(f"{path} row {r + 2}, column {names[c]}: {shown} is not a finite number{unit}; "
                                      "fix or remove that row")
    return values


def joint_table(path, chain):
    """The CSV ``path`` read by the reader of measurement and targets files (its unit tags,
    ``q2[rad]``, applied; joint columns named by the robot's joints renamed q1 ... qN)."""
    return _named_joints(_read_table(path), chain.joint_names)


def read_joints(path, chain, what="configurations"):
    """Joint values of a CSV (columns q1 … qN in deg, mm on prismatic joints, or tagged with
    their unit, ``q2[rad]``, or named by the robot's joints, as in a measurement file; others
    ignored) -> ((N, n) rad, header).  One-line errors for missing columns, empty,
    non-numeric or NaN cells, radian-looking values and values beyond the joint limits."""
    data = joint_table(path, chain)
    header = data.header
    check(path, replace(READERS["configurations"], reading_as=f"a file of {what}"), header=header,
          column=data.column)
    names = [f"q{k}" for k in range(1, chain.n_joints + 1)]
    missing = [name for name in names if name not in header]
    if missing:
        raise FileFormatError(f"{path} lacks column{'s' if len(missing) > 1 else ''} {', '.join(missing)}: {what} need "
                              f"the joint values q1 ... q{chain.n_joints} of robot '{chain.name}' (deg; mm on "
                              "prismatic joints)")
    values = data.numbers(names)
    # Untagged revolute columns only: a column tagged with its unit says what it holds.
    untagged = values[:, [k for k in np.flatnonzero(chain.revolute) if names[k] not in data.scales]]
    check_joint_table(untagged, path)  # the one test without a robot (robocal.io.units)
    q = chain.joints_from_file(values)
    tolerance = np.where(chain.revolute, np.radians(LIMIT_TOLERANCE), LIMIT_TOLERANCE)
    beyond = np.flatnonzero(np.any((q < chain.lower - tolerance) | (q > chain.upper + tolerance), axis=1))
    if beyond.size:
        outside = (q[beyond[0]] < chain.lower - tolerance) | (q[beyond[0]] > chain.upper + tolerance)
        joint = int(np.flatnonzero(outside)[0])
        raise InputError(f"{path} row {data.lines[beyond[0]]}: q{joint + 1} = {values[beyond[0], joint]:.6g} lies "
                         f"beyond joint {joint + 1}'s limits of robot '{chain.name}' "
                         f"({len(beyond)} row{'s' if beyond.size > 1 else ''} "
                         "so): remove those rows or fix the robot file's min and max")
    return np.clip(q, chain.lower, chain.upper), header


def write_poses(path, chain, joints, extra=None):
    """The poses CSV (module notes), atomically."""
    degrees = chain.joints_to_file(joints)
    nominal = chain.fk_positions(joints)
    columns = {"pose": [str(k) for k in range(1, len(joints) + 1)]}
    for j in range(chain.n_joints):
        columns[f"q{j + 1}"] = [number_text(v) for v in degrees[:, j]]
    for c, axis in enumerate("xyz"):
        columns[f"{axis}_nominal"] = [f"{v:.3f}" for v in nominal[:, c]]
    columns.update(extra or {})
    columns = marked(columns, "poses")
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(list(columns))
    writer.writerows(zip(*columns.values()))
    write_text_atomic(path, buffer.getvalue())


def number_text(value):
    # Six decimals of a degree (3.6 milli-arcseconds): far below any controller's resolution.
    text = f"{value:.6f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def read_placements(path):
    """(K, 4, 4) fixture poses (robot base frame, mm) and their ids from a placements CSV
    (module notes)."""
    header, rows = table(path)
    check(path, "placements", header=header, column=_cells(header, rows))
    columns = ["x", "y", "z", "rx", "ry", "rz"]
    missing = [c for c in columns if c not in header]
    if missing:
        raise FileFormatError(f"{path} lacks column{'s' if len(missing) > 1 else ''} "
                              f"{', '.join(missing)}: a placements "
                              "file gives the fixture frame in the robot base frame as x, y, z (mm), rx, ry, rz (deg)")
    if not rows:
        raise FileFormatError(f"{path} has a header but no placements")
    values = numbers(path, header, rows, columns)
    check_angles(values[:, 3:], f"the rx, ry, rz of {path}")  # the one test of typed angles
    names = ([row[header.index("fixture")].strip() if header.index("fixture") < len(row) else "" for row in rows]
             if "fixture" in header else [f"P{k + 1}" for k in range(len(rows))])
    if any(not name for name in names) or len(set(names)) < len(names):
        raise FileFormatError(f"{path}: every placement needs its own non-empty id in the fixture column")
    poses = np.stack([compose_pose(v[:3], np.radians(v[3:])) for v in values])
    return poses, names
