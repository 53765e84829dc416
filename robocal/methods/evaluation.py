"""Scoring a fitted method on observations: the position error beside the registered
nominal's, or on ball-in-socket data the socket consistency beside the nominal robot's.
``evaluate`` and the report both use these, so their figures agree."""
import warnings
from dataclasses import replace

import numpy as np

from ..errors import InputError, RobocalWarning
from ..estimation.constraint import socket_deviations, socket_errors
from ..estimation.metrics import error_stats
from ..io.fixtures import fixture_from_dict
from .socket_bound import socket_bound_scores

# A calibrated model that still misses by this much is almost certainly the wrong robot,
# wrong units or a different measurement frame.
SUSPICIOUS_RESIDUAL_MM = 20.0
SOCKET_METRIC = "socket consistency: distance of each ball centre from the mean of its socket group"


def position_residuals(fitted, observations):
    """(before, after), each (N, 3) mm: measured minus the registered nominal robot, and
    measured minus the fitted method's prediction."""
    if observations.positions is None:
        raise InputError(f"{observations.path or 'the data'} has no x, y, z columns: measured positions are "
                         "needed to score the position error")
    q = observations.joints
    return observations.positions - fitted.reference_.fk_positions(q), observations.positions - fitted.predict(q)


def orientation_stats(poses, rotations):
    """``rot_mean_deg``, ``rot_rms_deg``, ``rot_max_deg``: the angle (deg) of the rotation
    between each modelled TCP orientation (``poses`` (N, 4, 4)) and the measured one
    (``rotations`` (N, 3, 3)), over the poses."""
    relative = np.einsum("nji,njk->nik", np.asarray(poses)[:, :3, :3], np.asarray(rotations, dtype=float))
    cosine = np.clip((np.trace(relative, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.degrees(np.arccos(cosine))
    return {"rot_mean_deg": float(angle.mean()), "rot_rms_deg": float(np.sqrt(np.mean(angle ** 2))),
            "rot_max_deg": float(angle.max())}


def position_scores(fitted, observations, robot_name):
    """(before, after, statistics): :func:`error_stats` of the method's error with the
    nominal's under ``nominal``; warns when the error is too large to be this robot's data."""
    before, after = position_residuals(fitted, observations)
    stats = {**error_stats(after).to_dict(), "nominal": error_stats(before).to_dict()}
    if observations.rotations is not None:
        q = observations.joints
        stats.update(orientation_stats(fitted.compensator_.chain.fk(q), observations.rotations))
        stats["nominal"].update(orientation_stats(fitted.reference_.fk(q), observations.rotations))
    if stats["mean_mm"] > SUSPICIOUS_RESIDUAL_MM:
        warnings.warn(RobocalWarning(
            f"the residual is {stats['mean_mm']:.1f} mm mean after calibration: is {observations.path} "
            f"from robot '{robot_name}', in mm and degrees, in the frame the model was fitted in?"), stacklevel=2)
    return before, after, stats


def with_fixture(fitted, observations, model_path):
    """Ball-in-socket ``observations`` with a fixture: their own, or the one the model keeps."""
    if observations.placement is None:
        raise InputError(f"{observations.path} has no fixture and socket columns")
    if observations.fixture is not None:
        return observations
    if fitted.record_.fixture is None:
        raise InputError(f"{observations.path} is ball-in-socket data and {model_path} stores no fixture: "
                         "give --fixture FIX.toml")
    return replace(observations, fixture=fixture_from_dict(fitted.record_.fixture, model_path))


def socket_scores(fitted, observations):
    """Socket consistency and socket-distance errors (:func:`socket_errors`) of the fitted
    model's kinematics, with the nominal robot's under ``nominal``; warns, as
    :func:`position_scores` does, when they are too large to be this robot's data."""
    obs = observations
    args = (obs.joints, obs.placement, obs.socket, obs.fixture)
    after = socket_errors(fitted.compensator_.chain, *args)
    # Either figure gives the wrong robot away: the ball centres of one socket scatter, or
    # the sockets come out at other distances than the fixture's.
    worst = max(after.get("mean_mm", 0.0), after["socket_distance"].get("mean_mm", 0.0))
    if worst > SUSPICIOUS_RESIDUAL_MM:
        warnings.warn(RobocalWarning(
            f"the socket consistency is {after.get('mean_mm', 0.0):.1f} mm mean (socket distances off by "
            f"{after['socket_distance'].get('mean_mm', 0.0):.1f} mm) after calibration: is {obs.path or 'the data'} "
            f"from robot '{fitted.reference_.name}', with joint values in degrees, and is the fixture "
            f"'{obs.fixture.name}' the one it was measured on?"), stacklevel=2)
    # The share of configurations within the model's 95 % bound of the socket consistency.
    bound = socket_bound_scores(fitted, obs)
    for off in (bound.get("bound95") or {}).get("placements_off", []):
        warnings.warn(RobocalWarning(
            f"fixture placement {off['placement']}: {off['within_share']:.0%} of its configurations lie within their "
            f"95 % bound (median deviation {off['median_error_mm']:.3g} mm, bound {off['median_bound_mm']:.3g} mm): "
            "its seatings are not what the model expects there; check that placement (ball and socket clean, "
            "fixture clamped) and measure it again"), stacklevel=2)
    return {"metric": SOCKET_METRIC, **after, "nominal": socket_errors(fitted.reference_, *args), **bound}


def socket_residuals(fitted, observations):
    """(before, after, ball centres), each (N, 3) mm: each ball centre's deviation from its
    socket group's mean for the nominal and the fitted model, and the fitted ball centres."""
    obs = observations
    args = (obs.joints, obs.placement, obs.socket, obs.fixture)
    before, _ = socket_deviations(fitted.reference_, *args)
    after, centres = socket_deviations(fitted.compensator_.chain, *args)
    return before, after, centres
