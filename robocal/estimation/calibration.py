"""Model-based (parametric) calibration: identify the kinematic parameters, base and tool
from measured TCP positions (and orientations) with Levenberg–Marquardt.

The Jacobian is the chain's analytic identification Jacobian and every step is applied with
:meth:`Chain.perturbed`, so each iteration re-linearises exactly where the model is.  The
robot is calibrated in its own parameterisation: DH and modified DH carry Hayati's beta on
parallel axes, which removes the DH singularity there, and export needs no conversion.
"""
import warnings
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError, RobocalWarning
from ..kinematics.compliant import with_compliance
from ..kinematics.tolerances import prior_sigmas, tolerances_of
from .identifiability import NEAR_PARALLEL, analyse
from .identification import (Analysis, FittedCalibration, IdentifiedResult, check_iterations, check_payload,
                             check_prior, identified_parameters, identify, implausible_fit, one_of,
                             tolerance_prior, tolerance_rms)
from .least_squares import blocked_r_factor, held_in_blocks, levenberg_marquardt
from .least_squares import residual as residual_of
from .metrics import error_stats
from .registration import register_base_and_tool

__all__ = ["PARAMETER_SETS", "LOSSES", "CalibrationResult", "KinematicCalibration", "OutlierError", "OutlierWarning",
           "candidate_parameters", "check_payload", "identified_parameters", "parameter_terms"]

PARAMETER_SETS = ("offsets", "full", "full+gains", "full+compliance", "full+compliance+gains")
LOSSES = ("linear", "huber", "soft_l1")
# "tolerances": maximum a posteriori, each parameter's deviation weighed against its
# manufacturing tolerance (robocal.kinematics.tolerances); "none": plain least squares.
PRIORS = ("tolerances", "none")
# Nominal geometry of the right robot in the right unit lands within a few mm; a calibrated
# model that still misses by this much is fitting the wrong robot, unit or data.  A robust
# fit is judged on the poses it kept (weight >= OUTLIER_WEIGHT): the ones it down-weighted
# are listed, not counted.
WRONG_ROBOT_RMS_MM = 10.0
# A robust loss's pose weight below this marks an outlier (huber: a residual beyond twice the
# scale, i.e. 6x the median by default; clean tracker data: 0 of 1,000 UR5 poses, 16 of 1,495
# UR10 poses weighted by their sigmas, all within 2.2 mm).
OUTLIER_WEIGHT = 0.5
# A plain fit that passes can still be pulled by a few wrong poses (one UR5 pose 20 mm off:
# held-out error 0.104 -> 0.178 mm, training RMS 0.89 mm).  On clean tracker data every pose
# of a plain fit lies within 5x the median residual (UR5 2.8, UR10 A 2.8, UR10 B 4.9); a pose
# beyond SUSPECT_MEDIANS x the median and SUSPECT_MM is named in a warning.
SUSPECT_MEDIANS = 20.0
SUSPECT_MM = 1.0
# How many outlying poses a message names before "and N more".
NAMED_POSES = 10
# Manufacturing and assembly put a real robot within millimetres and a fraction of a degree
# of its drawing (typical calibrations find 0.1-5 mm and 0.01-0.5 deg, base and tool
# measured from the registered start).  A fit that needs a tenth of the reach or ten degrees
# has turned the model into another robot: a full DH model of one six-axis arm can fit
# another's positions exactly (KR 150-2 joints with UR10 positions: 0.000 mm residual with
# d2 moved by 1956 mm), so a small residual alone proves nothing.
IMPLAUSIBLE_REACH_FRACTION = 0.1
IMPLAUSIBLE_ANGLE_DEG = 10.0


