"""The one data check every method meets before it fits: can these be this robot's data, in
these units?

Methods that calibrate the robot's parameters (kinematic, hybrid, constraint, the network on
a kinematic base) answer it in their own fit: a maximum a posteriori calibration refuses data
it can explain only by moving the robot far beyond its tolerances, or not at all
(:func:`robocal.estimation.identification.implausible_fit`).  Error models (Kriging, the
network over the nominal robot) would fit another robot's errors as happily as this one's,
so they meet the same test here: a calibration of the ``full`` set (``offsets`` on too few
poses for it) under the tolerances, whose refusal is theirs.  Its verdict is the only thing
kept; the error model is fitted to the data as given.
"""
import warnings

import numpy as np

from ..errors import InputError, RobocalWarning
from ..io.units import reach_mm
from .calibration import KinematicCalibration, OutlierError, OutlierWarning, candidate_parameters

# The check fits at most this many poses, evenly spread over the file: the verdict of a few
# thousand poses is that of all of them, at a bounded cost.
CHECK_POSES = 2000
# Equations per parameter below which the check fits the joint offsets only.
EQUATIONS_PER_PARAMETER = 3


# No robot is measured this close to its nominal model on every pose (mm): its deviations
# from the robot file, and the instrument's noise, are each ten times larger.  Closer, the
# positions were computed from the joints (targets, a plan), written to a few decimals.
NOMINAL_GAP_MM = 0.01


# A measured position repeated exactly on rows where the nominal robot's TCP lies this far
# apart (mm) did not follow the robot: no instrument reads the same point to every written
# decimal for poses that far apart (repeat visits of one pose lie micrometres apart).
STUCK_MM = 10.0


# Poses a calibration fits must spread over more than a point: the nominal TCP at least this
# share of the robot's reach (RMS distance about the poses' centre).  The shipped datasets
# spread 0.24 to 0.41 (UR5, UR10 A, B, D), and the least spread of 2000 random 12-pose draws
# of each is 0.15.  Poses within +-0.5 deg of one posture spread 0.003 (a UR5), +-2 deg 0.012,
# +-5 deg 0.03: below this share the joints barely move and no model is determined.  Above
# it, a cluster (+-5 deg: a re-registration in a corner of the cell) is fitted, and its
# predicted error and domain say how far it holds (robocal.methods.expectation, domain).
CLUSTER_SHARE = 0.01
# Fewer distinct poses than this are left to the fit's own count of equations.
CLUSTER_JUDGED_POSES = 3


def check_spread(chain, observations):
    """InputError, in one line, when the poses of ``observations`` (positions) are clustered:
    the nominal TCP spreads less than :data:`CLUSTER_SHARE` of ``chain``'s reach over them, so
    no fit can determine the model from them.  Only fits meet it: a model may be scored on a
    cluster (``evaluate``), and a design may add poses to one (``--existing``)."""
    if observations.positions is None:
        return
    if len(np.unique(np.round(observations.joints, 9), axis=0)) < CLUSTER_JUDGED_POSES:
        return
    tcp = chain.fk_positions(observations.joints)
    spread = float(np.sqrt(np.mean(np.sum((tcp - tcp.mean(axis=0)) ** 2, axis=1))))
    reach = reach_mm(chain)
    if spread >= CLUSTER_SHARE * reach:
        return
    moved = float(np.degrees(np.ptp(observations.joints[:, np.asarray(chain.revolute, dtype=bool)], axis=0).max(
        initial=0.0)))
    raise InputError(f"{observations.path or 'the data'}: its {observations.n_poses} poses are clustered (no joint "
                     f"moves more than {moved:.3g} deg; the TCP spreads {spread:.3g} mm about their centre) and cannot "
                     f"determine the model of '{chain.name}': measure poses spread over the workspace, the TCP at "
                     f"least {CLUSTER_SHARE * reach:.0f} mm about their centre ({CLUSTER_SHARE:.0%} of the "
                     f"{reach:.0f} mm reach), each joint over tens of degrees")


def check_measured(chain, observations, *, fitting=True):
    """InputError, in one line, when every measured position of ``observations`` is
    ``chain``'s own forward kinematics of its joints, within :data:`NOMINAL_GAP_MM`: the file
    holds targets or a plan computed from the nominal robot, not measurements; when a
    position is repeated exactly on rows whose poses lie :data:`STUCK_MM` apart (a column
    filled down, an instrument that lost its target); and, when ``fitting``, when the poses
    are clustered (:func:`check_spread`).  Ball-in-socket data (no positions) pass."""
    if observations.positions is None or observations.n_poses == 0:
        return
    check_positions_follow_the_robot(chain, observations)
    gap = np.linalg.norm(chain.fk_positions(observations.joints) - observations.positions, axis=1).max()
    if gap < NOMINAL_GAP_MM:
        raise InputError(f"{observations.path or 'the data'}: its positions are the nominal robot's own forward "
                         f"kinematics of its joints (within {gap:.2g} mm on every row): targets or a plan, not "
                         "measurements; measure these poses and give the measured x, y, z (mm)")
    if fitting:
        check_spread(chain, observations)


