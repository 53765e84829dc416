"""UR10 series D (ipa, ISO cubes) as an ISO 9283 campaign in the robot's base frame.

Each row of the series gives the commanded pose (``Goal x..yaw``: m and rad, ROS'
``base_link`` frame, of a TCP 109 mm along the flange's z axis), the joint readings and the
probe's measured pose in the tracker's frame.  The standard compares attained with commanded
positions in one frame, so the tracker is registered to the robot: the tracker -> base
transform and the probe's offset in the commanded TCP frame are the least-squares fit of
every visit's measured position to its commanded pose.  That fit takes the mean of the
robot's error into the frame (as any registration of an instrument to a robot does), so the
campaign's AP is the error left about it; RP and RD do not depend on it.

Commands are written in the controller's base frame (``base_link`` turned by 180 deg about
z, robocal's UR10 frame), so that robocal's UR10 model predicts them from ``q1..q6``.
"""
from __future__ import annotations

import numpy as np

from ..spatial import compose_pose, rot_z, so3_exp
from ..spatial.transforms import kabsch
from .datasets import _columns, _data_file, _read_rows, _source

SERIES_D = "ipa_ur10/Series_D/measurements_iso_cubes.csv"
GOAL = ["Goal x", "Goal y", "Goal z", "Goal roll", "Goal pitch", "Goal yaw"]
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint"]
MEASURED = ["measurement_x", "measurement_y", "measurement_z"]


def series_d_campaign(root=None):
    """The series as a campaign: a dict of columns (N,) in file units, ``x_cmd, y_cmd,
    z_cmd`` and ``x, y, z`` (mm, controller base frame), ``q1..q6`` (deg), and the
    registration: ``registration_rms_mm`` (the fit's residual) and ``probe_mm`` (3,)."""
    path = _data_file(_source(root), SERIES_D)
    header, rows = _read_rows(path, ";")
    goal = _columns(path, header, rows, GOAL, decimal_comma=True)
    joints = _columns(path, header, rows, JOINTS, decimal_comma=True)
    measured = _columns(path, header, rows, MEASURED, decimal_comma=True)
    # base_link -> controller base: 180 deg about z.
    turn = np.eye(4)
    turn[:3, :3] = rot_z(np.pi)
    commanded = turn @ compose_pose(goal[:, :3] * 1000.0, goal[:, 3:])
    rotation, shift, probe, residual = _register(commanded, measured)
    attained = (measured - shift) @ rotation  # p_base = R^T (p_tracker - t)
    target = commanded[:, :3, 3] + np.einsum("nij,j->ni", commanded[:, :3, :3], probe)
    columns = {"x_cmd": target[:, 0], "y_cmd": target[:, 1], "z_cmd": target[:, 2],
               "x": attained[:, 0], "y": attained[:, 1], "z": attained[:, 2]}
    columns.update({f"q{k + 1}": np.degrees(joints[:, k]) for k in range(6)})
    return {"columns": columns, "registration_rms_mm": float(np.sqrt(np.mean(residual ** 2) * 3)),
            "probe_mm": probe, "path": str(path)}


def _register(commanded, measured):
    """(R (3, 3), t (3,), probe (3,), residuals (3N,) mm) with measured ≈ R (C_R probe +
    C_t) + t: the tracker -> base transform and the probe in the commanded TCP frame."""
    from scipy.optimize import least_squares  # loaded when used: the command line starts faster

    start_rotation, start_shift = kabsch(commanded[:, :3, 3], measured)

    def unpack(v):
        return so3_exp(v[:3]) @ start_rotation, v[3:6] + start_shift, v[6:]

    def residuals(v):
        rotation, shift, probe = unpack(v)
        points = commanded[:, :3, 3] + np.einsum("nij,j->ni", commanded[:, :3, :3], probe)
        return (points @ rotation.T + shift - measured).ravel()

    fit = least_squares(residuals, np.zeros(9), method="lm", xtol=1e-15, ftol=1e-15)
    rotation, shift, probe = unpack(fit.x)
    return rotation, shift, probe, fit.fun


def write_series_d_campaign(path, root=None):
    """Write the campaign (:func:`series_d_campaign`) as an ISO 9283 campaign CSV; returns
    what ``robocal dataset`` reports of it."""
    from .atomic import write_text_atomic
    from .csv_writing import csv_text

    campaign = series_d_campaign(root)
    columns = campaign["columns"]
    write_text_atomic(path, csv_text(list(columns), zip(*([repr(float(v)) for v in values]
                                                          for values in columns.values()))))
    return {"iso_campaign": str(path), "registration_rms_mm": round(campaign["registration_rms_mm"], 4),
            "probe_mm": [round(float(v), 3) for v in campaign["probe_mm"]]}
