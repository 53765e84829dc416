"""The estimator of the calibration from position and distance constraints: a ball on the
flange seated in the sockets of a fixture, joint angles only (docs/ARCHITECTURE.md; the constraint method).

Model: the global product of exponentials T = exp([S1]q1) ... exp([Sn]qn) M, with the ball
centre as the tool (flange -> ball).  Every configuration gives a computed ball centre p(q).

* Position constraint: two configurations in the same socket of one placement put the ball
  at one point, so p_i - p_j = 0; linearised, (J_i - J_j) x = -(p_i - p_j) with J the
  chain's identification Jacobian (its adjoint-transformed twists).
* Distance constraint: two configurations in different sockets of one placement put the
  balls the known socket distance D apart: |p_i - p_j| - D = 0; linearised with the unit
  vector u = (p_i - p_j) / |p_i - p_j|: u^T (J_i - J_j) x = D - |p_i - p_j|.

Both kinds are stacked, each weighted by 1/sqrt(its number of pairs) so that neither
dominates by count, and solved by damped, column-scaled Gauss-Newton to convergence, each
step applied with :meth:`Chain.perturbed` so the next linearisation is exact.

Constraints between ball positions do not change when the whole robot moves, so the base
frame (6 DoF) is unobservable; without distance constraints nothing fixes the size of the
robot either (scale).  The identifiability analysis therefore runs on the constraint
Jacobian with those seven directions as extra leading columns: the parameter combinations
that only mimic them become dependent and are fixed at their starting values, with a reason.
Parameters are preferred from the tip inwards (ball offset, then the joints from the last
to the first), so what is fixed is joint 1's axis and what the base shares with joint 2:
the calibrated model keeps the nominal base.

The analyse → fit → re-analyse loop, the covariance and the refit without loose joint gains
are :mod:`robocal.estimation.identification`'s; this module brings the constraint rows and
the base and scale directions of the analysis, with their reasons.
"""
import warnings
from dataclasses import dataclass, replace

import numpy as np

from ...errors import InputError, RobocalWarning
from ...kinematics.compliant import with_compliance
from ...kinematics.parameters import FRAME_KINDS
from ...spatial import so3_log
from ..identifiability import analyse
from ..identification import (BASE, TOOL_POSITION, Analysis, FittedCalibration, IdentifiedResult, check_iterations,
                              check_prior, implausible_fit, tolerance_prior,
                              check_payload, identify, one_of)
from ..least_squares import damped_least_squares
from .data import PAIRINGS, check_groups, constraint_pairs, pair_weights, socket_data
from .metrics import deviation_jacobian, grouped_socket_errors

SCALE = "scale"
# Beyond this the combination a parameter would need to explain, once the base (and scale)
# directions are allowed, is still there: the dependency has another cause.
_LABEL_TOLERANCE = 1e-6
# A socket-distance mismatch at the nominal model is blamed on the data (wrong fixture file,
# unit or socket ids) beyond this slack plus 4x the scatter of the ball centres of that
# placement (the nominal model's own error, seen through the constraints).
_DISTANCE_SLACK_MM = 1.0
_DISTANCE_SLACK_RELATIVE = 0.02
_DISTANCE_SCATTER_FACTOR = 4.0
# A fixture's distances within this factor of the poses' distances in another unit are in
# that unit (inches and cm are 2.5 apart, the nearest two).
DISTANCE_UNIT_BAND = 1.25

_BASE_REASON = ("the base frame (6 DoF): moving the whole robot changes no constraint between "
                "ball positions; the calibrated model keeps the starting base")
_SCALE_REASON = ("without distance constraints (two sockets of one placement) nothing fixes the "
                 "size of the robot: lengths are found only relative to each other")


