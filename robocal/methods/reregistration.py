"""Re-registration: a calibrated model carried to a new set-up (the tracker moved, the tool
changed) by re-identifying only its frames from a few poses.

Everything the model identified is kept — link parameters, joint compliance, joint gains,
the error model — and only the base (measurement frame → robot base) and the TCP position
in the flange frame are identified again, optionally with the joint offsets
(``parameters="frames+offsets"``, after a robot was re-mastered).  The tool orientation
joins them when the data carry orientations and the model was calibrated with them:
positions alone do not see it (turning the tool about the TCP moves no TCP).

The estimator (:mod:`robocal.estimation.reregistration`) fits the frames to what the whole
model predicts, its error model moved with the frame (:class:`ReframedErrorModel`); this
module is the method around it: the checks, the auto model's pair and its choice of what
answers outside the domain, the domain and the record.
"""
from __future__ import annotations

import copy
import dataclasses
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..compensation import Compensator
from ..errors import FileFormatError, InputError, RobocalWarning
from ..estimation.calibration import IMPLAUSIBLE_ANGLE_DEG, IMPLAUSIBLE_REACH_FRACTION
from ..estimation.identifiability import IdentifiabilityReport
from ..estimation.identification import BASE, TOOL_POSITION, identify, tolerance_prior
from ..estimation.metrics import error_stats
from ..estimation.registration import kabsch, register_base_and_tool
from ..io.model_file import robot_hash
from ..settings import Choice, Setting
from ..spatial import make_transform, pose_to_xyz_rpy, so3_log
from ..estimation.reregistration import FrameProblem, ReframedErrorModel  # noqa: F401  (ReframedErrorModel: for callers)
from .fallback import DomainFallback
from .reframed import is_reframed, reframed_document, reframed_from_document  # noqa: F401
from ..estimation.plausibility import check_robot_data

# calibrate MODEL.json NEW.csv --method frames: a model file re-registered on a new set-up.
FRAMES = "frames"
PARAMETER_CHOICES = ("frames", "frames+offsets")
# Re-registration's one setting (calibrate --method frames --parameters ...).
FRAME_PARAMETERS = Setting("parameters", "frames", "--parameters",
                           "frames (base and tool) or frames+offsets (and the joint offsets)",
                           Choice(PARAMETER_CHOICES))
TOOL_ORIENTATION = ("tool_rx", "tool_ry", "tool_rz")
# Row weights when the data carry no standard deviations: the kinematic calibration's
# defaults, so that orientation rows weigh against position rows as they did in the fit
# that made the model (0.02 mm and 0.01 deg).
POSITION_SIGMA_MM = 0.02
ORIENTATION_SIGMA_DEG = 0.01
# Twice as many equations as parameters: the residual then has as many degrees of freedom
# as the fit has parameters, enough for the residual check below to mean something (15
# poses give 45 equations for base and tool; the issue asks for 10-25 poses).
EQUATIONS_PER_PARAMETER = 2
# The Kabsch start needs three points off a line; a fourth checks them.
MIN_POSES = 4
# A re-registered model that misses the new poses by more than this many times the RMS it
# had on its training data (and by more than RESIDUAL_FLOOR_MM, below which tracker noise
# and the usual spread between set-ups dominate) no longer describes the robot: warn.
RESIDUAL_FACTOR = 3.0
RESIDUAL_FLOOR_MM = 0.5
MAX_ITERATIONS = 50


