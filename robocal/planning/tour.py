"""The order to measure the chosen poses in: short motions between them.

A move between two configurations takes about as long as its largest joint motion (the
joints of a point-to-point move travel together), so the distance is the largest
|q_a - q_b| over the joints (deg; mm on prismatic joints).  :func:`tour` builds a
nearest-neighbour path from a start, improves it by 2-opt (reversing a stretch whenever that
shortens the path) and never returns a path longer than the order it was given.
"""
import numpy as np

# 2-opt passes over the path at most (each pass is O(n^2), vectorised per position).
TWO_OPT_PASSES = 50


def distances(joints):
    """(n, n) largest joint motion between each pair of configurations."""
    q = np.asarray(joints, dtype=float)
    return np.max(np.abs(q[:, None, :] - q[None, :, :]), axis=2)


def path_length(joints, order=None, start=None):
    """Total motion along ``joints`` taken in ``order`` (default as given), from ``start``
    (a configuration) when given."""
    q = np.asarray(joints, dtype=float)
    q = q if order is None else q[np.asarray(order)]
    if start is not None:
        q = np.vstack([np.asarray(start, dtype=float)[None], q])
    return float(np.sum(np.max(np.abs(np.diff(q, axis=0)), axis=1))) if len(q) > 1 else 0.0


def _nearest_neighbour(dist, first):
    count = len(dist)
    order = [first]
    left = np.ones(count, dtype=bool)
    left[first] = False
    for _ in range(count - 1):
        row = np.where(left, dist[order[-1]], np.inf)
        nxt = int(np.argmin(row))
        order.append(nxt)
        left[nxt] = False
    return np.array(order)


def _two_opt(dist, order, fixed_first):
    """Reverse stretches of an open path while that shortens it; with ``fixed_first`` the
    first element stays (it follows the start)."""
    order = order.copy()
    count = len(order)
    low = 1 if fixed_first else 0
    for _ in range(TWO_OPT_PASSES):
        improved = False
        for i in range(low, count - 1):
            # Reverse order[i..j]: edges (i-1, i) and (j, j+1) become (i-1, j) and (i, j+1).
            j = np.arange(i + 1, count)
            a, b = order[i - 1] if i > 0 else None, order[i]
            c, d = order[j], np.append(order[j[:-1] + 1], -1)
            before = dist[b, c] * 0.0
            after = before.copy()
            if a is not None:
                before += dist[a, b]
                after += dist[a, c]
            inner = d >= 0
            before[inner] += dist[c[inner], d[inner]]
            after[inner] += dist[b, d[inner]]
            gain = before - after
            k = int(np.argmax(gain))
            if gain[k] > 1e-12:
                order[i:j[k] + 1] = order[i:j[k] + 1][::-1]
                improved = True
        if not improved:
            break
    return order


def tour(joints, start=None):
    """An order (indices) to visit ``joints`` (n, dof) in, starting next to ``start`` (the
    configuration the robot stands in, e.g. the last pose measured before) or, without one,
    at the configuration nearest to the middle of the set; never longer than the given order
    (measured from the same start)."""
    q = np.asarray(joints, dtype=float)
    count = len(q)
    if count <= 2:
        return np.arange(count)
    dist = distances(q)
    if start is None:
        middle = (q.min(axis=0) + q.max(axis=0)) / 2
        first = int(np.argmin(np.max(np.abs(q - middle), axis=1)))
    else:
        first = int(np.argmin(np.max(np.abs(q - np.asarray(start, dtype=float)), axis=1)))
    order = _two_opt(dist, _nearest_neighbour(dist, first), fixed_first=start is not None)
    given = np.arange(count)
    if path_length(q, order, start) > path_length(q, given, start):
        return given
    return order
