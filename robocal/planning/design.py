"""Which poses to measure: :func:`design_poses` chooses ``count`` of the candidate
configurations for a calibration campaign and predicts what they will give.

The default criterion, ``prediction``, minimises the mean squared error of the calibrated
TCP position over the target configurations (the candidates themselves unless the user
names the targets): it aims at what a calibration is for.  It chooses one pose per stratum of
the targets (:func:`robocal.planning.exchange.select_stratified`), so that errors the
calibration cannot model are averaged as the targets will see them.  ``d-optimal`` (log det
of the information of the identifiable, scaled parameters) treats every parameter alike and
beats random poses held out by less.  ``space-filling``
spreads the poses over configuration space, for residual models (Kriging, hybrid, network)
that learn the error as a function of the joints; ``variance`` serves them too, choosing one
pose at a time where a Gaussian-process prior over the joints' sines and cosines is least
certain given the poses before.  See :mod:`robocal.planning.criteria`.

A joint noise (``joint_noise_deg``, deg: gear backlash or play at every joint, which no
calibration models) makes a pose's reading noisier the further the arm reaches
(:func:`robocal.planning.information.joint_covariance`); ``prediction`` then minimises the
sandwich covariance of the least-squares fit at the targets
(:class:`robocal.planning.criteria.SandwichState`), and the predicted held-out error counts
the targets' own joint noise.  A sag (``sag_deg``: how far gravity bends the most loaded
joint) is, for a parameter set without compliances, a systematic error of unknown size that
the fit leaves out (:func:`robocal.planning.information.sag_columns`); ``prediction`` then
also minimises its expected effect at the targets, which favours poses whose sag the
geometry absorbs as the targets' would be, and the prediction counts what remains.  On the
simulated KR 150-2 (0.005 deg backlash, 0.02 mm tracker, gravity compliance) both stated take
designed poses to what an oracle that knows the simulated robot reaches (bench/design.py).

Whatever the criterion, the summary is that of the parametric calibration: the predicted
standard error of each identifiable parameter, O1 and the noise amplification index of the
chosen poses, and the predicted held-out error propagated from the covariance with the
stated noise, beside the median of random selections of the same size.
"""
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..estimation.calibration import parameter_terms
from ..estimation.identifiability import analyse
from .criteria import (CRITERIA, DEFAULT_CRITERION, InformationState, SandwichState, SpacingState, VarianceKernel,
                       VarianceState, check_criterion, information_start)
from .exchange import select, select_stratified, strata
from .information import information_model, joint_covariance, noise_of, sag_columns
from .tour import path_length, tour

# The mean of a 3-D isotropic Gaussian error's length over its RMS: sqrt(8 / (3 pi)).
MEAN_OVER_RMS = float(np.sqrt(8.0 / (3.0 * np.pi)))
# Random selections the summary compares the design with.
RANDOM_DRAWS = 20
# Joints whose motion moves the TCP less than this share of the most moving joint's (over the
# candidates) are left out of the space-filling distance (the last axis with the TCP on it).
STILL_JOINT = 1e-3
# The orders the poses can be written in.
ORDERS = ("tour", "random")
# Targets the prediction criterion averages over at most (a fixed subsample beyond).
MAX_TARGETS = 20_000