# ------------------------------------------------------------------ the record
@dataclass(frozen=True)
class ReregistrationRecord:
    """What a re-registration did (file units: mm and degrees; JSON-ready by :meth:`to_dict`).

    parameters: 'frames' or 'frames+offsets'; poses: how many; rows: their file rows;
    orientations_used: whether orientation rows were fitted; frame: T, old measurement frame
    → new (4x4, mm); tracker_shift_mm, tracker_turn_deg: its translation and rotation angle;
    base, tool: the new frames as {"xyz": mm, "rpy": deg}; tool_change_mm: new minus old TCP
    position in the flange frame; offset_changes: {name: change} of the joint offsets
    identified (deg; mm for a prismatic joint); std_errors: {name: standard error} of the
    identified parameters (mm, deg);
    identifiability: the :class:`IdentifiabilityReport` (rank, condition number, and in
    ``fixed`` what could not be identified and why); residual_before: the model as it stood
    on these poses; residual_after: the re-registered model; residual_reference: the nominal
    robot registered to them; training_rms_mm: the model's kinematic RMS on its training data
    (what residual_after is judged against); iterations, converged; warnings: the warnings
    given, as text.
    """

    parameters: str
    poses: int
    rows: tuple
    orientations_used: bool
    frame: tuple
    tracker_shift_mm: float
    tracker_turn_deg: float
    base: dict
    tool: dict
    tool_change_mm: tuple
    offset_changes: dict
    std_errors: dict
    identifiability: IdentifiabilityReport
    residual_before: dict
    residual_after: dict
    residual_reference: dict
    training_rms_mm: float | None
    iterations: int
    converged: bool
    warnings: tuple = field(default=())
    # An auto model's choice of what answers outside its domain on the new set-up
    # (reregister): {answers_outside, alternative, poses, rms_mm: {label: mm or None}}.
    outside_choice: dict | None = None

    def to_dict(self):
        return {"parameters": self.parameters, "poses": self.poses, "rows": list(self.rows),
                "orientations_used": self.orientations_used, "frame": [list(r) for r in self.frame],
                "tracker_shift_mm": self.tracker_shift_mm, "tracker_turn_deg": self.tracker_turn_deg,
                "base": self.base, "tool": self.tool, "tool_change_mm": list(self.tool_change_mm),
                "offset_changes": dict(self.offset_changes), "std_errors": dict(self.std_errors),
                "identifiability": self.identifiability.to_dict(), "residual_before": self.residual_before,
                "residual_after": self.residual_after, "residual_reference": self.residual_reference,
                "training_rms_mm": self.training_rms_mm, "iterations": self.iterations,
                "converged": self.converged, "warnings": list(self.warnings),
                **({} if self.outside_choice is None else {"outside_choice": self.outside_choice})}

    @classmethod
    def from_dict(cls, doc):
        """The record back from :meth:`to_dict`; FileFormatError, in one line, if damaged."""
        try:
            ident = dict(doc["identifiability"])
            report = IdentifiabilityReport(
                identified=tuple(ident["identified"]), fixed=dict(ident["fixed"]), rank=int(ident["rank"]),
                rows=int(ident["rows"]), condition_number=float(ident["condition_number"]), o1=float(ident["o1"]),
                o3=float(ident["o3"]), noise_amplification=float(ident["noise_amplification"]))
            rms = doc["training_rms_mm"]
            return cls(
                parameters=str(doc["parameters"]), poses=int(doc["poses"]), rows=tuple(int(r) for r in doc["rows"]),
                orientations_used=bool(doc["orientations_used"]),
                frame=tuple(tuple(float(v) for v in row) for row in doc["frame"]),
                tracker_shift_mm=float(doc["tracker_shift_mm"]), tracker_turn_deg=float(doc["tracker_turn_deg"]),
                base=dict(doc["base"]), tool=dict(doc["tool"]),
                tool_change_mm=tuple(float(v) for v in doc["tool_change_mm"]),
                offset_changes={str(k): float(v) for k, v in doc["offset_changes"].items()},
                std_errors={str(k): float(v) for k, v in doc["std_errors"].items()}, identifiability=report,
                residual_before=dict(doc["residual_before"]), residual_after=dict(doc["residual_after"]),
                residual_reference=dict(doc["residual_reference"]),
                training_rms_mm=None if rms is None else float(rms), iterations=int(doc["iterations"]),
                converged=bool(doc["converged"]), warnings=tuple(str(w) for w in doc.get("warnings", ())),
                outside_choice=None if doc.get("outside_choice") is None else dict(doc["outside_choice"]))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise FileFormatError(f"the re-registration record is damaged ({type(exc).__name__}: {exc}); "
                                  "regenerate the model file") from None


