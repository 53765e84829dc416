"""The error to expect where the robot will work, for every method (``calibrate`` reports it,
keeps it in the model file, and refuses a model predicted to do worse than no calibration).

Every fitted method has a parametric anchor, a calibration under the tolerances: its own
(kinematic; the hybrid's and a kinematic-based network's base), else the one the data check
made (:mod:`robocal.estimation.plausibility`).  Its posterior, propagated to the working range
(:mod:`robocal.estimation.prediction`), predicts the error of the calibrated and of the
registered nominal robot at each configuration there.  A method with an error model is
judged inside its training domain by its own held-out errors (k folds, the Kriging's
hyperparameters kept), and outside it against the anchor's posterior: the robot is drawn
from it there, and the model's error is the distance to what the model predicts, its
fallback (the anchor's calibrated model if it has one, else the nominal robot) plus what the
error model still adds there, a Kriging's extrapolated trend or a network's output.  Taken
as its fallback alone, a Kriging from 40 UR5 poses where only joint 1 moved was predicted as
good as the registered nominal robot (3.08 mm) and missed by 61.0 mm (now 60.9 predicted);
from 40 poses moving joint 1 over its range and joints 2 and 3 by ±40 deg, it now misses
7.74 mm and is predicted 7.32 (tests/test_predicted_error.py).
"""

import warnings

import numpy as np

from ..errors import InputError, RobocalWarning
from ..estimation.prediction import PredictedError, error_norms, prediction_draws, working_range

# Folds of the held-out estimate inside the training domain (methods that refit at fixed
# hyperparameters; a method that trains from scratch, the network, uses FEW_FOLDS).
FOLDS = 5
FEW_FOLDS = 2


def expected_error(method, chain, observations, work_joints=None, seed=0):
    """The :class:`~robocal.estimation.prediction.PredictedError` of a fitted ``method`` on
    its training ``observations`` over ``work_joints`` (M, n) rad (default: uniform in the
    joint limits).  For ball-in-socket data, the socket consistency the calibration predicts
    at sockets where ``work_joints`` put the ball, each reached as the training sockets are
    (:func:`~robocal.estimation.prediction.socket_prediction`); None when there is nothing to
    predict from."""
    if observations.positions is None:
        return _socket_error(method, observations, work_joints, seed)
    if getattr(method, "frames_posterior_", None) is not None:
        return reregistered_error(method, work_joints, seed)
    anchor = getattr(method, "calibration_", None)
    own = anchor is not None and hasattr(anchor.result_, "orientation_rms_deg")  # a position calibration
    if not own:
        anchor = getattr(method, "data_check_", None)
    if anchor is None:
        from ..estimation.plausibility import check_robot_data

        anchor = check_robot_data(chain, observations, "tolerances", getattr(method, "tolerance_scale", 1.0))
    if anchor is None:
        return None  # too few poses to judge anything
    calibrated, nominal, where = prediction_draws(anchor, observations.joints, observations.positions, work_joints,
                                                  seed=seed, vectors=True)
    if method.compensator_.error_model is not None:
        work = where.joints
        inside = method.domain_.check(work).inside if getattr(method, "domain_", None) is not None \
            else np.zeros(len(work), dtype=bool)
        errors = held_out_errors(method, chain, observations, seed=seed)
        drawn = np.random.default_rng(seed).choice(errors, size=(len(work), calibrated.shape[-1]))
        drawn[~inside] = _errors_outside(method, anchor, work[~inside], calibrated[~inside])
        calibrated = drawn
    else:
        calibrated = np.linalg.norm(calibrated, axis=1)
    return PredictedError.of_draws(calibrated, np.linalg.norm(nominal, axis=1), where,
                                   getattr(anchor.result_, "tolerance_scale", 1.0))


def _errors_outside(method, anchor, joints, deviations):
    """(M, DRAWS) mm: the model's error at ``joints`` (M, n) rad outside its domain, the
    robot being drawn from the anchor's posterior there (its calibrated chain plus
    ``deviations`` (M, 3, DRAWS) mm drawn from it) and the model's positions being what it
    predicts: its fallback's, plus what the error model still adds there."""
    if not len(joints):
        return np.zeros(deviations.shape[::2])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobocalWarning)  # its own extrapolation warning: the fit shows it once
        predicted = np.nan_to_num(np.asarray(method.predict(joints), dtype=float))
    robot = anchor.chain_.fk_positions(joints)[:, :, None] + deviations
    return np.linalg.norm(robot - predicted[:, :, None], axis=1)


def _socket_error(method, observations, work_joints, seed):
    """The constraint calibration's predicted socket consistency over ``work_joints`` (M, n)
    rad (default: uniform in the joint limits), or None."""
    calibration = getattr(method, "calibration_", None)
    if calibration is None or observations.placement is None or observations.fixture is None:
        return None
    from ..estimation.constraint.data import socket_data
    from ..estimation.prediction import socket_prediction

    data = socket_data(calibration.start_chain_, observations.joints, observations.placement, observations.socket,
                       observations.fixture)
    return socket_prediction(calibration, data, work_joints, seed)


