"""What a fitted model did not model, and the 95 % bound outside its training domain.

Outside the training domain (another arm branch, a joint beyond its measured range) held-out
poses of the training data cannot check a model, so the bound there
(:mod:`robocal.methods.bound`) rests on a model of why the error grows.  The growth with the
joint-space distance from the training configurations, calibrated on regions left out of
the training data, extrapolated badly across arm branches (``bench/bound_coverage.py``):
a branch flip is a long way in joint space, yet on UR10 series B's other elbow side the
kinematic model's error only doubled and the bound was 5.2 times it; on series A's other
shoulder side the error grew sevenfold.  What grows is what the model did not model:

* **omitted parameters.**  A calibration identifies its parameter set (``full``: links,
  base, tool); the robot also has what it left out: the compliance of its loaded joints and a
  gain per joint (``full+compliance+gains``), and, for an error model over the nominal robot
  (Kriging, the network on its default base), every link parameter too.  On the training
  poses the fitted parameters absorb what those did there; elsewhere the absorbed part no
  longer matches.  With each omitted parameter θ drawn from its tolerance prior
  (:mod:`robocal.kinematics.tolerances`, as the robot file states it: a fold's fit estimates
  its own tolerance scale, which made σ_o differ from fold to fold) the model's error from
  them at x is M(x) θ, M(x) = J_omitted(x) − J_fitted(x) · B, B the fitted parameters'
  response to the omitted ones on the training poses (the posterior's gain: B = Σ J_fittedᵀ
  J_omitted / noise; for a registered nominal, the registration's least squares), and its
  standard deviation σ_o(x) = sqrt(Σ_k τ_k² |M(x)_k|²) (mm).  It needs no distance: it is
  small where the training poses were, and bounded everywhere by the tolerances.  For the
  kinematic model trained on one side of a UR10 arm branch (bench/bound_coverage.py) its
  median is 16 to 17 times its training-side value on the other side (series A shoulder,
  series A elbow, series B elbow), where the error grew 7, 1.6 and 2.3 times: σ_o says where
  the model carries what it absorbed, not how much that weighs on a given robot, which the
  regions left out calibrate (κ below: 0.39, 0.15 and 0 on those three);
* **what a model over the TCP position cannot tell apart.**  A Kriging over the position
  learns the error where the training poses were, as a function of where the TCP was, so it
  absorbs the omitted parameters' error M(q_t) θ of the training configuration q_t at each
  position: at a configuration q reaching the same position with another arm branch it
  commands a correction made for q_t.  Its σ_o is that of M(q) − M(q_a), q_a the training
  configuration (of the anchors kept) whose TCP lies nearest q's: small where the training
  poses reached the position as q does, large across a branch flip.  Against M(q) alone,
  which Kriging absorbs on the training side too, the bound on UR10 series B's other elbow
  side covered 0.28 of its poses (``bench/bound_coverage.py``);
* **the model's own scale** s(x) = sqrt(σ(x)² + r²) of the bound inside (its posterior or
  Kriging σ, and the held-out residual scale).

The bound outside is q_o · sqrt(a² s(x)² + κ² σ_o(x)²): a (how much the residual scale grows
in a region left out) and κ (how large the omitted parameters are against their tolerances)
by maximum likelihood on the held-out poses that lay outside their fold's domain (regions
left out: joint-space clusters and an arm branch's sides, :mod:`robocal.methods.bound_folds`),
each error norm e taken as sqrt(v/3) times a chi variable of three degrees of freedom, v =
a² s² + κ² σ_o²; then q_o, the split-conformal quantile of e / sqrt(a² s² + κ² σ_o²) over the
same poses.  κ is kept only where it raises the likelihood significantly (LIKELIHOOD_RATIO):
where the regions left out barely exercise what was omitted, it is not identified, and fitted
anyway it swung with the seed of the regions.  A model over the position is the exception:
its regions left out reach their positions as its training did, so they rarely identify κ,
and its training poses give it instead (the registered nominal robot's residuals there are
M(q) θ: κ² = mean(e² / σ_o²)).  No held-out pose checks that part of the bound, which then
takes its own likelihood's 95 % factor: sqrt((q_o a s)² + (CHI3_95 κ σ_o)²).  The bound
outside is never below the bound the same configuration would have inside, q · s(x).
"""
from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