# ---------------------------------------------------------------- the function
def reregister(fitted, observations, parameters="frames", *, robot=None):
    """The fitted method carried to the set-up of ``observations``: its frames identified
    again from them, everything else kept.

    A model of ``calibrate --method auto`` that keeps an alternative to its fallback (the
    other of the rigid and the compliant kinematic calibrations, ``outside_alternative_``)
    is re-registered with each; the one whose re-registered model misses the new poses it
    answers for least answers outside the domain, the other stays the alternative.  Both
    refit the same frames on the same poses, so their residuals there compare fairly: the
    new set-up is the only evidence of what carries to it (a compliance identified on one
    set-up absorbs what was particular to it: ipa UR10 series B's does not carry to A).

    Parameters
    ----------
    fitted : Method
        A fitted position method (kinematic, kriging, hybrid, ann, ...); it is not changed.
    observations : Observations
        Measured TCP positions (and orientations) of the same robot on the new set-up, in
        its measurement frame (mm, rad); 10 to 25 poses spread over the workspace suffice.
    parameters : str
        'frames' (base and TCP position; the tool orientation too when the data and the
        model have orientations) or 'frames+offsets' (the joint offsets as well, those the
        frames do not absorb).
    robot : Chain, optional
        The robot ``observations`` were read for; refused if it is not the model's.

    Returns
    -------
    A new fitted method of the same class, its attributes copied, with ``compensator_`` on
    the re-registered chain and the error model moved to the new frame
    (:class:`ReframedErrorModel`), ``reference_`` the nominal robot registered to the poses
    (the "before" in the new set-up), and ``reregistration_`` a :class:`ReregistrationRecord`.

    Raises InputError for socket data or models, another robot, too few poses, frames the
    poses cannot determine, or poses that cannot be this robot's in mm and degrees (the data
    check of :mod:`robocal.estimation.plausibility`); warns (RobocalWarning) for a tool change
    beyond a tenth of the reach, joint offsets moved by more than 10 deg, and a residual far
    above the model's training one.
    """
    alternative = getattr(fitted, "outside_alternative_", None)
    if alternative is None or not isinstance(fitted.compensator_, DomainFallback):
        return _reregister(fitted, observations, parameters, robot)
    fallback = fitted.compensator_
    swapped = copy.copy(fitted)
    swapped.compensator_ = dataclasses.replace(fallback, outside=alternative[1], label=alternative[0])
    pair, said = [], []
    for model in (fitted, swapped):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            pair.append(_reregister(model, observations, parameters, robot))
        said.append(caught)
    misses = [_outside_rms(model, observations) for model in pair]
    # Keep the fallback unless the new poses it answers for show the alternative better.
    pick = 1 if misses[0] is not None and misses[1] < misses[0] else 0
    for note in said[pick]:
        # The chosen pair's warnings only, once each.
        warnings.warn_explicit(note.message, note.category, note.filename, note.lineno)
    chosen, other = pair[pick], pair[1 - pick]
    chosen.outside_alternative_ = (other.compensator_.label, other.compensator_.outside)
    labels = (fallback.label, alternative[0])
    choice = {"answers_outside": labels[pick], "alternative": labels[1 - pick],
              "poses": 0 if misses[0] is None else int(np.count_nonzero(
                  fitted.compensator_.outside_mask(observations.joints))),
              "rms_mm": {label: miss for label, miss in zip(labels, misses)}}
    chosen.reregistration_ = dataclasses.replace(chosen.reregistration_, outside_choice=choice)
    chosen.record_ = fitted.record_.replace(reregistration=chosen.reregistration_.to_dict())
    return chosen


def _outside_rms(moved, observations):
    """RMS (mm) of the re-registered ``moved`` model's error on the poses of
    ``observations`` its fallback answers for, or None when it answers for none."""
    outside = moved.compensator_.outside_mask(observations.joints)
    if not outside.any():
        return None
    error = observations.positions[outside] - moved.predict(observations.joints[outside])
    return float(np.sqrt(np.mean(np.sum(error ** 2, axis=1))))


