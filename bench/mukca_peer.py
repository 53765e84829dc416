"""The MUKCa calibration objective, written from its paper for a like-for-like comparison.

Franzese, Spahn, Kober, Della Santina, arXiv:2503.12584 (2025): every URDF joint origin of
the Panda (xyz, rpy of joints 1-7) and the ball's origin are free; the cost is, summed over
placements, the scatter of the ball centres about each socket's mean (the two sockets
weighted by their counts) plus the squared error of the distance between the two means, plus
1e-4 times the number of placements times the squared change of the joint origins (SI units);
IPOPT stops after 30 iterations.  Needs CasADi (``pip install '.[bench]'``, IPOPT included);
the bench skips this peer without it.  Not part of robocal.
"""
import xml.etree.ElementTree as ET

import numpy as np

ARM_JOINTS = [f"panda_joint{i}" for i in range(1, 8)]
FIXED_BEFORE_BALL = ["panda_joint8", "panda_hand_joint", "panda_hand_tcp_joint"]
REGULARISATION = 1e-4
MAX_ITERATIONS = 30
SOCKET_DISTANCE_M = 0.05


def available():
    try:
        import casadi  # noqa: F401
    except ImportError:
        return False
    return True


def _origins(urdf_path):
    origins = {}
    for joint in ET.parse(urdf_path).getroot().findall("joint"):
        origin = joint.find("origin")
        xyz = origin.get("xyz", "0 0 0") if origin is not None else "0 0 0"
        rpy = origin.get("rpy", "0 0 0") if origin is not None else "0 0 0"
        origins[joint.get("name")] = np.array([float(v) for v in (xyz + " " + rpy).split()])
    return origins


def _transform(ca, p):
    """URDF origin: translation, then fixed-axis roll, pitch, yaw."""
    cr, sr, cp, sp, cy, sy = ca.cos(p[3]), ca.sin(p[3]), ca.cos(p[4]), ca.sin(p[4]), ca.cos(p[5]), ca.sin(p[5])
    return ca.vertcat(
        ca.horzcat(cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr, p[0]),
        ca.horzcat(sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr, p[1]),
        ca.horzcat(-sp, cp * sr, cp * cr, p[2]),
        ca.horzcat(0, 0, 0, 1),
    )


class MukcaObjective:
    """fit(groups) on training placements, then ball_centres(q) in mm.

    groups: one (q_socket_0, q_socket_1) pair of (M, 7) rad arrays per placement."""

    def __init__(self, urdf_path):
        import casadi as ca

        self._ca = ca
        origins = _origins(urdf_path)
        self.start = np.concatenate([origins[name] for name in ARM_JOINTS + ["ball_joint"]])
        self.params = ca.SX.sym("p", self.start.size)
        q = ca.SX.sym("q", len(ARM_JOINTS))
        frame = ca.SX.eye(4)
        for i in range(len(ARM_JOINTS)):
            c, s = ca.cos(q[i]), ca.sin(q[i])
            turn = ca.vertcat(ca.horzcat(c, -s, 0, 0), ca.horzcat(s, c, 0, 0), ca.horzcat(0, 0, 1, 0),
                              ca.horzcat(0, 0, 0, 1))
            frame = frame @ _transform(ca, self.params[6 * i:6 * i + 6]) @ turn
        for name in FIXED_BEFORE_BALL:
            frame = frame @ _transform(ca, ca.DM(origins[name]))
        frame = frame @ _transform(ca, self.params[-6:])
        self._ball = ca.Function("ball", [q, self.params], [frame[:3, 3]])
        self.values = self.start.copy()

    def fit(self, groups):
        ca = self._ca
        cost = 0
        for sockets in groups:
            centres = [self._ball.map(len(s))(np.asarray(s).T, self.params) for s in sockets]
            counts = [len(s) for s in sockets]
            means = [ca.sum2(c) / n for c, n in zip(centres, counts)]
            scatter = [ca.sum1(ca.sum2((c - m) ** 2)) / n for c, m, n in zip(centres, means, counts)]
            cost += sum(v * n for v, n in zip(scatter, counts)) / sum(counts)
            cost += (ca.norm_2(means[0] - means[1]) - SOCKET_DISTANCE_M) ** 2
        arm = slice(0, 6 * len(ARM_JOINTS))
        cost += len(groups) * REGULARISATION * ca.sumsqr(self.params[arm] - self.start[arm])
        solver = ca.nlpsol("mukca", "ipopt", {"x": self.params, "f": cost},
                           {"ipopt": {"print_level": 0, "max_iter": MAX_ITERATIONS, "sb": "yes"}, "print_time": False})
        self.values = np.array(solver(x0=self.start)["x"]).ravel()
        return self

    def ball_centres(self, q):
        """(N, 3) mm for joint angles q (N, 7) rad."""
        return np.array(self._ball.map(len(q))(np.asarray(q).T, self.values)).T * 1000.0
