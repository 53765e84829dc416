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

* measurement files: joints (degrees or radians, judged column by column: any subset of the
  revolute columns may be in radians) and positions (mm, metres, cm, inches, micrometres),
  the nominal robot registered to the positions (base by a rigid fit, tool by linear least
  squares, alternated), and the lengths' scale against the robot's:
  :func:`check_measurement_units`;
* targets files: positions as a length about the robot and, with posture hints, spread as the
  hints' TCP; posture hints (degrees or radians, by column) by how far the hint's TCP lies
  from its target: :func:`check_target_units`;
* positions without a robot (an ISO 9283 campaign, a tracker's points): the size of a robot's
  poses in mm, and commanded and measured in one unit: :func:`check_point_lengths`,
  :func:`check_same_unit`;
* lengths a user types or a file carries without measurements to judge them by (design's
  ``--box``, ``--tool``, ``--tracker``, ``--region``, ``--walls``; a fixture's socket
  spacings): their size against the robot's reach (or a fixture's smallest span), and which
  other unit would make them a length of that robot: :func:`check_lengths`;
* angles typed or carried without a robot's TCP to judge them by (``--rpy``, ``--hint``
  without targets, the ``rx, ry, rz`` of a targets file, a measurement file and an ISO 9283
  campaign, its ``rx_cmd, ry_cmd, rz_cmd``): :func:`looks_like_radians`, the one numeric
  test, and :func:`check_angles`, its refusal; measured beside commanded angles (an ISO
  campaign), also in one unit: :func:`check_same_angle_unit`.