def _reregister(fitted, observations, parameters, robot):
    """:func:`reregister` of one model (with its fallback, if it has one)."""
    compensator = _check_model(fitted, robot)
    FRAME_PARAMETERS.check(parameters)
    q, positions = _check_data(observations, compensator.chain)
    training = fitted.record_.calibration
    use_rotations = (observations.rotations is not None and training is not None
                     and training.orientation_rms_deg is not None)
    rotations = observations.rotations if use_rotations else None
    old = compensator.chain
    candidates = list(BASE) + list(TOOL_POSITION) + (list(TOOL_ORIENTATION) if use_rotations else [])
    if parameters == "frames+offsets":
        candidates += [old.rigid.offset_parameter(k) for k in range(old.n_joints)]
    _require_poses(q, len(candidates), 6 if use_rotations else 3, observations.path)

    # The one data check every method meets: can these be this robot's poses, in mm and degrees?
    check_robot_data(compensator.controller if compensator.controller is not None else compensator.nominal,
                     observations)
    problem = FrameProblem(compensator, q, positions, rotations, _weights(observations, use_rotations),
                           max_iterations=MAX_ITERATIONS)
    before = error_stats(positions - fitted.predict(q))
    # The tracker may have moved by metres and turned by anything: a rigid fit of the model's
    # positions onto the measured ones starts the Gauss-Newton steps near the answer.
    turn, shift = kabsch(old.fk_positions(q), positions)
    start = old.replace(base=make_transform(turn, shift) @ old.base)
    prior = tolerance_prior(start, candidates, q, "tolerances", 1.0,
                            lambda chain, names: chain.parameter_values(names) - start.parameter_values(names))
    found = identify(start, candidates, **problem.steps(prior), prior=prior)
    chain = found.chain
    _refuse_undetermined(found.report, candidates)

    error_model = problem.moved_error_model(chain)
    reference = register_base_and_tool(compensator.controller if compensator.controller is not None
                                       else compensator.nominal, q, positions)[0]
    new = copy.copy(fitted)
    new.compensator_ = Compensator(chain, error_model, nominal=reference, error_input=compensator.error_input,
                                   controller=compensator.controller, reference=reference)
    if problem.fallback is not None:
        # The pair moves together (calibrate --method auto): the fallback with the same frames.
        moved = problem.moved_fallback(chain)
        new.compensator_ = DomainFallback(new.compensator_, Compensator(
            moved, None, nominal=moved.rigid, controller=compensator.controller, reference=reference),
            compensator.domain, compensator.label)
    new.reference_ = reference
    domain = getattr(fitted, "domain_", None)
    if domain is not None and getattr(domain, "box_min", None) is not None:
        new.domain_ = _moved_box(domain, problem.frame(chain))
    after = error_stats(positions - new.predict(q))
    training_rms = _training_rms(fitted.record_)
    new.frames_posterior_ = _frames_posterior(fitted, found, after)
    if getattr(new, "domain_", None) is not None:
        # The domain follows: where the few poses pin the frames more loosely than the model's
        # own error, the model is not what answers there.
        names, covariance, own = new.frames_posterior_
        new.domain_ = dataclasses.replace(new.domain_, frames=(names, covariance, own * np.sqrt(3.0)))
    if problem.fallback is not None and getattr(new, "domain_", None) is not None:
        # The pair decides by the domain the model now has.
        new.compensator_ = dataclasses.replace(new.compensator_, domain=new.domain_)
        after = error_stats(positions - new.predict(q))
    notes = _warnings(old, chain, q, found.names, after.rms_mm, training_rms)
    for note in notes:
        warnings.warn(note, RobocalWarning, stacklevel=2)
    new.reregistration_ = _record(parameters, observations, use_rotations, problem, old, chain, found,
                                  before, after, error_stats(positions - reference.fk_positions(q)),
                                  training_rms, notes)
    new.record_ = fitted.record_.replace(reregistration=new.reregistration_.to_dict())
    return new