# ------------------------------------------------------------------- rows
def constraint_rows(chain, joints, pairs, names=None, weights=(1.0, 1.0)):
    """Constraint residual rows (mm) at ``chain`` and, given ``names``, their Jacobian
    w.r.t. those parameters' deviations (the ones :meth:`Chain.perturbed` applies).

    Rows: the position rows, then one row per distance pair (|p_i - p_j| - D).  Position
    rows are 3 per pair (p_i - p_j); for every pair of each socket group they are 3 per
    configuration, sqrt(M) (p_i - mean of its group of M): the sum over all pairs of
    |p_i - p_j|^2 is M times the scatter about the mean, so this gives the same cost, normal
    matrix and gradient with N rows instead of about N M / 2.  ``weights``: (position,
    distance) row weights.  Returns ((m,) residual, (m, P) Jacobian or None).
    """
    jac = None if names is None else chain.identification_jacobian(joints, names)[:, :3, :]
    return _stack(chain.fk_positions(joints), jac, pairs, weights)


def _stack(p, jac, pairs, weights):
    """Weighted residual rows (and Jacobian rows if ``jac`` (N, 3, C) is given)."""
    w_pos, w_dist = weights
    k, m = pairs.distance.T
    v = p[k] - p[m]
    length = np.linalg.norm(v, axis=1)
    if pairs.group is not None and len(pairs.position):
        members = np.zeros((pairs.group.max() + 1, len(p)))
        members[pairs.group, np.arange(len(p))] = 1.0
        sizes = members.sum(axis=1)
        root = w_pos * np.sqrt(sizes)[pairs.group]

        def difference(values):
            flat = values.reshape(len(p), -1)
            return (root[:, None] * (flat - ((members @ flat) / sizes[:, None])[pairs.group])).reshape(values.shape)
    else:
        i, j = pairs.position.T

        def difference(values):
            return w_pos * (values[i] - values[j])
    r = np.concatenate([difference(p).reshape(-1), w_dist * (length - pairs.target)])
    if jac is None:
        return r, None
    rows_pos = difference(jac).reshape(-1, jac.shape[2])
    u = v / np.maximum(length, 1e-300)[:, None]
    if pairs.blocks is not None and len(pairs.distance) == len(pairs.target):
        # u_ij^T J_i - u_ij^T J_j over each block of pairs without gathering J per pair
        # (several times faster at 30 configurations per socket).
        rows_dist, start = [], 0
        for a, b in pairs.blocks:
            unit = u[start:start + a.size * b.size].reshape(a.size, b.size, 3)
            start += a.size * b.size
            rows_dist.append((unit @ jac[a] - np.swapaxes(np.swapaxes(unit, 0, 1) @ jac[b], 0, 1))
                             .reshape(-1, jac.shape[2]))
        rows_dist = w_dist * np.concatenate(rows_dist) if rows_dist else np.zeros((0, jac.shape[2]))
    else:
        rows_dist = w_dist * np.einsum("kc,kcp->kp", u, jac[k] - jac[m])
    return r, np.vstack([rows_pos, rows_dist])



@dataclass(frozen=True)
class ConstraintResult(IdentifiedResult):
    """What a constraint calibration found (all JSON-ready through :meth:`to_dict`).

    The fields of :class:`~robocal.estimation.identification.IdentifiedResult` (values and
    std_errors: deviations from the starting POE model, rad and mm; residual_before /
    residual_after: :func:`socket_errors` of the starting and the calibrated model on the
    training data), and unobservable: what no constraint can see ("base frame", and "scale"
    without distance constraints); pairs: {"pairing", "position", "distance"} counts.
    """

    unobservable: tuple
    pairs: dict

    def _details(self):
        return {
            "unobservable": list(self.unobservable),
            "pairs": dict(self.pairs),
            "residual_before": self.residual_before,
            "residual_after": self.residual_after,
            "iterations": self.iterations,
            "converged": self.converged,
        }

    @classmethod
    def from_dict(cls, doc, chain):
        """The result back from :meth:`to_dict` (``chain`` as given there); KeyError,
        TypeError or ValueError if ``doc`` is damaged."""
        return cls(**cls._shared_fields(doc, chain), unobservable=tuple(str(u) for u in doc["unobservable"]),
                   pairs=dict(doc["pairs"]))


