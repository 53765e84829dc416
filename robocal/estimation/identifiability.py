"""Which model parameters a data set can determine, and why the others cannot be.

Columns of the identification Jacobian are scaled to unit norm and taken in a preferred
order (base, tool, then the links from the base out); a column joins the identified set when
it adds a direction the columns before it do not span (QR diagonal above a tolerance).  A
column that does not is fixed, and its least-squares expression in the identified columns
names the parameters it cannot be told apart from; geometry then says why (parallel axes, a
base rotation and a joint offset about the same axis, a point on the last axis).
"""
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

# A scaled column whose component outside the span of the columns before it is below this
# is treated as a combination of them.  Its standard error would be about 1/1000 of its effect
# per unit of noise amplified a thousandfold: on the UR5 tracker data 1e-6 kept a wrist
# offset with a 38 deg standard error (condition number 2e5); 1e-3 fixes it and its partner,
# with the same held-out error and a condition number of 99.
RANK_TOLERANCE = 1e-3
# Correlations above this are reported as strongly correlated pairs.
STRONG_CORRELATION = 0.95
# Sine of the angle below which two joint axes count as parallel (Hayati's beta applies).
NEAR_PARALLEL = 0.05


@dataclass(frozen=True)
class IdentifiabilityReport:
    """What the data can determine.

    identified: names kept; fixed: {name: reason}; rank; condition_number, o1 (product of
    singular values to the power 1/P, over sqrt(rows)), o3 (smallest singular value) and
    noise_amplification (sigma_min^2 / sigma_max) of the column-scaled Jacobian of the
    identified parameters.
    """

    identified: tuple
    fixed: dict
    rank: int
    rows: int
    condition_number: float
    o1: float
    o3: float
    noise_amplification: float
    singular_values: tuple = field(default=())

    def to_dict(self):
        return {"identified": list(self.identified), "fixed": dict(self.fixed), "rank": self.rank,
                "rows": self.rows, "condition_number": self.condition_number, "o1": self.o1,
                "o3": self.o3, "noise_amplification": self.noise_amplification}


def _parallel_pairs(chain):
    from ..kinematics import to_poe

    axes = to_poe(chain.rigid).axes
    n = len(axes)
    return {(i + 1, j + 1) for i in range(n) for j in range(i + 1, n)
            if np.linalg.norm(np.cross(axes[i], axes[j])) < NEAR_PARALLEL}


def _joint_of(chain, name):
    """(kind, 1-based joint or None) of a parameter of ``chain``; a name outside its space
    (the constraint calibration's 'scale') is its own kind, of no joint."""
    parameter = chain.parameters.get(name)
    return (name, None) if parameter is None else (parameter.kind, parameter.joint)


def _reason(chain, name, partners, parallel, moves):
    """A sentence on why ``name`` cannot be identified."""
    stem, joint = _joint_of(chain, name)
    if not moves:
        if joint == chain.n_joints and stem in ("theta", "alpha", "beta"):
            return f"{name} does not move the TCP: it lies on the axis of joint {joint}"
        return f"{name} does not move the TCP in these poses"
    for partner in partners:
        p_stem, p_joint = _joint_of(chain, partner)
        if stem == "theta" and joint == 1 and partner == "base_rz":
            return "base rotation about z absorbs the joint-1 offset (theta1)"
        if stem == "d" and joint == 1 and partner == "base_z":
            return "the base height absorbs d1"
        if stem == p_stem and joint and p_joint and tuple(sorted((joint, p_joint))) in parallel:
            return (f"{partner} and {name} cannot be separated: axes {min(joint, p_joint)} and "
                    f"{max(joint, p_joint)} are parallel")
    listed = ", ".join(partners) if partners else "the other parameters"
    return f"{name} cannot be separated from {listed}: they move the TCP the same way in these poses"


def analyse(chain, jacobian, names, tolerance=RANK_TOLERANCE, explain=True):
    """Select the identifiable parameters of a (rows, P) Jacobian whose columns are ``names``
    in order of preference; returns (kept column indices, IdentifiabilityReport).
    ``chain`` (rigid or compliant) gives the parameters' records and the geometry the reasons
    cite.  ``explain=False`` skips the reasons (the fixed parameters map to "")."""
    rows, count = jacobian.shape
    norms = np.linalg.norm(jacobian, axis=0)
    biggest = norms.max() if count else 0.0
    moving = norms > 1e-12 * max(biggest, 1e-300)
    scaled = jacobian / np.where(moving, norms, 1.0)
    # QR in the order of preference: |R_jj| is the part of column j outside the span of all
    # columns before it, which is exactly the greedy selection.
    diag = np.abs(np.diag(np.linalg.qr(scaled, mode="r")))
    kept = [j for j in range(count) if moving[j] and diag[j] > tolerance]
    fixed = {names[j]: "" for j in range(count) if j not in kept}
    parallel = _parallel_pairs(chain) if explain and fixed else set()
    for j in range(count):
        if not explain or j in kept:
            continue
        if not moving[j]:
            fixed[names[j]] = _reason(chain, names[j], [], parallel, moves=False)
        else:
            previous = [k for k in kept if k < j]
            coef = np.linalg.lstsq(scaled[:, previous], scaled[:, j], rcond=None)[0]
            order = np.argsort(-np.abs(coef))
            partners = [names[previous[k]] for k in order[:3] if abs(coef[k]) > 0.1 * np.abs(coef).max()]
            fixed[names[j]] = _reason(chain, names[j], partners, parallel, moves=True)
    if not kept:
        raise InputError("the data determine none of the parameters: measure poses spread over the workspace")
    sv = np.linalg.svd(scaled[:, kept], compute_uv=False)
    report = IdentifiabilityReport(
        identified=tuple(names[k] for k in kept), fixed=fixed, rank=len(kept), rows=rows,
        condition_number=float(sv[0] / sv[-1]), o1=float(np.exp(np.mean(np.log(sv))) / np.sqrt(rows)),
        o3=float(sv[-1]), noise_amplification=float(sv[-1] ** 2 / sv[0]), singular_values=tuple(sv.tolist()),
    )
    return kept, report