@dataclass(frozen=True)
class Design:
    """A chosen set of poses and what it predicts (JSON-ready through :meth:`to_dict`).

    joints: (count, n) rad, in the order to measure them (a short tour); indices: (count,)
    their rows among the candidates; criterion; exchanges: exchange steps after the greedy
    selection; names: the identifiable parameters; std_errors: (P,) predicted standard errors
    (rad, mm, ...; file_units converts to units, as files show them); fixed: {name: reason} for those the candidates
    cannot determine; noise: (mean) standard deviation of a reading, mm; joint_noise_deg: deg at
    every revolute joint (0: none); sag_deg: deg, the gravity bending the parameters leave out
    (0: none, or the parameter set has compliances); model_rms: predicted
    RMS error of the calibrated TCP over the targets (mm, without the reading's own noise);
    held_out_rms / held_out_mean: the same with the noise of a held-out reading added;
    random_model_rms: the median of model_rms over random selections of the same size (None
    when the candidates are too few to draw from); o1, noise_amplification, condition_number:
    of the chosen poses (with those measured before); tour_length / given_length: the
    largest-joint motion along the order written (the tour, or a random order) and along the
    order of choice (deg; mm on prismatic joints); max_variance, variance_prior (``variance``
    only): the largest predictive variance left over the candidates, relative to the process
    variance, and where the prior's hyperparameters came from.
    """

    joints: np.ndarray
    indices: np.ndarray
    criterion: str
    exchanges: int
    names: tuple
    std_errors: np.ndarray
    file_units: np.ndarray
    units: tuple
    fixed: dict
    noise: float
    model_rms: float
    held_out_rms: float
    held_out_mean: float
    random_model_rms: float | None
    o1: float
    noise_amplification: float
    condition_number: float
    tour_length: float
    given_length: float
    n_candidates: int
    n_existing: int
    max_variance: float | None = None
    variance_prior: str | None = None
    joint_noise_deg: float = 0.0
    sag_deg: float = 0.0

    def std_errors_as_files_show(self):
        """{name: {"std_error", "unit"}}: each identifiable parameter's predicted standard error
        in the unit files show it in (deg, mm, ...)."""
        return {n: {"std_error": float(s * f), "unit": u}
                for n, s, f, u in zip(self.names, self.std_errors, self.file_units, self.units)}

    def to_dict(self):
        return {
            "poses": int(len(self.joints)), "candidates": self.n_candidates, "existing": self.n_existing,
            "criterion": self.criterion, "exchanges": self.exchanges, "noise_mm": self.noise,
            "joint_noise_deg": self.joint_noise_deg, "sag_deg": self.sag_deg,
            "predicted": {"model_rms_mm": self.model_rms, "held_out_rms_mm": self.held_out_rms,
                          "held_out_mean_mm": self.held_out_mean, "random_model_rms_mm": self.random_model_rms},
            "o1": self.o1, "noise_amplification": self.noise_amplification,
            "condition_number": self.condition_number,
            "std_errors": self.std_errors_as_files_show(),
            "fixed": dict(self.fixed),
            "tour_deg": self.tour_length, "order_of_choice_deg": self.given_length,
            **({} if self.max_variance is None else {
                "variance": {"max_relative": self.max_variance, "prior": self.variance_prior}}),
        }


def _check_joints(chain, joints, what):
    q = chain.joint_batch(joints)
    if not np.all(np.isfinite(q)):
        row = int(np.flatnonzero(~np.all(np.isfinite(q), axis=1))[0])
        raise InputError(f"{what} {row} has NaN or infinite joint values: remove or fix it")
    return q


def target_weight(info, targets=None):
    """W = mean over the targets of J_t^T J_t (scaled, unweighted), (P, P): the targets'
    configurations (rad), or the candidates when None."""
    if targets is None:
        rows = info.blocks * info.sigma[:, None, None]
    else:
        rows = info.rows_of(targets)
    if len(rows) > MAX_TARGETS:
        rows = rows[np.random.default_rng(0).choice(len(rows), MAX_TARGETS, replace=False)]
    flat = rows.reshape(-1, rows.shape[2])
    return flat.T @ flat / len(rows)


def spacing_points(chain, candidates, others=None):
    """Candidates (and ``others``: poses measured before, or targets) scaled to [0, 1] per
    joint over the candidates' range, the joints that do not move the TCP left out: the
    points of the space-filling criterion and of the strata."""
    moving = np.linalg.norm(chain.rigid.jacobian(candidates)[:, :3, :], axis=1).max(axis=0)
    keep = moving > STILL_JOINT * moving.max()
    low, high = candidates.min(axis=0), candidates.max(axis=0)
    span = np.where(high > low, high - low, 1.0)

    def scaled(q):
        return ((q - low) / span)[:, keep]

    return scaled(candidates), None if others is None else scaled(others)


