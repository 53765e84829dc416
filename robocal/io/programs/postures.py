"""The posture a program names, computed from joint values, so that the inverse kinematics
branch a target asks for can be chosen.

Both KUKA's status and ABB's cfx come from the same two facts about an arm with a spherical
wrist, plus the sign of axis 5:

* whether the wrist centre lies behind axis 1 (its x in the frame that turns with axis 1 is
  negative: KUKA's "overhead area", status bit 0; ABB's "behind axis 1", cfx bit 2);
* on which side of the stretched arm the elbow is (KUKA's "A3 >= phi", status bit 1, is 1
  at the home posture A2 = -90, A3 = 90; ABB's "wrist centre behind the lower arm", cfx
  bit 1, is 0 at the zero posture).

KUKA: S = overhead + 2 elbow + 4 (A5 < 0); T bit k is 1 when axis k + 1 is negative.
ABB confdata: cf1, cf4, cf6 the quadrants floor(angle / 90 deg) of axes 1, 4 and 6;
cfx = 4 behind + 2 elbow + (axis 5 < 0).
"""
import numpy as np

# Controller postures (deg) at which the elbow bit is known: KUKA's home has bit 1 set, ABB's
# zero posture has the wrist centre in front of the lower arm.
KUKA_ELBOW_SET = (0.0, -90.0, 90.0, 0.0, 45.0, 0.0)
ABB_ELBOW_CLEAR = (0.0, 0.0, 0.0, 0.0, 45.0, 0.0)


def _closest_points(p1, d1, p2, d2):
    """Midpoints of the closest points of lines (p1, d1) and (p2, d2): (N, 3)."""
    w = p1 - p2
    a, b, c = (d1 * d1).sum(-1), (d1 * d2).sum(-1), (d2 * d2).sum(-1)
    d, e = (d1 * w).sum(-1), (d2 * w).sum(-1)
    den = np.where(np.abs(a * c - b * b) < 1e-12, 1.0, a * c - b * b)
    s, t = (b * e - c * d) / den, (a * e - b * d) / den
    return 0.5 * (p1 + s[:, None] * d1 + p2 + t[:, None] * d2)


def _arm(chain, q):
    """(behind (N,) bool, elbow sign (N,)) of controller joints q (N, 6) rad."""
    rot, origin, _ = chain.joint_frames(q)
    axes = rot[..., 2]  # (N, n, 3)
    centre = _closest_points(origin[:, 4], axes[:, 4], origin[:, 5], axes[:, 5])
    # The frame that turns with axis 1: forward is where the wrist centre lies at zero.
    rot0, origin0, _ = chain.joint_frames(np.zeros((1, chain.n_joints)))
    centre0 = _closest_points(origin0[:, 4], rot0[:, 4, :, 2], origin0[:, 5], rot0[:, 5, :, 2])
    local = np.einsum("ji,j->i", rot0[0, 0], centre0[0] - origin0[0, 0])
    forward = np.einsum("nij,j->ni", rot[:, 0], local)
    forward -= (forward * axes[:, 0]).sum(-1, keepdims=True) * axes[:, 0]
    behind = ((centre - origin[:, 0]) * forward).sum(-1) < 0
    elbow = np.einsum("ni,ni->n", np.cross(centre - origin[:, 2], origin[:, 2] - origin[:, 1]), axes[:, 2])
    return behind, np.sign(elbow)


def _elbow_bit(chain, sign, reference, value):
    """The elbow bit of configurations whose elbow sign is ``sign``: ``value`` on the side
    of the ``reference`` posture (controller deg), 1 - value on the other."""
    _, at_reference = _arm(chain, chain.joints_from_file(np.array([reference])))
    return np.where(sign == at_reference[0], value, 1 - value)


def kuka(chain, q):
    """(S (N,), T (N,)) of controller joints q (N, 6) rad."""
    degrees = np.degrees(q)
    behind, sign = _arm(chain, q)
    elbow = _elbow_bit(chain, sign, KUKA_ELBOW_SET, 1)
    status = behind.astype(int) + 2 * elbow + 4 * (degrees[:, 4] < 0)
    turn = ((degrees < 0) * (1 << np.arange(q.shape[1]))).sum(axis=1)
    return status, turn


def abb(chain, q):
    """(cf1, cf4, cf6, cfx) (N, 4) of controller joints q (N, 6) rad."""
    degrees = np.degrees(q)
    behind, sign = _arm(chain, q)
    elbow = _elbow_bit(chain, sign, ABB_ELBOW_CLEAR, 0)
    quadrants = np.floor(degrees[:, [0, 3, 5]] / 90.0).astype(int)
    cfx = 4 * behind.astype(int) + 2 * elbow + (degrees[:, 4] < 0)
    return np.column_stack([quadrants, cfx])
