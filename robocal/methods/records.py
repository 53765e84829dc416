"""What a fit did, as named records: what the model file's ``training`` entry keeps, what
``calibrate --json`` prints, and what the command line and the report render.

Every record is a frozen dataclass with ``to_dict`` (the JSON the model file holds: keys and
values as they always were, so files written before these classes existed read back) and
``from_dict``.  Figures are in file units: mm, and degrees for angles (see ``units``).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

from ..estimation.identifiability import IdentifiabilityReport


def _present(record, names):
    """``{name: value}`` of the named fields whose value is not None."""
    return {name: getattr(record, name) for name in names if getattr(record, name) is not None}


@dataclass(frozen=True)
class ParameterEstimate:
    """An identified parameter: its deviation from the starting model and (posterior)
    standard error, in the file unit of the parameter (mm, deg, urad/(N*m) or ppm); with a
    prior, its tolerance (None: no prior) and the share of the prior variance the data
    removed (None for a plain fit)."""

    deviation: float
    std_error: float
    prior_std: float | None = None
    data_share: float | None = None

    def to_dict(self):
        out = {"deviation": self.deviation, "std_error": self.std_error}
        if self.data_share is not None:
            out.update(prior_std=self.prior_std, data_share=self.data_share)
        return out

    @classmethod
    def from_dict(cls, doc):
        share = doc.get("data_share")
        prior = doc.get("prior_std")
        return cls(float(doc["deviation"]), float(doc["std_error"]), None if prior is None else float(prior),
                   None if share is None else float(share))


@dataclass(frozen=True)
class CalibrationRecord:
    """A parametric calibration (kinematic or constraint).

    parameters: {name: ParameterEstimate}; units: what the units of the deviations are;
    correlated_pairs: ((name, name, correlation), ...) beyond 0.95; identifiability: the
    :class:`IdentifiabilityReport`; residual_before / residual_after: statistics of the
    starting and the calibrated model on the training data; iterations, converged.  Kinematic
    calibrations add orientation_rms_deg (None without measured orientations), outliers
    (indices a robust loss down-weighted) and outlier_rows (their file lines); constraint
    calibrations add unobservable (what no constraint can see) and pairs (counts).
    """

    parameters: dict
    units: str
    correlated_pairs: tuple
    identifiability: IdentifiabilityReport
    residual_before: dict
    residual_after: dict
    iterations: int
    converged: bool
    kind: str = "kinematic"  # "kinematic" (instrument data) or "constraint" (ball in sockets)
    orientation_rms_deg: float | None = None
    outliers: tuple = ()
    outlier_rows: tuple = ()
    unobservable: tuple = ()
    pairs: dict = field(default_factory=dict)

    @property
    def held_by_prior(self):
        """Names whose prior variance the data reduced by less than half: kept near nominal."""
        from ..estimation.identification import HELD_BY_PRIOR

        return tuple(n for n, p in self.parameters.items() if p.data_share is not None and p.data_share < HELD_BY_PRIOR)

    def to_dict(self):
        out = {"parameters": {name: p.to_dict() for name, p in self.parameters.items()},
               "units": self.units, "correlated_pairs": [list(p) for p in self.correlated_pairs],
               "identifiability": self.identifiability.to_dict(),
               "residual_before": self.residual_before, "residual_after": self.residual_after,
               "iterations": self.iterations, "converged": self.converged}
        if self.kind == "constraint":
            return {**out, "unobservable": list(self.unobservable), "pairs": dict(self.pairs)}
        out.update(orientation_rms_deg=self.orientation_rms_deg, outliers=list(self.outliers))
        if self.outlier_rows:
            out["outlier_rows"] = list(self.outlier_rows)
        return out

    @classmethod
    def from_dict(cls, doc):
        ident = doc["identifiability"]
        common = dict(
            parameters={name: ParameterEstimate.from_dict(p) for name, p in doc["parameters"].items()},
            units=doc["units"], correlated_pairs=tuple(tuple(p) for p in doc["correlated_pairs"]),
            identifiability=IdentifiabilityReport(**{f.name: ident[f.name] for f in fields(IdentifiabilityReport)
                                                     if f.name in ident}),
            residual_before=doc["residual_before"], residual_after=doc["residual_after"],
            iterations=doc["iterations"], converged=doc["converged"])
        if "unobservable" in doc:
            return cls(**common, kind="constraint", unobservable=tuple(doc["unobservable"]),
                       pairs=dict(doc.get("pairs", {})))
        return cls(**common, orientation_rms_deg=doc.get("orientation_rms_deg"),
                   outliers=tuple(doc.get("outliers", ())), outlier_rows=tuple(doc.get("outlier_rows", ())))


@dataclass(frozen=True)
class FitRecord:
    """What a fit did (statistics as :func:`~robocal.estimation.metrics.error_stats` gives them).

    residual_before: the reference (the registered nominal) on the training data;
    residual_after_training: the fitted model on the training data; registered: whether
    base and tool were registered; nominal_in_given_frame: the nominal robot in the data's
    frame, before any registration; iterations: of that registration; calibration: the
    :class:`CalibrationRecord` of a parametric calibration; diagnostics: the error model's
    warnings; base_model and network: a network's base model and training record;
    fixture: the fixture of ball-in-socket data (``fixture_to_dict``); reregistration: what
    re-registering the model on a new set-up did (``ReregistrationRecord.to_dict``);
    predicted_error: the error to expect over the working range
    (:class:`~robocal.estimation.prediction.PredictedError` as a dict).
    """

    residual_before: dict
    residual_after_training: dict
    registered: bool | None = None
    nominal_in_given_frame: dict | None = None
    iterations: int | None = None
    calibration: CalibrationRecord | None = None
    diagnostics: list | None = None
    base_model: str | None = None
    network: dict | None = None
    fixture: dict | None = None
    reregistration: dict | None = None
    # The error to expect where the robot will work (PredictedError.to_dict), when calibrate
    # computed it.
    predicted_error: dict | None = None

    def to_dict(self):
        """JSON-ready, without the entries this method does not have."""
        out = _present(self, [f.name for f in fields(self)])
        if self.calibration is not None:
            out["calibration"] = self.calibration.to_dict()
        return out

    @classmethod
    def from_dict(cls, doc):
        """The record of a model file's ``training`` entry (other keys there are the data's)."""
        values = {f.name: doc.get(f.name) for f in fields(cls)}
        if values["calibration"] is not None:
            values["calibration"] = CalibrationRecord.from_dict(values["calibration"])
        return cls(**values)

    def replace(self, **changes):
        return type(self)(**{**{f.name: getattr(self, f.name) for f in fields(self)}, **changes})


@dataclass(frozen=True)
class ReportFigure:
    """A diagnostic a method adds to its report: ``kind`` names the plot
    (``kriging_uncertainty``: ``data`` has ``model`` and ``points`` (N, 3) mm;
    ``fitness_history``: ``data`` has ``history``)."""

    kind: str
    title: str
    caption: str
    data: dict
