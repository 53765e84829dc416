"""The error to expect where the robot will work, from a calibration's posterior.

A parametric calibration leaves each parameter with a posterior: well-seen parameters pinned
by the data, the others held near nominal by their tolerances.  Propagated through the
identification Jacobian at the configurations where the robot will work, plus the residual
that no parameter explains, it predicts the position error there: E = J Σ Jᵀ + s² I per
configuration, with Σ the posterior covariance of every parameter that has a tolerance or
was identified, and s² the residual variance per coordinate.  The registered nominal robot
gets the same prediction with only its base and tool fitted, so a calibration that would do
worse than no calibration where the robot works can be told.

Ball-in-socket data hold no position to miss: what they score is socket consistency, each
ball centre's deviation from its socket's mean.  Its prediction (:func:`socket_prediction`)
puts sockets where the robot will work, reaches each in several postures (:func:`working_sockets`),
and propagates the posterior through how those deviations move with the parameters, plus the
ball's scatter the training shows.  A working socket is reached with the arm varied as the
training varied it and the ball stick tilted and turned at least as robocal's socket plans
do.  A campaign that reached each socket in two similar postures (MUKCa Panda 3, 12 seatings,
the stick turned about itself by at most 36 deg between them) was predicted 0.29 mm when
reached like its own, and missed 1.04 mm on the placements left out, which the protocol
reached with the stick turned by up to 180 deg; tilted and turned at random, 0.85 mm.

How far a robot lies from its drawing is its own: the tolerances are the prior's shape, and
their common scale is the one the calibration estimated from the data (the evidence fixed
point of :func:`~robocal.estimation.least_squares.tolerance_scale_estimate`), so that
directions the poses never saw are expected to deviate as the seen ones did.
"""
from dataclasses import dataclass

import numpy as np

from ..spatial import so3_exp

# At most this many training poses form the posterior (evenly spread; their information is
# scaled up to all poses), and this many uniform configurations stand for the working range.
POSTERIOR_POSES = 2000
WORKING_POSES = 1000
# Draws per configuration for the mean and 95th percentile of the error norm.
DRAWS = 16
# Predicted means closer than this are a tie: a micrometre (as model choice counts held-out
# differences), or 2 % of the nominal's mean, four times the relative standard error of a
# mean of WORKING_POSES x DRAWS drawn norms.
TIE_MM = 1e-3
TIE_FRACTION = 0.02
# Ball-in-socket data: the working range stands as this many sockets, each reached by this
# many configurations (WORKING_POSES in all; the MUKCa units reach a socket about 30 times,
# whose deviations from their mean are sqrt(29/30) / sqrt(9/10), 3 %, larger), within so many
# IK iterations (MUKCa Panda 3: of the reaches that converge within 100, 91 % do within 30;
# about half of all converge, the others ask for a turn beyond the wrist's limits).
SOCKETS = 100
# A working socket is reached with the ball stick tilted from one approach by as much as the
# training tilted it (the 90th percentile; MUKCa Pandas: 42, 46 and 49 deg), and at least as
# much as robocal's socket plans tilt it (planning.sockets.MAX_TILT_DEG), turned about itself
# at random.  Below 90: the ball comes from the socket's side.
REACH_TILT_DEG = 30.0
MAX_REACH_TILT_DEG = 80.0
REACHES = 10
IK_ITERATIONS = 30


@dataclass(frozen=True)
class WorkingRange:
    """Where the robot will work: joints (M, n) rad, and text saying what they are."""

    joints: np.ndarray
    text: str


