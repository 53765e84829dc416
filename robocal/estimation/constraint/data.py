"""Ball-in-socket data: configurations grouped by (placement, socket), and the pairs of
configurations the position and distance constraints are written on."""
from dataclasses import dataclass

import numpy as np

from ...errors import InputError

PAIRINGS = ("all", "spanning")


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
    try:
        q = np.asarray(joints, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"joints must be numbers, (N, {chain.n_joints}) rad (mm for prismatic joints), for "
                         f"{chain.name}") from None
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
    position rows then take the equivalent centred form (see
    :func:`~robocal.estimation.constraint.estimator.constraint_rows`).
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


def pair_weights(pairs):
    """Per-pair weights: each kind sums to the same total whatever its number of pairs."""
    w_pos = 1.0 / np.sqrt(len(pairs.position)) if len(pairs.position) else 0.0
    w_dist = 1.0 / np.sqrt(len(pairs.distance)) if len(pairs.distance) else 0.0
    return w_pos, w_dist


def check_groups(data):
    """InputError if a (placement, socket) group has a single configuration."""
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
