"""Model-based (parametric) calibration: identify the kinematic parameters, base and tool
from measured TCP positions (and orientations) with Levenberg–Marquardt.

The Jacobian is the chain's analytic identification Jacobian and every step is applied with
:meth:`Chain.perturbed`, so each iteration re-linearises exactly where the model is.  The
robot is calibrated in its own parameterisation: DH and modified DH carry Hayati's beta on
parallel axes, which removes the DH singularity there, and export needs no conversion.
"""
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..kinematics.compliant import UNITS_NOTE, file_units, with_compliance
from ..spatial import make_transform
from .identifiability import NEAR_PARALLEL, STRONG_CORRELATION, analyse, loose_gains
from .least_squares import levenberg_marquardt
from .least_squares import residual as residual_of
from .metrics import error_stats
from .registration import kabsch

PARAMETER_SETS = ("offsets", "full", "full+gains", "full+compliance", "full+compliance+gains")
LOSSES = ("linear", "huber", "soft_l1")
# Nominal geometry of the right robot in the right unit lands within a few mm; a calibrated
# model that still misses by this much is fitting the wrong robot, unit or data.
WRONG_ROBOT_RMS_MM = 10.0


def identified_parameters(chain, result):
    """The part of a calibration record every method shares: each identified parameter's
    deviation and standard error in file units, correlated pairs and the identifiability."""
    unit = file_units(chain, result.names)
    return {
        "parameters": {n: {"deviation": float(v), "std_error": float(s)}
                       for n, v, s in zip(result.names, result.values * unit, result.std_errors * unit)},
        "units": UNITS_NOTE,
        "correlated_pairs": [list(p) for p in result.correlated_pairs],
        "identifiability": result.identifiability.to_dict(),
    }


@dataclass(frozen=True)
class CalibrationResult:
    """What a calibration found (all JSON-ready through :meth:`to_dict`)."""

    names: tuple
    values: np.ndarray          # identified deviations from the starting model (rad, mm)
    std_errors: np.ndarray      # standard errors of the deviations (rad, mm)
    correlated_pairs: tuple     # ((name, name, correlation), ...)
    identifiability: object     # IdentifiabilityReport
    residual_before: dict
    residual_after: dict
    orientation_rms_deg: float | None
    iterations: int
    converged: bool
    outliers: tuple             # indices of poses a robust loss down-weighted

    def to_dict(self, chain):
        """Deviations and standard errors in file units (deg for angles, mm for lengths)."""
        return {
            **identified_parameters(chain, self),
            "residual_before": self.residual_before,
            "residual_after": self.residual_after,
            "orientation_rms_deg": self.orientation_rms_deg,
            "iterations": self.iterations,
            "converged": self.converged,
            "outliers": list(self.outliers),
        }


def check_payload(payload):
    """None, or a validated payload mass in kg."""
    if payload is None:
        return None
    value = float(payload)
    if not np.isfinite(value) or value < 0:
        raise InputError(f"payload must be a mass in kg >= 0, got {payload}")
    return value


def parameter_terms(parameters):
    """The extras a parameter set adds to the geometry: {'compliance', 'gains'} or fewer."""
    if parameters not in PARAMETER_SETS:
        raise InputError(f"parameter set must be one of {', '.join(PARAMETER_SETS)}, got {parameters!r}")
    return set(parameters.split("+")[1:])


def candidate_parameters(chain, parameters="full", *, base=True, tool_orientation=False):
    """Parameter names in order of preference for the identifiability analysis (joint gains
    last, so that the geometry explains what it can)."""
    terms = parameter_terms(parameters)
    names = chain.parameter_names(("base",)) if base else []
    tool = chain.parameter_names(("tool",))
    names += tool if tool_orientation else tool[:3]
    if parameters == "offsets":
        return names + chain.parameter_names(("offsets",))
    from ..kinematics import to_poe

    chain = getattr(chain, "rigid", chain)

    axes = to_poe(chain).axes
    parallel = [np.linalg.norm(np.cross(axes[i], axes[i + 1])) < NEAR_PARALLEL for i in range(chain.n_joints - 1)]
    for k in range(1, chain.n_joints + 1):
        if chain.convention == "poe":
            names += [f"{p}{k}" for p in ("theta", "ux", "uy", "wx", "wy")]
            continue
        names += [f"{p}{k}" for p in ("theta", "d", "a", "alpha")]
        # Hayati's beta where this link joins two (nearly) parallel axes.
        pair = (k - 1) if chain.convention == "dh" else (k - 2)
        if 0 <= pair < len(parallel) and parallel[pair]:
            names.append(f"beta{k}")
    if chain.convention == "poe":
        names += chain.parameter_names(("home",))
    if "gains" in terms:
        names += chain.parameter_names(("gains",))
    return names