@dataclass(frozen=True)
class PredictedError:
    """The position error (mm) to expect over a working range.

    mean_mm, p95_mm: the calibrated model's; nominal_mean_mm, nominal_p95_mm: the registered
    nominal robot's; where: what the working range is; poses: its configurations;
    tolerance_scale: the evidence estimate of how far this robot lies from its drawing, in
    tolerances.
    """

    mean_mm: float
    p95_mm: float
    nominal_mean_mm: float
    nominal_p95_mm: float
    where: str
    poses: int
    tolerance_scale: float

    def to_dict(self):
        return {"mean_mm": self.mean_mm, "p95_mm": self.p95_mm, "nominal_mean_mm": self.nominal_mean_mm,
                "nominal_p95_mm": self.nominal_p95_mm, "where": self.where, "poses": self.poses,
                "tolerance_scale": self.tolerance_scale}

    @property
    def worse_than_nominal(self):
        """Whether the model is predicted to miss by more than the registered nominal robot,
        beyond a tie (TIE_MM) and the spread of the drawn means (TIE_FRACTION)."""
        return self.mean_mm - self.nominal_mean_mm > max(TIE_MM, TIE_FRACTION * self.nominal_mean_mm)

    @classmethod
    def of_draws(cls, calibrated, nominal, where, scale):
        """From drawn error norms (M, DRAWS) mm of the model and the registered nominal robot
        over the :class:`WorkingRange` ``where``."""
        return cls(mean_mm=float(np.mean(calibrated)), p95_mm=float(np.percentile(calibrated, 95)),
                   nominal_mean_mm=float(np.mean(nominal)), nominal_p95_mm=float(np.percentile(nominal, 95)),
                   where=where.text, poses=len(where.joints), tolerance_scale=float(scale))


def working_range(chain, targets=None, count=WORKING_POSES, seed=0):
    """The :class:`WorkingRange`: ``targets`` (M, n) rad as given, else ``count`` uniform
    configurations within the joint limits (finite ones; ±180 deg where a limit is open)."""
    if targets is not None:
        return WorkingRange(np.asarray(targets, dtype=float), f"the {len(targets)} given configurations")
    lower = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    upper = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    q = np.random.default_rng(seed).uniform(lower, upper, size=(count, chain.n_joints))
    return WorkingRange(q, f"{count} configurations uniform within the joint limits")


def _rows(chain, joints, names, rows=3):
    """(3M, P) position rows of the identification Jacobian at ``joints``."""
    return chain.identification_jacobian(joints, list(names))[:, :rows, :].reshape(-1, len(names))


def _posterior(information, prior_std, noise):
    """(P, P) posterior covariance from the data's information JᵀJ (mm rows), the noise
    variance per row and the prior standard deviations (inf: none)."""
    precision = information / max(noise, 1e-300)
    finite = np.isfinite(prior_std)
    precision[finite, finite] += 1.0 / prior_std[finite] ** 2
    return np.linalg.pinv(precision, hermitian=True)


def error_draws(jacobian, cov, noise, count, seed):
    """(count, 3, DRAWS) mm: errors drawn from N(0, J Σ Jᵀ + noise I) per configuration, for
    ``jacobian`` (3 count, P) rows, ``cov`` (P, P) and ``noise`` mm² per coordinate."""
    j = jacobian.reshape(count, 3, -1)
    e_cov = j @ cov @ np.swapaxes(j, 1, 2) + noise * np.eye(3)
    w, v = np.linalg.eigh(e_cov)
    root = v * np.sqrt(np.clip(w, 0.0, None))[:, None, :]
    z = np.random.default_rng(seed).standard_normal((count, 3, DRAWS))
    return root @ z


def error_norms(jacobian, cov, noise, count, seed):
    """(count * DRAWS,) norms of errors drawn from N(0, J Σ Jᵀ + noise I) per configuration."""
    return error_norms_per_pose(jacobian, cov, noise, count, seed).reshape(-1)


def error_norms_per_pose(jacobian, cov, noise, count, seed):
    """(count, DRAWS) norms of errors drawn from N(0, J Σ Jᵀ + noise I) per configuration."""
    return np.linalg.norm(error_draws(jacobian, cov, noise, count, seed), axis=1)