# The omitted parameters' Jacobian is built on at most this many training poses (evenly
# spread), as the posterior is (robocal.methods.model_sigma.POSTERIOR_POSES).
OMITTED_POSES = 2000
# The 95 % quantile of a chi of three degrees of freedom over sqrt(3): the bound's factor on
# a spread no held-out pose checks (the norm of an error whose coordinates have variance v/3).
CHI3_95 = math.sqrt(7.814727903251178 / 3.0)
# A model over the TCP position keeps at most this many training configurations (evenly
# spread) as the anchors its σ_o is taken against; stored in the model file (6 numbers each).
ANCHOR_POSES = 1000
# The likelihood's variance never falls below this share of the largest (a degenerate
# calibration pose with s = σ_o = 0 would otherwise make it infinite).
VARIANCE_FLOOR = 1e-12
# κ is kept only when the held-out regions support it: twice the log-likelihood gained by
# fitting it must pass the chi-square quantile of one degree of freedom at 95 %.  On UR10
# series B's other elbow side the 34 to 42 poses outside their fold's domain do not (their
# σ_o is a tenth of the other side's), and κ fitted anyway went from 0 to 0.9 with the seed
# of the regions, the bound from 1.8 to 4.1 times the median error.
LIKELIHOOD_RATIO = 3.841


@dataclass(frozen=True)
class Omitted:
    """σ_o of the module docstring for one fitted model.

    fitted : tuple of str
        The model's fitted parameters whose response B is kept (none for an unregistered
        nominal robot).
    names : tuple of str
        The omitted parameters (compliances of loaded joints, gains, links).
    prior_std : (E,) array
        Their tolerance prior τ (internal units: rad/(N·m), fraction, mm, rad).
    response : (P, E) array
        B: how far the fitted parameters moved per unit of each omitted one on the
        training poses.
    compliant : bool
        Whether compliances are among ``names`` (the Jacobian is then a compliant chain's,
        with the default mass model and ``payload``).
    payload : float or None
        kg at the TCP of that mass model (None: the robot's own).
    anchors : (K, n) array or None
        For a model over the TCP position: training configurations (rad), σ_o being taken
        of M(q) − M(q_a), q_a the anchor whose nominal TCP lies nearest q's.
    scale : float or None
        For a model over the TCP position: κ as its training poses give it (the registered
        nominal robot's residuals there are the omitted parameters' error M(q) θ), used
        where the regions left out do not identify κ.  A model over the joints (the network)
        keeps κ = 0 there: its regions left out are joint-space ones, which do exercise
        σ_o (with the training κ, UR10 A's other shoulder side went from 0.87 covered to 1.00).
    """

    fitted: tuple = field(repr=False)
    names: tuple
    prior_std: np.ndarray = field(repr=False)
    response: np.ndarray = field(repr=False)
    compliant: bool = False
    payload: float | None = None
    anchors: np.ndarray | None = field(default=None, repr=False)
    scale: float | None = None
    # The compliant chain and the anchors' tree, built at first use; a copy (dataclasses.replace) starts empty.
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def _chain(self, chain):
        if not self.compliant or hasattr(chain, "mass_model"):
            return chain
        # Built once per chain: building compiles its programs (some 3 ms), which a served
        # target outside the domain would otherwise pay at every request.
        cached = self._cache.get("chain")
        if cached is not None and cached[0] is chain:
            return cached[1]
        from ..kinematics.compliant import CompliantChain
        from ..kinematics.gravity import default_mass_model

        compliant = CompliantChain(chain, default_mass_model(chain, self.payload), np.zeros(chain.n_joints))
        self._cache["chain"] = (chain, compliant)
        return compliant

    def sigma(self, chain, joints):
        """(N,) mm: σ_o at ``joints`` (N, n) rad of the model's ``chain``; NaN for a NaN row."""
        joints = np.atleast_2d(np.asarray(joints, dtype=float))
        out = np.full(len(joints), np.nan)
        known = np.all(np.isfinite(joints), axis=1)
        if known.any():
            missed = self._missed(chain, joints[known])
            if self.anchors is not None:
                missed = missed - self._missed(chain, self.anchors[self._nearest_anchor(chain, joints[known])])
            out[known] = np.sqrt(np.einsum("mce,e->m", missed ** 2, self.prior_std ** 2))
        return out

    def _missed(self, chain, joints):
        """(M, 3, E) M(q): the omitted parameters' position rows less the fitted ones' response."""
        jac = self._chain(chain).identification_jacobian(joints, list(self.fitted) + list(self.names))[:, :3, :]
        missed = jac[:, :, len(self.fitted):]
        if len(self.fitted):
            missed = missed - np.einsum("mcp,pe->mce", jac[:, :, :len(self.fitted)], self.response)
        return missed

    def _nearest_anchor(self, chain, joints):
        """(M,) the index of the anchor whose nominal TCP lies nearest each configuration's."""
        cached = self._cache.get("anchors")
        if cached is None or cached[0] is not chain:
            from scipy.spatial import cKDTree

            cached = (chain, cKDTree(chain.fk_positions(self.anchors)))
            self._cache["anchors"] = cached
        return cached[1].query(chain.fk_positions(joints))[1]

    def to_dict(self):
        return {"fitted": list(self.fitted), "names": list(self.names), "prior_std": self.prior_std.tolist(),
                "response": self.response.tolist(), "compliant": self.compliant, "payload": self.payload,
                "anchors": None if self.anchors is None else self.anchors.tolist(), "scale": self.scale}

    @classmethod
    def from_dict(cls, document):
        """ValueError (or KeyError, TypeError) when the entry is damaged."""
        fitted = tuple(str(n) for n in document["fitted"])
        names = tuple(str(n) for n in document["names"])
        prior_std = np.asarray(document["prior_std"], dtype=float).reshape(-1)
        response = np.asarray(document["response"], dtype=float).reshape(len(fitted), len(names))
        if len(prior_std) != len(names) or not (np.all(np.isfinite(prior_std)) and np.all(np.isfinite(response))):
            raise ValueError("the omitted parameters' prior and response must be finite, one per parameter")
        payload, anchors, scale = document.get("payload"), document.get("anchors"), document.get("scale")
        if scale is not None and not (math.isfinite(float(scale)) and float(scale) >= 0):
            raise ValueError("the omitted parameters' scale must be finite and >= 0")
        if anchors is not None:
            anchors = np.asarray(anchors, dtype=float)
            if anchors.ndim != 2 or not len(anchors) or not np.all(np.isfinite(anchors)):
                raise ValueError("the omitted parameters' anchors must be finite configurations, one per row")
        return cls(fitted=fitted, names=names, prior_std=prior_std, response=response,
                   compliant=bool(document.get("compliant", False)),
                   payload=None if payload is None else float(payload), anchors=anchors,
                   scale=None if scale is None else float(scale))