"""
from __future__ import annotations

import numpy as np

from ..errors import FileFormatError, InputError
from ..spatial.transforms import kabsch

# File value x factor = degrees / mm.
ANGLE_UNITS = {"degrees": 1.0, "radians": 180.0 / np.pi}
LENGTH_UNITS = {"mm": 1.0, "metres": 1000.0, "cm": 10.0, "inches": 25.4, "micrometres": 1e-3}
# Another reading of the units must explain the data this many times better than the stated
# one to overrule it.  Right units on the shipped data (UR5, UR10 A and B): the registered
# nominal robot misses by 0.3 % of the positions' spread; radians read as degrees by 200 %
# and more.
EVIDENCE_RATIO = 10.0
# A reading overrules the stated one only if it explains the data: the nominal robot misses
# them by at most this share of their spread (right units on the shipped data: 0.1 to 0.3 %).
# Poses that barely move (a cluster) leave every reading far from this.
EXPLAINED_SHARE = 0.1
# Posture hints are seeds, not the solution: on the shipped UR5 targets the right reading
# leaves 31 mm (median) between a hint's TCP and its target, the wrist (q4..q6) in radians
# 202 mm, every joint in radians 476 mm.  A hint reading must be this many times nearer.
HINT_EVIDENCE_RATIO = 4.0
# Readings whose misfits are within this factor of the best one are as good as it (a hint is
# a seed: its TCP lies a few mm from the target in the right reading, whatever q6 is).
SAME_MISFIT = 1.5
# Radians are considered only when every revolute joint value lies within one turn (plus the
# rounding of a limit) and the values move: a file of tiny degree readings is not radians.
# Judged column by column: every subset of such columns is a reading (a 6-axis arm: at most 63).
ONE_TURN = 2.0 * np.pi * 1.02
RADIAN_MIN_SPREAD = 0.2
MAX_SUBSET_COLUMNS = 7
# Poses the measurement evidence uses (evenly spaced through the file): enough to judge,
# few enough that a million-pose file is judged in milliseconds.
EVIDENCE_POSES = 300
# The measured positions' spread (RMS distance from their centroid) over the nominal model's
# at the same joints.  Right unit and robot: 0.9992 (UR5), 0.9995 and 1.0008 (UR10 A and B);
# an unknown tool or base shifts it a little (base: not at all).  Metres give 1/1000, inches
# 1/25.4, cm 1/10, micrometres 1000; the band leaves a factor of 2 to cm and 20 to µm, for a
# tool the robot file does not have.
SPREAD_RATIO_BAND = (0.2, 50.0)
# Positions spreading this many times less than the largest unit robocal knows (metres) would
# make them do not move at all: no unit explains them, they are the same point over and over.
STILL_FACTOR = 20.0
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


def _radian_candidates(chain, joint_values):
    """The revolute columns of ``joint_values`` (N, n, file units) that may be radians: every
    value within one turn.  A file may mix units by column (a controller export whose wrist
    joints are in radians), so each column is judged, not the file at once."""
    values = np.asarray(joint_values, dtype=float)
    return [int(j) for j in np.flatnonzero(np.asarray(chain.revolute, dtype=bool))
            if values.size and np.abs(values[:, j]).max() <= ONE_TURN]


def _angle_readings(chain, joint_values):
    """The readings of the revolute joint values (N, n, file units): tuples of the columns read
    as radians, () for all in degrees.  A reading is considered only when its columns move (by
    RADIAN_MIN_SPREAD): a file of tiny degree readings is not radians.  Every subset of the
    candidate columns, up to MAX_SUBSET_COLUMNS of them (then the candidates at once, and each
    alone)."""
    values = np.asarray(joint_values, dtype=float)
    candidates = _radian_candidates(chain, values)
    if len(candidates) <= MAX_SUBSET_COLUMNS:
        subsets = [tuple(c for k, c in enumerate(candidates) if mask >> k & 1)
                   for mask in range(1, 1 << len(candidates))]
    else:
        subsets = [tuple(candidates)] + [(c,) for c in candidates]
    return [()] + [cols for cols in subsets if np.ptp(values[:, list(cols)], axis=0).max() >= RADIAN_MIN_SPREAD]


def _columns(chain, cols):
    """'q4..q6', 'q2, q5' (1-based joint names of the column indices ``cols``)."""
    cols = sorted(cols)
    if len(cols) > 2 and cols == list(range(cols[0], cols[-1] + 1)):
        return f"q{cols[0] + 1}..q{cols[-1] + 1}"
    return ", ".join(f"q{c + 1}" for c in cols)


def _all_revolute(chain, cols):
    return len(cols) == int(np.sum(np.asarray(chain.revolute, dtype=bool)))


def _in_degrees(chain, joint_values, cols):
    """Joint values (N, n, file units) in radians internally, the columns ``cols`` read as
    radians and the other revolute ones as degrees."""
    values = np.array(joint_values, dtype=float)
    revolute = np.asarray(chain.revolute, dtype=bool).copy()
    values[:, list(cols)] *= ANGLE_UNITS["radians"]
    revolute[list(cols)] = False
    values[:, revolute] *= ANGLE_UNITS["degrees"]
    return chain.joints_from_file(values)


def evidence(chain, joint_values, positions):
    """{(angle reading, length unit): the nominal robot's registered misfit over the positions'
    spread} for every reading of a measurement file's units (joint values and positions as
    in the file; an angle reading is the tuple of columns read as radians, () for degrees,
    :func:`_angle_readings`); about 0.003 in the right units on the shipped data."""
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


def _verdict(misfits, stated, ratio=EVIDENCE_RATIO, explains=np.inf):
    """The reading that overrules ``stated`` (a key of ``misfits``) by ``ratio`` and itself
    explains the data (misfit at most ``explains``), or None.  Of
    readings as good as the best (within SAME_MISFIT), the one with the most radian columns:
    a joint that does not move the TCP (a wrist roll on its axis) fits either way, and its
    column is in the unit of its neighbours."""
    best = min(misfits, key=misfits.get)
    if best == stated or misfits[best] * ratio >= misfits[stated] or misfits[best] > explains:
        return None
    same = [key for key in misfits if misfits[key] <= misfits[best] * SAME_MISFIT]
    def columns(key):  # (columns, length unit) of a measurement reading, columns of a hint reading
        return key[0] if key and isinstance(key[0], tuple) else key

    return max(same, key=lambda key: (len(columns(key)), -misfits[key]))


def _spread(points):
    """RMS distance (mm) of the points from their centroid."""
    return float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))


def _which_joints(chain, cols):
    """'the joint values' (every revolute column) or 'the joint values q4..q6'."""
    return "the joint values" if _all_revolute(chain, cols) else f"the joint values {_columns(chain, cols)}"


def check_measurement_units(chain, joint_values, positions, path):
    """InputError when the units of a measurement file are not degrees and mm, judged by
    ``chain``'s nominal robot from the joint values (N, n) and positions (N, 3) as in the
    file.  Joint angles: another reading (some or all revolute columns in radians) must
    explain the data :data:`EVIDENCE_RATIO` times better (:func:`evidence`).  Lengths: the
    positions must spread over the poses as the robot's TCP does (:func:`_check_spread`)."""
    joint_values = np.asarray(joint_values, dtype=float)
    positions = np.asarray(positions, dtype=float)
    if len(joint_values) < 2:
        return
    if len(joint_values) >= 4 and len(_angle_readings(chain, joint_values)) > 1:
        misfits = evidence(chain, joint_values, positions)
        better = _verdict(misfits, ((), "mm"), explains=EXPLAINED_SHARE)
        if better is not None and better[0]:
            lengths = "" if better[1] == "mm" else f" and x, y, z look like {better[1]}"
            raise InputError(
                f"{path or 'the data'}: {_which_joints(chain, better[0])} look like radians{lengths}: read so, the "
                f"nominal '{chain.name}' misses them by {misfits[better]:.1%} of their spread; read as degrees and mm "
                f"by {misfits[(), 'mm']:.0%}; robocal reads mm and degrees: convert "
                + ("the file (numpy.degrees()" if _all_revolute(chain, better[0]) else
                   f"{_columns(chain, better[0])} (numpy.degrees()")
                + (", x 1000 for metres" if better[1] == "metres" else "") + ")")
    _check_spread(chain, chain.joints_from_file(joint_values), positions,
                  f"the measured positions of {path or 'the data'}")


