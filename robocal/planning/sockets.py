"""Ball-in-socket planning: where to put the fixture and, per socket, which configurations
to seat the ball in, for the constraint calibration
(:class:`~robocal.estimation.constraint.ConstraintCalibration`).

Candidates (:func:`socket_candidates`): for every candidate placement (a fixture pose in the
robot base frame) and socket, configurations that put the ball (the tool origin) in the
socket from above, the tool z axis tilted from the fixture normal by up to ``max_tilt_deg``
and turned about itself, solved by the nominal inverse kinematics from postures of a fixed
random pool nearest to each orientation (so that arm branches vary as well as wrist angles).

Information (:func:`socket_information`): a seated configuration i of placement k says that
the ball centre p(q_i; x) is socket s of the fixture at its unknown pose T_k.  Linearised,

    J_i x - G_i xi_k = residual,   G_i = [I_3, -[c_i]_x]     (xi_k: a small rigid motion of T_k)

with J_i the constraint calibration's identification Jacobian (POE model, ball offset and
joint axes from the tip inwards: :func:`~robocal.estimation.constraint.candidate_parameters`)
and c_i the socket's centre relative to the placement's.  The unknown placement poses are
columns of the same least-squares problem, so a configuration's rows form a 3 x (P + 6K)
block and the information is additive: the states of :mod:`robocal.planning.criteria` and
their rank-3 updates apply unchanged.  This is the constraint calibration's own model
(position constraints: one point per socket; distance constraints: the sockets' known
spacing), with the fixture as a rigid body.  What no configuration can see (the base frame,
what the base shares with the first joint) is found, as the calibration finds it, by the
identifiability analysis on the information of all candidates with the placements
eliminated, and left out.

Choice (:func:`design_sockets`): with fewer placements wanted than given, placements are
added one at a time, each with a starting set per socket (configurations spread in joint
space), the one that improves the criterion most first; then each chosen configuration is
exchanged for the best candidate of its own (placement, socket), sweeping until none
changes, so that every socket keeps exactly ``per_socket`` configurations.

The criteria are those of the parametric design: ``prediction`` (default: the mean squared
error of the calibrated ball centres over all candidate configurations, each placement's
rigid motion taken out: what socket consistency sees) or ``d-optimal``.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..estimation.constraint import candidate_parameters
from ..estimation.identifiability import analyse
from ..kinematics import to_poe
from ..kinematics.ik import solve_ik
from ..spatial import hat, so3_exp
from .candidates import MARGIN_DEG, usable
from .criteria import InformationState, information_start
from .exchange import swap_within

SOCKET_CRITERIA = ("prediction", "d-optimal")
# Orientations tried per (placement, socket); the reachable ones are the candidates.
ORIENTATIONS = 60
# The ball comes from above: the tool axis at most this far from the fixture normal (the
# constraint simulation's default; a socket's rim stops a steeper approach).
MAX_TILT_DEG = 30.0
# Random postures whose nearest (position and orientation) seed the IK; a fixed seed, as the
# pool belongs to the method, not to the user's draw.  Each target takes one of the
# HINT_CHOICES nearest, so that neighbouring targets may land on other arm branches.
HINT_POOL = 4096
HINT_CHOICES = 4
# Sweeps of exchange within the sockets at most.
SWEEPS = 20
# Candidate placements drawn in a region: fixture poses tried, level, yaw uniform.
REGION_PLACEMENTS = 12


@dataclass(frozen=True)
class SocketCandidates:
    """Configurations that seat the ball in the sockets of candidate placements.

    joints: (N, n) rad; placement: (N,) index into ``names`` / ``poses``; socket: (N,) index
    into ``fixture.ids``; poses: (K, 4, 4) fixture poses in the robot base frame (mm);
    names: (K,) placement ids, what the poses CSV's ``fixture`` column will hold."""

    joints: np.ndarray
    placement: np.ndarray
    socket: np.ndarray
    poses: np.ndarray
    names: tuple
    fixture: object

    @property
    def group(self):
        """(N,) index of the (placement, socket) group."""
        return self.placement * len(self.fixture.ids) + self.socket