def _frames_posterior(fitted, found, after):
    """(names, covariance (mm, rad), the model's own error per axis, mm) of a re-registration's
    frames.  The frames were fitted through the model's own errors as well as the tracker's
    noise: on poses that cover little those errors are systematic and the frames take them up,
    so their covariance is that of the larger of the two (the fit's residual per axis, or the
    model's own error before it moved: its predicted error, else its training residual)."""
    before = fitted.record_.predicted_error or {}
    training = fitted.record_.residual_after_training or {}
    # E|e| of an isotropic 3-D Gaussian of sigma s per axis is s * sqrt(8 / pi).
    own = before.get("mean_mm", training.get("rms_mm", 0.0) * np.sqrt(8 / np.pi / 3)) / np.sqrt(8 / np.pi)
    residual = (after.rms_mm or 0.0) ** 2 / 3.0
    covariance = found.covariance * max(1.0, own ** 2 / max(residual, 1e-300))
    return tuple(found.names), covariance, float(own)


def _moved_box(domain, frame):
    """The domain with its training box (axis-aligned, old measurement frame) carried to the new
    frame: the box around its eight corners moved, which holds every training position."""
    corners = np.array(np.meshgrid(*zip(domain.box_min, domain.box_max), indexing="ij")).reshape(3, -1).T
    moved = corners @ frame[:3, :3].T + frame[:3, 3]
    return dataclasses.replace(domain, box_min=moved.min(axis=0), box_max=moved.max(axis=0))


def _check_model(fitted, robot):
    """The fitted method's compensator, or InputError for what cannot be re-registered."""
    compensator = getattr(fitted, "compensator_", None)
    if compensator is None:
        raise InputError("the model is not fitted: fit it (or load its model file) before re-registering it")
    if getattr(fitted, "data_kind", "position") != "position":
        raise InputError(f"a {fitted.name} model is calibrated from ball-in-socket data, which have no measurement "
                         "frame to move: re-registration is for models of measured TCP positions")
    controller = compensator.controller if compensator.controller is not None else compensator.nominal
    if robot is not None and controller is not None and robot_hash(robot) != robot_hash(controller):
        raise InputError(f"the model belongs to robot '{controller.name}' (hash {robot_hash(controller)}), the data "
                         f"to '{robot.name}' (hash {robot_hash(robot)}): re-register the model of this robot")
    return compensator


def _check_data(observations, chain):
    """(joints (N, n), positions (N, 3)) of the new poses, or InputError."""
    where = getattr(observations, "path", "") or "the data"
    if getattr(observations, "positions", None) is None:
        raise InputError(f"{where} has no x, y, z columns (ball-in-socket data?): re-registration is for measured "
                         "TCP positions in the new set-up's measurement frame")
    q, positions = observations.joints, observations.positions
    if q.shape[1] != chain.n_joints:
        raise InputError(f"{where} has {q.shape[1]} joint columns for the {chain.n_joints}-joint robot "
                         f"'{chain.name}': these data are not of this model's robot")
    arrays = [q, positions] + [a for a in (observations.rotations, observations.sigmas) if a is not None]
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise InputError(f"{where} contains NaN or infinite values: remove or fix those poses")
    return q, positions


def _require_poses(q, count, rows, where):
    """InputError unless the distinct poses give EQUATIONS_PER_PARAMETER equations per parameter."""
    distinct = len(np.unique(np.round(q, 9), axis=0))
    need = max(MIN_POSES, int(np.ceil(EQUATIONS_PER_PARAMETER * count / rows)))
    if distinct < need:
        raise InputError(f"{where or 'the data'} holds {distinct} distinct pose(s): re-registering {count} parameters "
                         f"needs at least {need} poses spread over the workspace; measure more")


def _weights(observations, orientations):
    """(N, 3 or 6) row weights, 1/sigma: the data's sigmas, else the calibration's defaults."""
    count = observations.n_poses
    sigmas = observations.sigmas if observations.sigmas is not None else np.full((count, 3), POSITION_SIGMA_MM)
    if np.any(sigmas <= 0):
        raise InputError("standard deviations (sx, sy, sz) must be > 0")
    w = 1.0 / sigmas
    if orientations:
        w = np.hstack([w, np.full((count, 3), 1.0 / np.radians(ORIENTATION_SIGMA_DEG))])
    return w