def _check_spread(chain, joints, positions, what, measured_positions=True):
    """InputError when the positions (N, 3) of ``what`` do not spread over the joints (N, n)
    rad as the nominal robot's TCP does, within :data:`SPREAD_RATIO_BAND` (a scale, which no
    base or tool changes much); the message names the unit the ratio is nearest to.  Joints
    over which the model moves less than SPREAD_JUDGED_MM say nothing.  Measured positions
    that barely move at all are named as such (``measured_positions``; a target may be
    asked for in several postures, so targets are not)."""
    model = _spread(chain.rigid.fk_positions(joints))
    if model < SPREAD_JUDGED_MM:
        return
    measured = _spread(positions)
    ratio = measured / model
    low, high = SPREAD_RATIO_BAND
    if low <= ratio <= high:
        return
    others = {name: 1.0 / factor for name, factor in LENGTH_UNITS.items() if name != "mm"}
    if measured_positions and ratio < min(others.values()) / STILL_FACTOR:
        _refuse_still_positions(chain, positions, measured, model, what)
    unit = min(others, key=lambda name: abs(np.log(max(ratio, 1e-300) / others[name])))
    if abs(np.log(ratio / others[unit])) > np.log(2.0):
        looks = f"they are not in mm for this robot (1 mm of the model is {ratio:.3g} in the file)"
    else:
        looks = f"they look like {unit}"
    raise InputError(
        f"{what} spread {measured:.3g} over these poses where the model of '{chain.name}' spreads {model:.0f} mm: "
        f"{looks}; give x, y, z in mm (or check the robot file)")