def candidate_parameters(chain, gains=False):
    """Parameters of the POE ``chain`` in order of preference: the ball offset, then each
    joint's offset and axis placement from the last joint to the first, then the home pose,
    then (``gains``) each joint's gain."""
    links = [p for p in chain.parameters if p.group == "link"]
    names = list(TOOL_POSITION)
    for k in range(chain.n_joints, 0, -1):
        names += [p.name for p in links if p.joint == k]
    return names + chain.parameter_names(("home",) + (("gains",) if gains else ()))


class ConstraintCalibration(FittedCalibration):
    """Calibration from ball-in-socket data, scikit-learn style.

    Parameters
    ----------
    pairs : str
        'all' (every pair; the most equations) or 'spanning' (each configuration in about two
        pairs; far fewer rows).
    distance : bool
        Use distance constraints; the data must then have two sockets of one placement
        somewhere (else InputError: the robot's size would be the nominal's guess behind a
        perfect-looking fit).  False: position constraints only, scale unidentifiable.
    compliance : bool
        Also identify one compliance per joint gravity loads (see
        :class:`~robocal.kinematics.compliant.CompliantChain`), with ``payload`` kg at the TCP
        (the ball and what carries it; default: none if the robot file gives link masses,
        else the rated payload of a robot of that size).
    gains : bool
        Also identify a gain per joint (a scale error of its reading).
    max_iterations, tolerance
        As :func:`~robocal.estimation.least_squares.damped_least_squares`.

    The settings are stored as given and checked by :meth:`fit`.  After it: ``chain_`` (the
    calibrated POE chain, tool = flange -> ball centre, base = the starting one; a
    CompliantChain with ``compliance``), ``start_chain_`` (the starting model in POE form),
    ``names_`` and ``result_`` (a :class:`ConstraintResult`).
    """

    KIND = "constraint"
    RESULT = ConstraintResult

    def __init__(self, pairs="all", *, distance=True, compliance=False, gains=False, payload=None,
                 max_iterations=50, tolerance=1e-7, prior="tolerances", tolerance_scale=1.0):
        self.pairs = pairs
        self.distance = distance
        self.compliance = compliance
        self.gains = gains
        self.payload = payload
        self.max_iterations = max_iterations
        self.tolerance = tolerance
        self.prior = prior
        self.tolerance_scale = tolerance_scale

    def get_settings(self):
        """The settings, as given to ``__init__``."""
        return {"pairs": self.pairs, "distance": self.distance, "compliance": self.compliance,
                "gains": self.gains, "payload": self.payload, "max_iterations": self.max_iterations,
                "tolerance": self.tolerance, "prior": self.prior, "tolerance_scale": self.tolerance_scale}

    def _validate(self):
        """InputError naming the first bad setting; returns the payload (kg or None)."""
        one_of(self.pairs, PAIRINGS, "pairs")
        check_iterations(self.max_iterations)
        check_prior(self.prior, self.tolerance_scale)
        return check_payload(self.payload)

    def _pairs(self, data):
        """The pairs the fit uses and the spanning pairs the analysis and covariance use."""
        pairs = constraint_pairs(data, self.pairs)
        spanning = constraint_pairs(data, "spanning")
        if not self.distance:
            pairs = replace(pairs, distance=pairs.distance[:0], target=pairs.target[:0], blocks=None)
            spanning = replace(spanning, distance=spanning.distance[:0], target=spanning.target[:0])
        return pairs, spanning

    def fit(self, chain, joints, fixture_ids, socket_ids, fixture):
        """Identify the parameters.

        Parameters
        ----------
        chain : Chain
            The nominal model (any convention; fitted in POE form).
        joints : (N, n) array, rad (mm for prismatic joints)
        fixture_ids, socket_ids : (N,) arrays
            Placement and socket of each configuration.
        fixture : :class:`~robocal.io.fixtures.Fixture`

        Returns self, with ``chain_``, ``start_chain_``, ``names_`` and ``result_``.
        """
        from ...kinematics import to_poe

        payload = self._validate()
        if not hasattr(fixture, "ids"):
            raise InputError("fixture must be a Fixture (robocal.io.fixtures.read_fixture), "
                             f"got {type(fixture).__name__}")
        data = socket_data(chain, joints, fixture_ids, socket_ids, fixture)
        check_groups(data)
        start = to_poe(chain)
        pairs, spanning = self._pairs(data)
        # Under the tolerances a parameter the equations do not pin is held by its prior, and
        # whether the data can be this robot's (and fixture's) is judged after the fit, by how
        # far the fit moves it (implausible_fit).  Without them, the data alone must determine
        # every parameter and agree with the fixture beforehand.
        judged_by_prior = self.prior != "none"
        if not judged_by_prior:
            _check_equations(spanning, start, bool(len(pairs.distance)))
        if self.distance and not len(pairs.distance):
            # Position constraints alone fit any size of robot: the result would look perfect
            # (every socket consistent) with the lengths only the nominal's guess.
            raise InputError(
                "no placement has the ball in two different sockets ("
                + ("one placement, one socket" if len(data.placements) == 1 else
                   f"{len(data.placements)} placements, one socket each") + "): distances "
                "between sockets are needed to fix the robot's size; record at least two sockets of one placement "
                "(better all sockets of several); to fit the shape alone, with the nominal's size, use "
                "ConstraintCalibration(distance=False) in Python")
        before = _check_distances(start, data, bool(len(pairs.distance)), units_only=judged_by_prior)
        candidates = candidate_parameters(start, self.gains)
        if len(data.placements) == 1 and not self.compliance:
            # Enough for what the data pin (the rest is held by its prior), not for the workspace.
            warnings.warn(RobocalWarning(
                f"ball-in-socket data from one fixture placement ({data.placements[0]}): the model is fitted where "
                "that placement puts the ball, its error elsewhere is not measured; measure at two or more "
                "placements"), stacklevel=2)
        if self.compliance and len(data.placements) == 1:
            warnings.warn(RobocalWarning(
                "joint compliance from one fixture placement: it fits that placement and may be worse "
                "elsewhere (MUKCa panda_1: 1.10 mm on the other placements against 0.91 without it); "
                "measure at two or more placements"), stacklevel=2)
        if self.compliance:
            start, compliances = with_compliance(start, data.joints, payload)
            candidates += compliances
        self._prior = tolerance_prior(start, candidates, data.joints, self.prior, self.tolerance_scale,
                                      lambda chain, names: poe_deviations(start, chain, names))
        found = identify(start, candidates, **self._steps(data, pairs, spanning), joints=data.joints,
                         prior=self._prior)
        after = grouped_socket_errors(found.chain, data)
        if self._prior is not None:
            tolerances = self._prior.sigmas(list(found.names))
            failure = implausible_fit(
                found.names, poe_deviations(start, found.chain, found.names), tolerances, before["rms_mm"],
                after["rms_mm"], 0.0, lambda: _tolerance_consistency(start, data, candidates, self._prior),
                start.parameters,
                override="--tolerance-scale, or [tolerances] in the robot file",
                distances=None if not len(pairs.distance) else (
                    before["socket_distance"]["rms_mm"], after["socket_distance"]["rms_mm"],
                    _tolerance_distances(start, data, spanning, candidates, self._prior)))
            if failure is not None:
                raise InputError(failure.replace("these data are not this robot's",
                                                 "these ball-in-socket data are not this robot's (or fixture's)"))
        self.chain_ = found.chain
        self.start_chain_ = start
        self.names_ = found.names
        self.result_ = ConstraintResult(
            names=found.names, values=poe_deviations(start, found.chain, found.names),
            std_errors=found.std_errors, correlated_pairs=found.correlated_pairs, identifiability=found.report,
            residual_before=before, residual_after=after, prior_std=None if self._prior is None else found.prior_std,
            tolerance_scale=found.prior_scale,
            unobservable=("base frame",) + (() if len(pairs.distance) else ("scale",)),
            pairs={"pairing": self.pairs, "position": int(len(pairs.position)),
                   "distance": int(len(pairs.distance))},
            iterations=found.iterations, converged=found.converged,
        )
        return self

    def _steps(self, data, pairs, spanning):
        """What the identification core asks of this calibration.  The spanning pairs see
        every configuration and both kinds of constraint, so they tell which directions the
        data determine as all pairs do, with a tenth of the rows; the covariance comes from
        them too (all pairs reuse each configuration many times and would make the errors
        look smaller)."""
        q, weights, spanning_weights = data.joints, pair_weights(pairs), pair_weights(spanning)

        def fit(chain, names):
            return damped_least_squares(
                chain, names, lambda c: constraint_rows(c, q, pairs, names, weights),
                lambda c: constraint_rows(c, q, pairs, weights=weights)[0],
                max_iterations=self.max_iterations, tolerance=self.tolerance, prior=self._prior)

        return {"analyse": lambda chain, candidates: _analysis(chain, q, spanning, spanning_weights, candidates),
                "fit": fit,
                "linearise": lambda fitted, names: constraint_rows(fitted.chain, q, spanning, names, spanning_weights)}

    def predict(self, joints):
        """Ball centres of the calibrated model.

        joints: (N, n) rad (mm for prismatic joints), as commanded.  Returns (N, 3) mm in
        the starting model's base frame.  InputError if not fitted.
        """
        return super().predict(joints)


