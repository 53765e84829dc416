"""How well a chain's ball centres agree with a fixture: socket consistency and socket
distances, for any chain (nominal, calibrated, compliant)."""
import numpy as np

from ..metrics import error_stats
from .data import socket_data


def socket_errors(chain, joints, fixture_ids, socket_ids, fixture):
    """How well a chain's ball centres agree with the fixture, for any chain.

    Socket consistency: distance of each computed ball centre from the mean of its
    (placement, socket) group (groups of one configuration say nothing and are left out),
    as :func:`error_stats` (``n``, ``mean_mm``, ``rms_mm``, ``max_mm``, ...).  Under
    ``socket_distance``: for each placement and pair of its sockets, |distance between the
    group means| - known distance: ``n``, ``mean_mm`` / ``rms_mm`` / ``max_mm`` of its
    magnitude and ``signed_mean_mm``.
    """
    return grouped_socket_errors(chain, socket_data(chain, joints, fixture_ids, socket_ids, fixture))


def socket_deviations(chain, joints, fixture_ids, socket_ids, fixture):
    """(N, 3) mm: each computed ball centre minus the mean of its (placement, socket) group,
    and (N, 3) the ball centres; what :func:`socket_errors` summarises, pose by pose."""
    data = socket_data(chain, joints, fixture_ids, socket_ids, fixture)
    _, _, _, deviations, means = grouped_socket_errors(chain, data, per_placement=True)
    return deviations, means[data.group] + deviations


def grouped_socket_errors(chain, data, per_placement=False):
    """:func:`socket_errors` of grouped ``data`` (a SocketData); with ``per_placement`` also
    the socket-distance errors (mm), their (placement, group a, group b), the (N, 3)
    deviations from the group means and the (G, 3) group means."""
    p = chain.fk_positions(data.joints)
    sizes = data.group_sizes
    means = np.stack([np.bincount(data.group, weights=p[:, c]) for c in range(3)], axis=1) / sizes[:, None]
    shared = sizes[data.group] > 1
    out = error_stats(p[shared] - means[data.group[shared]]).to_dict()
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


def deviation_jacobian(chain, data, names):
    """(K, 3, P): how each ball centre's deviation from its socket's mean (the K
    configurations whose socket holds more than one) moves with the named parameters:
    what socket consistency sees of a parameter deviation."""
    positions = chain.identification_jacobian(data.joints, list(names))[:, :3, :]
    sizes = np.bincount(data.group)
    flat = positions.reshape(len(positions), -1)
    means = np.stack([np.bincount(data.group, weights=flat[:, c], minlength=len(sizes))
                      for c in range(flat.shape[1])], axis=1) / sizes[:, None]
    shared = sizes[data.group] > 1
    return (flat - means[data.group])[shared].reshape(-1, 3, len(names))