def predicted_draws(chain, train_joints, residual, names, prior_std, *, identified, scale=1.0, frame_names=(),
                    work_joints=None, seed=0, vectors=False):
    """Drawn error norms over the working range: ((M, DRAWS) mm of the calibrated model, the
    same of the registered nominal robot, the :class:`WorkingRange`); with ``vectors`` the
    drawn errors themselves, (M, 3, DRAWS) mm.

    chain: the calibrated chain; train_joints: (N, n) rad; residual: (N, 3) mm its training
    residual; names: every parameter with a tolerance or identified; prior_std: (P,) their
    tolerances (inf: none), and ``scale`` the fit's estimate of how many tolerances this robot
    lies from its drawing (:func:`~robocal.estimation.least_squares.tolerance_scale_estimate`);
    identified: how many of them the fit identified (the residual's degrees of freedom);
    frame_names: those that are base and tool (the registered nominal fits only them);
    work_joints: (M, n) where the robot will work (default: :func:`working_range`).
    """
    names = list(names)
    prior_std = np.asarray(prior_std, dtype=float)
    q = np.asarray(train_joints, dtype=float)
    pick = np.linspace(0, len(q) - 1, min(len(q), POSTERIOR_POSES)).astype(int)
    jac = _rows(chain, q[pick], names)
    information = jac.T @ jac * (len(q) / len(pick))
    noise = float(np.sum(np.asarray(residual) ** 2)) / max(3 * len(q) - identified, 1)
    cov = _posterior(information.copy(), prior_std * scale, noise)
    where = working_range(chain, work_joints)
    work_jac = _rows(chain, where.joints, names)
    draws = error_draws if vectors else error_norms_per_pose
    calibrated = draws(work_jac, cov, noise, len(where.joints), seed)
    # The registered nominal robot: only base and tool fitted, every other parameter at its prior.
    frame = np.array([n in frame_names for n in names])
    nominal_info = np.where(np.outer(frame, frame), information, 0.0)
    nominal_cov = _posterior(nominal_info, np.where(frame, np.inf, prior_std * scale), noise)
    nominal = draws(work_jac, nominal_cov, noise, len(where.joints), seed)
    return calibrated, nominal, where


def _posterior_names(calibration, joints):
    """(names, (P,) tolerances) of what a fitted calibration's posterior covers: the
    parameters it identified, then those it held fixed that have a tolerance (at nominal:
    on poses that do not see them their prior is all there is)."""
    from ..kinematics.tolerances import prior_sigmas, tolerances_of

    result, start = calibration.result_, calibration.start_chain_
    tolerances = tolerances_of(start, getattr(calibration, "tolerance_scale", 1.0))
    names = list(result.names) + [n for n in result.identifiability.fixed if n in start.parameters]
    prior_std = prior_sigmas(start, names, tolerances, joints)
    keep = np.isfinite(prior_std) | (np.arange(len(names)) < len(result.names))
    return [n for n, k in zip(names, keep) if k], prior_std[keep]


def prediction_draws(calibration, joints, positions, work_joints=None, seed=0, vectors=False):
    """:func:`predicted_draws` of a fitted
    :class:`~robocal.estimation.calibration.KinematicCalibration` on its training data
    ``joints`` (N, n) rad and ``positions`` (N, 3) mm: its identified parameters and, at
    their nominal values, those it held fixed that have a tolerance."""

    result = calibration.result_
    start = calibration.start_chain_
    names, prior_std = _posterior_names(calibration, joints)
    frames = [n for n in names if start.parameters[n].group in ("base", "tool")]
    residual = np.asarray(positions, dtype=float) - calibration.chain_.fk_positions(joints)
    return predicted_draws(calibration.chain_, joints, residual, names, prior_std, identified=len(result.names),
                           scale=result.tolerance_scale, frame_names=frames, work_joints=work_joints, seed=seed,
                           vectors=vectors)


def calibration_prediction(calibration, joints, positions, work_joints=None, seed=0):
    """The :class:`PredictedError` of a fitted kinematic calibration (:func:`prediction_draws`)."""
    calibrated, nominal, where = prediction_draws(calibration, joints, positions, work_joints, seed)
    return PredictedError.of_draws(calibrated, nominal, where, calibration.result_.tolerance_scale)


