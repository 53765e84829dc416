"""Gravity loads on the joints of a chain, from a deliberately simple mass model.

Both the simulator (a true robot whose joints give way under gravity) and the calibration
(which identifies how much they give way) need the gravity torque of every joint at many
configurations, so it lives with the kinematics.

Mass model:

* link i (the body that joint i moves and joint i+1 does not) is one point mass halfway
  between the origin of joint i and the origin of joint i+1, the origin of a joint being
  the point on its axis that ``Chain.joint_frames`` reports; the last link's mass sits
  halfway between the last joint origin and the TCP;
* the payload is a point mass at the TCP;
* gravity points along -z of the chain's world frame, g = 9.80665 m/s².

The gravity torque of joint i is the moment of the weights of everything it carries about
its axis, tau_i = z_i · sum_j (p_j - o_i) x m_j g, which equals -dV/dq_i for the potential
energy V = sum_j m_j g z_j.  Prismatic joints carry the force z_i · sum m_j g (N).
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

GRAVITY = 9.80665  # m/s², standard gravity
MM = 1e-3  # metres per millimetre: torques are N·m while positions are mm

# The design every robot's default mass model is scaled from: a KUKA KR 150-2, 3.46 m of
# links between joint origins and TCP, about 1000 kg of moving structure, 150 kg payload.
REFERENCE_LENGTH = 3463.0  # mm
REFERENCE_ARM_MASS = 1000.0  # kg
REFERENCE_PAYLOAD = 150.0  # kg


def per_joint(values, n, what):
    """A validated (n,) float array of finite values >= 0."""
    out = np.array(values, dtype=float).reshape(-1)
    if out.shape != (n,):
        raise InputError(f"{what} needs one value per joint ({n}), got {out.size}")
    if not np.all(np.isfinite(out)) or np.any(out < 0):
        raise InputError(f"{what} must be finite and >= 0, got {out.tolist()}")
    return out


@dataclass(frozen=True, eq=False)
class MassModel:
    """Point masses of the links (kg, one per joint) and of the payload at the TCP (kg)."""

    link_masses: np.ndarray
    payload: float = 0.0

    def __post_init__(self):
        masses = np.array(self.link_masses, dtype=float).reshape(-1)
        object.__setattr__(self, "link_masses", per_joint(masses, masses.size, "link masses (kg)"))
        payload = float(self.payload)
        if not np.isfinite(payload) or payload < 0:
            raise InputError(f"payload must be a finite mass >= 0 kg, got {self.payload}")
        object.__setattr__(self, "payload", payload)

    @property
    def masses(self):
        """(n + 1,) kg: the link masses, then the payload."""
        return np.append(self.link_masses, self.payload)

    def check_robot(self, chain):
        """InputError unless this describes as many links as ``chain`` has joints."""
        if self.link_masses.size != chain.n_joints:
            raise InputError(
                f"the mass model describes {self.link_masses.size} links; robot {chain.name!r} "
                f"has {chain.n_joints} joints"
            )

    def _bodies(self, chain, q):
        """Joint axes (N, n, 3), joint origins (N, n, 3) and mass positions (N, n + 1, 3)."""
        self.check_robot(chain)
        rot, origins, tcp = chain.joint_frames(q)
        tip = tcp[:, None, :3, 3]
        ends = np.concatenate([origins[:, 1:], tip], axis=1)
        return rot[..., 2], origins, np.concatenate([0.5 * (origins + ends), tip], axis=1)

    def mass_points(self, chain, q):
        """(N, n + 1, 3) positions (mm, world frame) of the link masses and the payload."""
        return self._bodies(chain, q)[2]

    def gravity_torque(self, chain, q):
        """(N, n) torque (N·m; N for prismatic joints) that gravity exerts on each model joint.

        Vectorised over configurations: joint i carries bodies i..n, so the suffix sums of
        the masses and of their first moments give every joint's load at once.
        """
        axis, origins, points = self._bodies(chain, q)
        masses = self.masses
        carried = np.cumsum(masses[::-1])[::-1][:-1]  # (n,) mass joint i carries
        moments = np.cumsum((points * masses[:, None])[:, ::-1], axis=1)[:, ::-1][:, :-1]
        arm = (moments - carried[:, None] * origins) * MM  # (N, n, 3) kg·m about each joint
        # z · (r x (0, 0, -g)) = g (z_y r_x - z_x r_y); a prismatic joint carries z · (0, 0, -g) M.
        revolute = GRAVITY * (axis[..., 1] * arm[..., 0] - axis[..., 0] * arm[..., 1])
        prismatic = -GRAVITY * carried * axis[..., 2]
        return np.where(chain.revolute, revolute, prismatic)


def link_lengths(chain):
    """(n,) mm between consecutive joint origins, the last one to the TCP.

    They do not depend on the configuration: both ends of each are fixed in the same link.
    """
    _, origins, tcp = chain.joint_frames(np.zeros(chain.n_joints))
    ends = np.concatenate([origins[0, 1:], tcp[0, None, :3, 3]])
    return np.linalg.norm(ends - origins[0], axis=1)


def size_factor(chain):
    """The robot's total link length over the reference design's."""
    return link_lengths(chain).sum() / REFERENCE_LENGTH


def scaled_mass_model(chain, payload=None):
    """The reference design scaled to ``chain``'s size s: masses grow as s³, the moving mass
    spread over the links in proportion to their length; the payload (kg at the TCP) is the
    rated one scaled the same way unless given."""
    lengths = link_lengths(chain)
    size = lengths.sum() / REFERENCE_LENGTH
    return MassModel(link_masses=REFERENCE_ARM_MASS * size**3 * lengths / lengths.sum(),
                     payload=REFERENCE_PAYLOAD * size**3 if payload is None else payload)


# No arm carries more than a few times its own moving mass (a cobot its third, a KR 150 a
# sixth, the lightest-armed designs about one): a payload above this many times the arm's
# link masses is another unit (grams for kg), and would bend the model by metres.
LARGEST_PAYLOAD_PER_ARM_MASS = 5.0


def default_mass_model(chain, payload=None):
    """The robot's own link masses when its file gives them (``mass`` per joint) with
    ``payload`` kg at the TCP (default 0: the file describes the arm, and a calibration
    target weighs little), else :func:`scaled_mass_model`.  InputError for a payload above
    LARGEST_PAYLOAD_PER_ARM_MASS times the arm's link masses."""
    model = (scaled_mass_model(chain, payload) if chain.masses is None
             else MassModel(link_masses=chain.masses, payload=0.0 if payload is None else payload))
    arm = float(np.sum(model.link_masses))
    if payload is not None and payload > LARGEST_PAYLOAD_PER_ARM_MASS * arm:
        raise InputError(f"--payload {payload:g} kg is more than {LARGEST_PAYLOAD_PER_ARM_MASS:g} times the "
                         f"arm's own {arm:.1f} kg ('{chain.name}'): give the payload in kg (grams divided by 1000)")
    return model