def _orientations(pose, count, max_tilt_deg, rng):
    """(count, 3, 3) tool orientations against the fixture normal (tool z = -fixture z),
    tilted about a random axis of the fixture plane and turned about the tool axis."""
    against = pose[:3, :3] @ np.diag([1.0, -1.0, -1.0])
    angle = rng.uniform(-np.pi, np.pi, count)
    axis = np.column_stack([np.cos(angle), np.sin(angle), np.zeros(count)]) @ pose[:3, :3].T
    # Uniform over the cap of directions, not over the tilt angle: as many steep as upright.
    tilt = np.arccos(1.0 - rng.uniform(0.0, 1.0, count) * (1.0 - np.cos(np.radians(max_tilt_deg))))
    spin = np.column_stack([np.zeros((count, 2)), rng.uniform(-np.pi, np.pi, count)])
    return so3_exp(axis * tilt[:, None]) @ against @ so3_exp(spin)


def socket_candidates(chain, fixture, poses, names=None, *, orientations=ORIENTATIONS, max_tilt_deg=MAX_TILT_DEG,
                      margin_deg=MARGIN_DEG, seed=0):
    """:class:`SocketCandidates` of ``chain`` (its tool is the ball centre) for ``fixture``
    at ``poses`` (K, 4, 4) in the robot base frame, mm: up to ``orientations`` per socket and
    placement (module notes), those the nominal IK reaches ``margin_deg`` inside the limits
    and away from singularities.  Placements where some socket has fewer than two are left
    out; InputError if none is left."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 4, 4)
    names = tuple(f"P{k + 1}" for k in range(len(poses))) if names is None else tuple(str(n) for n in names)
    if not 0.0 <= max_tilt_deg < 90.0:
        raise InputError(f"the largest tilt must lie in [0, 90) deg (the ball comes from above), got {max_tilt_deg}")
    rng = np.random.default_rng(seed)
    pool = chain.random_configurations(HINT_POOL, np.random.default_rng(0))
    pool_poses = chain.fk(pool)
    lever = float(np.max(np.linalg.norm(pool_poses[:, :3, 3], axis=1)))
    sockets = np.array([fixture.sockets[s] for s in fixture.ids])
    joints, placement, socket = [], [], []
    for k, pose in enumerate(poses):
        index = np.repeat(np.arange(len(sockets)), orientations)
        targets = np.zeros((len(index), 4, 4))
        targets[:, :3, :3] = _orientations(pose, len(index), max_tilt_deg, rng)
        targets[:, :3, 3] = sockets[index] @ pose[:3, :3].T + pose[:3, 3]
        targets[:, 3, 3] = 1.0
        # Distance to each pool posture: position, plus the orientation's 3 - trace(R^T R')
        # (which grows with the angle between them) at the reach as lever.
        cost = (np.linalg.norm(pool_poses[None, :, :3, 3] - targets[:, None, :3, 3], axis=2)
                + lever * (3.0 - np.einsum("pij,tij->tp", pool_poses[:, :3, :3], targets[:, :3, :3])))
        nearest = np.argpartition(cost, HINT_CHOICES, axis=1)[:, :HINT_CHOICES]
        hints = pool[nearest[np.arange(len(index)), rng.integers(0, HINT_CHOICES, len(index))]]
        result = solve_ik(chain, targets, hints)
        ok = result.success.copy()
        ok[ok] = usable(chain, result.q[ok], margin_deg)
        counts = np.bincount(index[ok], minlength=len(sockets))
        if counts.min() < 2:
            continue
        joints.append(result.q[ok])
        placement.append(np.full(int(ok.sum()), k))
        socket.append(index[ok])
    if not joints:
        raise InputError(f"the robot '{chain.name}' reaches every socket of fixture '{fixture.name}' in two or more "
                         "orientations at none of the placements: place the fixture nearer (base frame, mm), allow a "
                         "larger tilt, or check the robot's tool (the ball centre)")
    kept = sorted(set(np.concatenate(placement).tolist()))
    renumber = {k: r for r, k in enumerate(kept)}
    return SocketCandidates(np.concatenate(joints), np.array([renumber[k] for k in np.concatenate(placement)]),
                            np.concatenate(socket), poses[kept], tuple(names[k] for k in kept), fixture)


def region_placements(fixture, low, high, count=REGION_PLACEMENTS, seed=0):
    """(count, 4, 4) level fixture poses (fixture z up, yaw uniform) with the sockets' centroid
    uniform in the box ``low`` .. ``high`` (3,) mm of the robot base frame."""
    low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
    if low.shape != (3,) or high.shape != (3,) or not np.all(np.isfinite(low) & np.isfinite(high)) or np.any(
            low > high):
        raise InputError("the region is xmin,xmax,ymin,ymax,zmin,zmax in mm with each min <= its max")
    rng = np.random.default_rng(seed)
    centroid = np.mean([fixture.sockets[s] for s in fixture.ids], axis=0)
    poses = np.zeros((count, 4, 4))
    poses[:, :3, :3] = so3_exp(np.column_stack([np.zeros((count, 2)), rng.uniform(-np.pi, np.pi, count)]))
    where = low + rng.uniform(0.0, 1.0, (count, 3)) * (high - low)
    poses[:, :3, 3] = where - poses[:, :3, :3] @ centroid
    poses[:, 3, 3] = 1.0
    return poses


@dataclass(frozen=True)
class SocketInformation:
    """The information of the candidates (module notes).

    names: the identifiable parameters of the POE model; fixed: {name: reason} for the others;
    blocks: (N, 3, P + 6K) scaled rows, the parameters' columns first, then six per
    placement; n_parameters: P; W: (P + 6K, P + 6K) the prediction weight: the mean over the
    candidates of the rows' information with the placements eliminated (zero on the
    placements' columns)."""

    names: tuple
    fixed: dict
    blocks: np.ndarray
    n_parameters: int
    W: np.ndarray