def omitted_of(method, chain_used, observations, calibration=None, posterior=None):
    """The :class:`Omitted` of a fitted ``method`` whose kinematic model is ``chain_used``,
    trained on ``observations`` (joints (N, n) rad, positions (N, 3) mm), or None when it
    omits nothing with a tolerance.

    calibration, posterior : its parametric calibration (a fitted KinematicCalibration) and
        that calibration's posterior (names, covariance), or None for a model over the
        nominal robot (Kriging, the network on its default base), whose omitted parameters
        are the links too and whose fitted ones the registered base and tool (when it
        registered)."""
    from ..kinematics.tolerances import prior_sigmas, tolerances_of

    q = np.asarray(observations.joints, dtype=float)
    covered = set() if posterior is None else set(posterior[0])
    candidates = []
    if calibration is None:
        # Over the nominal robot: every link parameter is omitted (POE chains: and the home pose).
        groups = ("links", "home") if chain_used.convention == "poe" else ("links",)
        candidates += chain_used.parameter_names(groups)
    candidates += chain_used.parameter_names(("gains",))
    jac_chain, compliant, payload = chain_used, False, getattr(method, "payload", None)
    if not hasattr(chain_used, "mass_model"):
        from ..kinematics.compliant import with_compliance

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                jac_chain, loaded = with_compliance(chain_used, q, payload)
        except (InputError, ValueError):
            jac_chain, loaded = chain_used, []
        candidates += loaded
        compliant = bool(loaded)
    names = [n for n in dict.fromkeys(candidates) if n not in covered]
    prior_std = prior_sigmas(jac_chain, names, tolerances_of(jac_chain), q) if names else np.zeros(0)
    keep = np.isfinite(prior_std) & (prior_std > 0)
    names, prior_std = [n for n, k in zip(names, keep) if k], prior_std[keep]
    compliant = compliant and any(jac_chain.parameters[n].group == "compliance" for n in names)
    if not names:
        return None
    pick = q[np.linspace(0, len(q) - 1, min(len(q), OMITTED_POSES)).astype(int)]
    if posterior is not None:
        fitted, covariance = list(posterior[0]), np.asarray(posterior[1], dtype=float)
        jac = _rows(jac_chain, pick, fitted + names)
        residual = np.asarray(observations.positions, dtype=float) - calibration.chain_.fk_positions(q)
        noise = max(float(np.sum(residual ** 2)) / max(3 * len(q) - len(calibration.result_.names), 1), 1e-300)
        gain = jac[:, :len(fitted)].T @ jac[:, len(fitted):] * (len(q) / len(pick)) / noise
        response = covariance @ gain
    elif getattr(getattr(method, "record_", None), "registered", False):
        from ..estimation.identification import BASE, TOOL_POSITION

        fitted = list(BASE) + list(TOOL_POSITION)
        jac = _rows(jac_chain, pick, fitted + names)
        response = np.linalg.pinv(jac[:, :len(fitted)]) @ jac[:, len(fitted):]
    else:
        fitted, response = [], np.zeros((0, len(names)))
    # A model over the TCP position (the Kriging's default inputs): σ_o against the training
    # configuration reaching the nearest position (module docstring).
    over_position = calibration is None and getattr(method, "inputs", None) == "position"
    anchors = q[np.linspace(0, len(q) - 1, min(len(q), ANCHOR_POSES)).astype(int)] if over_position else None
    omitted = Omitted(fitted=tuple(fitted), names=tuple(names), prior_std=np.asarray(prior_std, dtype=float),
                      response=response, compliant=compliant, payload=payload)
    if not over_position:
        return omitted
    return dataclasses.replace(_with_training_scale(omitted, chain_used, pick, observations), anchors=anchors)