def _analysis(chain, q, pairs, weights, candidates):
    """The identifiability of the constraint Jacobian at ``chain`` (an :class:`Analysis`).

    The base and scale directions lead the columns (see the module docstring).  Only the
    column geometry matters, so the analysis runs on R of a QR decomposition (R^T R = A^T A):
    every least-squares question about the columns costs a P x P problem, not a rows x P one.
    """
    absolute = chain.identification_jacobian(q, list(BASE) + candidates)[:, :3, :]
    p = chain.fk_positions(q)
    columns = np.concatenate([absolute[:, :, :6], p[:, :, None], absolute[:, :, 6:]], axis=2)
    jac = _stack(p, columns, pairs, weights)[1]
    # A uniform scale about the base changes every distance: it is a direction the data
    # cannot see only through position constraints.
    jac[pairs.position_rows:, 6] = 0.0
    rows = len(jac)
    jac = np.linalg.qr(jac, mode="r")
    if len(jac) < jac.shape[1]:
        # Fewer constraint rows than parameters (a single placement, few configurations): R is
        # (rows, P); its missing rows are zeros, and the parameters beyond the rank are fixed.
        jac = np.vstack([jac, np.zeros((jac.shape[1] - len(jac), jac.shape[1]))])
    names = list(BASE) + [SCALE] + candidates
    kept, _ = analyse(chain, jac, names, explain=False)
    real = [k for k in kept if k >= 7]

    def report():
        _, explained = analyse(chain, jac, names, explain=True)
        fixed = {name: _BASE_REASON for name in BASE}
        if not len(pairs.distance):
            fixed[SCALE] = _SCALE_REASON
        flat = columns.reshape(-1, columns.shape[2])
        norms = np.linalg.norm(flat, axis=0)
        compressed = np.linalg.qr(flat / np.where(norms > 0, norms, 1.0), mode="r")
        for j, name in enumerate(names[7:], start=7):
            if j not in kept:
                fixed[name] = _label(chain.parameters[name], explained.fixed[name], compressed, j,
                                     [k for k in real if k < j])
        _, stats = analyse(chain, jac[:, real], [names[k] for k in real], explain=False)
        # o1 is normalised by the number of rows: those of the constraint Jacobian, not of R.
        return replace(stats, fixed=fixed, rows=rows, o1=stats.o1 * np.sqrt(stats.rows / rows))

    return Analysis(tuple(names[k] for k in real), report)


