"""Kriging error model in the DACE form (Lophaven, Nielsen & Søndergaard, 2002).

Each output column is modelled as

    y(x) = f(x)ᵀβ + z(x),

a regression trend ``f`` (constant, linear or quadratic polynomial) plus a stationary
Gaussian process ``z`` of variance σ² and correlation

    gaussian:  R(x, x') = exp(−Σ_k θ_k (x_k − x'_k)²)
    matern52:  R(x, x') = (1 + √5 h + 5h²/3) exp(−√5 h),   h² = Σ_k θ_k (x_k − x'_k)²

on inputs and outputs standardised to zero mean and unit variance.  For given θ, β comes
from generalised least squares and σ² from its residual; θ (and optionally a nugget) then
maximises the concentrated log-likelihood

    ℓ(θ) = −½ (n log σ̂²(θ) + log det C(θ) + n (1 + log 2π)),   C = R + (nugget + jitter) I,

with L-BFGS-B on log θ and the analytic gradient.  Because β̂ and σ̂² are the exact maximisers
of the full likelihood for fixed θ, their own derivatives drop out (envelope theorem) and

    ∂ℓ/∂θ_k = ½ tr((α αᵀ/σ̂² − C⁻¹) ∂C/∂θ_k),   α = C⁻¹(y − F β̂),

where α uses the GLS β̂ at the same θ; with ∂C/∂nugget = I the same formula gives the
nugget's derivative.

Prediction at x with r = R(x, X):

    ŷ(x) = f(x)ᵀβ̂ + rᵀα
    MSE(x) = σ̂² (1 + uᵀ(FᵀC⁻¹F)⁻¹u − rᵀC⁻¹r),   u = FᵀC⁻¹r − f(x),

the mean squared error of the best linear unbiased predictor of the noise-free field.

The package, each module depending only on those listed before it:

- :mod:`.correlation`: the trend basis, the correlation functions, the jittered Cholesky factor;
- :mod:`.exact`: the exact likelihood and its gradient;
- :mod:`.bordered`, :mod:`.vecchia_prediction`, :mod:`.stand_ins`, :mod:`.vecchia`: the Vecchia
  approximation (batched factorisations, the fitted state and its local predictors, the search's
  stand-ins for the exact likelihood, the likelihood itself);
- :mod:`.training`: a fit's standardised data and the problem (exact or Vecchia) built on them;
- :mod:`.search`: the hyperparameter search (L-BFGS-B from screened starts, in parallel per output);
- :mod:`.point`: the exact predictor at one point (the fit's factors prepared once);
- :mod:`.model`: the :class:`Kriging` estimator (settings, fit, predict, its JSON document).
"""
from .correlation import (JITTER_START, MAX_CONDITION, correlation_from_squared, latin_hypercube, matern52_slope,
                          trend_basis, trend_size)
from .model import (APPROXIMATIONS, AUTO_VECCHIA_ABOVE, CORRELATIONS, FORMAT, FORMAT_VERSION, REGRESSIONS,
                    Kriging)

__all__ = ["APPROXIMATIONS", "AUTO_VECCHIA_ABOVE", "CORRELATIONS", "FORMAT", "FORMAT_VERSION", "JITTER_START",
           "MAX_CONDITION", "REGRESSIONS", "Kriging", "correlation_from_squared", "latin_hypercube",
           "matern52_slope", "trend_basis", "trend_size"]