def _with_training_scale(omitted, chain, pick, observations):
    """``omitted`` with its ``scale``: κ by maximum likelihood on the registered nominal
    robot's residuals at the training poses (each norm sqrt(κ² σ_o² / 3) times a chi of three
    degrees of freedom, σ_o there without anchors: κ² = mean(e² / σ_o²))."""
    q = np.asarray(observations.joints, dtype=float)
    index = np.linspace(0, len(q) - 1, len(pick)).astype(int)
    residual = np.linalg.norm(np.asarray(observations.positions, dtype=float)[index] - chain.fk_positions(pick), axis=1)
    spread = omitted.sigma(chain, pick)
    usable = np.isfinite(spread) & (spread > VARIANCE_FLOOR ** 0.5 * max(float(np.nanmax(spread)), 1e-300))
    if not usable.any():
        return omitted
    return dataclasses.replace(omitted, scale=float(np.sqrt(np.mean(residual[usable] ** 2 / spread[usable] ** 2))))


def _rows(chain, joints, names):
    """(3M, P) position rows of the identification Jacobian."""
    return chain.identification_jacobian(joints, list(names))[:, :3, :].reshape(-1, len(names))



# ------------------------------------------------------------------ the bound outside
@dataclass(frozen=True)
class OutsideScale:
    """The bound outside the domain: sqrt((q_o a s(x))² + (f_o κ σ_o(x))²) (module docstring).

    factor : float
        q_o, the split-conformal quantile of the calibration poses' normalised errors.
    residual_growth : float
        a (dimensionless).
    omitted_scale : float
        κ (dimensionless; 0 when nothing is omitted).
    omitted : Omitted or None
        What σ_o is computed from.
    omitted_factor : float or None
        f_o: q_o (None) where the regions left out fitted κ; where κ is the training poses'
        (:attr:`Omitted.scale`), no held-out pose checks that part of the bound, and it
        takes the 95 % quantile of its own likelihood, CHI3_95.
    """

    factor: float
    residual_growth: float
    omitted_scale: float
    omitted: Omitted | None = None
    omitted_factor: float | None = None

    @property
    def _omitted_factor(self):
        return self.factor if self.omitted_factor is None else self.omitted_factor

    def bound(self, scale, omitted_sigma, inside_factor):
        """(N,) mm from s(x) and σ_o(x) (N,) mm (σ_o ignored when nothing is omitted), never
        below the bound inside the domain, ``inside_factor`` · s(x)."""
        scale = np.asarray(scale, dtype=float)
        spread = (self._omitted_factor * self.omitted_scale * np.asarray(omitted_sigma, dtype=float)
                  if self.omitted is not None else 0.0)
        return np.maximum(np.sqrt((self.factor * self.residual_growth * scale) ** 2 + spread ** 2),
                          inside_factor * scale)

    def bound_one(self, scale, omitted_sigma, inside_factor):
        """:meth:`bound` of one configuration, on floats."""
        spread = self._omitted_factor * self.omitted_scale * omitted_sigma if self.omitted is not None else 0.0
        grown = self.factor * self.residual_growth * scale
        return max(math.sqrt(grown * grown + spread * spread), inside_factor * scale)

    def to_dict(self):
        return {"factor": self.factor, "residual_growth": self.residual_growth, "omitted_scale": self.omitted_scale,
                "omitted": None if self.omitted is None else self.omitted.to_dict(),
                "omitted_factor": self.omitted_factor}

    @classmethod
    def from_dict(cls, document):
        numbers = [float(document[k]) for k in ("factor", "residual_growth", "omitted_scale")]
        omitted_factor = document.get("omitted_factor")
        if omitted_factor is not None:
            omitted_factor = float(omitted_factor)
        if not all(math.isfinite(v) and v >= 0 for v in numbers + [omitted_factor or 0.0]):
            raise ValueError("the outside factor and scales must be finite and >= 0")
        omitted = document.get("omitted")
        return cls(*numbers, omitted=None if omitted is None else Omitted.from_dict(omitted),
                   omitted_factor=omitted_factor)