def poe_deviations(start, fitted, names):
    """The deviations (rad, mm) that :meth:`Chain.perturbed` would apply to the POE chain
    ``start`` to give ``fitted``, for the named parameters (links, tool, home, gains,
    compliances): exact, so a deviation read here means what the parameter name says."""
    out = []
    for parameter in start.parameters.records(names):
        if parameter.group == "compliance":
            out.append(fitted.compliance[parameter.joint - 1] - start.compliance[parameter.joint - 1])
        else:
            out.append(_poe_deviation(start.rigid, fitted.rigid, parameter))
    return np.array(out, dtype=float)


def _poe_deviation(start, fitted, parameter):
    """One rigid parameter's deviation from POE ``start`` to ``fitted``."""
    if parameter.joint is None:
        before, after = getattr(start, parameter.group), getattr(fitted, parameter.group)
        k = FRAME_KINDS.index(parameter.kind)
        if k < 3:
            return (before[:3, :3].T @ (after[:3, 3] - before[:3, 3]))[k]
        return so3_log(before[:3, :3].T @ after[:3, :3])[k - 3]
    i = parameter.joint - 1
    if parameter.kind == "theta":
        return fitted.theta[i] - start.theta[i]
    if parameter.group == "gains":
        return (fitted.parameter_values([parameter.name]) - start.parameter_values([parameter.name]))[0]
    frame = start.poe_frames()[i]
    w = frame[:3, :3].T @ fitted.axes[i]
    p = frame[:3, :3].T @ (fitted.points[i] - frame[:3, 3])
    # The moved frame is F Trans(ux, uy, 0) Rot([wx, wy, 0]): its origin is where the new
    # axis crosses F's x-y plane, and Rot([wx, wy, 0]) turns z onto the new axis.
    angle = np.arctan2(np.hypot(w[0], w[1]), w[2])
    factor = angle / np.sin(angle) if angle > 1e-12 else 1.0
    crossing = p - w * (p[2] / w[2])
    return {"ux": crossing[0], "uy": crossing[1], "wx": -factor * w[1], "wy": factor * w[0]}[parameter.kind]