class _Prediction:
    """The parametric calibration's error at the targets for a set of candidates, and the
    ``prediction`` criterion's state: the information already there (``start``, ``B_start``
    with the joint noise of the poses measured before), the candidates' relative
    covariances ``C`` (None: none), and the sag's shapes (``bias`` (N, 3, k) weighted as the
    blocks, ``r`` (P, k), ``g_start`` of the poses before, ``floor``: the sag's mean squared
    size at the targets), None without one."""

    def __init__(self, info, W, start, B_start, C=None, bias=None, r=None, g_start=None, floor=0.0):
        self.info, self.W, self.start, self.B_start, self.C = info, W, start, B_start, C
        self.bias, self.r, self.g_start, self.floor = bias, r, g_start, floor

    def _C(self):
        return np.broadcast_to(np.eye(3), (len(self.info.blocks), 3, 3)) if self.C is None else self.C

    def state(self):
        if self.C is None and self.bias is None:
            return InformationState(self.info.blocks, self.start, self.W)
        return SandwichState(self.info.blocks, self.start, self.W, self._C(), self.B_start, bias=self.bias, r=self.r,
                             g_start=self.g_start)

    def covariance(self, index):
        """(P, P) the scaled parameters' covariance after the candidates ``index`` (with those
        measured before, counted once in ``start``)."""
        blocks = self.info.blocks[index]
        flat = blocks.reshape(-1, blocks.shape[2])
        inverse = np.linalg.inv(self.start + flat.T @ flat)
        if self.C is None and self.bias is None:
            return inverse
        B = self.B_start + np.einsum("kip,kij,kjq->pq", blocks, self._C()[index], blocks)
        return inverse @ B @ inverse

    def model_rms(self, index):
        """Predicted RMS error of the calibrated TCP over the targets (mm), without the
        readings' own noise: the covariance's, and with a sag the part of it left over."""
        cov = self.covariance(index)
        mse = float(np.sum(self.W * cov))
        if self.bias is not None:
            blocks = self.info.blocks[index]
            g = self.g_start + np.einsum("kip,kim->pm", blocks, self.bias[index])
            flat = blocks.reshape(-1, blocks.shape[2])
            x = np.linalg.solve(self.start + flat.T @ flat, g)
            mse += float(np.sum(x * (self.W @ x)) - 2 * np.sum(x * self.r)) + self.floor
        return float(np.sqrt(max(mse, 0.0)))


