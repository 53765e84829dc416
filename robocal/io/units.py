"""Which units a file's numbers are in, judged by the robot: the one unit-evidence test.

robocal's files are in degrees and mm (``../shared/DESIGN.md``).  A file in radians or
metres is still made of plausible numbers, so no threshold on the numbers alone tells it: a
radian joint reading is a small angle in degrees, a metre a short length in mm.  What does
tell it is the robot.  Read in the right units, the nominal robot explains the data to a few
mm (the calibration's whole business is the rest); read in the wrong ones, it misses by a
sizeable part of its reach.  So every reader that meets the robot asks the same question
(:func:`evidence`): for each reading of the file's units, how far does the nominal robot
miss?  The stated units stand unless another reading explains the data
:data:`EVIDENCE_RATIO` times better; then the file is refused, naming the units that fit.

* measurement files: joints (degrees or radians) and positions (mm, metres, cm, inches,
  micrometres), the nominal robot registered to the positions (base by a rigid fit, tool by
  linear least squares, alternated), and the lengths' scale against the robot's:
  :func:`check_measurement_units`;
* posture hints in targets files (degrees or radians): how far the hint's TCP lies from its
  target: :func:`check_hint_units`.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..spatial.transforms import kabsch

# File value x factor = degrees / mm.
ANGLE_UNITS = {"degrees": 1.0, "radians": 180.0 / np.pi}
LENGTH_UNITS = {"mm": 1.0, "metres": 1000.0, "cm": 10.0, "inches": 25.4, "micrometres": 1e-3}
# Another reading of the units must explain the data this many times better than the stated
# one to overrule it.  Right units on the shipped data (UR5, UR10 A and B): the registered
# nominal robot misses by 0.3 % of the positions' spread; radians read as degrees by 200 %
# and more.
EVIDENCE_RATIO = 10.0
# Radians are considered only when every revolute joint value lies within one turn (plus the
# rounding of a limit) and the values move: a file of tiny degree readings is not radians.
ONE_TURN = 2.0 * np.pi * 1.02
RADIAN_MIN_SPREAD = 0.2
# Poses the measurement evidence uses (evenly spaced through the file): enough to judge,
# few enough that a million-pose file is judged in milliseconds.
EVIDENCE_POSES = 300
# The measured positions' spread (RMS distance from their centroid) over the nominal model's
# at the same joints.  Right unit and robot: 0.9992 (UR5), 0.9995 and 1.0008 (UR10 A and B);
# an unknown tool or base shifts it a little (base: not at all).  Metres give 1/1000, inches
# 1/25.4, cm 1/10, micrometres 1000; the band leaves a factor of 2 to cm and 20 to µm, for a
# tool the robot file does not have.
SPREAD_RATIO_BAND = (0.2, 50.0)
# The model must move this much (RMS, mm) over the poses for the ratio to mean anything.
SPREAD_JUDGED_MM = 10.0
# Rounds of base (rigid fit) and tool (least squares) registration.
REGISTRATION_ROUNDS = 4


def _flange_frames(chain, joints_rad):
    """(rotations (N, 3, 3), origins (N, 3) mm) of the flange, in the robot base frame."""
    frames = chain.rigid.replace(base=np.eye(4), tool=np.eye(4)).fk(joints_rad)
    return frames[:, :3, :3], frames[:, :3, 3]


def registered_misfit(chain, joints_rad, positions_mm):
    """RMS distance (mm) left between ``positions_mm`` (N, 3) and the nominal robot's TCP at
    ``joints_rad`` (N, n) after registering the base (rigid fit) and the tool position
    (least squares), alternated; inf where the positions cannot be registered (collinear)."""
    rotations, origins = _flange_frames(chain, joints_rad)
    tool = np.asarray(chain.tool, dtype=float)[:3, 3]
    for _ in range(REGISTRATION_ROUNDS):
        model = origins + rotations @ tool
        try:
            rotation, shift = kabsch(model, positions_mm)
        except InputError:
            return np.inf
        in_base = (positions_mm - shift) @ rotation  # R^T (p - b), row by row
        # Least squares for t in origins + R_i t = in_base: R_i orthonormal, so the mean.
        tool = np.mean(np.einsum("nji,nj->ni", rotations, in_base - origins), axis=0)
    model = origins + rotations @ tool
    rotation, shift = kabsch(model, positions_mm)
    left = positions_mm - (model @ rotation.T + shift)
    return float(np.sqrt(np.mean(np.sum(left ** 2, axis=1))))


def _angle_readings(chain, joint_values):
    """The angle units the revolute joint values (N, n, file units) may be in."""
    revolute = np.asarray(joint_values, dtype=float)[:, np.asarray(chain.revolute, dtype=bool)]
    possible = ["degrees"]
    if revolute.size and np.abs(revolute).max() <= ONE_TURN and np.ptp(revolute, axis=0).max() >= RADIAN_MIN_SPREAD:
        possible.append("radians")
    return possible


def _in_degrees(chain, joint_values, angle):
    values = np.array(joint_values, dtype=float)
    revolute = np.asarray(chain.revolute, dtype=bool)
    values[:, revolute] *= ANGLE_UNITS[angle]
    return chain.joints_from_file(values)


def evidence(chain, joint_values, positions):
    """{(angle unit, length unit): the nominal robot's registered misfit over the positions'
    spread} for every reading of a measurement file's units (joint values and positions as
    in the file); about 0.003 in the right units on the shipped data."""
    joint_values = np.asarray(joint_values, dtype=float)
    positions = np.asarray(positions, dtype=float)
    if len(joint_values) > EVIDENCE_POSES:
        pick = np.linspace(0, len(joint_values) - 1, EVIDENCE_POSES).round().astype(int)
        joint_values, positions = joint_values[pick], positions[pick]
    out = {}
    spread = _spread(positions)
    for angle in _angle_readings(chain, joint_values):
        joints = _in_degrees(chain, joint_values, angle)
        for length, factor in LENGTH_UNITS.items():
            # Relative to the positions' spread in that unit: misfits in mm of different
            # readings of the lengths are not comparable, shares of the spread are.
            out[(angle, length)] = registered_misfit(chain, joints, positions * factor) / max(spread * factor, 1e-300)
    return out


def _verdict(misfits, stated):
    """The reading that overrules ``stated`` (a key of ``misfits``), or None."""
    best = min(misfits, key=misfits.get)
    if best != stated and misfits[best] * EVIDENCE_RATIO < misfits[stated]:
        return best
    return None


def _spread(points):
    """RMS distance (mm) of the points from their centroid."""
    return float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))


def check_measurement_units(chain, joint_values, positions, path):
    """InputError when the units of a measurement file are not degrees and mm, judged by
    ``chain``'s nominal robot from the joint values (N, n) and positions (N, 3) as in the
    file.  Joint angles: another reading (radians) must explain the data
    :data:`EVIDENCE_RATIO` times better (:func:`evidence`).  Lengths: the positions must
    spread over the poses as the robot's TCP does, within :data:`SPREAD_RATIO_BAND` (a
    scale, which no base or tool changes much); the message names the unit the ratio is
    nearest to."""
    joint_values = np.asarray(joint_values, dtype=float)
    positions = np.asarray(positions, dtype=float)
    if len(joint_values) < 2:
        return
    if len(joint_values) >= 4 and "radians" in _angle_readings(chain, joint_values):
        misfits = evidence(chain, joint_values, positions)
        better = _verdict(misfits, ("degrees", "mm"))
        if better is not None and better[0] == "radians":
            lengths = "" if better[1] == "mm" else f" and x, y, z look like {better[1]}"
            raise InputError(
                f"{path or 'the data'}: the joint values look like radians{lengths}: read so, the nominal "
                f"'{chain.name}' misses them by {misfits[better]:.1%} of their spread; read as degrees and mm by "
                f"{misfits['degrees', 'mm']:.0%}; robocal reads mm and degrees: convert the file (numpy.degrees()"
                + (", x 1000 for metres" if better[1] == "metres" else "") + ")")
    model = _spread(chain.rigid.fk_positions(chain.joints_from_file(joint_values)))
    if model < SPREAD_JUDGED_MM:
        return
    measured = _spread(positions)
    ratio = measured / model
    low, high = SPREAD_RATIO_BAND
    if low <= ratio <= high:
        return
    others = {name: 1.0 / factor for name, factor in LENGTH_UNITS.items() if name != "mm"}
    unit = min(others, key=lambda name: abs(np.log(max(ratio, 1e-300) / others[name])))
    if measured == 0.0:
        looks = "every row gives the same position"
    elif abs(np.log(ratio / others[unit])) > np.log(2.0):
        looks = f"they are not in mm for this robot (1 mm of the model is {ratio:.3g} in the file)"
    else:
        looks = f"they look like {unit}"
    raise InputError(
        f"the measured positions of {path or 'the data'} spread {measured:.3g} over these poses where the "
        f"model of '{chain.name}' spreads {model:.0f} mm: {looks}; give x, y, z in mm (or check the robot file)")


def check_hint_units(chain, hint_values, target_positions, path):
    """InputError when the posture hints (N, n, file units) of a targets file put the TCP
    far nearer their targets (N, 3) mm read as radians than as degrees: a radian hint read
    as degrees picks another arm branch for every target."""
    hint_values = np.asarray(hint_values, dtype=float)
    if "radians" not in _angle_readings(chain, hint_values):
        return
    misses = {angle: float(np.median(np.linalg.norm(
        chain.fk_positions(_in_degrees(chain, hint_values, angle)) - target_positions, axis=1)))
        for angle in ("degrees", "radians")}
    if _verdict(misses, "degrees") is None:
        return
    raise InputError(f"{path}: the posture hints q1..q{chain.n_joints} look like radians: read so, the robot's TCP "
                     f"lies {misses['radians']:.3g} mm from its targets (median), read as degrees "
                     f"{misses['degrees']:.3g} mm, on other arm branches; robocal reads degrees: convert them with "
                     "numpy.degrees()")
