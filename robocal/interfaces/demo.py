"""``robocal demo``: the Kriging compensation experiment of Liu et al. (2022), end to end.

KUKA KR 150-2 with the ``liu2022`` geometric deviations; 150 Latin-hypercube targets in
x 1200..2200, y -800..800, z 400..1400 mm with the flange pointing down; the first 50 train
a Kriging model of the position error over the nominal position, the last 100 are
compensated (command P - ê(P) through the nominal IK) and measured on the simulated robot.
Every figure is computed in this run; the published ones are printed beside them.
"""
import time
from dataclasses import dataclass

import numpy as np
from rich.table import Table

from ..estimation.metrics import ErrorStats, error_stats
from ..io.library import builtin
from ..io.observations import Observations
from ..methods import KrigingMethod
from ..simulation import liu2022_plan, make_true_robot

PUBLISHED = {
    "before_mean_mm": 1.6778,
    "after_mean_mm": 0.0018,
    "after_max_mm": 0.0084,
}


@dataclass(frozen=True)
class Demonstrated:
    """What ``demo`` measured: the experiment of Liu et al. (2022) (:func:`run_demo`).

    Attributes
    ----------
    robot, experiment : str
        The robot's name, and the experiment in a sentence.
    training_points, test_points : int
        The targets the Kriging model is fitted on, and those compensated.
    before_all, before : ErrorStats
        The true robot's position error at every target, and at the test targets (mm).
    predicted_compensation, prediction_deviation : ErrorStats
        The model's predicted error at the test targets, and that less the true one (mm).
    after, after_iterated : ErrorStats
        The error left after compensation at the reachable test targets, with one
        correction and iterated to a fixed point (mm).
    reachable : int
        How many compensated test targets the robot reaches.
    kriging : dict
        The fitted model's ``theta``, ``nugget`` and ``diagnostics``, and ``fit_seconds``
        and ``compensate_seconds`` (s).
    published : dict
        The paper's figures (mm): ``before_mean_mm``, ``after_mean_mm``, ``after_max_mm``.
    """

    robot: str
    experiment: str
    training_points: int
    test_points: int
    before_all: ErrorStats
    before: ErrorStats
    predicted_compensation: ErrorStats
    prediction_deviation: ErrorStats
    after: ErrorStats
    after_iterated: ErrorStats
    reachable: int
    kriging: dict
    published: dict

    def to_dict(self):
        statistics = ("before_all", "before", "predicted_compensation", "prediction_deviation", "after",
                      "after_iterated")
        return {"robot": self.robot, "experiment": self.experiment, "training_points": self.training_points,
                "test_points": self.test_points, **{name: getattr(self, name).to_dict() for name in statistics},
                "reachable": self.reachable, "kriging": self.kriging, "published": self.published}


def _compensated(truth, compensator, targets, hint, iterate):
    result = compensator.commands(targets, hint=hint, iterate=iterate)
    reached = truth.positions(result.q[result.success])
    return result, reached - targets[result.success, :3, 3]


def run_demo():
    """Run the experiment; returns a :class:`Demonstrated`."""
    chain = builtin("kr150-2")
    truth = make_true_robot(chain, "liu2022")
    q, targets, train, test = liu2022_plan(chain)
    nominal = targets[:, :3, 3]
    errors = truth.positions(q) - nominal

    t0 = time.perf_counter()
    fitted = KrigingMethod(register="no").fit(chain, Observations.of(q[train], truth.positions(q[train])))
    compensator = fitted.compensator_
    fit_seconds = time.perf_counter() - t0
    model = compensator.error_model
    predicted = model.predict(nominal[test])

    t0 = time.perf_counter()
    result, after = _compensated(truth, compensator, targets[test], q[test], iterate=False)
    compensate_seconds = time.perf_counter() - t0
    _, after_iterated = _compensated(truth, compensator, targets[test], q[test], iterate=True)

    return Demonstrated(
        robot=chain.name,
        experiment="liu2022: 150 Latin-hypercube targets, 50 train, 100 test",
        training_points=int(len(train)),
        test_points=int(len(test)),
        before_all=error_stats(errors),
        before=error_stats(errors[test]),
        predicted_compensation=error_stats(predicted),
        prediction_deviation=error_stats(predicted - errors[test]),
        after=error_stats(after),
        after_iterated=error_stats(after_iterated),
        reachable=int(result.success.sum()),
        kriging={
            "theta": np.asarray(model.theta_).tolist(),
            "nugget": np.asarray(model.nugget_).tolist(),
            "diagnostics": list(getattr(model, "diagnostics_", [])),
            "fit_seconds": fit_seconds,
            "compensate_seconds": compensate_seconds,
        },
        published=dict(PUBLISHED),
    )


# (label, result attribute, decimals, published mean, published max): the rows of the paper's
# Tables 3-5, with labels short enough for an 80-column terminal.
ROWS = (
    ("before, all 150", "before_all", 4, PUBLISHED["before_mean_mm"], None),
    ("before, 100 test", "before", 4, None, None),
    ("predicted (T3)", "predicted_compensation", 4, None, None),
    ("pred.-actual (T4)", "prediction_deviation", 5, None, None),
    ("after (T5)", "after", 5, PUBLISHED["after_mean_mm"], PUBLISHED["after_max_mm"]),
    ("after, fixed point", "after_iterated", 5, None, None),
)


def _pair(mean, largest, digits):
    return f"{mean:.{digits}f} / {largest:.{digits}f}"


def demo_tables(result):
    """Rich renderables laid out like the paper's Tables 3-5: the single-point error with the
    published figures, then the error along each axis (mean / max of |e|, mm)."""
    single = Table(title=f"{result.robot}: {result.experiment}")
    for col in ("|e| (mm)", "mean", "max", "published"):
        single.add_column(col, justify="right")
    axes = Table(title="per axis: mean / max of |e_x|, |e_y|, |e_z| (mm)")
    for col in ("", "x", "y", "z"):
        axes.add_column(col, justify="right")
    for label, key, digits, published_mean, published_max in ROWS:
        stats = getattr(result, key)
        published = "-" if published_mean is None else (
            f"{published_mean:.4f}" + ("" if published_max is None else f" / {published_max:.4f}"))
        single.add_row(label, f"{stats.mean_mm:.{digits}f}", f"{stats.max_mm:.{digits}f}", published)
        axes.add_row(label, *(_pair(getattr(stats, f"{a}_mean_mm"), getattr(stats, f"{a}_max_mm"), 4) for a in "xyz"))
    k = result.kriging
    notes = (f"Kriging fitted on {result.training_points} points in {k['fit_seconds']:.2f} s; "
             f"{result.reachable}/{result.test_points} compensated targets reachable; "
             f"compensation (IK of 100 targets) {k['compensate_seconds'] * 1e3:.0f} ms.")
    out = [single, axes, notes]
    out += [f"note: {d}" for d in k["diagnostics"]]
    return out