class OutlierError(InputError):
    """A plain (linear) fit that a few gross outliers spoil: a robust fit of the same data
    succeeds once it down-weights them.

    Attributes: ``poses`` the outlying poses (0-based indices, worst first), ``misses`` their
    residuals under the robust fit (mm), ``inlier_rms`` the robust fit's RMS on the other poses
    (mm), ``problem`` what went wrong with the plain fit.  :meth:`naming` gives the same error
    with the poses named another way (file rows).
    """

    def __init__(self, problem, poses, misses, inlier_rms, *, labels=None, where=""):
        self.problem = problem
        self.poses = tuple(int(i) for i in poses)
        self.misses = tuple(float(m) for m in misses)
        self.inlier_rms = float(inlier_rms)
        self._labels = labels
        self._where = where
        super().__init__(self._message())

    def naming(self, labels, where=""):
        """This error with pose i named ``labels[i]`` (a file row) and ``where`` the file."""
        return OutlierError(self.problem, self.poses, self.misses, self.inlier_rms, labels=labels, where=where)

    def _message(self):
        count = len(self.poses)
        names = _named(self.poses, count, self._labels, self._where)
        spread = _range_mm(self.misses)
        return (f"{self.problem}: {names} miss{'es' if count == 1 else ''} by {spread} where the other poses fit "
                f"within {self.inlier_rms:.2f} mm RMS; fix or remove {'them' if count > 1 else 'it'}, or calibrate "
                "with a robust loss (--loss huber), which down-weights and lists them")


class OutlierWarning(RobocalWarning):
    """A plain fit that went through with a few poses far off the rest: ``poses`` (0-based,
    worst first), ``misses`` their residuals (mm), ``median`` the median residual (mm).
    :meth:`naming` gives the same warning with the poses named another way (file rows)."""

    def __init__(self, poses, misses, median, *, labels=None, where=""):
        self.poses = tuple(int(i) for i in poses)
        self.misses = tuple(float(m) for m in misses)
        self.median = float(median)
        self._labels = labels
        self._where = where
        super().__init__(self._message())

    def naming(self, labels, where=""):
        """This warning with pose i named ``labels[i]`` (a file row) and ``where`` the file."""
        return OutlierWarning(self.poses, self.misses, self.median, labels=labels, where=where)

    def _message(self):
        count = len(self.poses)
        names = _named(self.poses, count, self._labels, self._where)
        spread = _range_mm(self.misses)
        return (f"{names} miss{'es' if count == 1 else ''} by {spread} after calibration where the median pose "
                f"misses by {self.median:.2f} mm: a plain fit lets {'them' if count > 1 else 'it'} pull the whole "
                f"model; check {'them' if count > 1 else 'it'}, or calibrate with a robust loss (--loss huber), "
                "which down-weights such poses")


def _named(poses, count, labels, where):
    """'poses 3 and 7 (0-based) (worst first)' or 'rows 5 and 9 of data.csv (worst first)'."""
    shown = poses[:NAMED_POSES]
    worst = ", worst first" if count > 1 else ""
    if labels is None:
        return f"pose{'s' if count > 1 else ''} {_listed([str(i) for i in shown], count)} (0-based{worst})"
    return (f"row{'s' if count > 1 else ''} {_listed([str(int(labels[i])) for i in shown], count)}"
            + (f" of {where}" if where else "") + (f" ({worst[2:]})" if worst else ""))


def _range_mm(values):
    """'5.2 mm' or '50.3 to 480.1 mm'."""
    low, high = f"{min(values):.1f}", f"{max(values):.1f}"
    return f"{low} mm" if low == high else f"{low} to {high} mm"


def _listed(names, count):
    """'a, b and c' for the names, '… and N more' when ``count`` exceeds them."""
    if count > len(names):
        return f"{', '.join(names)} and {count - len(names)} more"
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