def fit_outside(error, scale, omitted_sigma, omitted, quantile):
    """The :class:`OutsideScale` of held-out poses outside their fold's domain: error norms,
    the fold model's s and σ_o there (N,) mm; ``quantile`` the conformal quantile function.
    None without poses."""
    from scipy.optimize import minimize

    error, scale = np.asarray(error, dtype=float), np.asarray(scale, dtype=float)
    spread = np.zeros_like(scale) if omitted is None else np.nan_to_num(np.asarray(omitted_sigma, dtype=float))
    if not len(error):
        return None
    floor = VARIANCE_FLOOR * max(float(np.max(scale ** 2 + spread ** 2)), 1e-300)

    def negative_log_likelihood(log_squares):
        a2, k2 = np.exp(log_squares)
        variance = np.maximum(a2 * scale ** 2 + k2 * spread ** 2, floor) / 3.0
        return float(np.sum(1.5 * np.log(variance) + error ** 2 / (2.0 * variance)))

    # Without the omitted parameters (κ = 0) the likelihood's a has a closed form.
    growth, kappa, omitted_factor = float(np.sqrt(np.mean(error ** 2 / np.maximum(scale ** 2, floor)))), 0.0, None
    if np.any(spread > 0):
        starts = ([0.0, -2.0], [0.0, 0.0], [1.0, -4.0])
        best = min((minimize(negative_log_likelihood, start, method="Nelder-Mead",
                             options={"xatol": 1e-6, "fatol": 1e-9, "maxiter": 2000}) for start in starts),
                   key=lambda result: result.fun)
        # κ only where the regions left out support it (likelihood ratio against κ = 0).
        if 2.0 * (negative_log_likelihood(np.log([growth ** 2, 1e-300])) - best.fun) > LIKELIHOOD_RATIO:
            growth, kappa = (float(v) for v in np.sqrt(np.exp(best.x)))
    if kappa == 0.0 and omitted is not None and omitted.scale:
        # The training poses' κ (a model over the position) where the regions left out do
        # not identify it: they reach their positions as the training did, and so may barely
        # exercise its σ_o.
        kappa, omitted_factor = omitted.scale, CHI3_95
        fixed = minimize(lambda log_a2: negative_log_likelihood([log_a2[0], 2.0 * math.log(kappa)]), [0.0],
                         method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-9})
        growth = float(np.sqrt(np.exp(fixed.x[0])))
    normaliser = np.sqrt(np.maximum((growth * scale) ** 2 + (kappa * spread) ** 2, floor))
    factor = quantile(error / normaliser)
    if not math.isfinite(factor):
        return None
    return OutsideScale(factor=float(factor), residual_growth=growth, omitted_scale=kappa, omitted=omitted,
                        omitted_factor=omitted_factor)
