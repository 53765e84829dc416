"""What one measured pose tells the parametric calibration: the rows of the identification
Jacobian it adds, on the parameters the calibration will identify, scaled and weighted.

The parameter list is the one :class:`~robocal.estimation.calibration.KinematicCalibration`
sets up (:func:`~robocal.estimation.calibration.candidate_parameters`: base frame, tool
position, the links with Hayati's beta on parallel axes, the joint gains or compliances of
the larger sets), reduced to what the whole candidate set can determine by the same
identifiability analysis the calibration runs (:func:`~robocal.estimation.identifiability.analyse`).
Columns are scaled so that each has unit RMS over the candidates (a pose "counts one" for
each parameter); every pose's three position rows are divided by the standard deviation of
its reading, so that the information matrix M = sum of A_i^T A_i of the chosen poses is the
inverse of the covariance of the scaled parameters, in mm^-2 per scaled unit squared.

A laser tracker's noise grows with distance: with ``tracker`` (its position in the robot
base frame, mm) a pose's sigma is sqrt(noise^2 + (per_metre * distance / 1000)^2).

A joint noise b (deg; :func:`joint_covariance`) is an error at every revolute joint that the
calibration does not model, independent from pose to pose: gear backlash (a joint stands
+-b off its command depending on the side it came from) or the play of a worn joint.  At
the TCP it is J_q diag(b^2) J_q^T, which grows with the reach: 0.005 deg of backlash on each
joint of a KUKA KR 150-2 is 0.2-0.3 mm at the TCP, ten times a tracker's 0.02 mm.

A sag s (deg; :func:`sag_columns`) is the gravity bending of the joints that a parameter set
without compliances leaves out: systematic, with the shape of each loaded joint's gravity
torque and a size the design does not know, taken as one compliance common to the joints
with a standard deviation that bends the most loaded joint by s at its largest torque.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..estimation.calibration import candidate_parameters, parameter_terms
from ..estimation.identifiability import analyse
from ..kinematics.compliant import with_compliance

# Length-dependent part of a laser tracker's standard uncertainty, mm per metre of distance
# (a typical absolute-interferometer tracker: about 15 um + 6 um/m as a maximum permissible
# error, of which a standard deviation is about half).
TRACKER_PER_METRE = 0.003


@dataclass(frozen=True)
class InformationModel:
    """The per-pose information of a set of candidate configurations.

    names: the identifiable parameters (tuple of str, the calibration's order); fixed:
    {name: reason} for the parameters of the set that the candidates cannot determine;
    chain: the model the Jacobian was taken at (compliant for the compliance sets);
    blocks: (N, 3, P) weighted, scaled Jacobian rows A_i of the candidates; scale: (P,)
    internal units -> scaled units (a scaled parameter is value * scale); sigma: (N,) mm, each
    candidate's noise; file_units: (P,) internal -> file units (deg, mm, ppm).
    """

    names: tuple
    fixed: dict
    chain: object
    blocks: np.ndarray
    scale: np.ndarray
    sigma: np.ndarray
    file_units: np.ndarray

    @property
    def n_parameters(self):
        return len(self.names)

    def rows_of(self, joints, sigma=None):
        """(M, 3, P) weighted scaled rows of other configurations (rad) with the same
        parameters and scaling; ``sigma`` (M,) mm or None for unweighted rows (targets)."""
        jac = self.chain.identification_jacobian(joints, self.names)[:, :3, :] / self.scale
        return jac if sigma is None else jac / np.asarray(sigma, float)[:, None, None]


def parameter_names(chain, parameters, joints, payload=None):
    """(the chain the Jacobian is taken at, the calibration's candidate parameter names) for
    a parameter set, as :class:`KinematicCalibration` sets them up for these ``joints``."""
    names = candidate_parameters(chain, parameters)
    if "compliance" in parameter_terms(parameters):
        chain, compliances = with_compliance(chain, joints, payload)
        names += compliances
    return chain, names


def noise_of(chain, joints, noise, tracker=None, per_metre=TRACKER_PER_METRE):
    """(N,) standard deviation (mm) of each pose's position reading: ``noise``, growing with
    the distance from ``tracker`` (x, y, z in mm, robot base frame) when it is given."""
    noise = float(noise)
    if not np.isfinite(noise) or noise <= 0:
        raise InputError(f"the measurement noise must be a standard deviation > 0 mm, got {noise}")
    count = len(joints)
    if tracker is None:
        return np.full(count, noise)
    where = np.asarray(tracker, dtype=float)
    if where.shape != (3,) or not np.all(np.isfinite(where)):
        raise InputError(f"the tracker position must be x, y, z in mm, got {np.ravel(tracker).tolist()}")
    distance = np.linalg.norm(chain.fk_positions(joints) - where, axis=1)
    return np.sqrt(noise ** 2 + (per_metre * distance / 1000.0) ** 2)


def joint_covariance(chain, joints, sigma, joint_noise_deg):
    """(N, 3, 3) covariance of each pose's position reading relative to sigma^2 (``sigma``
    (N,) mm, the reading's own noise): I + (b / sigma)^2 J_q J_q^T over the revolute joints,
    b = ``joint_noise_deg`` deg (module notes).  None when the joint noise is 0."""
    joint_noise_deg = float(joint_noise_deg)
    if not np.isfinite(joint_noise_deg) or joint_noise_deg < 0:
        raise InputError(f"the joint noise must be a standard deviation >= 0 deg, got {joint_noise_deg}")
    if joint_noise_deg == 0:
        return None
    jac = chain.rigid.jacobian(np.asarray(joints, dtype=float))[:, :3, :] * np.where(chain.revolute, 1.0, 0.0)
    relative = np.radians(joint_noise_deg) / np.asarray(sigma, dtype=float)
    return np.eye(3) + relative[:, None, None] ** 2 * np.einsum("kij,klj->kil", jac, jac)


def sag_columns(chain, joints, sag_deg, *, reference=None, payload=None):
    """(N, 3, k) mm: the TCP displacement at ``joints`` (N, n) rad of each of the k loaded
    joints (:func:`~robocal.kinematics.compliant.with_compliance`) bending by ``sag_deg`` deg
    times its gravity torque over the largest torque of any joint over ``reference`` (default
    ``joints``): the shapes of the sag a parameter set without compliances leaves out (module
    notes).  None when the sag is 0."""
    sag_deg = float(sag_deg)
    if not np.isfinite(sag_deg) or sag_deg < 0:
        raise InputError(f"the sag must be an angle >= 0 deg, got {sag_deg}")
    if sag_deg == 0:
        return None
    q = np.asarray(joints, dtype=float)
    compliant, names = with_compliance(chain, q if reference is None else reference, payload)
    largest = np.abs(compliant.gravity_torque(q if reference is None else reference)).max()
    loaded = [compliant.parameters[name].joint - 1 for name in names]
    if not loaded or largest <= 0:
        return None
    torque = compliant.gravity_torque(q)[:, loaded] / largest
    jac = chain.rigid.jacobian(q)[:, :3, :][:, :, loaded]
    return jac * torque[:, None, :] * np.radians(sag_deg)


def information_model(chain, joints, parameters="full", *, noise=0.02, tracker=None, payload=None):
    """The :class:`InformationModel` of candidate configurations ``joints`` (N, n) rad for
    the calibration of ``parameters`` (a parameter set of :mod:`robocal.estimation.calibration`).

    The identifiable set is what all candidates together determine: a design can only choose
    among them, so what they cannot tell apart no subset can."""
    q = np.asarray(joints, dtype=float)
    model_chain, names = parameter_names(chain, parameters, q, payload)
    sigma = noise_of(chain, q, noise, tracker)
    jac = model_chain.identification_jacobian(q, names)[:, :3, :]
    kept, report = analyse(model_chain, (jac / sigma[:, None, None]).reshape(-1, len(names)), names)
    jac = jac[:, :, kept]
    scale = np.sqrt(np.mean(np.sum(jac ** 2, axis=1), axis=0))
    identified = tuple(names[k] for k in kept)
    return InformationModel(
        names=identified, fixed=dict(report.fixed), chain=model_chain, blocks=jac / scale / sigma[:, None, None],
        scale=scale, sigma=sigma, file_units=model_chain.parameters.file_units(identified))