def _label(parameter, reason, absolute, column, previous):
    """The reason a parameter is fixed: the base frame, the scale, or ``reason`` as found."""
    name = parameter.name
    target = absolute[:, column]

    def leftover(extra):
        basis = np.concatenate([absolute[:, extra], absolute[:, previous]], axis=1)
        if basis.shape[1] == 0:
            return np.linalg.norm(target)
        return np.linalg.norm(target - basis @ np.linalg.lstsq(basis, target, rcond=None)[0])

    if np.linalg.norm(target) == 0 or leftover([]) <= _LABEL_TOLERANCE:
        if parameter.kind == "theta" and parameter.joint != 1 and np.linalg.norm(target) > 0:
            joint = parameter.joint
            return (f"{name} (joint {joint}'s zero offset) is taken up by the axes after joint {joint} "
                    "and the ball offset: in a POE model they express the same motion")
        return reason
    if leftover(list(range(6))) <= _LABEL_TOLERANCE:
        return f"{name} is fixed with the base frame: with the parameters kept it only moves the whole robot"
    if leftover(list(range(7))) <= _LABEL_TOLERANCE:
        return f"{name} is fixed with the scale: " + _SCALE_REASON
    return reason


def _tolerance_consistency(start, data, names, prior):
    """mm RMS of the socket consistency a robot within its tolerances shows before any
    calibration: each ball centre's deviation from its socket's mean under the prior."""
    sigma = prior.sigmas(list(names))
    held = np.isfinite(sigma)
    rows = deviation_jacobian(start, data, [n for n, h in zip(names, held) if h]) * sigma[held]
    return float(np.sqrt(np.sum(rows ** 2) / max(len(rows), 1)))


def _tolerance_distances(start, data, spanning, names, prior):
    """mm RMS of the socket distances' errors a robot within its tolerances shows before any
    calibration (the spanning pairs' distance rows under the prior)."""
    sigma = prior.sigmas(list(names))
    held = np.isfinite(sigma)
    _, jac = constraint_rows(start, data.joints, spanning, [n for n, h in zip(names, held) if h], (0.0, 1.0))
    rows = jac[len(jac) - len(spanning.distance):] * sigma[held]
    return float(np.sqrt(np.sum(rows ** 2) / max(len(rows), 1)))


