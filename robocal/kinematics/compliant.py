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

The class declares what the calibration and the compensation ask of a chain: forward
kinematics, identification Jacobian, the parameter space, perturbation, the rigid chain's
geometry, limits and joint conversions.  What it does not declare (the geometric Jacobian,
joint frames, POE frames) belongs to ``rigid``: ask the rigid chain for it.
"""
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import FileFormatError, InputError
from .gravity import MassModel, default_mass_model
from .parameters import COMPLIANCE, FILE_UNIT, ParameterSpace

# A joint whose gravity torque never exceeds this share of the most loaded joint's gets no
# compliance parameter: its deflection would be far below any measurement noise.
LOADED_SHARE = 0.01
UNITS_NOTE = "mm for lengths, deg for angles, urad/(N*m) for compliances, ppm for joint gains"
# Deflections of a few hundredths of a degree are gone after this many fixed-point steps
# (each shrinks the error by about dtau/dq · c, below 1e-3).
COMMAND_ITERATIONS = 6
GRAVITY_NOTE = "-z of the robot base"


def file_units(chain, names):
    """(P,) factors from internal units (mm, rad, rad/(N·m), gain) to the ones files and
    reports show (mm, deg, µrad/(N·m), ppm)."""
    return chain.parameters.file_units(names)


def _rigid_field(name):
    return property(lambda self: getattr(self.rigid, name), doc=f"The rigid chain's ``{name}``.")


def _rigid_method(name):
    def method(self, *args, **kwargs):
        return getattr(self.rigid, name)(*args, **kwargs)

    method.__name__ = name
    method.__doc__ = f"The rigid chain's :meth:`~robocal.kinematics.Chain.{name}` (joints as commanded)."
    return method


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

    # ------------------------------------------------ what is the rigid chain's
    # Geometry, limits and joint conversions do not change with the compliance.
    name = _rigid_field("name")
    convention = _rigid_field("convention")
    joint_types = _rigid_field("joint_types")
    joint_names = _rigid_field("joint_names")
    n_joints = _rigid_field("n_joints")
    revolute = _rigid_field("revolute")
    theta = _rigid_field("theta")
    d = _rigid_field("d")
    a = _rigid_field("a")
    alpha = _rigid_field("alpha")
    beta = _rigid_field("beta")
    axes = _rigid_field("axes")
    points = _rigid_field("points")
    home = _rigid_field("home")
    joint_map = _rigid_field("joint_map")
    lower = _rigid_field("lower")
    upper = _rigid_field("upper")
    base = _rigid_field("base")
    flange = _rigid_field("flange")
    tool = _rigid_field("tool")
    masses = _rigid_field("masses")
    tolerances = _rigid_field("tolerances")
    within_limits = _rigid_method("within_limits")
    random_configurations = _rigid_method("random_configurations")
    joints_from_file = _rigid_method("joints_from_file")
    joints_to_file = _rigid_method("joints_to_file")
    model_joints = _rigid_method("model_joints")
    joint_batch = _rigid_method("joint_batch")

    # ------------------------------------------------------------ deflection
    def gravity_torque(self, q):
        """(N, n) N·m, gravity along -z of the robot base."""
        return self.mass_model.gravity_torque(self._upright, np.atleast_2d(np.asarray(q, dtype=float)))

    @cached_property
    def _upright(self):
        # The rigid chain with its base at the origin, kept: a new chain compiles its program
        # again (some 0.3 ms), and the compensation asks for the torque a dozen times a target.
        return self.rigid.replace(base=np.eye(4))

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
        """TCP pose of the deflected robot at commanded joints: as :meth:`Chain.fk`."""
        return self.rigid.fk(self.deflected(q))

    def fk_positions(self, q):
        """TCP positions of the deflected robot at commanded joints: as :meth:`Chain.fk_positions`."""
        return self.rigid.fk_positions(self.deflected(q))

    # ------------------------------------------------------------ parameters
    @cached_property
    def parameters(self):
        """The rigid chain's parameter space plus one compliance per joint."""
        return ParameterSpace.of_chain(self.rigid.convention, self.rigid.joint_types, compliance=True)

    def replace(self, **changes):
        """A copy with some fields of the rigid chain changed, the same compliance."""
        return CompliantChain(self.rigid.replace(**changes), self.mass_model, self.compliance)

    def parameter_names(self, groups=("links", "base", "tool")):
        """As :meth:`Chain.parameter_names`, with the group 'compliance' as well."""
        out = self.rigid.parameter_names(tuple(g for g in groups if g != COMPLIANCE))
        if COMPLIANCE in groups:
            out += self.parameters.of_group(COMPLIANCE)
        return out

    def is_angular(self, name):
        """True for parameters measured in radians (compliances are not)."""
        return self.parameters[name].angular

    def _split(self, names):
        """Per name the 0-based joint of a compliance (None for any other), and the
        positions of the geometric names."""
        records = [self.parameters.get(name) for name in names]
        joints = [p.joint - 1 if p is not None and p.group == COMPLIANCE else None for p in records]
        return joints, [j for j, k in enumerate(joints) if k is None]

    def parameter_values(self, names=None):
        """Current values of named parameters (compliances in rad/(N·m))."""
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
        """A new compliant chain with parameter deviations applied: as :meth:`Chain.perturbed`,
        compliances adding to theirs."""
        items = dict(names) if deviations is None else dict(zip(names, np.asarray(deviations, float).reshape(-1)))
        compliance = self.compliance.copy()
        geometric = {}
        for name, value in items.items():
            p = self.parameters.get(name)
            if p is not None and p.group == COMPLIANCE:
                compliance[p.joint - 1] += value
            else:
                geometric[name] = value
        rigid = self.rigid.perturbed(geometric) if geometric else self.rigid
        return CompliantChain(rigid, self.mass_model, compliance)

    # ------------------------------------------------------------ model files
    def compliance_document(self):
        """The joint compliance as model files keep it: masses (kg), compliances
        (µrad/(N·m)) and the direction of gravity, JSON-ready."""
        return {"link_masses_kg": self.mass_model.link_masses.tolist(), "payload_kg": self.mass_model.payload,
                "compliance_urad_per_nm": (self.compliance * FILE_UNIT).tolist(), "gravity": GRAVITY_NOTE}

    @classmethod
    def from_document(cls, chain, doc, where="the model file"):
        """``chain`` made compliant by a :meth:`compliance_document`; FileFormatError, naming
        ``where``, if the document is damaged."""
        try:
            mass = MassModel(doc["link_masses_kg"], doc["payload_kg"])
            return cls(chain, mass, [c / FILE_UNIT for c in doc["compliance_urad_per_nm"]])
        except (KeyError, TypeError, ValueError, InputError) as exc:
            raise FileFormatError(f"{where}: 'joint_compliance' is damaged ({exc}); regenerate the file") from None


def with_compliance(chain, joints, payload=None):
    """``chain`` made compliant (all compliances zero, the default mass model with ``payload``
    kg at the TCP, by default as there) and the names of the compliances of its loaded
    joints: revolute joints whose gravity torque over ``joints`` reaches LOADED_SHARE of the
    most loaded joint's."""
    compliant = CompliantChain(chain, default_mass_model(chain, payload), np.zeros(chain.n_joints))
    peak = np.abs(compliant.gravity_torque(joints)).max(axis=0)
    loaded = chain.revolute & (peak > LOADED_SHARE * max(peak.max(), 1e-300))
    names = compliant.parameters.of_group(COMPLIANCE)
    return compliant, [names[k] for k in np.flatnonzero(loaded)]
