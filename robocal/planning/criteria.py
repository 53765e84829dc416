"""Design criteria as states that a selection adds poses to and removes poses from, each
step judged for every candidate at once.

Parametric calibration (:class:`InformationState`): the chosen poses' information matrix
M = R + sum A_i^T A_i (R a small ridge, plus the poses already measured) and its inverse
P = M^-1, the covariance of the scaled parameters.  A pose's block A_i is 3 x P, so adding or
removing one is a rank-3 change, done by the Woodbury identity:

    S = I_3 + s A P A^T,  P' = P - s P A^T S^-1 A P        (s = +1 add, -1 remove)
    log det M' = log det M + log det S
    trace(W P') = trace(W P) - s trace(S^-1 A P W P A^T)

which for all N candidates is two (3N x P) @ (P x P) products and a batch of 3 x 3 solves:
no Python loop over candidates.  (The change a step accepts is applied to M and P = M^-1
recomputed, one P x P inverse.)

* ``prediction`` (I-optimality, the default): minimise trace(W P), the mean squared error
  of the predicted TCP positions over a set of target configurations, W = mean of
  J_t^T J_t.  This is the goal of a calibration: the error where the robot will work, not
  the parameters themselves; it weighs a parameter by how much it moves the TCP at the
  targets, and a combination the targets never see costs nothing.
* ``d-optimal``: maximise log det M (FIGAROH's and most of the literature's choice): the
  volume of the parameters' confidence ellipsoid, with every scaled parameter equally
  important.  Held out it beats random poses by less than ``prediction`` (15 poses: KR 150-2
  12 % against 14 %, UR5 19 % against 26 %; bench/design.py).

With a joint noise (:func:`robocal.planning.information.joint_covariance`: an error at
every joint that the model does not explain, gear backlash first) a pose's reading is no
longer equally noisy in every direction nor at every pose: its covariance relative to the
weights is C_i = I + (b / sigma_i)^2 J_q J_q^T (J_q the TCP's position Jacobian in the
joints), large where the arm reaches out.  The calibration still fits by (weighted) least
squares, so its covariance is the sandwich P B P with B = R + sum A_i^T C_i A_i (the ridge R
counted as a prior of matching covariance, so that B = M without joint noise), and
``prediction`` minimises trace(W P B P) (:class:`SandwichState`).  Adding or removing pose i
(s = +1 or -1; U = A P, S = I + s U A^T, D = S^-1, K = U W U^T, L = U W P B U^T,
G = U B U^T, all 3 x 3 per candidate):

    trace(W P'B'P') = trace(W P B P) + s tr(C K) - 2s tr(D L) - 2s tr(D K C (S - I))
                      + tr(D K D G) + s tr(D K D (S - I) C (S - I))

three more (3N x P) @ (P x P) products than ``prediction`` without joint noise.  With a
systematic error b_i per pose that the parameters do not model (``bias``), the estimate moves
by x = P g, g = sum A_i^T b_i, and the criterion adds x^T W x - 2 x^T r (r = mean over the
targets of J_t^T b_t); a pose changes x by U^T z, z = s D (b_i - A_i x) (recursive least
squares).  The error may be known (the simulated truth's unmodelled part, which
bench/design.py's bound knows and a design does not) or a sum of k shapes b_i^(m) with
independent unit-variance amplitudes of unknown sign, such as the gravity sag that a
parameter set without compliances leaves out (:func:`robocal.planning.information.sag_columns`):
the expected criterion then adds the same terms summed over the shapes (bias (N, 3, k)).

Residual models (Kriging, hybrid, network) learn a function over the configurations, so
their design is ``space-filling`` (:class:`SpacingState`): minimise the Morris–Mitchell
sum of d_ij^-p over the pairs of chosen configurations (p = SPACING_POWER; maximin distance
as p grows), in joint space scaled to [0, 1] per joint.  Adding or removing a pose changes
the sum by its own row of distances, so both are exact and vectorised.

A residual model can also be designed by ``variance`` (:class:`VarianceState`): a Gaussian
process prior over the joints' sines and cosines (the ``sincos`` inputs of robocal's
joint-space Kriging, :class:`~robocal.estimation.joint_kriging.JointFeatures`) and, one pose
at a time, the candidate where its predictive variance given the poses chosen so far (and
those measured before) is largest.  Conditioning on one more pose i is a rank-one update of
every candidate's variance,

    u = (k(., i) - U^T U[:, i]) / sqrt(v_i + nugget),  v <- v - u^2,  U <- [U; u],

(U the rows of the earlier updates: a pivoted Cholesky factor), one correlation column and
one (k x N) product per step.  The choice is sequential, without exchange: a removal would
need a downdate, and the greedy choice already bounds the largest variance left (it is
farthest-point sampling in the kernel's metric).

Every state exposes ``score`` (larger is better), ``gains_of_adding(mask)`` (N,),
``gains_of_removing()`` (one per removable chosen pose), ``add(i)`` and ``remove(i)``
(:class:`VarianceState` only the first three).
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..estimation.joint_kriging import JointFeatures, moving_joints
from ..estimation.kriging import correlation_from_squared

CRITERIA = ("prediction", "d-optimal", "space-filling", "variance")
DEFAULT_CRITERION = "prediction"
# The ridge that makes M invertible before the design has P poses, relative to the
# information of one average pose: small enough to vanish once the parameters are
# determined (1e-6 of a pose), large enough to keep P finite in double precision.
RIDGE = 1e-6
# Morris–Mitchell exponent of the space-filling criterion.
SPACING_POWER = 10
# The variance criterion's fixed hyperparameters when no measured data give them: theta =
# VARIANCE_THETA / d on inputs standardised over the candidates (Kriging's own starting
# value: a correlation of about 1/e between typical pairs of points) and a nugget (noise
# variance relative to the process variance) of VARIANCE_NUGGET, a tracker's 0.02 mm against
# residual errors of about 0.1 mm.
VARIANCE_THETA = 0.5
VARIANCE_NUGGET = 0.04


def check_criterion(criterion):
    if criterion not in CRITERIA:
        raise InputError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    return criterion


def woodbury(P, blocks, sign, W=None):
    """For each block A (K, 3, P): (log det S, trace(S^-1 A P W P A^T) or None, S^-1, A P)."""
    AP = (blocks.reshape(-1, P.shape[0]) @ P).reshape(blocks.shape)
    S = np.eye(3) + sign * np.einsum("kip,kjp->kij", AP, blocks)
    sign_det, logdet = np.linalg.slogdet(S)
    logdet = np.where(sign_det > 0, logdet, -np.inf)
    S_inv = np.linalg.inv(S)
    if W is None:
        return logdet, None, S_inv, AP
    APW = (AP.reshape(-1, P.shape[0]) @ W).reshape(blocks.shape)
    quad = np.einsum("kip,kjp->kij", APW, AP)
    return logdet, np.einsum("kij,kji->k", S_inv, quad), S_inv, AP


class _ChosenSet:
    """A set of chosen candidates that ``_update(i, +1 or -1)`` keeps the state of."""

    def add(self, i):
        self.chosen.append(int(i))
        self._update(i, +1)

    def remove(self, i):
        self.chosen.remove(int(i))
        self._update(i, -1)


class InformationState(_ChosenSet):
    """The information of a growing set of poses (see the module notes).

    blocks: (N, 3, P) candidate blocks; start: (P, P) information already there (the ridge
    and the poses measured before); W: (P, P) target weight for ``prediction``, None for
    ``d-optimal``.
    """

    def __init__(self, blocks, start, W=None):
        self.blocks = blocks
        self.M = np.array(start, dtype=float)
        self.W = W
        self.chosen = []
        self._refresh()

    def _refresh(self):
        self.P = np.linalg.inv(self.M)
        self.P = (self.P + self.P.T) / 2

    @property
    def score(self):
        """log det M (d-optimal) or -trace(W P) (prediction: minus the mean squared error)."""
        if self.W is None:
            return float(np.linalg.slogdet(self.M)[1])
        return -float(np.sum(self.W * self.P))

    def _gains(self, blocks, sign):
        logdet, trace, _, _ = woodbury(self.P, blocks, sign, self.W)
        if self.W is None:
            return logdet
        # A removal that leaves M singular (S not positive) costs everything.
        return np.where(np.isfinite(logdet), sign * trace, -np.inf)

    def gains_of_adding(self, available):
        """(N,) score gained by adding each candidate (-inf where not ``available``)."""
        gains = np.full(len(self.blocks), -np.inf)
        index = np.flatnonzero(available)
        gains[index] = self._gains(self.blocks[index], +1)
        return gains

    def gains_of_removing(self):
        """(k,) score gained (negative: lost) by removing each chosen pose."""
        return self._gains(self.blocks[self.chosen], -1)

    def _update(self, i, sign):
        # The accepted change itself is one P x P inverse, recomputed rather than updated: it
        # costs nothing beside judging the candidates, and no rounding builds up while the
        # ridge still dominates M.
        block = self.blocks[i]
        self.M += sign * block.T @ block
        self._refresh()


class SandwichState(_ChosenSet):
    """Least squares under a per-pose covariance (see the module notes): the expected mean
    squared error of the calibrated TCP at the targets, trace(W P B P), plus with ``bias``
    the squared error of the estimate's systematic shift.

    blocks: (N, 3, P) candidate blocks (weighted, as for :class:`InformationState`); start:
    (P, P) the information already there (ridge and poses measured before); W: (P, P) the
    target weight; C: (N, 3, 3) each candidate's covariance relative to its weights; B_start:
    (P, P) what the poses already there contribute to B (default ``start``: the ridge, with
    C = I); bias: (N, 3) a known systematic error of each candidate's reading, or (N, 3, k)
    k shapes of one with unit-variance amplitudes of unknown sign (weighted as the blocks);
    r: (P,) or (P, k) mean over the targets of J_t^T b_t (unweighted rows); g_start: the
    sum of A_i^T b_i of the poses already there, default none.  The score is minus the
    criterion (without the targets' own error, mean |b_t|^2).
    """

    def __init__(self, blocks, start, W, C, B_start=None, bias=None, r=None, g_start=None):
        self.blocks, self.W, self.C = blocks, W, C
        self.M = np.array(start, dtype=float)
        self.B = np.array(start if B_start is None else B_start, dtype=float)
        size = blocks.shape[2]
        # Kept as k shapes: (N, 3, k), r (P, k), g (P, k).
        self.bias = None if bias is None else (bias[:, :, None] if bias.ndim == 2 else bias)
        shapes = 1 if self.bias is None else self.bias.shape[2]
        self.r = np.zeros((size, shapes)) if r is None else np.asarray(r, dtype=float).reshape(size, shapes)
        self.g = np.zeros((size, shapes)) if g_start is None else np.array(g_start, dtype=float).reshape(size, shapes)
        self.chosen = []
        self._refresh()

    def _refresh(self):
        P = np.linalg.inv(self.M)
        self.P = (P + P.T) / 2
        self.x = self.P @ self.g
        self._WPB = self.W @ self.P @ self.B
        self._variance = float(np.sum(self.W * (self.P @ self.B @ self.P)))
        self._shift = float(np.sum(self.x * (self.W @ self.x)) - 2 * np.sum(self.x * self.r))

    @property
    def covariance(self):
        """(P, P) the covariance of the scaled parameters, P B P."""
        return self.P @ self.B @ self.P

    @property
    def score(self):
        return -(self._variance + self._shift)

    def _criterion(self, index, sign):
        A, C = self.blocks[index], self.C[index]
        size = A.shape[2]
        U = (A.reshape(-1, size) @ self.P).reshape(A.shape)

        def sandwich(matrix):
            # (k, 3, 3): U matrix U^T for every candidate.
            return np.einsum("kip,kjp->kij", (U.reshape(-1, size) @ matrix).reshape(A.shape), U)

        S = np.eye(3) + sign * np.einsum("kip,kjp->kij", U, A)
        sign_det = np.linalg.slogdet(S)[0]
        D = np.linalg.inv(S)
        K, L, G = sandwich(self.W), sandwich(self._WPB), sandwich(self.B)
        SI = S - np.eye(3)
        DK = D @ K
        DKD = DK @ D
        value = (self._variance + sign * np.einsum("kij,kji->k", C, K) - 2 * sign * np.einsum("kij,kji->k", D, L)
                 - 2 * sign * np.einsum("kij,kji->k", DK @ C, SI) + np.einsum("kij,kji->k", DKD, G)
                 + sign * np.einsum("kij,kji->k", DKD, SI @ C @ SI))
        if self.bias is not None:
            z = sign * (D @ (self.bias[index] - A @ self.x))          # (k, 3, shapes)
            h = U @ (self.W @ self.x - self.r)                         # (k, 3, shapes)
            value = value + self._shift + 2 * np.einsum("kim,kim->k", z, h) + np.einsum("kim,kij,kjm->k", z, K, z)
        # A removal that leaves M singular (S not positive) costs everything.
        return np.where(sign_det > 0, -value - self.score, -np.inf)

    def gains_of_adding(self, available):
        gains = np.full(len(self.blocks), -np.inf)
        index = np.flatnonzero(available)
        gains[index] = self._criterion(index, +1)
        return gains

    def gains_of_removing(self):
        return self._criterion(np.array(self.chosen, dtype=int), -1)

    def _update(self, i, sign):
        block = self.blocks[i]
        self.M += sign * block.T @ block
        self.B += sign * block.T @ self.C[i] @ block
        if self.bias is not None:
            self.g += sign * block.T @ self.bias[i]
        self._refresh()


def information_start(candidate_blocks, before_blocks=None):
    """The information before the design: the ridge (RIDGE times the information of an
    average candidate, per parameter) plus that of the poses measured before."""
    count, _, n_parameters = candidate_blocks.shape
    typical = float(np.sum(candidate_blocks ** 2) / count / n_parameters)
    start = RIDGE * typical * np.eye(n_parameters)
    if before_blocks is not None and len(before_blocks):
        flat = before_blocks.reshape(-1, n_parameters)
        start = start + flat.T @ flat
    return start


class SpacingState:
    """Space filling in scaled joint space (see the module notes).

    points: (N, d) candidates scaled to [0, 1]; before: (k, d) poses measured before (they
    repel, and are never removed).  The score is minus T, the sum of d^-p over the pairs of
    chosen poses and over the chosen poses paired with those before.
    """

    def __init__(self, points, before=None):
        self.points = points
        self.chosen = []
        self.total = 0.0
        # Each candidate's sum of d^-p to the poses chosen so far and those before (itself
        # left out).
        self._near = np.zeros(len(points))
        if before is not None and len(before):
            for start in range(0, len(before), 256):
                self._near += self._repulsion(before[start:start + 256]).sum(axis=0)

    def _repulsion(self, others, own=None):
        """(k, N) d^-p from each of ``others`` to every candidate (0 at index ``own``)."""
        d2 = np.sum((others[:, None, :] - self.points[None]) ** 2, axis=2)
        out = 1.0 / np.maximum(d2, 1e-24) ** (SPACING_POWER / 2)
        if own is not None:
            out[0, own] = 0.0
        return out

    @property
    def score(self):
        return -self.total

    def gains_of_adding(self, available):
        return np.where(available, -self._near, -np.inf)

    def gains_of_removing(self):
        return self._near[self.chosen].copy()

    def add(self, i):
        self.total += self._near[i]
        self._near += self._repulsion(self.points[i][None], own=i)[0]
        self.chosen.append(int(i))

    def remove(self, i):
        self.chosen.remove(int(i))
        self._near -= self._repulsion(self.points[i][None], own=i)[0]
        self.total -= self._near[i]


@dataclass(frozen=True)
class VarianceKernel:
    """The Gaussian-process prior of the ``variance`` criterion.

    joints: indices of the joints whose sines and cosines are the inputs; mean, scale: (d,)
    the inputs' standardisation; theta: (d,) Gaussian-correlation weights on the standardised
    inputs (R = exp(-sum theta_k (x_k - x'_k)^2)); nugget: noise variance relative to the
    process variance; source: where the values came from (for the summary)."""

    joints: np.ndarray
    mean: np.ndarray
    scale: np.ndarray
    theta: np.ndarray
    nugget: float
    source: str

    @classmethod
    def default(cls, chain, candidates):
        """The fixed prior (VARIANCE_THETA, VARIANCE_NUGGET) over the joints that move the TCP
        across ``candidates`` (N, n) rad, standardised over them."""
        joints = moving_joints(chain, candidates)
        if not len(joints):
            raise InputError("no joint moves the TCP across the candidates: the variance criterion needs candidates "
                             "that differ in the joints")
        x = JointFeatures("sincos", joints, chain.revolute).transform(candidates)
        mean, scale = x.mean(axis=0), x.std(axis=0)
        d = x.shape[1]
        return cls(joints, mean, np.where(scale > 0, scale, 1.0), np.full(d, VARIANCE_THETA / d), VARIANCE_NUGGET,
                   f"fixed: theta = {VARIANCE_THETA:g}/d on standardised sin/cos inputs, nugget {VARIANCE_NUGGET:g}")

    @classmethod
    def of_kriging(cls, joint_kriging, source):
        """The prior of a fitted ``sincos`` :class:`~robocal.estimation.joint_kriging.JointKriging`:
        its inputs, the geometric mean of its outputs' theta, the largest nugget."""
        features, model = joint_kriging.features_, joint_kriging.kriging_
        theta = np.exp(np.mean(np.log(np.atleast_2d(model.theta_)), axis=0))
        return cls(features.joints, model._x_mean, model._x_scale, theta, float(np.max(model.nugget_)), source)

    def points(self, chain, joints):
        """(N, d) standardised inputs of configurations ``joints`` (N, n) rad."""
        x = JointFeatures("sincos", self.joints, chain.revolute).transform(joints)
        return (x - self.mean) / self.scale


class VarianceState:
    """Largest predictive variance (see the module notes).

    points: (N, d) standardised inputs of the candidates; kernel: a :class:`VarianceKernel`;
    before: (k, d) inputs of the poses measured before (conditioned on first, never chosen).
    ``variance`` (N,) is each candidate's predictive variance relative to the process
    variance; the score is minus its maximum.
    """

    def __init__(self, points, kernel, before=None):
        self.kernel = kernel
        self.count = len(points)
        self._all = points if before is None or not len(before) else np.concatenate([points, before])
        self._variance = np.ones(len(self._all))
        self._rows = np.zeros((0, len(self._all)))
        self.chosen = []
        for i in range(self.count, len(self._all)):
            self._condition(i)

    @property
    def variance(self):
        return self._variance[:self.count]

    def _condition(self, i):
        squared = ((self._all - self._all[i]) ** 2) @ self.kernel.theta
        column = correlation_from_squared(squared, "gaussian")
        column -= self._rows[:, i] @ self._rows
        row = column / np.sqrt(self._variance[i] + self.kernel.nugget)
        # Rounding can take a variance a hair below zero at a chosen point.
        self._variance = np.maximum(self._variance - row ** 2, 0.0)
        self._rows = np.vstack([self._rows, row])

    @property
    def score(self):
        return -float(self.variance.max())

    def gains_of_adding(self, available):
        return np.where(available, self.variance, -np.inf)

    def add(self, i):
        self.chosen.append(int(i))
        self._condition(int(i))
