"""A rigid chain whose loaded joints give way under gravity: what ``full+compliance``
calibration identifies.

Each model joint i deflects by c_i · tau_i(q), tau_i the gravity torque of
:class:`~robocal.kinematics.gravity.MassModel` at the commanded configuration and c_i the
joint's compliance (rad/(N·m)).  The robot then stands where the rigid chain puts the
deflected joints.  Only the product c_i · tau_i moves the robot, so the compliances are
relative to the mass model: a mass model twice too heavy gives compliances half as large
and the same deflections.

Gravity points along -z of the robot base (a floor-mounted robot), not of the measurement
frame, whose z a laser tracker need not keep vertical.

The class offers what the calibration and the compensation ask of a chain (forward
kinematics, identification Jacobian, named parameters, perturbation) and hands everything
else to the rigid chain.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .chain import gain_index
from .gravity import MassModel, default_mass_model

PREFIX = "compliance"
# A joint whose gravity torque never exceeds this share of the most loaded joint's gets no
# compliance parameter: its deflection would be far below any measurement noise.
LOADED_SHARE = 0.01
# Compliances are shown in micro-radians per N·m (a 150 kg-class joint: about 0.01).
FILE_UNIT = 1e6
UNITS_NOTE = "mm for lengths, deg for angles, urad/(N*m) for compliances, ppm for joint gains"
# Deflections of a few hundredths of a degree are gone after this many fixed-point steps
# (each shrinks the error by about dtau/dq · c, below 1e-3).
COMMAND_ITERATIONS = 6


def file_units(chain, names):
    """(P,) factors from internal units (mm, rad, rad/(N·m), gain) to the ones files and
    reports show (mm, deg, µrad/(N·m), ppm)."""
    n_joints = getattr(chain, "rigid", chain).n_joints
    return np.array([FILE_UNIT if compliance_index(n) is not None or gain_index(n, n_joints) is not None
                     else np.degrees(1.0) if chain.is_angular(n) else 1.0 for n in names])


def compliance_index(name):
    """Joint index (0-based) of a compliance parameter name, or None for any other name."""
    if name.startswith(PREFIX) and name[len(PREFIX):].isdigit():
        return int(name[len(PREFIX):]) - 1
    return None


@dataclass(frozen=True, eq=False)
class CompliantChain:
    """rigid: the chain; mass_model: its MassModel; compliance: (n,) rad/(N·m) per model
    joint (0 for a joint taken as rigid; the identified value may be of either sign)."""

    rigid: object
    mass_model: MassModel
    compliance: np.ndarray

    def __post_init__(self):
        self.mass_model.check_robot(self.rigid)
        compliance = np.array(self.compliance, dtype=float).reshape(-1)
        if compliance.shape != (self.rigid.n_joints,) or not np.all(np.isfinite(compliance)):
            raise InputError(f"compliance needs {self.rigid.n_joints} finite values, got {compliance.tolist()}")
        object.__setattr__(self, "compliance", compliance)

    def __getattr__(self, name):
        # Geometry, limits and names are the rigid chain's.
        if name in ("rigid", "mass_model", "compliance"):
            raise AttributeError(name)
        return getattr(self.rigid, name)

    # ------------------------------------------------------------ deflection
    def gravity_torque(self, q):
        """(N, n) N·m, gravity along -z of the robot base."""
        upright = self.rigid.replace(base=np.eye(4))
        return self.mass_model.gravity_torque(upright, np.atleast_2d(np.asarray(q, dtype=float)))

    def deflection(self, q):
        """(N, n) model-joint deflection (rad) at commanded joints q."""
        return self.gravity_torque(q) * self.compliance

    def deflected(self, q):
        """The controller joints at which the rigid chain stands when q is commanded."""
        q2 = np.atleast_2d(np.asarray(q, dtype=float))
        out = q2 + np.linalg.solve(self.rigid.joint_map, self.deflection(q2).T).T
        return out[0] if np.ndim(q) == 1 else out

    def commands_for(self, q_rigid):
        """Commanded joints that make the compliant robot stand at ``q_rigid`` of the rigid chain
        (the fixed point of q = q_rigid - deflection(q)); NaN rows stay NaN."""
        q_rigid = np.atleast_2d(np.asarray(q_rigid, dtype=float))
        q = q_rigid.copy()
        for _ in range(COMMAND_ITERATIONS):
            q = q_rigid - (self.deflected(q) - q)
        return q

    # ------------------------------------------------------------ kinematics
    def fk(self, q):
        return self.rigid.fk(self.deflected(q))

    def fk_positions(self, q):
        return self.rigid.fk_positions(self.deflected(q))

    # ------------------------------------------------------------ parameters
    def replace(self, **changes):
        return CompliantChain(self.rigid.replace(**changes), self.mass_model, self.compliance)

    def parameter_names(self, groups=("links", "base", "tool")):
        names = [g for g in groups if g != "compliance"]
        out = self.rigid.parameter_names(tuple(names))
        if "compliance" in groups:
            out += [f"{PREFIX}{k}" for k in range(1, self.rigid.n_joints + 1)]
        return out

    def is_angular(self, name):
        return False if compliance_index(name) is not None else self.rigid.is_angular(name)

    def _split(self, names):
        joints = [compliance_index(name) for name in names]
        geometric = [j for j, k in enumerate(joints) if k is None]
        return joints, geometric

    def parameter_values(self, names=None):
        names = self.parameter_names() if names is None else list(names)
        joints, geometric = self._split(names)
        out = np.array([0.0 if k is None else self.compliance[k] for k in joints])
        out[geometric] = self.rigid.parameter_values([names[j] for j in geometric])
        return out

    def identification_jacobian(self, q, names=None):
        """(N, 6, P).  Geometric columns at the deflected joints (their change of the torque
        is second order); compliance column i is the joint-i column times tau_i."""
        names = self.parameter_names() if names is None else list(names)
        q2 = np.atleast_2d(np.asarray(q, dtype=float))
        joints, geometric = self._split(names)
        loaded = sorted({k for k in joints if k is not None})
        extra = [f"theta{k + 1}" for k in loaded]
        standing = self.deflected(q2)
        jac = self.rigid.identification_jacobian(standing, [names[j] for j in geometric] + extra)
        out = np.empty((len(q2), 6, len(names)))
        out[:, :, geometric] = jac[:, :, :len(geometric)]
        if loaded:
            torque = self.gravity_torque(q2)
            joint_column = dict(zip(loaded, np.moveaxis(jac[:, :, len(geometric):], 2, 0)))
            for j, k in enumerate(joints):
                if k is not None:
                    out[:, :, j] = joint_column[k] * torque[:, k, None]
        return out

    def perturbed(self, names, deviations=None):
        items = dict(names) if deviations is None else dict(zip(names, np.asarray(deviations, float).reshape(-1)))
        compliance = self.compliance.copy()
        geometric = {}
        for name, value in items.items():
            k = compliance_index(name)
            if k is None:
                geometric[name] = value
            else:
                compliance[k] += value
        rigid = self.rigid.perturbed(geometric) if geometric else self.rigid
        return CompliantChain(rigid, self.mass_model, compliance)


def with_compliance(chain, joints, payload=None):
    """``chain`` made compliant (all compliances zero, the default mass model with ``payload``
    kg at the TCP, by default as there) and the names of the compliances of its loaded
    joints: revolute joints whose gravity torque over ``joints`` reaches LOADED_SHARE of the
    most loaded joint's."""
    compliant = CompliantChain(chain, default_mass_model(chain, payload), np.zeros(chain.n_joints))
    peak = np.abs(compliant.gravity_torque(joints)).max(axis=0)
    loaded = chain.revolute & (peak > LOADED_SHARE * max(peak.max(), 1e-300))
    return compliant, [f"{PREFIX}{k + 1}" for k in np.flatnonzero(loaded)]