def socket_prediction(calibration, data, work_joints=None, seed=0):
    """The :class:`PredictedError` of a fitted
    :class:`~robocal.estimation.constraint.ConstraintCalibration` as ball-in-socket data
    score it where the robot will work: each ball centre's deviation from its socket's mean,
    at sockets spread over the working range, each reached in several postures
    (:func:`working_sockets`).

    data: the training :class:`~robocal.estimation.constraint.data.SocketData`; work_joints:
    (M, n) rad, configurations that put the ball where sockets will be (default: uniform
    within the joint limits, :func:`working_range`).  The posterior comes from the constraint
    rows (spanning pairs) with the tolerances at the scale the fit estimated, propagated
    through the deviation Jacobian of those sockets' configurations; the ball's own scatter
    is drawn from the training deviations' lengths, in directions uniform on the sphere.
    Where no working socket can be reached (IK fails everywhere), the training
    configurations stand for them.
    """
    from .constraint.data import constraint_pairs, pair_weights
    from .constraint.estimator import constraint_rows
    from .constraint.metrics import deviation_jacobian, grouped_socket_errors

    result = calibration.result_
    chain = calibration.chain_
    names, prior_std = _posterior_names(calibration, data.joints)
    spanning = constraint_pairs(data, "spanning")
    residual, jac = constraint_rows(chain, data.joints, spanning, names, pair_weights(spanning))
    noise = float(residual @ residual) / max(len(residual) - len(result.names), 1)
    cov = _posterior(jac.T @ jac, prior_std * result.tolerance_scale, noise)
    nominal_cov = _posterior(np.zeros_like(cov), prior_std * result.tolerance_scale, noise)
    shared = np.bincount(data.group)[data.group] > 1
    deviations = grouped_socket_errors(chain, data, per_placement=True)[3][shared]
    lengths = np.linalg.norm(deviations, axis=1)
    sockets, where = working_sockets(chain.rigid, data, work_joints, seed)
    # Each configuration's ball centre minus its socket's mean, as a linear map of the deviations.
    deviation = deviation_jacobian(chain, sockets, names)
    count = len(deviation)
    deviation = deviation.reshape(-1, len(names))
    scatter = _scatter_draws(lengths, count, seed)
    calibrated = np.linalg.norm(error_draws(deviation, cov, 0.0, count, seed) + scatter, axis=1).reshape(-1)
    nominal = np.linalg.norm(error_draws(deviation, nominal_cov, 0.0, count, seed) + scatter, axis=1).reshape(-1)
    return PredictedError.of_draws(calibrated, nominal, where, result.tolerance_scale)


