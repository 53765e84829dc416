"""Calibration from position and distance constraints: a ball on the flange seated in the
sockets of a fixture, joint angles only (DESIGN.md, method 2).

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
"""
import warnings
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError, RobocalWarning
from ..kinematics.chain import FRAME_SUFFIXES, GAIN
from ..kinematics.compliant import compliance_index, with_compliance
from ..spatial import so3_log
from .calibration import check_payload, identified_parameters
from .identifiability import STRONG_CORRELATION, analyse, loose_gains
from .least_squares import damped_least_squares
from .metrics import error_stats

PAIRINGS = ("all", "spanning")
BASE = ("base_x", "base_y", "base_z", "base_rx", "base_ry", "base_rz")
TOOL_POSITION = ("tool_x", "tool_y", "tool_z")
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

_BASE_REASON = ("the base frame (6 DoF): moving the whole robot changes no constraint between "
                "ball positions; the calibrated model keeps the starting base")
_SCALE_REASON = ("without distance constraints (two sockets of one placement) nothing fixes the "
                 "size of the robot: lengths are found only relative to each other")


# --------------------------------------------------------------------------- data
@dataclass(frozen=True)
class SocketData:
    """Constraint data checked and grouped.

    joints: (N, n) rad; placement: (N,) placement index into ``placements``; socket: (N,)
    socket index into ``fixture.ids``; group: (N,) index of (placement, socket) groups.
    """

    joints: np.ndarray
    placements: tuple
    placement: np.ndarray
    socket: np.ndarray
    group: np.ndarray
    fixture: object

    @property
    def group_sizes(self):
        return np.bincount(self.group)


