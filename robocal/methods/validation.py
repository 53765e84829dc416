"""Held-out accuracy of any registered method: k-fold cross-validation and learning curves
on position data, leave-one-placement-out on ball-in-socket data, each beside the nominal
robot scored the same way (registered on the same training folds)."""
import numpy as np

from .. import parallel
from ..errors import InputError
from ..estimation.constraint import socket_deviations
from ..estimation.metrics import error_stats
from ..estimation.validation import fold_assignment, k_fold, learning_curve
from ..io.observations import Observations
from ..kinematics.chain import Chain
from . import make_method
from .frames import registered_nominal


def method_fitter(method, chain, observations, on_fit=None):
    """``fit(train_index) -> predict(test_index)`` (see :mod:`robocal.estimation.validation`)
    that fits a fresh copy of ``method`` (same settings) on the training rows; the predictor
    carries the fitted method as ``predict.fitted``."""
    q = observations.joints

    def fit(train):
        fitted = method.clone().fit(chain, observations.subset(train))
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


def fold_task(task):
    """One fold of :func:`cross_validate` run by a worker of :mod:`robocal.parallel` (plain
    data in and out): ``task`` holds the robot and observations (their ``to_plain``), the
    ``method`` name ("nominal": the nominal robot registered) and its ``settings``, and the
    ``train`` and ``test`` indices; returns the (len(test), 3) held-out predictions, mm."""
    chain = Chain.from_plain(task["robot"])
    observations = Observations.from_plain(task["observations"])
    train, test = np.asarray(task["train"]), np.asarray(task["test"])
    if task["method"] == "nominal":
        return nominal_fitter(chain, observations)(train)(test)
    method = make_method(task["method"], **task["settings"])
    return method_fitter(method, chain, observations)(train)(test)


def _fitted_on_executor(method, chain, observations, fold_of, runner, on_fit):
    """(fitter of ``method``, fitter of the registered nominal) whose folds (``fold_of``, as
    :func:`k_fold` draws them) were all fitted beforehand on ``runner``, two fits a fold at a
    time on its workers."""
    robot, plain = chain.to_plain(), observations.to_plain()
    folds = range(int(fold_of.max()) + 1)
    tasks = [{"robot": robot, "observations": plain, "method": name, "settings": settings,
              "train": np.flatnonzero(fold_of != fold), "test": np.flatnonzero(fold_of == fold)}
             for name, settings in ((method.name, method.get_settings()), ("nominal", {})) for fold in folds]
    predictions = runner.map(fold_task, tasks, on_done=None if on_fit is None else lambda index, result: on_fit())

    def fitter(offset):
        by_train = {tasks[offset + fold]["train"].tobytes(): predictions[offset + fold] for fold in folds}

        def fit(train):
            predicted = by_train[np.asarray(train).tobytes()]
            return lambda test: predicted
        return fit

    return fitter(0), fitter(len(folds))


def _summary(cv):  # the per-pose arrays stay out of the JSON
    return {key: cv[key] for key in ("k", "folds", "pooled")}


def cross_validate(method, chain, observations, *, folds=5, sizes=None, seed=0, on_fit=None):
    """The held-out error of ``method`` (unfitted) on ``observations`` of ``chain``.

    Position data: ``folds``-fold cross-validation with the random fold assignment of
    ``seed``, and a learning curve when ``sizes`` lists training sizes.  Ball-in-socket data:
    each fixture placement left out in turn.  ``on_fit()`` is called after every fit.  The
    folds run on the active :func:`robocal.parallel.executor` when there is one (the learning
    curve and the placements here).  Returns the JSON-ready dict ``robocal validate --json`` prints.
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
    fitter, nominal = method_fitter(method, chain, observations, on_fit), nominal_fitter(chain, observations, on_fit)
    runner = parallel.current()
    if runner.client is not None and 2 <= folds <= n:
        fold_fitter, nominal = _fitted_on_executor(method, chain, observations, fold_assignment(n, folds, seed),
                                                   runner, on_fit)
    else:
        fold_fitter = fitter
    result = {"method": method.name, "file": observations.path, "poses": n, "folds": folds,
              "cross_validation": _summary(k_fold(n, fold_fitter, measured, k=folds, seed=seed)),
              "nominal_cross_validation": _summary(k_fold(n, nominal, measured, k=folds, seed=seed))}
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
        fitted = method.clone().fit(chain, obs.subset(~test))
        if on_fit is not None:
            on_fit()
        held = obs.subset(test)
        for model, fold_list, pooled in ((fitted.compensator_.chain, folds, deviations),
                                         (chain, nominal_folds, nominal_deviations)):
            held_out, _ = socket_deviations(model, held.joints, held.placement, held.socket, held.fixture)
            pooled.append(held_out)
            fold_list.append({"fold": placement, "n_train": int((~test).sum()),
                              "held_out": error_stats(held_out).to_dict()})
    return {"method": method.name, "file": obs.path, "poses": obs.n_poses, "folds": len(placements),
            "metric": "socket consistency on the placement left out",
            "cross_validation": {"k": len(placements), "folds": folds,
                                 "pooled": error_stats(np.concatenate(deviations)).to_dict()},
            "nominal_cross_validation": {"k": len(placements), "folds": nominal_folds,
                                         "pooled": error_stats(np.concatenate(nominal_deviations)).to_dict()}}
