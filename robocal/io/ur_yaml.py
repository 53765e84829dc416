"""The kinematics YAML of Universal Robots' ROS 2 driver, from a calibrated UR arm.

``ur_description`` builds the arm from a file ``kinematics: {shoulder, upper_arm, forearm,
wrist_1, wrist_2, wrist_3}``, each with ``x, y, z`` (m) and ``roll, pitch, yaw`` (rad), plus
``hash``: joint i's ``<origin>`` in the URDF, from the previous joint's link (the first from
``base_link_inertia``, which is the controller's base frame) to link i at zero, about whose z
axis joint i turns.  The angles are applied as URDF applies an origin's rpy (fixed axes:
R = Rz(yaw) Ry(pitch) Rx(roll), as everywhere in robocal), and ``wrist_3_link`` is the
controller's tool flange (DH frame 6), which ``tool0`` follows by fixed rotations.

Link i of the nominal arm is UR's: DH frame i moved along its axis by ``d_i``, which is where
UR's meshes expect it.  Each calibrated link frame is the nominal one turned by the smallest
rotation that carries its z axis onto the calibrated joint axis and moved onto that axis, so
the meshes stay in place and the forward kinematics is exactly the calibrated one up to
``wrist_3_link``.  What lies beyond (a calibrated flange the last joint frame cannot carry),
the registration base and the tool are not in this file: :func:`ur_kinematics` returns them.

The file is written without a YAML library: six mappings of six numbers and a hash.
"""
from __future__ import annotations

import hashlib

import numpy as np

from ..errors import InputError
from ..spatial import chained, invert, matrix_to_rpy, so3_exp
from .atomic import write_text_atomic
from .urdf import MM_PER_M, _joint_origins

SEGMENTS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
# UR's DH structure: twist (deg) of each link; a1, a4..a6 and d2, d3 are zero.
UR_ALPHA_DEG = (90.0, 0.0, 0.0, 90.0, -90.0, 0.0)
# How far a nominal robot may lie from UR's structure and still be one (deg, mm).
STRUCTURE_TOLERANCE = 1e-6
# A flange beyond wrist_3_link below this (mm; rad) is rounding: nothing is left out.
NEGLIGIBLE = 1e-9


def check_ur(nominal):
    """The nominal robot in standard DH form, or InputError unless it is a Universal Robots
    arm (six revolute joints in UR's DH structure)."""
    from ..kinematics import to_dh

    refusal = (f"--format ur-yaml writes Universal Robots' ROS 2 kinematics file, but the robot {nominal.name!r} "
               "is not a UR arm (six revolute joints, twists 90, 0, 0, 90, -90, 0 deg): export toml or urdf")
    if nominal.n_joints != 6 or any(kind != "revolute" for kind in nominal.joint_types):
        raise InputError(refusal)
    try:
        dh = to_dh(nominal)
    except (InputError, ValueError, np.linalg.LinAlgError):
        raise InputError(refusal) from None
    zero_lengths = np.concatenate([dh.a[[0, 3, 4, 5]], dh.d[[1, 2]]])
    if (np.abs(np.degrees(dh.alpha) - UR_ALPHA_DEG).max() > STRUCTURE_TOLERANCE
            or np.abs(zero_lengths).max() > STRUCTURE_TOLERANCE):
        raise InputError(refusal)
    return dh


