"""What happens between a joint command and the link: gravity compliance and gear backlash.

Both act on the *model* joint variables (``Chain.model_joints``), because that is where a
gear sits: a coupled controller axis (FANUC's J2/J3) still has one gear per model joint.
They return offsets of the model variables; :func:`to_controller` turns an offset back into
controller joint values so that ``Chain.fk`` can evaluate the deflected configuration.

The mass model and the gravity torque are :mod:`robocal.kinematics.gravity`'s; a joint of
stiffness k_i (N·m/rad) gives way by tau_i / k_i in the direction gravity pulls.  Prismatic
joints take a stiffness in N/mm, so their deflection comes out in mm.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..kinematics.gravity import MassModel, per_joint


@dataclass(frozen=True, eq=False)
class Compliance:
    """Joint stiffness and the mass model that loads it.

    stiffness: (n,) per model joint, N·m/rad for revolute joints and N/mm for prismatic
        ones; ``inf`` makes a joint rigid.
    link_masses: (n,) kg, link i's point mass.
    payload: kg at the TCP.
    """

    stiffness: np.ndarray
    link_masses: np.ndarray
    payload: float = 0.0

    def __post_init__(self):
        stiffness = np.array(self.stiffness, dtype=float).reshape(-1)
        if np.any(stiffness <= 0) or np.any(np.isnan(stiffness)):
            raise InputError(f"joint stiffness must be > 0 (inf for a rigid joint), got {stiffness.tolist()}")
        object.__setattr__(self, "stiffness", stiffness)
        object.__setattr__(self, "link_masses", per_joint(self.link_masses, stiffness.size, "link masses (kg)"))
        object.__setattr__(self, "payload", self.mass_model.payload)

    @property
    def mass_model(self):
        return MassModel(self.link_masses, self.payload)

    @property
    def masses(self):
        """(n + 1,) kg: the link masses, then the payload."""
        return self.mass_model.masses

    def check_robot(self, chain):
        """InputError unless this describes as many joints as ``chain`` has."""
        if self.stiffness.size != chain.n_joints:
            raise InputError(
                f"the compliance describes {self.stiffness.size} joints; robot {chain.name!r} has {chain.n_joints}"
            )

    def gravity_torque(self, chain, q):
        """(N, n) gravity torque of each model joint (N·m; N for prismatic joints)."""
        self.check_robot(chain)
        return self.mass_model.gravity_torque(chain, q)

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
