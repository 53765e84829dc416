"""What happens between a joint command and the link: gravity compliance and gear backlash.

Both act on the *model* joint variables (``Chain.model_joints``), because that is where a
gear sits: a coupled controller axis (FANUC's J2/J3) still has one gear per model joint.
They return offsets of the model variables; :func:`to_controller` turns an offset back into
controller joint values so that ``Chain.fk`` can evaluate the deflected configuration.

Mass model (deliberately simple, for simulation only):

* link i (the body that joint i moves and joint i+1 does not) is one point mass halfway
  between the origin of joint i and the origin of joint i+1, the origin of a joint being
  the point on its axis that ``Chain.joint_frames`` reports; the last link's mass sits
  halfway between the last joint origin and the TCP;
* the payload is a point mass at the TCP;
* gravity points along -z of the world (measurement) frame, g = 9.80665 m/s².

The gravity torque of joint i is the moment of the weights of everything it carries about
its axis, tau_i = z_i · sum_j (p_j - o_i) x m_j g, which equals -dV/dq_i for the potential
energy V = sum_j m_j g z_j.  A joint of stiffness k_i (N·m/rad) then gives way by
tau_i / k_i in the direction gravity pulls.  Prismatic joints carry the force z_i · sum m_j g
(N) with a stiffness in N/mm, so their deflection comes out in mm.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

GRAVITY = 9.80665  # m/s², standard gravity
MM = 1e-3  # metres per millimetre: torques are N·m while positions are mm


def _per_joint(values, n, what):
    """A validated (n,) float array of finite values >= 0."""
    out = np.array(values, dtype=float).reshape(-1)
    if out.shape != (n,):
        raise InputError(f"{what} needs one value per joint ({n}), got {out.size}")
    if not np.all(np.isfinite(out)) or np.any(out < 0):
        raise InputError(f"{what} must be finite and >= 0, got {out.tolist()}")
    return out


@dataclass(frozen=True, eq=False)
class Compliance:
    """Joint stiffness and the mass model that loads it (see the module docstring).

    stiffness: (n,) per model joint, N·m/rad for revolute joints and N/mm for prismatic
        ones; ``inf`` makes a joint rigid.
    link_masses: (n,) kg, link i's point mass.
    payload: kg at the TCP.
    """

    stiffness: np.ndarray
    link_masses: np.ndarray
    payload: float = 0.0

    def __post_init__(self):
        n = np.size(self.stiffness)
        stiffness = np.array(self.stiffness, dtype=float).reshape(-1)
        if np.any(stiffness <= 0) or np.any(np.isnan(stiffness)):
            raise InputError(f"joint stiffness must be > 0 (inf for a rigid joint), got {stiffness.tolist()}")
        object.__setattr__(self, "stiffness", stiffness)
        object.__setattr__(self, "link_masses", _per_joint(self.link_masses, n, "link masses (kg)"))
        payload = float(self.payload)
        if not np.isfinite(payload) or payload < 0:
            raise InputError(f"payload must be a finite mass >= 0 kg, got {self.payload}")
        object.__setattr__(self, "payload", payload)

    @property
    def masses(self):
        """(n + 1,) kg: the link masses, then the payload."""
        return np.append(self.link_masses, self.payload)

    def check_robot(self, chain):
        """InputError unless this describes as many joints as ``chain`` has."""
        if self.stiffness.size != chain.n_joints:
            raise InputError(
                f"the compliance describes {self.stiffness.size} joints; robot {chain.name!r} has {chain.n_joints}"
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

    def potential_energy(self, chain, q):
        """(N,) gravitational potential energy (J) relative to z = 0 of the world frame."""
        heights = self.mass_points(chain, q)[..., 2] * MM
        return GRAVITY * heights @ self.masses

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

    def deflection(self, chain, q):
        """(N, n) model-joint deflection tau / k (rad; mm for prismatic joints)."""
        return self.gravity_torque(chain, q) / self.stiffness


def backlash_offsets(q_model, half_width, previous_model):
    """(N, n) backlash offsets of the model joints along a sequence of commands.

    Each joint sits ``+half_width`` off its command after moving in the positive direction
    and ``-half_width`` after moving in the negative one; a row that does not move a joint
    keeps the side of that joint's last motion, and a joint that has not moved yet sits in
    the middle of its play (offset 0).  ``previous_model`` (n,) is where the sequence starts.
    """
    path = np.vstack([previous_model[None, :], q_model])
    step = np.sign(np.diff(path, axis=0))
    rows = np.arange(step.shape[0])[:, None]
    # Row of each joint's latest motion so far (-1 before the first one): a running maximum
    # of the row numbers where the joint moved carries the last direction forward.
    last = np.maximum.accumulate(np.where(step != 0, rows, -1), axis=0)
    direction = np.where(last >= 0, np.take_along_axis(step, np.maximum(last, 0), axis=0), 0.0)
    return direction * half_width


def to_controller(chain, offset_model):
    """Model-joint offsets (N, n) -> the controller joint offsets that produce them."""
    return np.linalg.solve(chain.joint_map, offset_model.T).T