def socket_data(chain, joints, fixture_ids, socket_ids, fixture):
    """Check and group constraint data (joints in rad); raises InputError on bad input."""
    q = np.asarray(joints, dtype=float)
    if q.ndim != 2 or q.shape[1] != chain.n_joints:
        raise InputError(f"joints must be (N, {chain.n_joints}) for {chain.name}, got shape {q.shape}")
    placements_raw = np.asarray(fixture_ids).astype(str).reshape(-1)
    sockets_raw = np.asarray(socket_ids).astype(str).reshape(-1)
    if placements_raw.shape != (len(q),) or sockets_raw.shape != (len(q),):
        raise InputError(f"fixture and socket ids need one entry per configuration ({len(q)}), got "
                         f"{placements_raw.size} and {sockets_raw.size}")
    if len(q) == 0:
        raise InputError("no configurations: record the ball in the sockets of the fixture first")
    if not np.all(np.isfinite(q)):
        rows = np.flatnonzero(~np.all(np.isfinite(q), axis=1))
        raise InputError(f"joint values of configuration(s) {rows[:5].tolist()} are NaN or infinite: "
                         "remove or fix those rows")
    ids = fixture.ids
    known = np.isin(sockets_raw, ids)
    if not np.all(known):
        missing = sorted(set(sockets_raw[~known].tolist()))
        raise InputError(f"socket id(s) {', '.join(missing)} are not in fixture '{fixture.name}' "
                         f"(it has {', '.join(ids)}): check the socket column against the fixture file")
    order = np.argsort(ids)
    socket = order[np.searchsorted(np.array(ids), sockets_raw, sorter=order)]
    # Placements in order of first appearance, as the file lists them.
    names, first, placement = np.unique(placements_raw, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    placement = rank[placement.reshape(-1)]
    _, group = np.unique(placement * len(ids) + socket, return_inverse=True)
    return SocketData(q, tuple(names[order].tolist()), placement, socket, group.reshape(-1), fixture)


@dataclass(frozen=True)
class ConstraintPairs:
    """Indices of paired configurations: ``position`` (P, 2) within a socket, ``distance``
    (D, 2) across sockets of a placement with the known ``target`` (D,) distances in mm.

    ``group`` (N,) is set when ``position`` holds every pair of each socket group: the
    position rows then take the equivalent centred form (see :func:`constraint_residual`).
    """

    position: np.ndarray
    distance: np.ndarray
    target: np.ndarray
    group: np.ndarray | None = None
    # For every pair across two sockets: ((configurations of a), (configurations of b)) per
    # socket pair, in the order of ``distance``; rows are then formed block by block.
    blocks: tuple | None = None

    @property
    def position_rows(self):
        """Number of residual rows of the position constraints."""
        return 3 * (len(self.position) if self.group is None or not len(self.position) else self.group.size)


def constraint_pairs(data, pairs="all"):
    """Pairs for the two constraint models.

    pairs='all': every pair within a socket group, and every pair across two sockets of a
    placement.  pairs='spanning': a chain through each socket group (M - 1 pairs), and for
    each placement the first socket recorded paired with each other one, configuration k
    with configuration k (cycling the shorter list, so every configuration takes part).
    """
    if pairs not in PAIRINGS:
        raise InputError(f"pairs must be one of {', '.join(PAIRINGS)}, got {pairs!r}")
    members = [np.flatnonzero(data.group == g) for g in range(data.group.max() + 1)]
    position = []
    for m in members:
        if pairs == "all":
            i, j = np.triu_indices(m.size, 1)
            position.append(np.column_stack([m[i], m[j]]))
        else:
            position.append(np.column_stack([m[:-1], m[1:]]))
    distance, target, blocks = [], [], []
    for p in range(len(data.placements)):
        groups = [m for m in members if data.placement[m[0]] == p]
        groups.sort(key=lambda m: data.socket[m[0]])
        if pairs == "all":
            couples = [(a, b) for k, a in enumerate(groups) for b in groups[k + 1:]]
        else:
            couples = [(groups[0], b) for b in groups[1:]]
        for a, b in couples:
            if pairs == "all":
                i, j = np.meshgrid(a, b, indexing="ij")
                both = np.column_stack([i.ravel(), j.ravel()])
                blocks.append((a, b))
            else:
                k = np.arange(max(a.size, b.size))
                both = np.column_stack([a[k % a.size], b[k % b.size]])
            distance.append(both)
            ids = data.fixture.ids
            target.append(np.full(len(both), data.fixture.distance(ids[data.socket[a[0]]], ids[data.socket[b[0]]])))
    empty = np.zeros((0, 2), dtype=int)
    return ConstraintPairs(
        position=np.concatenate(position) if position else empty,
        distance=np.concatenate(distance) if distance else empty,
        target=np.concatenate(target) if target else np.zeros(0),
        group=data.group if pairs == "all" else None,
        blocks=tuple(blocks) if pairs == "all" else None,
    )


def _weights(pairs):
    """Per-pair weights: each kind sums to the same total whatever its number of pairs."""
    w_pos = 1.0 / np.sqrt(len(pairs.position)) if len(pairs.position) else 0.0
    w_dist = 1.0 / np.sqrt(len(pairs.distance)) if len(pairs.distance) else 0.0
    return w_pos, w_dist


def constraint_residual(chain, q, pairs):
    """Unweighted constraint residuals (mm): the position rows, then one row per distance
    pair (|p_i - p_j| - D).

    Position rows are 3 per pair (p_i - p_j); for every pair of each socket group they are
    3 per configuration, sqrt(M) (p_i - mean of its group of M): the sum over all pairs of
    |p_i - p_j|^2 is M times the scatter about the mean, so this gives the same cost, normal
    matrix and gradient with N rows instead of about N M / 2.
    """
    p = chain.fk_positions(q)
    return _stack(p, None, pairs, (1.0, 1.0))[0]


def constraint_jacobian(chain, q, pairs, names):
    """(residuals, Jacobian) of :func:`constraint_residual` w.r.t. the named parameter
    deviations (those :meth:`Chain.perturbed` applies): analytic, rows as there."""
    p = chain.fk_positions(q)
    jac = chain.identification_jacobian(q, names)[:, :3, :]
    return _stack(p, jac, pairs, (1.0, 1.0))


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


# ----------------------------------------------------------------------- metrics
def socket_errors(chain, joints, fixture_ids, socket_ids, fixture):
    """How well a chain's ball centres agree with the fixture, for any chain.

    Socket consistency: distance of each computed ball centre from the mean of its
    (placement, socket) group (groups of one configuration say nothing and are left out),
    as :func:`error_stats` (``n``, ``mean_mm``, ``rms_mm``, ``max_mm``, ...).  Under
    ``socket_distance``: for each placement and pair of its sockets, |distance between the
    group means| - known distance: ``n``, ``mean_mm`` / ``rms_mm`` / ``max_mm`` of its
    magnitude and ``signed_mean_mm``.
    """
    return _socket_errors(chain, socket_data(chain, joints, fixture_ids, socket_ids, fixture))


def socket_deviations(chain, joints, fixture_ids, socket_ids, fixture):
    """(N, 3) mm: each computed ball centre minus the mean of its (placement, socket) group,
    and (N, 3) the ball centres; what :func:`socket_errors` summarises, pose by pose."""
    data = socket_data(chain, joints, fixture_ids, socket_ids, fixture)
    _, _, _, deviations, means = _socket_errors(chain, data, per_placement=True)
    return deviations, means[data.group] + deviations


def _socket_errors(chain, data, per_placement=False):
    p = chain.fk_positions(data.joints)
    sizes = data.group_sizes
    means = np.stack([np.bincount(data.group, weights=p[:, c]) for c in range(3)], axis=1) / sizes[:, None]
    shared = sizes[data.group] > 1
    out = error_stats(p[shared] - means[data.group[shared]])
    group_placement = np.zeros(len(sizes), dtype=int)
    group_socket = np.zeros(len(sizes), dtype=int)
    group_placement[data.group], group_socket[data.group] = data.placement, data.socket
    ids = data.fixture.ids
    errors, where = [], []
    for placement in range(len(data.placements)):
        groups = np.flatnonzero(group_placement == placement)
        for x, a in enumerate(groups):
            for b in groups[x + 1:]:
                known = data.fixture.distance(ids[group_socket[a]], ids[group_socket[b]])
                errors.append(np.linalg.norm(means[a] - means[b]) - known)
                where.append((placement, a, b))
    errors = np.array(errors)
    out["socket_distance"] = {"n": int(errors.size)} if not errors.size else {
        "n": int(errors.size), "mean_mm": float(np.abs(errors).mean()),
        "rms_mm": float(np.sqrt(np.mean(errors**2))), "max_mm": float(np.abs(errors).max()),
        "signed_mean_mm": float(errors.mean()),
    }
    if per_placement:
        return out, errors, where, p - means[data.group], means
    return out


# ------------------------------------------------------------------------ result
@dataclass(frozen=True)
class ConstraintResult:
    """What a constraint calibration found (all JSON-ready through :meth:`to_dict`).

    residual_before / residual_after: :func:`socket_errors` of the starting and the
    calibrated model on the training data.  unobservable: what no constraint can see
    ("base frame", and "scale" without distance constraints).
    """

    names: tuple
    values: np.ndarray          # identified deviations from the starting POE model (rad, mm)
    std_errors: np.ndarray      # standard errors of the deviations (rad, mm)
    correlated_pairs: tuple
    identifiability: object     # IdentifiabilityReport
    residual_before: dict
    residual_after: dict
    unobservable: tuple
    pairs: dict                 # {"pairing", "position", "distance"} counts
    iterations: int
    converged: bool

    def to_dict(self, chain):
        """Deviations and standard errors in file units (deg for angles, mm for lengths)."""
        return {
            **identified_parameters(chain, self),
            "unobservable": list(self.unobservable),
            "pairs": dict(self.pairs),
            "residual_before": self.residual_before,
            "residual_after": self.residual_after,
            "iterations": self.iterations,
            "converged": self.converged,
        }


# ---------------------------------------------------------------------- estimator
def candidate_parameters(chain, gains=False):
    """Parameters of the POE ``chain`` in order of preference: the ball offset, then each
    joint's offset and axis placement from the last joint to the first, then the home pose,
    then (``gains``) each joint's gain."""
    names = list(TOOL_POSITION)
    for k in range(chain.n_joints, 0, -1):
        names += [f"{p}{k}" for p in ("theta", "ux", "uy", "wx", "wy")]
    return names + chain.parameter_names(("home",) + (("gains",) if gains else ()))


class ConstraintCalibration:
    """Calibration from ball-in-socket data, scikit-learn style.

    pairs: 'all' (every pair; the most equations) or 'spanning' (each configuration in
    about two pairs; far fewer rows).  distance: use distance constraints when the data
    have them (False: position constraints only, scale then unidentifiable).  compliance:
    also identify one compliance per joint gravity loads (see
    :class:`~robocal.kinematics.compliant.CompliantChain`), ``payload`` kg at the TCP (the ball
    and what carries it; default: none if the robot file gives link masses, else the rated
    payload of a robot of that size).  gains: also identify a gain per joint (a scale error
    of its reading).

    After :meth:`fit`: ``chain_`` (the calibrated POE chain, tool = flange -> ball centre,
    base = the starting one), ``start_chain_`` (the starting model in POE form),
    ``names_`` and ``result_`` (a :class:`ConstraintResult`).
    """

    def __init__(self, pairs="all", *, distance=True, compliance=False, gains=False, payload=None,
                 max_iterations=50, tolerance=1e-7):
        if pairs not in PAIRINGS:
            raise InputError(f"pairs must be one of {', '.join(PAIRINGS)}, got {pairs!r}")
        self.pairs = pairs
        self.compliance = compliance
        self.gains = gains
        self.payload = check_payload(payload)
        self.distance = distance
        self.max_iterations = max_iterations
        self.tolerance = tolerance

    def fit(self, chain, joints, fixture_ids, socket_ids, fixture):
        """joints (N, n) rad; fixture_ids, socket_ids (N,) placement and socket of each
        configuration; fixture a :class:`~robocal.io.fixtures.Fixture`.  Returns self."""
        from ..kinematics import to_poe

        data = socket_data(chain, joints, fixture_ids, socket_ids, fixture)
        _check_groups(data)
        start = to_poe(chain)
        pairs = constraint_pairs(data, self.pairs)
        spanning = constraint_pairs(data, "spanning")
        if not self.distance:
            pairs = replace(pairs, distance=pairs.distance[:0], target=pairs.target[:0], blocks=None)
            spanning = replace(spanning, distance=spanning.distance[:0], target=spanning.target[:0])
        _check_equations(spanning, start, bool(len(pairs.distance)))
        before = _check_distances(start, data, bool(len(pairs.distance)))
        candidates = candidate_parameters(start, self.gains)
        if self.compliance and len(data.placements) == 1:
            warnings.warn(RobocalWarning(
                "joint compliance from one fixture placement: it fits that placement and may be worse "
                "elsewhere (MUKCa panda_1: 1.10 mm on the other placements against 0.91 without it); "
                "measure at two or more placements"), stacklevel=2)
        if self.compliance:
            start, compliances = with_compliance(start, data.joints, self.payload)
            candidates += compliances
        weights = _weights(pairs)

        def linearise(names):
            return lambda c: _stack(c.fk_positions(data.joints),
                                    c.identification_jacobian(data.joints, names)[:, :3, :], pairs, weights)

        def residual(c):
            return _stack(c.fk_positions(data.joints), None, pairs, weights)[0]

        # Identifiability is local (see KinematicCalibration.fit): analyse, fit, analyse
        # again at the fit until the identified set settles.  The spanning pairs see every
        # configuration and both kinds of constraint, so they tell which directions the data
        # determine as all pairs do, with a tenth of the rows.
        def solve(candidates):
            fitted, names, iterations, converged = start, None, 0, False
            analysed = (spanning, _weights(spanning))
            for _ in range(3):
                identified, report = _analysis(fitted, data, *analysed, candidates)
                if identified == names:
                    break
                names = identified
                fitted, steps, converged = damped_least_squares(
                    fitted, names, linearise(names), residual, max_iterations=self.max_iterations,
                    tolerance=self.tolerance)
                iterations += steps
            else:
                _, report = _analysis(fitted, data, *analysed, candidates)
            std, correlated = _covariance(fitted, data.joints, spanning, names)
            return fitted, names, report(), iterations, converged, std, correlated

        fitted, names, report, iterations, converged, std, correlated = solve(candidates)
        loose = loose_gains(names, std, start.n_joints)
        if loose:
            fitted, names, report, more, converged, std, correlated = solve(
                [n for n in candidates if n not in loose])
            iterations += more
            report = replace(report, fixed={**report.fixed, **loose})
        unobservable = ("base frame",) + (() if len(pairs.distance) else ("scale",))
        self.chain_ = fitted
        self.start_chain_ = start
        self.names_ = tuple(names)
        self.result_ = ConstraintResult(
            names=tuple(names), values=poe_deviations(start, fitted, names),
            std_errors=std, correlated_pairs=correlated, identifiability=report,
            residual_before=before, residual_after=_socket_errors(fitted, data), unobservable=unobservable,
            pairs={"pairing": self.pairs, "position": int(len(pairs.position)),
                   "distance": int(len(pairs.distance))},
            iterations=iterations, converged=converged,
        )
        return self

    def predict(self, joints):
        """Ball centres (N, 3) mm of the calibrated model, in the starting model's base frame."""
        return self.chain_.fk_positions(np.asarray(joints, dtype=float))



def _analysis(chain, data, pairs, weights, candidates):
    """The identifiability of the constraint Jacobian at ``chain``: ``(identified names,
    report())``, the report with its reasons made only when asked for.

    The base and scale directions lead the columns (see the module docstring).  Only the
    column geometry matters, so the analysis runs on R of a QR decomposition (R^T R = A^T A):
    every least-squares question about the columns costs a P x P problem, not a rows x P one.
    """
    q = data.joints
    absolute = chain.identification_jacobian(q, list(BASE) + candidates)[:, :3, :]
    p = chain.fk_positions(q)
    columns = np.concatenate([absolute[:, :, :6], p[:, :, None], absolute[:, :, 6:]], axis=2)
    jac = _stack(p, columns, pairs, weights)[1]
    # A uniform scale about the base changes every distance: it is a direction the data
    # cannot see only through position constraints.
    jac[pairs.position_rows:, 6] = 0.0
    rows = len(jac)
    jac = np.linalg.qr(jac, mode="r")
    names = list(BASE) + [SCALE] + candidates
    rigid = getattr(chain, "rigid", chain)
    kept, _ = analyse(rigid, jac, names, explain=False)
    real = [k for k in kept if k >= 7]

    def report():
        _, explained = analyse(rigid, jac, names, explain=True)
        fixed = {name: _BASE_REASON for name in BASE}
        if not len(pairs.distance):
            fixed[SCALE] = _SCALE_REASON
        flat = columns.reshape(-1, columns.shape[2])
        norms = np.linalg.norm(flat, axis=0)
        compressed = np.linalg.qr(flat / np.where(norms > 0, norms, 1.0), mode="r")
        for j, name in enumerate(names[7:], start=7):
            if j not in kept:
                fixed[name] = _label(name, explained.fixed[name], compressed, j, [k for k in real if k < j])
        _, stats = analyse(rigid, jac[:, real], [names[k] for k in real], explain=False)
        # o1 is normalised by the number of rows: those of the constraint Jacobian, not of R.
        return replace(stats, fixed=fixed, rows=rows, o1=stats.o1 * np.sqrt(stats.rows / rows))

    return [names[k] for k in real], report


def poe_deviations(start, fitted, names):
    """The deviations (rad, mm) that :meth:`Chain.perturbed` would apply to the POE chain
    ``start`` to give ``fitted``, for the named parameters (links, tool, home): exact, so a
    deviation read here means what the parameter name says."""
    out = []
    for name in names:
        k = compliance_index(name)
        if k is not None:
            out.append(fitted.compliance[k] - start.compliance[k])
            continue
        start_rigid, fitted_rigid = getattr(start, "rigid", start), getattr(fitted, "rigid", fitted)
        out.append(_poe_deviation(start_rigid, fitted_rigid, name))
    return np.array(out, dtype=float)


def _poe_deviation(start, fitted, name):
    if "_" in name:
        group, suffix = name.split("_")
        before, after = getattr(start, group), getattr(fitted, group)
        k = FRAME_SUFFIXES.index(suffix)
        if k < 3:
            return (before[:3, :3].T @ (after[:3, 3] - before[:3, 3]))[k]
        return so3_log(before[:3, :3].T @ after[:3, :3])[k - 3]
    stem = name.rstrip("0123456789")
    i = int(name[len(stem):]) - 1
    if stem == "theta":
        return fitted.theta[i] - start.theta[i]
    if stem == GAIN:
        return (fitted.parameter_values([name]) - start.parameter_values([name]))[0]
    frame = start.poe_frames()[i]
    w = frame[:3, :3].T @ fitted.axes[i]
    p = frame[:3, :3].T @ (fitted.points[i] - frame[:3, 3])
    # The moved frame is F Trans(ux, uy, 0) Rot([wx, wy, 0]): its origin is where the new
    # axis crosses F's x-y plane, and Rot([wx, wy, 0]) turns z onto the new axis.
    angle = np.arctan2(np.hypot(w[0], w[1]), w[2])
    factor = angle / np.sin(angle) if angle > 1e-12 else 1.0
    crossing = p - w * (p[2] / w[2])
    return {"ux": crossing[0], "uy": crossing[1], "wx": -factor * w[1], "wy": factor * w[0]}[stem]


def _label(name, reason, absolute, column, previous):
    """The reason a parameter is fixed: the base frame, the scale, or ``reason`` as found."""
    target = absolute[:, column]

    def leftover(extra):
        basis = np.concatenate([absolute[:, extra], absolute[:, previous]], axis=1)
        if basis.shape[1] == 0:
            return np.linalg.norm(target)
        return np.linalg.norm(target - basis @ np.linalg.lstsq(basis, target, rcond=None)[0])

    if np.linalg.norm(target) == 0 or leftover([]) <= _LABEL_TOLERANCE:
        stem = name.rstrip("0123456789")
        if stem == "theta" and name != "theta1" and np.linalg.norm(target) > 0:
            joint = name[5:]
            return (f"{name} (joint {joint}'s zero offset) is taken up by the axes after joint {joint} "
                    "and the ball offset: in a POE model they express the same motion")
        return reason
    if leftover(list(range(6))) <= _LABEL_TOLERANCE:
        return f"{name} is fixed with the base frame: with the parameters kept it only moves the whole robot"
    if leftover(list(range(7))) <= _LABEL_TOLERANCE:
        return f"{name} is fixed with the scale: " + _SCALE_REASON
    return reason


def _covariance(chain, q, pairs, names):
    """Standard errors and strongly correlated pairs, from a spanning set of pairs: all
    pairs reuse each configuration many times and would make the errors look smaller."""
    weights = _weights(pairs)
    r, jac = _stack(chain.fk_positions(q), chain.identification_jacobian(q, names)[:, :3, :], pairs, weights)
    dof = max(len(r) - len(names), 1)
    sigma2 = float(r @ r) / dof
    scale = np.linalg.norm(jac, axis=0)
    scale[scale == 0] = 1.0
    cov = sigma2 * np.linalg.pinv((jac / scale).T @ (jac / scale)) / np.outer(scale, scale)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(std, std)
    upper = np.argwhere(np.triu(np.abs(corr) > STRONG_CORRELATION, 1))
    return std, tuple((names[a], names[b], float(corr[a, b])) for a, b in upper)


# -------------------------------------------------------------------- refusals
def _check_groups(data):
    sizes = data.group_sizes
    single = np.flatnonzero(sizes < 2)
    if single.size:
        g = single[0]
        row = int(np.flatnonzero(data.group == g)[0])
        raise InputError(
            f"placement '{data.placements[data.placement[row]]}', socket "
            f"'{data.fixture.ids[data.socket[row]]}' has a single configuration: a socket needs at "
            f"least two (in different orientations) to constrain anything; record more or drop it"
            + (f" ({single.size} such sockets)" if single.size > 1 else "")
        )


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


def _check_distances(chain, data, with_distance):
    """Socket errors of the starting model; InputError if a socket distance differs from
    the data by more than the nominal model's error can explain."""
    before, errors, where, deviations, _ = _socket_errors(chain, data, per_placement=True)
    if not with_distance:
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