class KinematicCalibration:
    """Levenberg–Marquardt identification of a chain's parameters, scikit-learn style.

    parameters: 'offsets', 'full', 'full+gains' (full, plus a gain per joint: a scale error
    of its reading), 'full+compliance' (full, plus one compliance per joint that gravity
    loads, the deflection being proportional to the gravity torque of
    :func:`robocal.kinematics.gravity.default_mass_model` with ``payload`` kg at the TCP, by
    default none if the robot file gives link masses, else the rated payload of a robot of
    that size) or 'full+compliance+gains'.  loss: 'linear', 'huber' or 'soft_l1' (per pose,
    on the weighted residual norm; ``f_scale`` in those units, default 3x the median).
    position_sigma (mm) and orientation_sigma (deg) weight rows when the data carry no
    sigmas.  register: start from a Kabsch fit of the base (use False for data already in
    the base frame of a chain whose base is right).  tolerance: stop when an iteration lowers
    the cost by less than this fraction (on tracker data 1e-7 and 1e-9 give the same held-out
    error to 1e-5 mm; noise-free data still converge to rounding).
    """

    def __init__(self, parameters="full", *, loss="linear", f_scale=None, position_sigma=0.02,
                 orientation_sigma=0.01, register=True, payload=None, max_iterations=50, tolerance=1e-7):
        if loss not in LOSSES:
            raise InputError(f"loss must be one of {', '.join(LOSSES)}, got {loss!r}")
        self.parameters = parameters
        self.loss = loss
        self.f_scale = f_scale
        self.position_sigma = position_sigma
        self.orientation_sigma = orientation_sigma
        self.register = register
        self.payload = check_payload(payload)
        self.max_iterations = max_iterations
        self.tolerance = tolerance

    # ------------------------------------------------------------------ data
    def _check(self, chain, joints, positions, orientations, sigmas):
        q = np.asarray(joints, dtype=float)
        p = np.asarray(positions, dtype=float)
        if q.ndim != 2 or q.shape[1] != chain.n_joints:
            raise InputError(f"joints must be (N, {chain.n_joints}) for {chain.name}, got {q.shape}")
        if p.shape != (len(q), 3):
            raise InputError(f"positions must be (N, 3) with N = {len(q)}, got {p.shape}")
        arrays = [q, p] + [np.asarray(a, float) for a in (orientations, sigmas) if a is not None]
        if not all(np.all(np.isfinite(a)) for a in arrays):
            raise InputError("the data contain NaN or infinite values: remove or fix those poses")
        distinct = len(np.unique(np.round(q, 9), axis=0))
        return q, p, distinct

    def _weights(self, count, sigmas, with_orientation):
        pos = (np.full((count, 3), float(self.position_sigma)) if sigmas is None
               else np.asarray(sigmas, dtype=float))
        if np.any(pos <= 0):
            raise InputError("standard deviations (sx, sy, sz) must be > 0")
        w = 1.0 / pos
        if with_orientation:
            w = np.hstack([w, np.full((count, 3), 1.0 / np.radians(self.orientation_sigma))])
        return w

    # ------------------------------------------------------------------ start
    @staticmethod
    def _start_tool_rotation(chain, q, rotations):
        """Closed-form tool rotation: the chordal mean of (R_base R_flange)^T R_measured."""
        flange = chain.replace(tool=np.eye(4)).fk(q)[:, :3, :3]
        samples = np.swapaxes(flange, 1, 2) @ rotations
        u, _, vt = np.linalg.svd(samples.sum(axis=0))
        rot = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
        tool = chain.tool.copy()
        tool[:3, :3] = rot
        return chain.replace(tool=tool)

    # ------------------------------------------------------------------- fit
    def fit(self, chain, joints, positions, orientations=None, sigmas=None):
        """joints (N, n) rad; positions (N, 3) mm; orientations (N, 3, 3) rotation matrices
        or None; sigmas (N, 3) mm or None.  Returns self with ``chain_`` and ``result_``."""
        q, target, distinct = self._check(chain, joints, positions, orientations, sigmas)
        rotations = None if orientations is None else np.asarray(orientations, dtype=float)
        with_orientation = rotations is not None
        rows_per_pose = 6 if with_orientation else 3
        names = candidate_parameters(chain, self.parameters, tool_orientation=with_orientation)
        compliant = None
        if "compliance" in parameter_terms(self.parameters):
            compliant, compliances = with_compliance(chain, q, self.payload)
            names += compliances
        if len(q) * rows_per_pose < len(names) or distinct * rows_per_pose < len(names):
            need = int(np.ceil(len(names) / rows_per_pose))
            raise InputError(
                f"{distinct} distinct poses give {distinct * rows_per_pose} equations for {len(names)} "
                f"parameters: measure at least {need} different poses (5 times as many is better)"
            )
        start = chain
        if self.register:
            # Closed-form base from nominal FK; the LM below refines base and tool with the rest.
            rot, shift = kabsch(chain.fk_positions(q), target)
            start = chain.replace(base=make_transform(rot, shift) @ chain.base)
        if with_orientation:
            start = self._start_tool_rotation(start, q, rotations)
        if compliant is not None:
            start = compliant.replace(base=start.base, tool=start.tool)
        weights = self._weights(len(q), sigmas, with_orientation)
        before = error_stats((target - start.fk_positions(q)))

        # Identifiability is local: nominal geometry can make parameters look dependent
        # (a TCP exactly on the last axis) that the real robot separates.  Analyse, fit, and
        # analyse again at the fit until the identified set settles.
        def solve(names):
            fitted, identified, total_iterations = start, None, 0
            for _ in range(3):
                jac = fitted.identification_jacobian(q, names)[:, :rows_per_pose, :]
                scaled = (jac * weights[:, :, None]).reshape(-1, len(names))
                # The reasons come once, from the last analysis.
                _, report = analyse(getattr(fitted, "rigid", fitted), scaled, names, explain=False)
                if report.identified == identified:
                    break
                identified = report.identified
                fitted, iterations, converged, robust = levenberg_marquardt(
                    fitted, q, target, identified, rotations=rotations, weights=weights,
                    pose_weights=self._robust_weights, max_iterations=self.max_iterations,
                    tolerance=self.tolerance)
                total_iterations += iterations
            _, report = analyse(getattr(fitted, "rigid", fitted), scaled, names)
            ident = list(identified)
            residual = residual_of(fitted, q, target, rotations)
            std, pairs = self._covariance(fitted, q, residual, weights * robust[:, None], ident, rows_per_pose)
            return fitted, ident, report, total_iterations, converged, robust, residual, std, pairs

        fitted, ident, report, iterations, converged, robust, residual, std, pairs = solve(names)
        loose = loose_gains(ident, std, chain.n_joints)
        if loose:
            fitted, ident, report, more, converged, robust, residual, std, pairs = solve(
                [n for n in names if n not in loose])
            iterations += more
            report = replace(report, fixed={**report.fixed, **loose})
        after = error_stats(residual[:, :3])
        if after["rms_mm"] > WRONG_ROBOT_RMS_MM:
            raise InputError(
                f"the residual is {after['rms_mm']:.1f} mm RMS after calibration: is this the right robot "
                "and unit (mm, degrees) for these data?"
            )
        values = self._deviations(chain, start, fitted, ident)
        self.chain_ = fitted
        self.start_chain_ = start
        self.names_ = tuple(ident)
        self.result_ = CalibrationResult(
            names=tuple(ident), values=values, std_errors=std, correlated_pairs=pairs,
            identifiability=report, residual_before=before, residual_after=after,
            orientation_rms_deg=(float(np.degrees(np.sqrt(np.mean(np.sum(residual[:, 3:] ** 2, axis=1)))))
                                 if with_orientation else None),
            iterations=iterations, converged=converged,
            outliers=tuple(int(i) for i in np.flatnonzero(robust < 0.5)),
        )
        return self

    def _robust_weights(self, residual_w):
        if self.loss == "linear":
            return np.ones(len(residual_w))
        norm = np.linalg.norm(residual_w, axis=1)
        scale = self.f_scale if self.f_scale is not None else 3.0 * max(np.median(norm), 1e-12)
        s = norm / scale
        if self.loss == "huber":
            return np.where(s <= 1.0, 1.0, 1.0 / np.maximum(s, 1e-300))
        return 1.0 / np.sqrt(1.0 + s * s)

    @staticmethod
    def _deviations(nominal, start, fitted, names):
        """Identified minus starting values, comparable in every parameter (rad, mm)."""
        return fitted.parameter_values(names) - start.parameter_values(names)

    @staticmethod
    def _covariance(chain, q, residual, weights, names, rows):
        jac = (chain.identification_jacobian(q, names)[:, :rows, :] * weights[:, :, None]).reshape(-1, len(names))
        r = (residual * weights).reshape(-1)
        dof = max(len(r) - len(names), 1)
        sigma2 = float(r @ r) / dof
        scale = np.linalg.norm(jac, axis=0)
        scale[scale == 0] = 1.0
        inv = np.linalg.pinv((jac / scale).T @ (jac / scale))
        cov = sigma2 * inv / np.outer(scale, scale)
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(std, std)
        pairs = []
        for i in range(len(names)):
            for j in range(i + 1, len(names)):
                if abs(corr[i, j]) > STRONG_CORRELATION:
                    pairs.append((names[i], names[j], float(corr[i, j])))
        return std, tuple(pairs)

    # --------------------------------------------------------------- predict
    def predict(self, joints):
        """TCP positions (N, 3) of the calibrated model."""
        return self.chain_.fk_positions(np.asarray(joints, dtype=float))
