"""The ISO 9283 campaign file: one row per visit of a commanded pose.

Columns: ``pose`` (optional: the commanded pose's name; without it visits are grouped by
their commanded position), ``cycle`` (optional), ``x_cmd, y_cmd, z_cmd`` (mm) and the
measured ``x, y, z`` (mm); optionally ``rx_cmd, ry_cmd, rz_cmd`` with ``rx, ry, rz`` (deg)
for the orientation characteristics; optionally the joint command ``q1..qN`` (deg, mm for
prismatic joints, or unit-tagged such as ``q2[rad]``), which ``iso9283 --model`` needs to
predict the compensated robot; optionally ``instrument`` (text: what measured the visit), which
the ISO page names.  Other columns are kept and ignored.  ``robocal iso9283
plan`` writes the same columns (with the joint command) without the measured ones.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import FileFormatError
from .csv_table import _read_table
from .file_kinds import KIND_COLUMN, check
from .tables import Measurements, warn_about_identical_rows
from .units import check_angles, check_point_lengths, check_same_angle_unit, check_same_unit

COMMANDED = ("x_cmd", "y_cmd", "z_cmd")
ATTAINED = ("x", "y", "z")
COMMANDED_ANGLES = ("rx_cmd", "ry_cmd", "rz_cmd")
ATTAINED_ANGLES = ("rx", "ry", "rz")


@dataclass(frozen=True)
class IsoCampaign:
    """Visits of an ISO 9283 campaign as in the file: ``commanded``/``attained`` (N, 3) mm,
    the angles (N, 3) deg or None, ``pose`` (N,) names or None, ``cycle`` (N,) or None,
    ``rows`` (N,) file lines, ``joints`` (N, n) the commanded q1..qn in file units (deg, mm)
    or None, ``instrument`` the distinct texts of an instrument column (in order) or None."""

    path: str
    commanded: np.ndarray
    attained: np.ndarray
    commanded_angles: np.ndarray | None
    attained_angles: np.ndarray | None
    pose: np.ndarray | None
    cycle: np.ndarray | None
    rows: np.ndarray
    joints: np.ndarray | None = None
    instrument: tuple | None = None


def read_iso_campaign(path) -> IsoCampaign:
    """Read an ISO 9283 campaign file (module notes).

    Raises:
        FileFormatError: a missing column group, cells that are not finite numbers, or
            orientation columns on one side only.
        InputError: positions that are not mm, angles that look like radians
            (:mod:`robocal.io.units`).
    """
    table = _read_table(path)
    check(table.path, "campaign", header=table.header, column=table.column)
    missing = [c for c in COMMANDED + ATTAINED if c not in table.header]
    if missing:
        raise FileFormatError(f"{table.path} lacks column{'s' if len(missing) > 1 else ''} {', '.join(missing)}: an "
                              "ISO 9283 campaign gives each visit's commanded x_cmd, y_cmd, z_cmd and measured x, y, z "
                              "(mm), and optionally pose, cycle, rx_cmd..rz_cmd and rx..rz (deg)")
    present = [set(group) <= set(table.header) for group in (COMMANDED_ANGLES, ATTAINED_ANGLES)]
    # A plan's commanded angles with positions measured only: the position figures alone.
    if present[1] and not present[0]:
        raise FileFormatError(f"{table.path} has {', '.join(ATTAINED_ANGLES)} but not {', '.join(COMMANDED_ANGLES)}: "
                              "orientation characteristics need the commanded angles beside the measured ones")
    angles = present[0] and present[1]
    cycle = None
    if "cycle" in table.header:
        cycle = table.numbers(["cycle"])[:, 0]
    commanded, attained = table.numbers(COMMANDED), table.numbers(ATTAINED)
    # The one unit evidence for positions without a robot (robocal.io.units).
    check_point_lengths(commanded, f"the commanded x_cmd, y_cmd, z_cmd of {table.path}")
    check_point_lengths(attained, f"the measured x, y, z of {table.path}")
    check_same_unit(commanded, attained, f"the measured x, y, z of {table.path}", "the commanded x_cmd, y_cmd, z_cmd")
    commanded_angles = table.numbers(COMMANDED_ANGLES) if angles else None
    attained_angles = table.numbers(ATTAINED_ANGLES) if angles else None
    if angles:
        # The one test of typed angles, as a targets or measurement file's rx, ry, rz meet it.
        check_angles(commanded_angles, f"the commanded rx_cmd, ry_cmd, rz_cmd of {table.path}")
        check_angles(attained_angles, f"the measured rx, ry, rz of {table.path}")
        check_same_angle_unit(commanded_angles, attained_angles, f"the measured rx, ry, rz of {table.path}",
                              "the commanded rx_cmd, ry_cmd, rz_cmd")
    campaign = IsoCampaign(
        path=table.path,
        commanded=commanded, attained=attained,
        commanded_angles=commanded_angles, attained_angles=attained_angles,
        pose=table.texts("pose") if "pose" in table.header else None,
        cycle=cycle, rows=table.lines, joints=_joint_command(table),
        instrument=tuple(dict.fromkeys(table.texts("instrument"))) if "instrument" in table.header else None)
    # A visit measured twice to every written decimal is one visit exported twice: the one
    # warning every reader of measured rows gives.
    warn_about_identical_rows(table.path, table.lines, [values for values in (
        campaign.pose, campaign.cycle, commanded, attained, commanded_angles, attained_angles, campaign.joints)
        if values is not None])
    return campaign


def campaign_measurements(campaign: IsoCampaign) -> Measurements:
    """The visits of ``campaign`` as a measurement file's rows (file units): each visit's joint
    command q1..qN with its measured x, y, z, for the checks every reader of a robot's data
    meets (units judged by the robot, the one data check); the campaign has a joint command."""
    return Measurements(path=campaign.path, joints=campaign.joints, positions=campaign.attained, rows=campaign.rows)


def _joint_command(table):
    """The commanded q1..qn (N, n) in deg (mm for prismatic joints), the consecutive joint
    columns from q1 on, or None without a q1 column."""
    names = []
    while f"q{len(names) + 1}" in table.header:
        names.append(f"q{len(names) + 1}")
    return table.numbers(names) if names else None


def write_plan(path, plan, chain):
    """Write ``plan`` (:class:`~robocal.acceptance.iso9283.CampaignPlan`) as a campaign file
    without measured columns: pose, cycle, x_cmd..rz_cmd (mm, deg) and q1..qN (deg), every
    cycle visiting P1..P5, and the column that says it is a plan (robocal.io.file_kinds); atomically."""
    import csv
    import io

    from .atomic import write_text_atomic

    degrees = chain.joints_to_file(plan.joints)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["pose", "cycle", *COMMANDED, *COMMANDED_ANGLES] + [f"q{k}" for k in range(1, chain.n_joints + 1)]
                    + [KIND_COLUMN])
    for cycle in range(1, plan.cycles + 1):
        for name, position, joints in zip(plan.names, plan.positions, degrees):
            writer.writerow([name, cycle, *(repr(float(v)) for v in position), *(repr(float(v)) for v in plan.rpy_deg),
                             *(repr(float(v)) for v in joints), "iso-plan"])
    return write_text_atomic(path, buffer.getvalue())