@dataclass(frozen=True)
class CalibrationResult(IdentifiedResult):
    """What a kinematic calibration found (all JSON-ready through :meth:`to_dict`).

    The fields of :class:`~robocal.estimation.identification.IdentifiedResult` (values and
    std_errors in rad, mm; residual_before / residual_after: :func:`error_stats` of the
    positions, mm), and orientation_rms_deg: the RMS orientation residual (deg) when
    orientations were fitted, else None; outliers: indices of the poses a robust loss
    down-weighted (weight below 0.5).
    """

    orientation_rms_deg: float | None
    outliers: tuple

    def _details(self):
        return {
            "residual_before": self.residual_before,
            "residual_after": self.residual_after,
            "orientation_rms_deg": self.orientation_rms_deg,
            "iterations": self.iterations,
            "converged": self.converged,
            "outliers": list(self.outliers),
        }

    @classmethod
    def from_dict(cls, doc, chain):
        """The result back from :meth:`to_dict` (``chain`` as given there); KeyError,
        TypeError or ValueError if ``doc`` is damaged."""
        rms = doc["orientation_rms_deg"]
        return cls(**cls._shared_fields(doc, chain), orientation_rms_deg=None if rms is None else float(rms),
                   outliers=tuple(int(i) for i in doc["outliers"]))


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

    chain = chain.rigid
    axes = to_poe(chain).axes
    parallel = [np.linalg.norm(np.cross(axes[i], axes[i + 1])) < NEAR_PARALLEL for i in range(chain.n_joints - 1)]
    links = [p for p in chain.parameters if p.group == "link"]
    for k in range(1, chain.n_joints + 1):
        # Hayati's beta only where this link joins two (nearly) parallel axes.
        pair = (k - 1) if chain.convention == "dh" else (k - 2)
        with_beta = 0 <= pair < len(parallel) and parallel[pair]
        names += [p.name for p in links if p.joint == k and (p.kind != "beta" or with_beta)]
    if chain.convention == "poe":
        names += chain.parameter_names(("home",))
    if "gains" in terms:
        names += chain.parameter_names(("gains",))
    return names


