"""Held-out accuracy of any registered method: k-fold cross-validation and learning curves
on position data, leave-one-placement-out on ball-in-socket data, each beside the nominal
robot scored the same way (registered on the same training folds)."""
import numpy as np

from ..errors import InputError
from ..estimation.constraint import socket_deviations
from ..estimation.metrics import error_stats
from ..estimation.validation import k_fold, learning_curve
from .frames import registered_nominal


def method_fitter(method, chain, observations, on_fit=None):
    """``fit(train_index) -> predict(test_index)`` (see :mod:`robocal.estimation.validation`)
    that fits a fresh copy of ``method`` (same settings) on the training rows; the predictor
    carries the fitted method as ``predict.fitted``."""
    q = observations.joints

    def fit(train):
        fitted = type(method)(**method.get_settings()).fit(chain, observations.subset(train))
        if on_fit is not None:
            on_fit()

        def predict(test):
            return fitted.predict(q[test])

        predict.fitted = fitted
        return predict

    return fit


def nominal_fitter(chain, observations, on_fit=None):
    """The same for the nominal robot registered on the training rows: the simplest model."""
    q, positions = observations.joints, observations.positions

    def fit(train):
        registered = registered_nominal(chain, q[train], positions[train])
        if on_fit is not None:
            on_fit()
        return lambda test: registered.fk_positions(q[test])

    return fit


def _summary(cv):  # the per-pose arrays stay out of the JSON
    return {key: cv[key] for key in ("k", "folds", "pooled")}


def cross_validate(method, chain, observations, *, folds=5, sizes=None, seed=0, on_fit=None):
    """The held-out error of ``method`` (unfitted) on ``observations`` of ``chain``.

    Position data: ``folds``-fold cross-validation with the random fold assignment of
    ``seed``, and a learning curve when ``sizes`` lists training sizes.  Ball-in-socket data:
    each fixture placement left out in turn.  ``on_fit()`` is called after every fit.
    Returns the JSON-ready dict ``robocal validate --json`` prints.
    """
    if method.data_kind == "sockets":
        if sizes:
            raise InputError("--sizes (a learning curve) is for position data; ball-in-socket data are "
                             "validated placement by placement")
        return placement_validation(method, chain, observations, on_fit)
    if observations.positions is None:
        raise InputError(f"{observations.path} has no x, y, z columns: the {method.name} method needs measured "
                         "positions")
    n, measured = observations.n_poses, observations.positions
    fitter = method_fitter(method, chain, observations, on_fit)
    result = {"method": method.name, "file": observations.path, "poses": n, "folds": folds,
              "cross_validation": _summary(k_fold(n, fitter, measured, k=folds, seed=seed)),
              "nominal_cross_validation": _summary(k_fold(n, nominal_fitter(chain, observations, on_fit), measured,
                                                          k=folds, seed=seed))}
    if sizes:
        result["learning_curve"] = learning_curve(n, fitter, measured, sizes, seed=seed)
    return result


def placement_validation(method, chain, observations, on_fit=None):
    """Leave one fixture placement out at a time: the method fitted on the others, its
    socket consistency on the one left out, beside the nominal model's."""
    from .constraint import require_sockets

    obs = require_sockets(observations)
    placements = sorted(set(obs.placement.tolist()))
    if len(placements) < 2:
        raise InputError(f"{obs.path} has one fixture placement: leave-one-placement-out needs two or more")
    folds, nominal_folds, deviations, nominal_deviations = [], [], [], []
    for placement in placements:
        test = obs.placement == placement
        fitted = type(method)(**method.get_settings()).fit(chain, obs.subset(~test))
        if on_fit is not None:
            on_fit()
        held = obs.subset(test)
        for model, fold_list, pooled in ((fitted.compensator_.chain, folds, deviations),
                                         (chain, nominal_folds, nominal_deviations)):
            held_out, _ = socket_deviations(model, held.joints, held.placement, held.socket, held.fixture)
            pooled.append(held_out)
            fold_list.append({"fold": placement, "n_train": int((~test).sum()), "held_out": error_stats(held_out)})
    return {"method": method.name, "file": obs.path, "poses": obs.n_poses, "folds": len(placements),
            "metric": "socket consistency on the placement left out",
            "cross_validation": {"k": len(placements), "folds": folds,
                                 "pooled": error_stats(np.concatenate(deviations))},
            "nominal_cross_validation": {"k": len(placements), "folds": nominal_folds,
                                         "pooled": error_stats(np.concatenate(nominal_deviations))}}