def check_target_units(chain, hint_values, target_positions, path):
    """InputError when the numbers of a targets file are not mm and degrees, judged by
    ``chain``: the same evidence as for measurements.

    * positions (N, 3) as in the file: a length about the robot (:func:`check_robot_lengths`:
      metres are a thousandth of one), and, with posture hints that move the TCP, spread as
      the hints' TCP does (:func:`_check_spread`: inches, cm);
    * posture hints (N, n, file units, or None): read with some or all revolute columns in
      radians, their TCP must not lie :data:`EVIDENCE_RATIO` times nearer the targets than
      read as degrees (a radian hint read as degrees picks another arm branch); hints that
      do not move over the file (one seed posture for every target) give no TCP evidence
      and meet the one test of typed angles (:func:`looks_like_radians`) on the columns
      within one turn."""
    target_positions = np.asarray(target_positions, dtype=float)
    if len(target_positions):
        check_robot_lengths(chain, target_positions, f"the target positions x, y, z of {path}")
    if hint_values is None:
        return
    hint_values = np.asarray(hint_values, dtype=float)
    readings = _angle_readings(chain, hint_values)
    if len(readings) > 1:
        misses = {cols: float(np.median(np.linalg.norm(
            chain.fk_positions(_in_degrees(chain, hint_values, cols)) - target_positions, axis=1)))
            for cols in readings}
        better = _verdict(misses, (), HINT_EVIDENCE_RATIO)
        if better is not None:
            named = f"q1..q{chain.n_joints}" if _all_revolute(chain, better) else _columns(chain, better)
            raise InputError(
                f"{path}: the posture hints {named} "
                f"look like radians: read so, the robot's TCP lies {misses[better]:.3g} mm from its targets (median), "
                f"read as degrees {misses[()]:.3g} mm, on other arm branches; robocal reads degrees: convert them "
                "with numpy.degrees()")
    else:
        candidates = _radian_candidates(chain, hint_values)
        if candidates and looks_like_radians(hint_values[:, candidates], ONE_TURN):
            largest = float(np.abs(hint_values[:, candidates]).max())
            raise InputError(
                f"{path}: the posture hints {_columns(chain, candidates)} look like radians (all within one turn, "
                f"largest {largest:.6g}, a multiple of pi/4 or a fraction beyond 1), but robocal reads degrees: "
                "convert them with numpy.degrees()")
    _check_spread(chain, chain.joints_from_file(hint_values), target_positions,
                  f"the target positions of {path}", measured_positions=False)


def _refuse_still_positions(chain, positions, measured, model, what):
    """InputError for measured positions that do not move while the robot's TCP does: no unit
    makes them positions of these poses (the same x, y, z copied down, an instrument that
    stayed on one point)."""
    found = (f"all {len(positions)} rows give the same x, y, z" if len(np.unique(positions, axis=0)) == 1 else
             f"they spread only {measured:.3g} over the {len(positions)} rows")
    raise InputError(
        f"{what} do not move with the robot: {found}, where the model of "
        f"'{chain.name}' "
        f"moves its TCP {model:.0f} mm over these poses; give each pose's own measured x, y, z (mm) (was the "
        "column filled down, or did the instrument lose its target?)")


def check_hint_units(chain, hint_values, target_positions, path):
    """Kept for callers of the posture hints alone: :func:`check_target_units`."""
    check_target_units(chain, hint_values, target_positions, path)


# --------------------------------------------------------------------------- typed lengths
# A length that locates something about a robot (a box it works in, a tool on its flange, a
# tracker beside it) is at least this share of the robot's reach: a UR5 (850 mm) gives
# 4.25 mm, a KR 150-2 (2.7 m) 13.5 mm.  The same lengths typed in metres are a thousandth of
# what they mean (a box 0.3..0.6, a 0.1 tool, a tracker at 2.5): far below it.
SMALLEST_REACH_SHARE = 1.0 / 200.0
# Joints sampled to measure the reach (seeded: the same robot is judged the same way).
REACH_SAMPLE = 256


def reach_mm(chain):
    """The largest distance (mm) of the flange from the base over ``chain``'s joint range."""
    joints = chain.random_configurations(REACH_SAMPLE, rng=0)
    rigid = chain.rigid.replace(base=np.eye(4), tool=np.eye(4))
    return float(np.linalg.norm(rigid.fk_positions(joints), axis=1).max())


def apart(*values):
    """The numbers ``values`` as texts with the fewest significant digits (three at least)
    that print different numbers differently: a message comparing 4.996 with 5.005 must not
    say "5, where at least 5"."""
    values = [float(v) for v in values]
    for digits in range(3, 18):
        texts = [f"{v:.{digits}g}" for v in values]
        if len(set(texts)) == len(set(values)):
            return texts
    return [repr(v) for v in values]