def check_robot_data(chain, observations, prior="tolerances", tolerance_scale=1.0, *, fitting=True):
    """InputError, in one line, when ``observations`` (positions) cannot be ``chain``'s data in
    mm and degrees, judged against the tolerances times ``tolerance_scale``; rows that do not
    fit the rest are named as the user's file lines.  ``prior`` 'none' skips the check; data
    too few for even the offsets pass unchecked (nothing can be judged from them).  Returns
    the calibration that judged them (fitted to at most CHECK_POSES of them), or None.
    Positions the robot's own forward kinematics computed are :func:`check_measured`'s to
    refuse, after the fit has checked what it is given.  ``fitting`` (data about to be fitted,
    not scored): clustered poses are refused first (:func:`check_spread`), whatever ``prior``."""
    if observations.positions is None:
        return None
    # Positions stuck while the robot moves are named as such, before they are judged as
    # another robot's (which they would look like).
    check_positions_follow_the_robot(chain, observations)
    if fitting:
        check_spread(chain, observations)
    if prior == "none":
        return None
    count = observations.n_poses
    pick = np.linspace(0, count - 1, min(count, CHECK_POSES)).astype(int)
    joints, positions = observations.joints[pick], observations.positions[pick]
    sigmas = None if observations.sigmas is None else observations.sigmas[pick]
    for parameters in ("full", "offsets"):
        calibration = KinematicCalibration(parameters, tolerance_scale=tolerance_scale)
        needed = len(candidate_parameters(chain, parameters)) * EQUATIONS_PER_PARAMETER
        if 3 * len(np.unique(np.round(joints, 9), axis=0)) >= needed:
            break
    else:
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RobocalWarning)
            warnings.simplefilter("ignore", OutlierWarning)
            calibration.fit(chain, joints, positions, sigmas=sigmas)
    except OutlierError as error:
        named = str(error.naming(np.asarray(observations.rows)[pick], observations.path))
        raise InputError(named.split("; fix or remove")[0] + ": they are not this robot's positions in mm; fix or "
                         "remove them") from None
    calibration.fitted_poses_ = pick
    return calibration


def check_model_data(model, observations, where):
    """The one check of data given to a fitted model (``evaluate``, ``report``): InputError,
    in one line, when ``observations`` are not data the model ``model`` (a
    :class:`~robocal.io.model_file.ModelFile` read from ``where``) can be scored on: measured
    positions for a model calibrated on ball-in-socket data (which has no measurement frame
    to compare them in), or data that cannot be its robot's (:func:`check_robot_data`, under
    the prior and tolerance scale the model was calibrated with)."""
    if model.training.get("kind") == "constraint" and observations.positions is not None:
        raise InputError(f"{where} was calibrated on ball-in-socket data, which give it no measurement frame, and "
                         f"{observations.path} holds measured positions (x, y, z): score it on ball-in-socket data "
                         "(fixture, socket columns), or calibrate a model on the positions")
    options = model.options or {}
    check_robot_data(model.nominal, observations, options.get("prior", "tolerances"),
                     options.get("tolerance_scale", 1.0), fitting=False)
    check_measured(model.nominal, observations, fitting=False)


def check_positions_follow_the_robot(chain, observations):
    """Before any fit (every method's, the robot-data check's): InputError naming the rows
    whose measured x, y, z repeat an earlier row's exactly while the nominal robot puts their
    TCPs :data:`STUCK_MM` or more apart."""
    if observations.positions is None or observations.n_poses < 2:
        return
    _, inverse, counts = np.unique(observations.positions, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    if counts.max() == 1:
        return
    model = chain.fk_positions(observations.joints)
    rows = np.asarray(observations.rows)
    stuck, first, apart = [], None, 0.0
    for group in np.flatnonzero(counts > 1):
        members = np.flatnonzero(inverse == group)
        distance = float(np.linalg.norm(model[members] - model[members[0]], axis=1).max())
        if distance >= STUCK_MM:
            stuck += list(members[1:])
            if first is None or members[0] < first:
                first, apart = members[0], distance
    if not stuck:
        return
    lines = [str(int(line)) for line in rows[np.sort(stuck)]]
    named = f"rows {', '.join(lines[:5])}" + (f" and {len(lines) - 5} more" if len(lines) > 5 else "") \
        if len(lines) > 1 else f"row {lines[0]}"
    raise InputError(f"{observations.path or 'the data'} {named}: the same measured x, y, z as an earlier row "
                     f"(row {int(rows[first])}) for poses whose TCPs lie up to {apart:.0f} mm apart: the positions do "
                     "not follow the robot (a column filled down, an instrument that lost its target?); give those "
                     "rows their measured x, y, z or remove them")