def design_poses(chain, count, candidates, *, criterion=DEFAULT_CRITERION, parameters="full", noise=0.02,
                 tracker=None, targets=None, existing=None, payload=None, refine=True, seed=0, order="tour",
                 kernel=None, joint_noise_deg=0.0, sag_deg=0.0, progress=None):
    """Choose ``count`` of ``candidates`` (N, n) rad to measure for a calibration of
    ``parameters`` (a parameter set) and predict the result.

    criterion: ``prediction`` (default), ``d-optimal``, ``space-filling`` or ``variance``
    (module notes); kernel: the ``variance`` criterion's prior (a
    :class:`~robocal.planning.criteria.VarianceKernel`; default its fixed hyperparameters).
    noise: standard deviation of a position reading per coordinate (mm); say here what the
    model will not explain (tracker noise plus the robot's unmodelled errors, e.g. an earlier
    calibration's residual RMS / sqrt(3)) and the predicted errors become held-out figures.
    tracker: its position (mm, robot base frame) when its noise grows with distance.
    joint_noise_deg: standard deviation (deg) of an error at every revolute joint that the
    calibration does not model, gear backlash or play (module notes; 0: none): the
    ``prediction`` criterion and the summary count it, the other criteria choose as
    without it.  sag_deg: how far gravity bends the most loaded joint (deg), for a parameter set
    without compliances (module notes; 0: none; ignored with compliances), counted as the
    joint noise is.  targets: (T, n) rad, where the robot will work (default: the candidates).  existing:
    (k, n) rad poses measured before, which the design complements (the tour starts next to
    the last of them).  refine: exchange after the greedy selection.  seed: the strata's
    k-means start and the random selections the summary compares with.  order: ``tour``
    (short motions) or ``random`` (a seeded shuffle: on a robot with gear backlash a tour
    approaches neighbouring poses from the same side, which biases the calibrated joint
    offsets where a random order averages the play out; see bench/design.py).
    progress: called as ``progress(stage=...)`` as each stage begins (a long design says
    where it is).  Returns a :class:`Design`.
    """
    check_criterion(criterion)
    progress = (lambda **info: None) if progress is None else progress
    q = _check_joints(chain, candidates, "candidate")
    before = None if existing is None or len(existing) == 0 else _check_joints(chain, existing, "measured pose")
    n_before = 0 if before is None else len(before)
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise InputError(f"the number of poses must be a whole number >= 1, got {count!r}")
    if count > len(q):
        raise InputError(f"{count} poses asked for but only {len(q)} candidates: ask for at most {len(q)} poses or "
                         "give more candidates")
    progress(stage=f"the information of {len(q)} candidates")
    info = information_model(chain, q, parameters, noise=noise, tracker=tracker, payload=payload)
    p = info.n_parameters
    if 3 * (count + n_before) < p:
        need = -(-p // 3) - n_before
        raise InputError(f"{count} poses{f' and {n_before} measured before' if n_before else ''} give "
                         f"{3 * (count + n_before)} equations for the {p} parameters the calibration identifies: "
                         f"ask for at least {need} poses (2 to 3 times as many is better), or a smaller parameter set")
    C = joint_covariance(chain, q, info.sigma, joint_noise_deg)
    before_sigma = None if before is None else noise_of(chain, before, noise, tracker)
    before_blocks = None if before is None else info.rows_of(before, before_sigma)
    start = information_start(info.blocks, before_blocks)
    B_start = start
    if C is not None and before is not None:
        excess = joint_covariance(chain, before, before_sigma, joint_noise_deg) - np.eye(3)
        B_start = start + np.einsum("kip,kij,kjq->pq", before_blocks, excess, before_blocks)
    target_q = None if targets is None else _check_joints(chain, targets, "target")
    W = target_weight(info, target_q)
    prediction = _Prediction(info, W, start, B_start, C)
    if "compliance" not in parameter_terms(parameters):
        prediction = _with_sag(prediction, chain, q, before, before_blocks, before_sigma, target_q, sag_deg, payload)
    if criterion == "space-filling":
        points, points_before = spacing_points(chain, q, before)
        state = SpacingState(points, points_before)
    elif criterion == "variance":
        kernel = VarianceKernel.default(chain, q) if kernel is None else kernel
        state = VarianceState(kernel.points(chain, q), kernel, None if before is None else kernel.points(chain, before))
    elif criterion == "prediction":
        state = prediction.state()
    else:
        state = InformationState(info.blocks, start, None)
    available = np.ones(len(q), dtype=bool)
    progress(stage=f"choosing {count} of {len(q)}")
    if criterion == "prediction":
        points, target_points = spacing_points(chain, q, None if targets is None else target_q)
        labels = strata(points, count, seed, target_points)
        chosen, steps = select_stratified(state, count, available, labels, points, refine=refine)
    elif criterion == "variance":
        # Sequential by definition (module notes of .criteria): no exchange.
        chosen, steps = select(state, count, available, refine=False)
    else:
        chosen, steps = select(state, count, available, refine=refine)
    if order not in ORDERS:
        raise InputError(f"order must be one of {', '.join(ORDERS)}, got {order!r}")
    if order == "tour":
        order = tour(q[chosen], None if before is None else before[-1])
    else:
        order = np.random.default_rng(seed).permutation(len(chosen))
    chosen_in_order = chosen[order]
    progress(stage="predicting the result")
    design = _summary(chain, info, q, chosen_in_order, chosen, criterion, steps, prediction, before, before_blocks,
                      seed, joint_noise_deg, target_q)
    design = replace(design, sag_deg=float(sag_deg) if prediction.bias is not None else 0.0)
    if criterion == "variance":
        design = replace(design, max_variance=-state.score, variance_prior=kernel.source)
    return design


def _with_sag(prediction, chain, q, before, before_blocks, before_sigma, target_q, sag_deg, payload):
    """``prediction`` with the sag's shapes (:func:`sag_columns`) for a parameter set that
    leaves it out; as it was when the sag is 0 or no joint is loaded."""
    info = prediction.info
    columns = sag_columns(chain, q, sag_deg, payload=payload)
    if columns is None:
        return prediction
    where = q if target_q is None else target_q
    at_targets = columns if target_q is None else sag_columns(chain, where, sag_deg, reference=q, payload=payload)
    rows = info.blocks * info.sigma[:, None, None] if target_q is None else info.rows_of(target_q)
    r = np.einsum("tip,tim->pm", rows, at_targets) / len(rows)
    floor = float(np.mean(np.sum(at_targets ** 2, axis=(1, 2))))
    g_start = np.zeros((info.n_parameters, columns.shape[2]))
    if before is not None:
        weighted = sag_columns(chain, before, sag_deg, reference=q, payload=payload) / before_sigma[:, None, None]
        g_start = np.einsum("kip,kim->pm", before_blocks, weighted)
    return _Prediction(info, prediction.W, prediction.start, prediction.B_start, prediction.C,
                       bias=columns / info.sigma[:, None, None], r=r, g_start=g_start, floor=floor)


def _summary(chain, info, q, chosen, order_of_choice, criterion, steps, prediction, before, before_blocks, seed,
             joint_noise_deg, target_q):
    C = prediction.C
    p = info.n_parameters
    blocks = info.blocks[chosen]
    flat = (blocks if before_blocks is None else np.concatenate([blocks, before_blocks])).reshape(-1, p)
    # The poses measured before are in the prediction's start (with their joint noise): only
    # the chosen ones are added to it.
    cov = prediction.covariance(chosen)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None)) / info.scale
    report = analyse(info.chain, flat, list(info.names), explain=False)[1]
    model_rms = prediction.model_rms(chosen)
    mean_sigma = float(np.sqrt(np.mean(info.sigma ** 2)))
    # A held-out reading has its own noise: the tracker's, and the joint noise at the targets.
    reading = 3 * mean_sigma ** 2
    if C is not None:
        where = q if target_q is None else target_q
        jac = chain.rigid.jacobian(where)[:, :3, :] * np.where(chain.revolute, 1.0, 0.0)
        reading += np.radians(joint_noise_deg) ** 2 * float(np.mean(np.sum(jac ** 2, axis=(1, 2))))
    held_out = float(np.sqrt(model_rms ** 2 + reading))
    random_rms = None
    count = len(chosen)
    if len(q) > count:
        rng = np.random.default_rng(seed)
        draws = [prediction.model_rms(rng.choice(len(q), count, replace=False)) for _ in range(RANDOM_DRAWS)]
        random_rms = float(np.median(draws))
    start_pose = None if before is None else before[-1]
    return Design(
        joints=q[chosen], indices=chosen, criterion=criterion, exchanges=int(steps), names=info.names,
        std_errors=std, file_units=info.file_units, units=tuple(info.chain.parameters[n].file_unit for n in info.names),
        fixed=info.fixed, noise=float(info.sigma[0] if np.all(info.sigma == info.sigma[0]) else np.mean(info.sigma)),
        model_rms=model_rms, held_out_rms=held_out, held_out_mean=MEAN_OVER_RMS * held_out,
        random_model_rms=random_rms, o1=report.o1, noise_amplification=report.noise_amplification,
        condition_number=report.condition_number,
        tour_length=_degrees(chain, path_length(q[chosen], start=start_pose)),
        given_length=_degrees(chain, path_length(q[order_of_choice], start=start_pose)),
        n_candidates=len(q), n_existing=0 if before is None else len(before), joint_noise_deg=float(joint_noise_deg))


def _degrees(chain, length):
    # The tour is measured in rad on revolute joints (mm on prismatic ones): report degrees
    # when every joint is revolute.
    return float(np.degrees(length)) if np.all(chain.revolute) else float(length)


__all__ = ["CRITERIA", "Design", "design_poses", "spacing_points", "target_weight"]