def ur_kinematics(nominal, calibrated):
    """The driver's six segments of ``calibrated`` (a rigid Chain, controller joint values)
    whose nominal robot is ``nominal``.

    Returns ``(segments, left_out)``: ``segments`` maps each name of :data:`SEGMENTS` to a
    4x4 transform (mm); ``left_out`` lists what the file cannot hold (text).

    Raises:
        InputError: not a UR arm; a joint map that is not the identity (gains, sign flips).
    """
    dh = check_ur(nominal)
    if not np.array_equal(calibrated.joint_map, np.eye(6)):
        raise InputError("UR's kinematics file holds no joint gains or sign changes, which this calibration has: "
                         "calibrate without gains, or export a robot file")
    nominal_frames = _frames(dh) @ _along_z(dh.d)
    calibrated_frames = _frames(calibrated)
    links = np.array([_onto_axis(n, c) for n, c in zip(nominal_frames, calibrated_frames)])
    origins, last = _joint_origins(calibrated)
    flange = calibrated_frames[-1] @ last @ calibrated.flange
    beyond = invert(links[-1]) @ flange
    left_out = []
    if _on_axis(calibrated_frames[-1], flange):
        links[-1] = flange  # the flange is a frame of the last joint's axis: wrist_3_link itself
    elif np.abs(beyond - np.eye(4)).max() > NEGLIGIBLE:
        xyz, rpy = beyond[:3, 3], np.degrees(matrix_to_rpy(beyond[:3, :3]))
        left_out.append(f"the calibrated flange beyond wrist_3_link (xyz {_listed(xyz)} mm, rpy {_listed(rpy)} deg): "
                        "add it to the TCP")
    if np.abs(calibrated.base - np.eye(4)).max() > NEGLIGIBLE:
        left_out.append("the base (measurement frame -> robot base): the driver's base_link is the robot's own")
    if np.abs(calibrated.tool - np.eye(4)).max() > NEGLIGIBLE:
        xyz = calibrated.tool[:3, 3]
        left_out.append(f"the tool (flange -> measured point, xyz {_listed(xyz)} mm): set it as the TCP")
    previous = np.eye(4)
    segments = {}
    for name, link in zip(SEGMENTS, links):
        segments[name] = invert(previous) @ link
        previous = link
    return segments, left_out


def write_ur_yaml(path, nominal, calibrated):
    """Write the driver's kinematics file of ``calibrated`` (see :func:`ur_kinematics`)
    atomically; returns what was left out (list of text)."""
    segments, left_out = ur_kinematics(nominal, calibrated)
    lines = [f"# UR kinematics of {calibrated.name!r}, calibrated by robocal: ur_description's",
             "# kinematics_parameters_file (metres, radians; rpy as a URDF origin applies them).",
             "# The hash is robocal's, not the controller's: the driver says the two differ,",
             "# which they do (this file replaces the controller's own calibration in ROS).",
             "kinematics:"]
    values = []
    for name in SEGMENTS:
        transform = segments[name]
        numbers = list(transform[:3, 3] / MM_PER_M) + list(matrix_to_rpy(transform[:3, :3]))
        numbers = [0.0 if abs(v) < 1e-15 else float(v) for v in numbers]
        values += numbers
        lines.append(f"  {name}:")
        lines += [f"    {key}: {value!r}" for key, value in zip(("x", "y", "z", "roll", "pitch", "yaw"), numbers)]
    digest = int(hashlib.sha256(repr(values).encode()).hexdigest()[:15], 16)
    lines.append(f"  hash: robocal_{digest}")
    write_text_atomic(path, "\n".join(lines) + "\n")
    return left_out


def _frames(chain):
    """Joint frames at zero (6, 4, 4) mm from the base, offsets folded in, base excluded."""
    return chained(_joint_origins(chain)[0])


def _along_z(lengths):
    """(n, 4, 4) translations by ``lengths`` (mm) along z."""
    out = np.tile(np.eye(4), (len(lengths), 1, 1))
    out[:, 2, 3] = lengths
    return out


def _onto_axis(nominal, calibrated):
    """The frame nearest to ``nominal`` (4x4) whose z axis is the z axis of ``calibrated``,
    through its origin: turned by the smallest rotation, then moved onto the axis."""
    direction, target = nominal[:3, 2], calibrated[:3, 2]
    cross = np.cross(direction, target)
    angle = np.arctan2(np.linalg.norm(cross), np.dot(direction, target))
    turn = np.eye(3) if angle < 1e-15 else so3_exp(cross / np.linalg.norm(cross) * angle)
    out = np.eye(4)
    out[:3, :3] = turn @ nominal[:3, :3]
    point = calibrated[:3, 3]
    out[:3, 3] = point + np.dot(nominal[:3, 3] - point, target) * target
    return out


def _on_axis(frame, candidate):
    """Whether ``candidate`` (4x4) turns about ``frame``'s z axis: same z, origin on it."""
    axis, point = frame[:3, 2], frame[:3, 3]
    offset = candidate[:3, 3] - point
    return bool(np.linalg.norm(candidate[:3, 2] - axis) < NEGLIGIBLE
                and np.linalg.norm(offset - np.dot(offset, axis) * axis) < NEGLIGIBLE)


def _listed(values):
    return ", ".join(f"{v:.4f}" for v in values)
