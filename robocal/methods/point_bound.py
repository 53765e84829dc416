"""A fitted 95 % bound (:class:`~robocal.methods.bound.PositionBound`) of one configuration,
on floats: what ``robocal serve`` asks per request.

The batch path (:meth:`PositionBound.predict`) costs some 230 µs for a batch of one, mostly
array set-up; this one prepares once per bound what does not depend on the configuration (the
posterior's layout, :class:`~robocal.methods.model_sigma.PointPosterior`; the search tree of
the training configurations, :class:`~robocal.methods.model_sigma.NearestTraining`) and
repeats the batch formula's operations on floats, so that the two agree to rounding
(``tests/test_model_sigma.py``).
"""
from __future__ import annotations

import math

import numpy as np

from .model_sigma import NearestTraining, PointPosterior, chain_of, posterior_sigma


class PointBound:
    """The bound of ``bound`` (a PositionBound, its own part: the caller picks the fallback's
    for a configuration outside the domain) at one configuration at a time."""

    def __init__(self, bound):
        self.bound_model = bound
        chain = chain_of(bound.method)
        self.chain = chain
        self.posterior = None if bound.posterior is None else PointPosterior(chain, *bound.posterior)
        self.nearest = NearestTraining(bound.training_joints, chain.revolute)

    def bound(self, joints, inside):
        """The bound (mm, a float) at ``joints`` (n,) rad, inside the domain or not (bool),
        without the set-up factor (the caller's)."""
        model = self.bound_model
        variance = 0.0
        if model.posterior is not None:
            sigma = self.posterior.sigma(joints)
            if sigma is None:  # a chain the point path does not cover
                sigma = float(posterior_sigma(self.chain, joints[None], *model.posterior)[0])
            variance = variance + sigma * sigma
        if model.method.compensator_.error_model is not None:
            own = model.method.uncertainty(joints[None])
            if own is not None:
                own = float(np.asarray(own, dtype=float)[0])
                variance = variance + own * own
        sigma = math.sqrt(variance)
        if not inside and model.outside is not None:
            # What the model did not model (robocal.methods.omitted): the batch's row, the
            # Jacobian of compliances being the compliant chain's (PointPosterior has none).
            spread = 0.0 if model.outside.omitted is None else float(model.omitted_sigma(joints[None])[0])
            scale = math.sqrt(sigma * sigma + model.residual_mm * model.residual_mm)
            return model.outside.bound_one(scale, spread, model.inside_factor)
        distance = None if inside else float(self.nearest.distance(joints[None])[0])
        return outside_bound_one(model.inside_factor, model.residual_mm, sigma, distance, model.growth_per_rad,
                                 model.sigma_growth_per_rad)


def outside_bound_one(factor, residual, sigma, distance, growth, sigma_growth):
    """:func:`outside_bound` of one configuration, on floats (the same operations)."""
    scale = math.sqrt(sigma * sigma + residual * residual)
    if distance is None:
        return factor * scale
    if growth is None and sigma_growth is None:
        return math.nan
    bound = 0.0
    if growth is not None:
        bound = factor * scale * (1.0 + growth * distance)
    if sigma_growth is not None:
        spread = sigma_growth * sigma * distance
        bound = max(bound, factor * math.sqrt(scale * scale + spread * spread))
    return bound