def _check_distance_units(data, errors, where):
    """InputError when the fixture's socket distances are the starting model's in another
    length unit: their ratio within DISTANCE_UNIT_BAND of a unit's, for every pair."""
    from ...io.units import LENGTH_UNITS

    ids = data.fixture.ids
    ratios = []
    for error, (_, a, b) in zip(errors, where):
        known = data.fixture.distance(ids[data.socket[np.flatnonzero(data.group == a)[0]]],
                                      ids[data.socket[np.flatnonzero(data.group == b)[0]]])
        if known > 0 and known + error > 0:
            ratios.append(known / (known + error))
    if not ratios:
        return
    ratio = float(np.exp(np.median(np.log(ratios))))
    for unit, factor in LENGTH_UNITS.items():
        if unit != "mm" and abs(np.log(ratio * factor)) < np.log(DISTANCE_UNIT_BAND):
            raise InputError(
                f"fixture '{data.fixture.name}': its socket distances are {ratio:.3g} of what the robot's poses put "
                f"between the sockets: they look like {unit}; give the fixture's socket positions in mm")


def _check_equations(spanning, chain, with_distance):
    """Enough independent equations for the parameters a perfect data set would identify."""
    equations = 3 * len(spanning.position) + len(spanning.distance)
    revolute = int(np.sum(chain.revolute))
    # A point on the flange: 4 per revolute and 2 per prismatic joint, plus 3 for the ball,
    # minus what constraints cannot see (base, and scale without distances).
    needed = 4 * revolute + 2 * (chain.n_joints - revolute) + 3 - 6 - (0 if with_distance else 1)
    if equations < needed:
        per_socket = int(np.ceil(needed / 3)) + 1
        raise InputError(
            f"the data give {equations} independent constraint equations for about {needed} parameters: "
            f"record more configurations per socket (at least {per_socket} in one socket, better 10 or more "
            "in each socket of several placements)"
        )


def _check_distances(chain, data, with_distance, units_only=False):
    """Socket errors of the starting model; InputError if a socket distance differs from
    the data by more than the nominal model's error can explain, or (``units_only``) only if
    it is the data's distance in another length unit (:data:`~robocal.io.units.LENGTH_UNITS`).

    The starting model's ball centre is a guess (the ball's offset on the flange is among
    what the calibration identifies), and a few seatings per socket in similar postures show
    little scatter around a mean the guess moved by centimetres (MUKCa Panda 1, three seatings
    per socket: 21.7 mm off at 2.7 mm of scatter; all 30: 2.1 mm at 10.8 mm).  So where the
    tolerances judge the fit, only a unit is told here."""
    before, errors, where, deviations, _ = grouped_socket_errors(chain, data, per_placement=True)
    if not with_distance:
        return before
    if units_only:
        _check_distance_units(data, errors, where)
        return before
    spread = np.linalg.norm(deviations, axis=1)
    for error, (placement, a, b) in zip(errors, where):
        rows = data.placement == placement
        scatter = float(np.sqrt(np.mean(spread[rows] ** 2)))
        ids = data.fixture.ids
        sa = ids[data.socket[np.flatnonzero(data.group == a)[0]]]
        sb = ids[data.socket[np.flatnonzero(data.group == b)[0]]]
        known = data.fixture.distance(sa, sb)
        limit = _DISTANCE_SLACK_MM + _DISTANCE_SLACK_RELATIVE * known + _DISTANCE_SCATTER_FACTOR * scatter
        if abs(error) > limit:
            raise InputError(
                f"placement '{data.placements[placement]}': sockets {sa} and {sb} are {known + error:.1f} mm "
                f"apart by the starting model but {known:.1f} mm in fixture '{data.fixture.name}', more than "
                f"the model's own error ({scatter:.2f} mm RMS scatter in that placement) can explain: check "
                "the fixture file (mm), the socket column and the robot"
            )
    return before