def working_sockets(chain, data, work_joints=None, seed=0, sockets=SOCKETS, reaches=REACHES):
    """Sockets where the robot will work, each reached by several configurations: ((a
    :class:`~robocal.estimation.constraint.data.SocketData` of them, one placement), the
    :class:`WorkingRange` of their configurations).

    chain: a rigid chain; data: the training SocketData (what stands for the working range
    when no socket can be reached); work_joints: (M, n) rad, configurations putting the ball
    where sockets will be (at most ``sockets`` of them, evenly picked), else ``sockets``
    uniform within the joint limits.  Each socket's configuration is joined by ``reaches`` - 1
    others: the ball at the same centre with the stick tilted from the first by up to the
    training's tilt (:func:`training_tilt`, at least REACH_TILT_DEG) and turned about itself
    at random, solved by the numerical IK (within the limits) from the first configuration
    plus a training offset from its socket's mean joint vector, so the arm varies as the
    training varied it; those it does not reach are dropped, and sockets left with one
    configuration too.  No socket left: the training data and their configurations.
    """
    from ..kinematics.ik import solve_numeric
    from .constraint.data import SocketData

    if work_joints is not None:
        work_joints = np.asarray(work_joints, dtype=float)
        work_joints = work_joints[np.linspace(0, len(work_joints) - 1, min(len(work_joints), sockets)).astype(int)]
    centres = working_range(chain, work_joints, count=sockets, seed=seed)
    q0 = centres.joints
    others = reaches - 1
    targets = np.repeat(chain.fk(q0), others, axis=0)
    tilt = min(MAX_REACH_TILT_DEG, max(REACH_TILT_DEG, training_tilt(chain, data)))
    targets[:, :3, :3] = _reach_orientations(targets[:, :3, :3], np.random.default_rng([seed, 2]), tilt)
    sizes = np.bincount(data.group)
    means = np.stack([np.bincount(data.group, weights=data.joints[:, c]) for c in range(chain.n_joints)],
                     axis=1) / sizes[:, None]
    offsets = (data.joints - means[data.group])[sizes[data.group] > 1]
    if not len(offsets):
        offsets = np.zeros((1, chain.n_joints))
    rng = np.random.default_rng(seed)
    seeds = (q0[:, None, :] + offsets[rng.integers(0, len(offsets), size=(len(q0), others))]).reshape(-1, q0.shape[1])
    reached = solve_numeric(chain, targets, seeds, max_iterations=IK_ITERATIONS)
    joints = np.concatenate([q0, reached.q])
    group = np.concatenate([np.arange(len(q0)), np.repeat(np.arange(len(q0)), others)])
    kept = np.concatenate([np.ones(len(q0), dtype=bool), reached.success])
    joints, group = joints[kept], group[kept]
    kept = np.bincount(group, minlength=len(q0))[group] > 1
    if not kept.any():
        shared = np.bincount(data.group)[data.group] > 1
        return data, WorkingRange(data.joints[shared], f"the {int(shared.sum())} training configurations' sockets "
                                                       "(no socket of the working range could be reached)")
    _, group = np.unique(group[kept], return_inverse=True)
    zeros = np.zeros(int(kept.sum()), dtype=int)
    found = SocketData(joints[kept], ("working range",), zeros, zeros, group.reshape(-1), data.fixture)
    return found, WorkingRange(found.joints, f"{len(found.joints)} configurations reaching {found.group.max() + 1} "
                                             f"sockets (up to {reaches} each, the stick tilted up to {tilt:.0f} deg "
                                             f"and turned) where {centres.text} put the ball")


def training_tilt(chain, data, percentile=90):
    """How far (deg) the training tilted the ball stick: the ``percentile`` of each
    configuration's tool z axis from its socket's mean axis, over sockets reached more than
    once (0 if none)."""
    axes = chain.fk(data.joints)[:, :3, 2]
    sizes = np.bincount(data.group)
    mean = np.stack([np.bincount(data.group, weights=axes[:, c]) for c in range(3)], axis=1)
    mean /= np.maximum(np.linalg.norm(mean, axis=1, keepdims=True), 1e-12)
    shared = sizes[data.group] > 1
    if not shared.any():
        return 0.0
    cosine = np.einsum("ij,ij->i", axes[shared], mean[data.group[shared]])
    return float(np.percentile(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))), percentile))


def _reach_orientations(rotations, rng, max_tilt_deg=REACH_TILT_DEG):
    """(K, 3, 3) ball-stick orientations reaching the same socket as ``rotations`` (K, 3, 3)
    do: the tool z axis tilted about a random axis across it by up to ``max_tilt_deg``
    (uniform over the cap of directions) and turned about itself at random."""
    count = len(rotations)
    angle = rng.uniform(-np.pi, np.pi, count)
    across = np.column_stack([np.cos(angle), np.sin(angle), np.zeros(count)])
    axis = np.einsum("kij,kj->ki", rotations, across)
    tilt = np.arccos(1.0 - rng.uniform(0.0, 1.0, count) * (1.0 - np.cos(np.radians(max_tilt_deg))))
    spin = np.column_stack([np.zeros((count, 2)), rng.uniform(-np.pi, np.pi, count)])
    return so3_exp(axis * tilt[:, None]) @ rotations @ so3_exp(spin)


def _scatter_draws(lengths, count, seed):
    """(count, 3, DRAWS) mm: the ball's scatter, the training deviations' ``lengths`` (K,) mm
    drawn at random, each in a direction uniform on the sphere."""
    rng = np.random.default_rng([seed, 1])
    direction = rng.standard_normal((count, 3, DRAWS))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    if not len(lengths):
        return 0.0 * direction
    return direction * rng.choice(lengths, size=(count, 1, DRAWS))