def reregistered_error(method, work_joints=None, seed=0):
    """The :class:`PredictedError` of a re-registered model: how loosely its few poses pin
    base and tool (their posterior propagated to the working range) on top of the error the
    model had before it moved (its own prediction, else its training residual), against the
    registered nominal robot's on the same poses."""
    names, cov, own = method.frames_posterior_
    chain = method.compensator_.chain
    before = method.record_.predicted_error or {}
    nominal = before.get("nominal_mean_mm", (method.record_.residual_before or {}).get("rms_mm", 0.0)
                         * np.sqrt(8 / np.pi / 3)) / np.sqrt(8 / np.pi)
    where = working_range(chain, work_joints)
    jac = chain.identification_jacobian(where.joints, list(names))[:, :3, :].reshape(-1, len(names))
    moved = error_norms(jac, cov, own ** 2, len(where.joints), seed)
    registered = error_norms(jac, cov, nominal ** 2, len(where.joints), seed)
    return PredictedError.of_draws(moved, registered, where, before.get("tolerance_scale", 1.0))


def held_out_errors(method, chain, observations, seed=0):
    """(N,) mm: each training pose's error under the method fitted without it, over k random
    folds of the selection engine (:func:`~robocal.methods.splits.random_split`,
    :func:`~robocal.methods.scoring.fold_errors`: :meth:`refit` when the method has one, the
    hyperparameters kept)."""
    from .scoring import fold_errors
    from .splits import random_split

    count = observations.n_poses
    folds = FOLDS if getattr(method, "refit", None) is not None else FEW_FOLDS
    if count < 2 * folds:
        raise InputError(f"{count} poses are too few to estimate the held-out error with {folds} folds")
    return fold_errors(method, chain, observations, random_split(count, folds, seed))


# What answers outside the training domain of an error model predicted worse than the nominal
# robot there: the rigid kinematic calibration, auto's fallback when no region split can tell
# whether the compliance carries (robocal.methods.selection.outside_choice), with the
# parameters of the calibration its prediction is anchored on (the data check's: "offsets"
# below some 35 poses), so that what answers is what the prediction drew the robot from.
OUTSIDE_FALLBACK = "full"


def fall_back_outside_if_worse(method, chain, observations, predicted, seed=0):
    """The :class:`PredictedError` of what will answer: ``method`` itself, or, when it has an
    error model that is predicted (``predicted``) to do worse over the working range than the
    registered nominal robot, ``method`` answering outside its training domain with the rigid
    kinematic calibration (:func:`~robocal.methods.fallback.wrap`, changed in place, with a
    warning) if that is not predicted worse.

    Outside their poses an error model extrapolates (a Kriging its trend, a network its
    output): trained on a random half of UR5 Tsinghua, whose poses cover a corner of the joint
    space, the Kriging was predicted to miss by 4.6 mm over the joint range and the network (20
    generations) by 5.4, the registered nominal robot by 3.2; with the fallback 0.165
    (bench/shipped_data.py).  At those configurations on a simulated UR5 they missed 3.5 to
    8.6 mm alone and 0.17 with the fallback (bench/predicted_error.py).
    """
    from . import make_method
    from .fallback import DomainFallback, wrap

    if (predicted is None or not predicted.worse_than_nominal or getattr(method, "domain_", None) is None
            or method.compensator_.error_model is None or isinstance(method.compensator_, DomainFallback)):
        return predicted
    anchor = getattr(method, "data_check_", None)
    parameters = getattr(anchor, "parameters", OUTSIDE_FALLBACK) if anchor is not None else OUTSIDE_FALLBACK
    if parameters not in ("full", "offsets"):
        parameters = OUTSIDE_FALLBACK
    try:
        fallback = make_method("kinematic", parameters=parameters).fit(chain, observations)
    except InputError:
        return predicted  # too few poses for it: the refusal stands
    alone = method.compensator_
    label = f"kinematic {parameters}"
    wrap(method, fallback, label)
    answered = expected_error(method, chain, observations, seed=seed)
    if answered is None or answered.worse_than_nominal:
        method.compensator_ = alone
        return predicted
    warnings.warn(RobocalWarning(
        f"outside its training domain this {method.name} model was predicted to miss by {predicted.mean_mm:.3g} mm "
        f"on average over {predicted.where}, worse than the registered nominal robot ({predicted.nominal_mean_mm:.3g} "
        f"mm): the {label} calibration answers there ({answered.mean_mm:.3g} mm predicted in all); "
        "--accept-extrapolation keeps the model's own extrapolation"), stacklevel=2)
    return answered


def refuse_if_worse_than_nominal(predicted, domain=None):
    """InputError in one line when ``predicted`` says the model does worse than the registered
    nominal robot over the working range: what the poses cover, and where to measure."""
    if predicted is None or not predicted.worse_than_nominal:
        return
    covers = ""
    if domain is not None:
        low, high = np.degrees(domain.joint_min), np.degrees(domain.joint_max)
        spans = ", ".join(f"q{k + 1} {lo:.0f}..{hi:.0f}" for k, (lo, hi) in enumerate(zip(low, high)))
        covers = f" the poses cover {spans} deg;"
    raise InputError(
        f"this model is predicted to miss by {predicted.mean_mm:.3g} mm on average over {predicted.where}, worse "
        f"than the registered nominal robot ({predicted.nominal_mean_mm:.3g} mm):{covers} measure poses where the "
        "robot will work (robocal design ROBOT --existing DATA adds them), or accept the extrapolation with "
        "--accept-extrapolation")