class KinematicCalibration(FittedCalibration):
    """Levenberg–Marquardt identification of a chain's parameters, scikit-learn style.

    Parameters
    ----------
    parameters : str
        'offsets', 'full', 'full+gains' (full, plus a gain per joint: a scale error of its
        reading), 'full+compliance' (full, plus one compliance per joint that gravity loads,
        the deflection being proportional to the gravity torque of
        :func:`robocal.kinematics.gravity.default_mass_model` with ``payload`` kg at the TCP,
        by default none if the robot file gives link masses, else the rated payload of a
        robot of that size) or 'full+compliance+gains'.
    loss : str
        'linear', 'huber' or 'soft_l1' (per pose, on the weighted residual norm; ``f_scale``
        in those units, default 3x the median).
    position_sigma, orientation_sigma_deg : float
        mm and deg (the angle's unit in its name): the row weights when the data carry no sigmas.
    register : bool
        Start from the nominal geometry with base and tool registered to the data
        (:func:`~robocal.estimation.registration.register_base_and_tool`; False for data
        already in the base frame of a chain whose base and tool are right).  That start is
        also the honest "before" of every figure, and deviations are measured from it.
    payload : float or None
        kg at the TCP, for the compliance sets.
    max_iterations, tolerance
        Stop when an iteration lowers the cost by less than ``tolerance`` of it (on tracker
        data 1e-7 and 1e-9 give the same held-out error to 1e-5 mm; noise-free data still
        converge to rounding).
    prior : str
        'tolerances' (maximum a posteriori: every link parameter, gain and compliance is
        weighed against its manufacturing tolerance, :mod:`robocal.kinematics.tolerances`,
        so one the poses cannot pin stays near nominal, "held by its prior") or 'none'
        (plain least squares).
    tolerance_scale : float
        Multiplies every tolerance (the robot file's ``[tolerances]`` or the defaults).

    The settings are stored as given and checked by :meth:`fit`.  After it: ``chain_`` (the
    calibrated chain, a CompliantChain for the compliance sets), ``start_chain_`` (the
    registered starting model), ``names_`` (the identified parameters) and ``result_`` (a
    :class:`CalibrationResult`).
    """

    KIND = "kinematic"
    RESULT = CalibrationResult

    def __init__(self, parameters="full", *, loss="linear", f_scale=None, position_sigma=0.02,
                 orientation_sigma_deg=0.01, register=True, payload=None, max_iterations=50, tolerance=1e-7,
                 prior="tolerances", tolerance_scale=1.0):
        self.parameters = parameters
        self.loss = loss
        self.f_scale = f_scale
        self.position_sigma = position_sigma
        self.orientation_sigma_deg = orientation_sigma_deg
        self.register = register
        self.payload = payload
        self.max_iterations = max_iterations
        self.tolerance = tolerance
        self.prior = prior
        self.tolerance_scale = tolerance_scale

    def get_settings(self):
        """The settings, as given to ``__init__``."""
        return {"parameters": self.parameters, "loss": self.loss, "f_scale": self.f_scale,
                "position_sigma": self.position_sigma, "orientation_sigma_deg": self.orientation_sigma_deg,
                "register": self.register, "payload": self.payload, "max_iterations": self.max_iterations,
                "tolerance": self.tolerance, "prior": self.prior, "tolerance_scale": self.tolerance_scale}

    @classmethod
    def from_dict(cls, doc):
        """As the base's; also reads documents written with ``orientation_sigma`` (deg)."""
        if isinstance(doc, dict) and isinstance(old := doc.get("settings"), dict) and "orientation_sigma" in old:
            renamed = {("orientation_sigma_deg" if k == "orientation_sigma" else k): v for k, v in old.items()}
            doc = {**doc, "settings": renamed}
        return super().from_dict(doc)

    def _validate(self):
        """InputError naming the first bad setting; returns the payload (kg or None)."""
        parameter_terms(self.parameters)
        one_of(self.loss, LOSSES, "loss")
        for setting in ("position_sigma", "orientation_sigma_deg"):
            value = getattr(self, setting)
            if not isinstance(value, (int, float)) or not value > 0:
                raise InputError(f"{setting} must be a number > 0, got {value!r}")
        if self.f_scale is not None and not (isinstance(self.f_scale, (int, float)) and self.f_scale > 0):
            raise InputError(f"f_scale must be None or a number > 0, got {self.f_scale!r}")
        if not isinstance(self.register, (bool, np.bool_)):
            raise InputError(f"register must be True or False, got {self.register!r}")
        check_iterations(self.max_iterations)
        check_prior(self.prior, self.tolerance_scale)
        return check_payload(self.payload)

    # ------------------------------------------------------------------ data
    def _check(self, chain, joints, positions, orientations, sigmas):
        try:
            q = np.asarray(joints, dtype=float)
            p = np.asarray(positions, dtype=float)
        except (TypeError, ValueError):
            raise InputError("joints (rad; mm for prismatic joints) and positions (mm) must be numbers") from None
        if q.ndim != 2 or q.shape[1] != chain.n_joints:
            raise InputError(f"joints must be (N, {chain.n_joints}) for {chain.name}, got {q.shape}")
        if p.shape != (len(q), 3):
            raise InputError(f"positions must be (N, 3) with N = {len(q)}, got {p.shape}")
        if orientations is not None and np.shape(orientations) != (len(q), 3, 3):
            raise InputError(f"orientations must be (N, 3, 3) rotation matrices with N = {len(q)}, "
                             f"got {np.shape(orientations)}")
        if sigmas is not None and np.shape(sigmas) != (len(q), 3):
            raise InputError(f"sigmas must be (N, 3) mm with N = {len(q)}, got {np.shape(sigmas)}")
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
            w = np.hstack([w, np.full((count, 3), 1.0 / np.radians(self.orientation_sigma_deg))])
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

    def _start(self, chain, q, target, rotations, compliant):
        """The starting model: base and tool position registered (the LM refines them with the
        rest), the tool rotation in closed form, the compliance when asked for."""
        start = chain
        if self.register:
            start = register_base_and_tool(chain, q, target)[0]
        if rotations is not None:
            start = self._start_tool_rotation(start, q, rotations)
        if compliant is not None:
            start = compliant.replace(base=start.base, tool=start.tool)
        return start

    # ------------------------------------------------------------------- fit
    def fit(self, chain, joints, positions, orientations=None, sigmas=None):
        """Identify the parameters.

        Parameters
        ----------
        chain : Chain
            The nominal model.
        joints : (N, n) array, rad (mm for prismatic joints)
        positions : (N, 3) array, mm
        orientations : (N, 3, 3) rotation matrices, or None
        sigmas : (N, 3) array, mm, or None

        Returns self, with ``chain_``, ``start_chain_``, ``names_`` and ``result_``.  Raises
        InputError for data that no calibration of this robot explains, and
        :class:`OutlierError` when a plain fit fails for a few poses that a robust fit
        down-weights (it names them).
        """
        payload = self._validate()
        q, target, distinct = self._check(chain, joints, positions, orientations, sigmas)
        rotations = None if orientations is None else np.asarray(orientations, dtype=float)
        rows = 6 if rotations is not None else 3
        names = candidate_parameters(chain, self.parameters, tool_orientation=rotations is not None)
        compliant = None
        if "compliance" in parameter_terms(self.parameters):
            compliant, compliances = with_compliance(chain, q, payload)
            names += compliances
        if len(q) * rows < len(names) or distinct * rows < len(names):
            need = int(np.ceil(len(names) / rows))
            raise InputError(
                f"{distinct} distinct poses give {distinct * rows} equations for {len(names)} "
                f"parameters: measure at least {need} different poses (5 times as many is better)"
            )
        start = self._start(chain, q, target, rotations, compliant)
        weights = self._weights(len(q), sigmas, rotations is not None)
        before = error_stats(target - start.fk_positions(q))
        self._prior = tolerance_prior(start, names, q, self.prior, self.tolerance_scale, _deviation_from(start))
        found, residual, failure = self._identify(start, names, q, target, rotations, weights, self._robust_weights)
        if failure is not None:
            if self.loss == "linear":
                self._name_outliers(failure, start, names, q, target, rotations, weights)
            raise InputError(failure)
        if self.loss == "linear":
            _warn_about_suspects(residual[:, :3])
        fitted = found.chain
        ident = list(found.names)
        values = fitted.parameter_values(ident) - start.parameter_values(ident)
        self.chain_ = fitted
        self.start_chain_ = start
        self.names_ = found.names
        self.result_ = CalibrationResult(
            names=found.names, values=values,
            std_errors=found.std_errors, correlated_pairs=found.correlated_pairs,
            identifiability=found.report, residual_before=before.to_dict(),
            residual_after=error_stats(residual[:, :3]).to_dict(),
            orientation_rms_deg=(float(np.degrees(np.sqrt(np.mean(np.sum(residual[:, 3:] ** 2, axis=1)))))
                                 if rotations is not None else None),
            iterations=found.iterations, converged=found.converged,
            outliers=tuple(int(i) for i in np.flatnonzero(found.fit.pose_weights < OUTLIER_WEIGHT)),
            prior_std=None if self._prior is None else found.prior_std, tolerance_scale=found.prior_scale,
        )
        return self

    def _identify(self, start, names, q, target, rotations, weights, robust_weights):
        """Identify from ``start``; returns (identification, residual (N, 3 or 6), failure):
        failure is the message of a fit that is no calibration (residual too large on the poses
        the loss kept, deviations beyond manufacturing), else None."""
        steps = self._steps(q, target, rotations, weights, robust_weights)
        found = identify(start, names, **steps, joints=q, prior=self._prior)
        fitted = found.chain
        residual = residual_of(fitted, q, target, rotations)
        kept = found.fit.pose_weights >= OUTLIER_WEIGHT
        if self._prior is not None:
            values = fitted.parameter_values(list(found.names)) - start.parameter_values(list(found.names))
            before = _rms((target - start.fk_positions(q))[kept]) if np.any(kept) else np.inf
            after = _rms(residual[kept, :3]) if np.any(kept) else np.inf
            noise = float(np.sqrt(np.mean(np.sum((1.0 / weights[:, :3]) ** 2, axis=1))))
            tolerances = self._prior.sigmas(list(found.names))
            # What a robot within its tolerances misses by: every link parameter's tolerance, whatever
            # set this fit identifies (an offsets-only fit leaves the links' errors in its residual).
            def expected():
                every = list(dict.fromkeys(candidate_parameters(start.rigid, "full") + list(names)))
                return tolerance_rms(start, q, every,
                                     prior_sigmas(start, every, tolerances_of(start, self.tolerance_scale), q))
            failure = implausible_fit(found.names, values, tolerances, before, after, noise, expected,
                                      start.parameters, override="--tolerance-scale, or [tolerances] in the robot file")
            return found, residual, failure
        rms = _rms(residual[kept, :3]) if np.any(kept) else np.inf
        if rms > WRONG_ROBOT_RMS_MM:
            on = "" if np.all(kept) else f" on the {np.count_nonzero(kept)} poses the robust loss kept"
            return found, residual, (f"the residual is {rms:.1f} mm RMS after calibration{on}: is this the right "
                                     "robot and unit (mm, degrees) for these data?")
        failure, slid = _implausible(start, q, found.names, fitted.parameter_values(list(found.names))
                                     - start.parameter_values(list(found.names)))
        if failure is None:
            return found, residual, None
        # The fit can slide along a valley of the residual into a second minimum far from the
        # drawing: 30 poses of the real UR5 chosen by robocal design took theta5 by -11 and
        # -32 deg (tool_z with it), predicting the other poses as well as the near minimum.
        # That one is found by fitting without what slid, then freeing it from there; data
        # that are not this robot's slide away again and are refused.
        held = identify(start, [n for n in names if n not in slid], **steps, joints=q, prior=self._prior)
        near = identify(held.chain, names, **steps, joints=q, prior=self._prior)
        values = near.chain.parameter_values(list(near.names)) - start.parameter_values(list(near.names))
        if _implausible(start, q, near.names, values)[0] is not None:
            return found, residual, (f"{failure}; if they are, these poses do not pin down "
                                     f"{' and '.join(slid[:3])}: measure more poses, in more orientations")
        near = replace(near, iterations=found.iterations + held.iterations + near.iterations)
        return near, residual_of(near.chain, q, target, rotations), None

    def _name_outliers(self, failure, start, names, q, target, rotations, weights):
        """Raise :class:`OutlierError` when a robust (huber) fit of the data that spoilt a plain
        fit succeeds: the poses it down-weights are what drove the plain fit away."""
        robust = KinematicCalibration(**{**self.get_settings(), "loss": "huber"})
        found, residual, robust_failure = self._identify(start, names, q, target, rotations, weights,
                                                         robust._robust_weights)
        outliers = np.flatnonzero(found.fit.pose_weights < OUTLIER_WEIGHT)
        if robust_failure is not None or len(outliers) == 0:
            return
        misses = np.linalg.norm(residual[outliers, :3], axis=1)
        order = np.argsort(-misses)
        kept = np.ones(len(q), dtype=bool)
        kept[outliers] = False
        problem = (failure.split(":")[0] if failure.startswith("the residual") else
                   "the calibration moves the robot far beyond manufacturing tolerances"
                   if failure.startswith("the calibration moves") else
                   "the calibration cannot explain these data")
        raise OutlierError(problem, outliers[order], misses[order], _rms(residual[kept, :3]))

    def _steps(self, q, target, rotations, weights, robust_weights):
        """What the identification core asks of this calibration: the analysis of the weighted
        position (and orientation) rows, the Levenberg–Marquardt fit with the robust loss, and
        the weighted rows at a fit for the covariance."""
        rows = weights.shape[1]
        # Large data never hold the whole Jacobian (robocal.estimation.least_squares): the
        # identifiability analysis, the fit and the standard errors work over blocks of poses.
        blocked = held_in_blocks(len(q))

        def weighted_jacobian(chain, names, w):
            """The weighted identification Jacobian (3 or 6 rows per pose, P), or for large
            data its R factor (P, P), accumulated over blocks of poses."""
            def rows_of(poses):
                jac = chain.identification_jacobian(q[poses], names)[:, :rows, :] * w[poses][:, :, None]
                return jac.reshape(-1, len(names))
            return blocked_r_factor(rows_of, len(q), len(names)) if blocked else rows_of(slice(None))

        def analyse_at(chain, candidates):
            scaled = weighted_jacobian(chain, candidates, weights)
            _, report = analyse(chain, scaled, candidates, explain=False)

            def explain():
                report = analyse(chain, scaled, candidates)[1]
                if not blocked:
                    return report
                # The R factor has P rows where the Jacobian has one per equation: O1 is per
                # root of the number of equations.
                count = len(q) * rows
                return replace(report, rows=count, o1=report.o1 * np.sqrt(report.rows / count))
            return Analysis(report.identified, explain)

        def fit(chain, names):
            return levenberg_marquardt(chain, q, target, names, rotations=rotations, weights=weights,
                                       pose_weights=robust_weights, max_iterations=self.max_iterations,
                                       tolerance=self.tolerance, prior=self._prior)

        def linearise(fitted, names):
            # The covariance needs the residual and JᵀJ only: the R factor serves for large data.
            w = weights * fitted.pose_weights[:, None]
            r = residual_of(fitted.chain, q, target, rotations) * w
            return r.reshape(-1), weighted_jacobian(fitted.chain, names, w)

        return {"analyse": analyse_at, "fit": fit, "linearise": linearise}

    def _robust_weights(self, residual_w):
        if self.loss == "linear":
            return np.ones(len(residual_w))
        norm = np.linalg.norm(residual_w, axis=1)
        scale = self.f_scale if self.f_scale is not None else 3.0 * max(np.median(norm), 1e-12)
        s = norm / scale
        if self.loss == "huber":
            return np.where(s <= 1.0, 1.0, 1.0 / np.maximum(s, 1e-300))
        return 1.0 / np.sqrt(1.0 + s * s)

    # --------------------------------------------------------------- predict
    def predict(self, joints):
        """TCP positions of the calibrated model.

        joints: (N, n) rad (mm for prismatic joints), as commanded.  Returns (N, 3) mm in the
        measurement frame the model was fitted in (the deflected robot's for the compliance
        sets).  InputError if not fitted.
        """
        return super().predict(joints)