def socket_information(chain, candidates, noise=0.02):
    """:class:`SocketInformation` of :class:`SocketCandidates` for a constraint calibration
    of ``chain``; ``noise``: standard deviation of a seated ball centre per coordinate (mm:
    seating, and the joints' reading noise through the arm)."""
    poe = to_poe(chain)
    names = candidate_parameters(poe)
    q = candidates.joints
    jac = poe.identification_jacobian(q, names)[:, :3, :]
    count, places = len(q), len(candidates.poses)
    # A small rigid motion (t, w) of placement k moves its socket at c by t + w x c: columns
    # [I, -[c]x], c from the placement's own origin so that the columns stay commensurate.
    centre = poe.fk_positions(q) - candidates.poses[candidates.placement, :3, 3]
    nuisance = np.concatenate([np.broadcast_to(np.eye(3), (count, 3, 3)), -hat(centre)], axis=2)
    # The parameters the candidates determine once the placements are unknown: analysed on a
    # square root of the information with the placements eliminated (a Schur complement).
    rows = np.zeros((count, 3, len(names) + 6 * places))
    rows[:, :, :len(names)] = jac
    for k in range(places):
        mine = candidates.placement == k
        rows[mine, :, len(names) + 6 * k:len(names) + 6 * k + 6] = -nuisance[mine]
    flat = rows.reshape(-1, rows.shape[2])
    norms = np.sqrt(np.mean(np.sum(rows ** 2, axis=1), axis=0))
    norms = np.where(norms > 0, norms, 1.0)
    M = (flat / norms).T @ (flat / norms)
    p = len(names)
    schur = M[:p, :p] - M[:p, p:] @ np.linalg.pinv(M[p:, p:], rcond=1e-10, hermitian=True) @ M[p:, :p]
    values, vectors = np.linalg.eigh((schur + schur.T) / 2)
    root = (vectors * np.sqrt(np.clip(values, 0.0, None))).T * norms[:p]
    kept, report = analyse(poe, root, names)
    columns = list(kept) + list(range(p, rows.shape[2]))
    blocks = rows[:, :, columns] / norms[columns] / float(noise)
    # The prediction weight is the same Schur complement per configuration, without noise: the
    # squared error of the calibrated ball centres once each placement's rigid motion is taken
    # out, which is what socket consistency and distances see.  (The plain mean of J^T J would
    # weigh the directions that only mimic moving the whole robot, which no constraint sees.)
    W = np.zeros((len(columns), len(columns)))
    W[:len(kept), :len(kept)] = schur[np.ix_(kept, kept)] / count
    return SocketInformation(tuple(names[k] for k in kept), dict(report.fixed), blocks, len(kept), W)