def check_lengths(size, smallest_mm, what, owner, measure="largest", fix="give them in mm"):
    """InputError when ``size`` (the largest length of ``what``, as typed, > 0) lies below
    ``smallest_mm``, the least a length of ``owner`` (a phrase: "a UR5 reaching 850 mm")
    can be in mm; ``measure`` says what ``size`` is ("largest", "distance from the origin" for a
    point judged by its distance from the origin).  The message names metres when they make
    it one, and prints the two numbers it compares so that they differ (:func:`apart`).  A
    zero size (a tool on the flange, a box at the origin) says nothing and passes."""
    size = float(size)
    if not np.isfinite(size) or size == 0.0 or size >= smallest_mm:
        return
    # Metres are what a length typed 1000 times too small is (a SI habit, a ROS export);
    # below even that, the numbers are no length of this kind in any unit.
    looks = "they look like metres" if size * LENGTH_UNITS["metres"] >= smallest_mm else "they are not mm"
    shown, least = apart(size, smallest_mm)
    raise InputError(f"{what}: {measure} {shown}, where {owner} needs at least {least} mm: {looks}; {fix}")


def check_robot_lengths(chain, values, what, *, position=False):
    """:func:`check_lengths` for lengths about ``chain``: ``values`` (any shape, mm as typed)
    of ``what`` (``'--box'``); ``position``: one point (a tool, a tracker), judged by its
    distance from the origin, else by the largest coordinate."""
    values = np.asarray(values, dtype=float)
    size = np.linalg.norm(values) if position else np.abs(values).max(initial=0.0)
    reach = reach_mm(chain)
    check_lengths(size, reach * SMALLEST_REACH_SHARE, what,
                  f"a length about robot '{chain.name}' (reach {reach:.0f} mm)",
                  "distance from the origin" if position else "largest")


# Positions measured about a robot without the robot to judge them (an ISO 9283 campaign, a
# tracker's point export): in any frame, the largest coordinate of a robot's poses in mm is at
# least this (a small arm's flange stands 100 mm and more from its base; a tracker stands
# metres away).  The same points in metres are a few units (a base frame) or the tracker's
# distance in metres.
SMALLEST_POINTS_MM = 20.0
# Two sets of positions of the same poses (commanded and attained) in the same unit spread
# alike: within this factor (an ISO campaign's robot misses its commands by a few mm).
SAME_SPREAD = 2.0


def check_point_lengths(points, what, fix="give them in mm"):
    """InputError when the positions ``points`` (N, 3, as read as mm) of ``what`` are no
    robot's poses in mm: the largest coordinate below :data:`SMALLEST_POINTS_MM` (metres)."""
    points = np.asarray(points, dtype=float)
    check_lengths(np.abs(points).max(initial=0.0), SMALLEST_POINTS_MM, what, "a position measured about a robot",
                  fix=fix)


def check_same_unit(reference, points, what, reference_what):
    """InputError when ``points`` (N, 3) spread unlike ``reference`` (N, 3), the same poses in
    mm, by more than :data:`SAME_SPREAD`: another length unit, named when one fits."""
    reference, points = np.asarray(reference, dtype=float), np.asarray(points, dtype=float)
    if len(reference) < 2 or _spread(reference) < SPREAD_JUDGED_MM:
        return
    ratio = _spread(points) / _spread(reference)
    if 1.0 / SAME_SPREAD <= ratio <= SAME_SPREAD:
        return
    others = {name: 1.0 / factor for name, factor in LENGTH_UNITS.items() if name != "mm"}
    unit = min(others, key=lambda name: abs(np.log(max(ratio, 1e-300) / others[name])))
    looks = (f"they look like {unit}" if ratio > 0 and abs(np.log(ratio / others[unit])) <= np.log(SAME_SPREAD)
             else "they are not in the same unit")
    raise InputError(f"{what} spread {_spread(points):.3g} where {reference_what} of the same poses spread "
                     f"{_spread(reference):.3g} mm: {looks}; give both in mm")


# --------------------------------------------------------------------------- typed angles
# Angles in radians, without a robot's TCP to judge them: every value within half a turn in
# radians (one turn for joint values), and one that a degree value would hardly be within
# that bound: either a fraction beyond RADIAN_LARGE (a tool within 3 deg of the base's axes,
# tilted 1.x deg or more), or within RADIAN_SNAP of a non-zero multiple of 45 deg in radians
# (pi, pi/2: the tool down or sideways, as radians write it).  Degree values (rx = 180; small
# whole tilts near zero; 0) pass.
RADIAN_HALF_TURN = np.pi + 1e-3
RADIAN_LARGE = 1.0
RADIAN_SNAP = 2e-3