def _refuse_undetermined(report, candidates):
    """InputError naming the frame parameters the poses do not determine (joint offsets the
    frames absorb are only reported: the model keeps its own)."""
    frames = [n for n in candidates if n in report.fixed and n.startswith(("base_", "tool_"))]
    if frames:
        reasons = "; ".join(report.fixed[n] for n in frames)
        raise InputError(f"these poses do not determine {', '.join(frames)} ({reasons}): measure poses that move "
                         "every joint, spread over the workspace")


def _training_rms(record):
    """The RMS (mm) of the model's kinematics on its training data: the calibrated chain's for a
    calibration, the registered nominal's for a model of the nominal's error; None if unknown."""
    stats = record.calibration.residual_after if record.calibration is not None else record.residual_before
    return None if not stats or "rms_mm" not in stats else float(stats["rms_mm"])


def _warnings(old, chain, q, names, rms, training_rms):
    """The texts of what looks implausible: a tool change beyond a tenth of the reach, joint
    offsets moved beyond IMPLAUSIBLE_ANGLE_DEG, a residual far above the training one."""
    notes = []
    reach = float(np.linalg.norm(old.rigid.replace(base=np.eye(4)).fk_positions(q), axis=1).max())
    change = float(np.linalg.norm(chain.tool[:3, 3] - old.tool[:3, 3]))
    if change > IMPLAUSIBLE_REACH_FRACTION * reach:
        notes.append(f"the TCP moved by {change:.0f} mm on the flange, more than {IMPLAUSIBLE_REACH_FRACTION:.0%} of "
                     f"the {reach:.0f} mm reach: if the tool was not changed that much, these poses are not of this "
                     "set-up")
    offsets = [n for n in names if old.parameters[n].group == "link"]
    moved = chain.parameter_values(offsets) - old.parameter_values(offsets)
    limit = np.radians(IMPLAUSIBLE_ANGLE_DEG)
    far = [f"{n} by {np.degrees(v):.1f} deg" for n, v in zip(offsets, moved) if abs(v) > limit]
    if far:
        notes.append(f"the joint offsets moved ({', '.join(far)}): a re-mastering does not move them that far; "
                     "check the joint readings")
    if training_rms is not None and rms > max(RESIDUAL_FACTOR * training_rms, RESIDUAL_FLOOR_MM):
        notes.append(f"the re-registered model misses these poses by {rms:.2f} mm RMS where its kinematics fitted the "
                     f"training data within {training_rms:.2f} mm: the robot may have changed (a collision, a repair, "
                     "another payload) or the poses lie where the model was not trained; recalibrate if it matters")
    return notes


def _xyz_rpy(transform):
    xyz, rpy = pose_to_xyz_rpy(transform)
    return {"xyz": np.asarray(xyz, float).tolist(), "rpy": np.degrees(rpy).tolist()}


def _record(parameters, observations, orientations, problem, old, chain, found, before, after, reference_stats,
            training_rms, notes):
    frame = problem.frame(chain)
    offsets = [n for n in found.names if chain.parameters[n].group == "link"]
    moved = chain.parameter_values(offsets) - old.parameter_values(offsets)
    units = chain.parameters.file_units(list(found.names))
    return ReregistrationRecord(
        parameters=parameters, poses=observations.n_poses, rows=tuple(int(r) for r in observations.rows),
        orientations_used=orientations, frame=tuple(tuple(float(v) for v in row) for row in frame),
        tracker_shift_mm=float(np.linalg.norm(frame[:3, 3])),
        tracker_turn_deg=float(np.degrees(np.linalg.norm(so3_log(frame[:3, :3])))),
        base=_xyz_rpy(chain.base), tool=_xyz_rpy(chain.tool),
        tool_change_mm=tuple(float(v) for v in chain.tool[:3, 3] - old.tool[:3, 3]),
        offset_changes={n: float(v * u) for n, v, u in zip(offsets, moved, chain.parameters.file_units(offsets))},
        std_errors={n: float(s * u) for n, s, u in zip(found.names, found.std_errors, units)},
        identifiability=found.report, residual_before=before.to_dict(), residual_after=after.to_dict(),
        residual_reference=reference_stats.to_dict(), training_rms_mm=training_rms, iterations=found.iterations,
        converged=found.converged, warnings=tuple(notes))