def _spread(points, count):
    """``count`` rows of ``points`` (m, d) spread apart: the first, then farthest-point."""
    chosen = [0]
    distance = np.linalg.norm(points - points[0], axis=1)
    for _ in range(count - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return np.array(chosen)


@dataclass(frozen=True)
class SocketDesign:
    """Chosen placements and configurations (JSON-ready through :meth:`to_dict`).

    joints: (count, n) rad; placement, socket: (count,) ids (str), grouped by placement, then
    socket; indices: their rows among the candidates; poses: {placement id: (4, 4)} of the
    chosen placements; names: the identifiable parameters; std_errors: (P,) their predicted
    standard errors (scaled units: relative, for comparison between designs); model_rms:
    predicted RMS error of the calibrated ball centre over all candidate configurations (mm,
    with the stated noise); random_model_rms: the median of it over random choices of the
    same placements and numbers (None when there is nothing to draw)."""

    joints: np.ndarray
    placement: np.ndarray
    socket: np.ndarray
    indices: np.ndarray
    poses: dict
    criterion: str
    per_socket: int
    names: tuple
    fixed: dict
    noise: float
    model_rms: float
    random_model_rms: float | None
    exchanges: int
    n_candidates: int
    n_placements: int

    def to_dict(self):
        return {"configurations": int(len(self.joints)), "candidates": self.n_candidates,
                "candidate_placements": self.n_placements, "placements": list(self.poses),
                "per_socket": self.per_socket, "criterion": self.criterion, "noise_mm": self.noise,
                "exchanges": self.exchanges,
                "predicted": {"model_rms_mm": self.model_rms, "random_model_rms_mm": self.random_model_rms},
                "identifiable": list(self.names), "fixed": dict(self.fixed)}


def _trace_rms(W, M):
    return float(np.sqrt(max(np.sum(W * np.linalg.inv(M)), 0.0)))


def design_sockets(chain, candidates, per_socket, placements=None, *, criterion="prediction", noise=0.02,
                   refine=True, seed=0):
    """Choose ``placements`` of the candidate placements (default all) and ``per_socket``
    configurations per socket of each (module notes) for a constraint calibration of
    ``chain``.  candidates: :class:`SocketCandidates`.  Returns a :class:`SocketDesign`."""
    if criterion not in SOCKET_CRITERIA:
        raise InputError(f"the ball-in-socket design's criterion must be one of {', '.join(SOCKET_CRITERIA)}, "
                         f"got {criterion!r}")
    places, sockets = len(candidates.poses), len(candidates.fixture.ids)
    placements = places if placements is None else placements
    if isinstance(placements, bool) or not isinstance(placements, (int, np.integer)) or not 1 <= placements <= places:
        raise InputError(f"the number of placements must be a whole number from 1 to the {places} reachable "
                         f"candidate placements, got {placements!r}")
    group = candidates.group
    sizes = np.bincount(group, minlength=places * sockets).reshape(places, sockets)
    if isinstance(per_socket, bool) or not isinstance(per_socket, (int, np.integer)) or per_socket < 2:
        raise InputError(f"configurations per socket must be a whole number >= 2 (one seats the ball, a second "
                         f"constrains the robot), got {per_socket!r}")
    usable_places = np.flatnonzero(sizes.min(axis=1) >= per_socket)
    if len(usable_places) < placements:
        raise InputError(f"{len(usable_places)} candidate placements reach every socket in {per_socket} orientations, "
                         f"{placements} asked for: ask for fewer configurations per socket or placements, or give "
                         "more candidate placements")
    info = socket_information(chain, candidates, noise)
    start = information_start(info.blocks)
    state = InformationState(info.blocks, start, info.W if criterion == "prediction" else None)
    spread = {}
    for k in usable_places:
        for s in range(sockets):
            members = np.flatnonzero(group == k * sockets + s)
            spread[k, s] = members[_spread(candidates.joints[members], per_socket)]
    chosen_places = []
    available = np.ones(len(candidates.joints), dtype=bool)
    for _ in range(placements):
        # A placement (with its starting sets) at a time: one P x P inverse per placement tried.
        best, best_score = None, -np.inf
        for k in usable_places:
            if k in chosen_places:
                continue
            rows = info.blocks[np.concatenate([spread[k, s] for s in range(sockets)])].reshape(-1, info.blocks.shape[2])
            M = state.M + rows.T @ rows
            score = np.linalg.slogdet(M)[1] if state.W is None else -np.sum(state.W * np.linalg.inv(M))
            if score > best_score:
                best, best_score = k, score
        chosen_places.append(int(best))
        for s in range(sockets):
            for i in spread[best, s]:
                state.add(i)
                available[i] = False
    steps = 0
    for _ in range(SWEEPS if refine else 0):
        changed = False
        for old in list(state.chosen):
            if swap_within(state, available, old, group == group[old]) != old:
                changed = True
                steps += 1
        if not changed:
            break
    chosen = np.array(state.chosen, dtype=int)
    chosen = chosen[np.lexsort((candidates.socket[chosen], [chosen_places.index(k) for k in
                                                              candidates.placement[chosen]]))]
    flat = info.blocks[chosen].reshape(-1, info.blocks.shape[2])
    M = start + flat.T @ flat
    cov = np.linalg.inv(M)
    random_rms = _random_rms(info, start, candidates, chosen_places, per_socket, usable_places, seed)
    ids = np.array(candidates.fixture.ids)
    names = np.array(candidates.names)
    return SocketDesign(
        joints=candidates.joints[chosen], placement=names[candidates.placement[chosen]],
        socket=ids[candidates.socket[chosen]], indices=chosen,
        poses={candidates.names[k]: candidates.poses[k] for k in chosen_places}, criterion=criterion,
        per_socket=int(per_socket), names=info.names, fixed=info.fixed, noise=float(noise),
        model_rms=float(np.sqrt(max(np.sum(info.W * cov), 0.0))), random_model_rms=random_rms, exchanges=steps,
        n_candidates=len(candidates.joints), n_placements=places)


# Random choices the summary compares the design with.
RANDOM_DRAWS = 20


def _random_rms(info, start, candidates, chosen_places, per_socket, usable_places, seed):
    """Median predicted RMS of random choices: as many placements drawn from those usable,
    ``per_socket`` random configurations per socket."""
    rng = np.random.default_rng(seed)
    sockets = len(candidates.fixture.ids)
    group = candidates.group
    if len(usable_places) == len(chosen_places) and all(
            np.sum(group == g) == per_socket for g in range(group.max() + 1)):
        return None
    draws = []
    for _ in range(RANDOM_DRAWS):
        places = rng.choice(usable_places, len(chosen_places), replace=False)
        index = np.concatenate([rng.choice(np.flatnonzero(group == k * sockets + s), per_socket, replace=False)
                                for k in places for s in range(sockets)])
        flat = info.blocks[index].reshape(-1, info.blocks.shape[2])
        draws.append(_trace_rms(info.W, start + flat.T @ flat))
    return float(np.median(draws))


__all__ = ["SOCKET_CRITERIA", "SocketCandidates", "SocketDesign", "SocketInformation", "design_sockets",
           "region_placements", "socket_candidates", "socket_information"]