def looks_like_radians(values, bound=RADIAN_HALF_TURN):
    """Whether the angles ``values`` (any shape, as typed) look like radians (see above);
    ``bound``: the largest magnitude radians would take (one turn for joint values)."""
    angles = np.abs(np.asarray(values, dtype=float))
    if angles.size == 0 or not np.all(np.isfinite(angles)) or angles.max() > bound:
        return False
    eighths = angles / (np.pi / 4)
    snapped = (np.round(eighths) >= 1) & (np.abs(eighths - np.round(eighths)) * (np.pi / 4) <= RADIAN_SNAP)
    large = (angles > RADIAN_LARGE) & (angles != np.round(angles))
    return bool(large.any() or snapped.any())


def check_angles(values, what, *, joints=False, fix="convert with numpy.degrees()"):
    """InputError when the angles ``values`` of ``what`` (``'the angles of --rpy'``, ``'the rx,
    ry, rz of FILE'``) look like radians (:func:`looks_like_radians`; ``joints``: joint values, within
    one turn); ``fix``: what to do."""
    if looks_like_radians(values, ONE_TURN if joints else RADIAN_HALF_TURN):
        largest = float(np.abs(np.asarray(values, dtype=float)).max())
        raise InputError(f"{what} look like radians (all within one {'turn' if joints else 'half-turn'}, largest "
                         f"{largest:.6g}), but robocal reads degrees: {fix}")


# Joint values of many rows without a robot to judge them (a joint log, a file of
# configurations): radians when every value lies within JOINT_RADIAN_BOUND and some column
# moves by JOINT_RADIAN_SPREAD over JOINT_RADIAN_ROWS rows or more (a file of tiny degree
# readings that barely move is not radians).
JOINT_RADIAN_BOUND = 6.3
JOINT_RADIAN_SPREAD = 0.5
JOINT_RADIAN_ROWS = 5


def joint_values_look_like_radians(values):
    """Whether the joint values ``values`` (N, k, as in the file; the columns a robot would
    read in degrees) of a file judged without a robot look like radians (see above)."""
    values = np.asarray(values, dtype=float)
    return bool(len(values) >= JOINT_RADIAN_ROWS and values.size and np.abs(values).max() < JOINT_RADIAN_BOUND
                and np.ptp(values, axis=0).max() >= JOINT_RADIAN_SPREAD)


def check_joint_table(values, path):
    """FileFormatError when the untagged revolute joint values ``values`` (N, k, as in the file)
    of ``path`` look like radians (:func:`joint_values_look_like_radians`): a file of
    configurations, a joint log."""
    if joint_values_look_like_radians(values):
        raise FileFormatError(f"all joint values of {path} lie within ±{JOINT_RADIAN_BOUND}: they look like radians, "
                              "but robocal reads degrees; tag the columns q1[rad] ... or convert them with "
                              "numpy.degrees()")


# Joint readings may pass a limit by a little (limits in data sheets are rounded, encoders
# overshoot); beyond this they are not the robot's (the packaged Panda data come within
# 1.1 deg of the limits, the UR data within 55 deg).
LIMIT_TOLERANCE_DEG = 0.5
LIMIT_TOLERANCE_MM = 0.5


def beyond_limits(chain, joints):
    """(N, n) bool: which of the joint values ``joints`` (N, n, rad or mm) lie beyond
    ``chain``'s limits by more than LIMIT_TOLERANCE_DEG / _MM."""
    tolerance = np.where(chain.revolute, np.radians(LIMIT_TOLERANCE_DEG), LIMIT_TOLERANCE_MM)
    return (joints < chain.lower - tolerance) | (joints > chain.upper + tolerance)