def _deviation_from(start):
    """deviation(chain, names): the named parameters of ``chain`` minus ``start``'s (whose
    values are read once per set of names: the fit asks at every step)."""
    reference = {}

    def deviation(chain, names):
        if chain is start:
            return np.zeros(len(names))
        key = tuple(names)
        if key not in reference:
            reference[key] = start.parameter_values(list(names))
        return chain.parameter_values(names) - reference[key]
    return deviation


def _warn_about_suspects(residual):
    """OutlierWarning for the poses of a plain fit beyond SUSPECT_MEDIANS x the median residual
    and SUSPECT_MM."""
    misses = np.linalg.norm(residual, axis=1)
    median = float(np.median(misses))
    suspects = np.flatnonzero(misses > max(SUSPECT_MEDIANS * median, SUSPECT_MM))
    if len(suspects):
        suspects = suspects[np.argsort(-misses[suspects])]
        warnings.warn(OutlierWarning(suspects, misses[suspects], median), stacklevel=3)


def _rms(residual):
    """RMS of the per-pose residual norms (mm)."""
    return float(np.sqrt(np.mean(np.sum(residual ** 2, axis=1))))


def _implausible(start, joints, names, values):
    """(message, names) when the identified deviations (rad, mm) are beyond what manufacturing
    can explain: lengths past IMPLAUSIBLE_REACH_FRACTION of the reach at these poses, angles
    past IMPLAUSIBLE_ANGLE_DEG; the message names the worst, ``names`` all of them.  (None, ())
    when they are plausible."""
    reach = float(np.linalg.norm(start.rigid.replace(base=np.eye(4)).fk_positions(joints), axis=1).max())
    space = start.parameters
    limits = {"mm": IMPLAUSIBLE_REACH_FRACTION * reach, "rad": np.radians(IMPLAUSIBLE_ANGLE_DEG)}
    beyond = [(abs(v) / limits[space[n].unit], n, v) for n, v in zip(names, values) if space[n].unit in limits]
    beyond = sorted((b for b in beyond if b[0] > 1.0), reverse=True)
    if beyond:
        said = ", ".join(f"{n} by {np.degrees(v):.1f} deg" if space[n].unit == "rad" else f"{n} by {v:.1f} mm"
                         for _, n, v in beyond[:3])
        message = (f"the calibration moves {said} from the registered nominal robot: far beyond manufacturing "
                   f"tolerances ({IMPLAUSIBLE_REACH_FRACTION:.0%} of the {reach:.0f} mm reach, "
                   f"{IMPLAUSIBLE_ANGLE_DEG:.0f} deg), so these data are not this robot's, or not in mm and degrees: "
                   "check the robot file and the data")
        return message, tuple(n for _, n, _ in beyond)
    return None, ()