def check_posture_units(chain, values, unit, what, fix):
    """InputError when the joint values ``values`` (n,) of one posture, written in ``unit`` (a
    key of :data:`ANGLE_UNITS`; prismatic joints in mm) as ``what`` (``'p.script, line 3:
    movej'``) gives them, are not in that unit for ``chain``: beyond its limits (the
    measurement reader's, :func:`beyond_limits`), naming the other unit when it brings them all
    within; or, in degrees, looking like radians (the one test of typed angles,
    :func:`check_angles`).  ``fix``: what the file takes and how to convert ('URScript takes
    radians: convert them with d2r()').  Values that are not finite (a partial posture) are
    not judged."""
    values = np.asarray(values, dtype=float)
    revolute = np.asarray(chain.revolute, dtype=bool)
    known = np.isfinite(values)
    if values.shape != (chain.n_joints,) or not known.any():
        return

    def beyond(reading):
        degrees = np.where(revolute & known, values * ANGLE_UNITS[reading], np.where(known, values, 0.0))
        return beyond_limits(chain, chain.joints_from_file(degrees[None]))[0] & known

    outside = beyond(unit)
    if outside.any():
        joint = int(np.flatnonzero(outside)[0])
        shown = ({"degrees": "deg", "radians": "rad"}[unit] if revolute[joint] else "mm")
        limits = chain.joints_to_file(np.vstack([chain.lower, chain.upper]))[:, joint]
        if revolute[joint]:
            limits = limits / ANGLE_UNITS[unit]
        other = next(name for name in ANGLE_UNITS if name != unit)
        looks = (f"they look like {other}; {fix}" if not beyond(other).any() else
                 "fix the posture or the robot file's min and max")
        raise InputError(f"{what}: q{joint + 1} = {values[joint]:.6g} {shown} lies beyond joint {joint + 1}'s limits "
                         f"{limits[0]:.6g} to {limits[1]:.6g} {shown} of the robot '{chain.name}': {looks}")
    if unit == "degrees":
        check_angles(values[revolute & known], f"{what}: the joint values", joints=True, fix=fix)


# Measured orientations of the poses a robot was commanded to (an ISO campaign) lie tenths of
# a degree from their commands.  Measured in radians and read as degrees, they lie tens of
# degrees from them; read as radians, within this (median over the visits of the largest of
# the three angles' differences, deg).
SAME_ANGLES_DEG = 5.0


def check_same_angle_unit(reference, values, what, reference_what):
    """InputError when the angles ``values`` (N, 3, as typed) of ``what`` lie more than
    :data:`SAME_ANGLES_DEG` from ``reference`` (N, 3 deg), the same poses' commanded angles,
    read as degrees, and within it read as radians, :data:`EVIDENCE_RATIO` times nearer: the
    evidence of commanded and measured in one unit (as :func:`check_same_unit` for lengths),
    for radians that :func:`looks_like_radians` cannot tell from small degree values."""
    reference, values = np.asarray(reference, dtype=float), np.asarray(values, dtype=float)
    if len(reference) == 0:
        return

    def miss(angles):
        difference = (angles - reference + 180.0) % 360.0 - 180.0
        return float(np.median(np.abs(difference).max(axis=1)))

    as_degrees, as_radians = miss(values), miss(values * ANGLE_UNITS["radians"])
    if as_degrees > SAME_ANGLES_DEG >= as_radians and as_radians * EVIDENCE_RATIO < as_degrees:
        raise InputError(f"{what} look like radians: read so, they lie {as_radians:.3g} deg from {reference_what} "
                         f"(median), read as degrees {as_degrees:.3g} deg; robocal reads degrees: convert them with "
                         "numpy.degrees()")


def check_typed_units(chain, *, box=None, rpy=None, hint=None, tool=None, tracker=None, region=None, walls=None):
    """InputError in one line when a number typed on the command line is in other units than
    mm and degrees (robocal.io.units: lengths judged by ``chain``'s reach, angles by the one
    test of typed angles): a --box in metres, an --rpy or --hint in radians."""
    for option, values in (("--box", box), ("--region", region), ("--walls", walls)):
        if values is not None:
            check_robot_lengths(chain, values, option)
    for option, values in (("--tool", tool), ("--tracker", tracker)):
        if values is not None:
            check_robot_lengths(chain, values, option, position=True)
    if rpy is not None:
        check_angles(rpy, "the angles of --rpy")
    if hint is not None:
        if len(hint) != chain.n_joints:
            raise InputError(f"--hint gives {len(hint)} joint values, but robot '{chain.name}' has {chain.n_joints} "
                             "joints: give one per joint, in degrees")
        revolute = np.asarray(chain.revolute, dtype=bool)
        check_angles(np.asarray(hint, dtype=float)[revolute], "the joint values of --hint", joints=True)
