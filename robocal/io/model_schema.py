"""The types a model file's entries must have, checked before anything is rebuilt from them.

A model file's checksum proves it is the file robocal wrote, or one whose editor recomputed
the checksum; it says nothing of what the entries hold.  Rebuilding a model from a document
whose ``training.residual_before.rms_mm`` is text, or whose ``options`` is a number, would fail
deep inside a verb with a traceback, or worse, be taken at face value.  :func:`check_document`
walks the document against :data:`MODEL_SCHEMA` and refuses the first entry of the wrong type
in one line that names it (``'domain.joints.min[2]'``).

The schema states types only.  Shapes (six joints, square covariances), ranges and the
robot documents' content are checked where the entries are rebuilt (``robot_file``,
``Domain.from_dict``, ``PositionBound.from_dict``, the error models' ``from_dict``).  Entries
the schema does not name are accepted as they are: documents differ by method and version,
and a newer robocal's extra entries are not an error.
"""
from __future__ import annotations

import numbers
from dataclasses import dataclass, field

from ..errors import FileFormatError


class Wrong(Exception):
    """An entry of the wrong type: ``where`` (a dotted path) and what it should have been."""

    def __init__(self, where, expected, value):
        self.where, self.expected, self.value = where, expected, value
        super().__init__(where)


def _kind(value):
    """How a JSON value is named in a message."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, numbers.Number):
        return "a number"
    return {str: "text", list: "a list", dict: "a table"}.get(type(value), type(value).__name__)


class Spec:
    """What an entry may be; :meth:`check` raises :class:`Wrong` if it is not."""

    expected = "?"

    def check(self, value, where):
        raise NotImplementedError


@dataclass(frozen=True)
class Scalar(Spec):
    """One JSON scalar: ``"number"``, ``"whole"``, ``"text"`` or ``"flag"``."""

    kind: str

    @property
    def expected(self):
        return {"number": "a number", "whole": "a whole number", "text": "text", "flag": "true or false"}[self.kind]

    def check(self, value, where):
        if self.kind == "flag":
            ok = isinstance(value, bool)
        elif self.kind == "text":
            ok = isinstance(value, str)
        else:  # JSON true/false are Python ints: never a number here
            ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
            if ok and self.kind == "whole":
                ok = float(value).is_integer()
        if not ok:
            raise Wrong(where, self.expected, value)


@dataclass(frozen=True)
class Anything(Spec):
    """Any JSON value (an entry whose content another module checks)."""

    expected = "anything"

    def check(self, value, where):
        return None


@dataclass(frozen=True)
class Maybe(Spec):
    """``spec`` or null."""

    spec: Spec

    @property
    def expected(self):
        return f"{self.spec.expected} or null"

    def check(self, value, where):
        if value is not None:
            try:
                self.spec.check(value, where)
            except Wrong as wrong:
                if wrong.where == where:  # the entry itself: say that null would do too
                    raise Wrong(where, self.expected, value) from None
                raise


@dataclass(frozen=True)
class OneOf(Spec):
    """One of several kinds (a nugget: a number or a list of them)."""

    specs: tuple

    @property
    def expected(self):
        return " or ".join(s.expected for s in self.specs)

    def check(self, value, where):
        for spec in self.specs:
            try:
                spec.check(value, where)
                return
            except Wrong:
                continue
        raise Wrong(where, self.expected, value)


@dataclass(frozen=True)
class ListOf(Spec):
    """A list whose every item is ``item``."""

    item: Spec

    @property
    def expected(self):
        return f"a list of {_plural(self.item.expected)}"

    def check(self, value, where):
        if not isinstance(value, list):
            raise Wrong(where, self.expected, value)
        # A Kriging's training points are 10^5 rows of numbers: one pass of type() (JSON
        # numbers are exactly int or float; true/false are bool) before naming the culprit.
        if self.item == NUMBER and all(type(v) is float or type(v) is int for v in value):
            return
        if self.item == NUMBERS and all(type(v) is float or type(v) is int for row in value if type(row) is list
                                        for v in row) and all(type(row) is list for row in value):
            return
        for k, entry in enumerate(value):
            self.item.check(entry, f"{where}[{k}]")


@dataclass(frozen=True)
class Table(Spec):
    """A JSON object: the ``fields`` it names are checked when present (those in ``required``
    must be); every other entry is checked against ``others``."""

    fields: dict = field(default_factory=dict)
    others: Spec = Anything()
    required: tuple = ()
    expected = "a table"

    def check(self, value, where):
        if not isinstance(value, dict):
            raise Wrong(where, self.expected, value)
        for key in self.required:
            if key not in value:
                raise Wrong(_join(where, key), "present", value)
        for key, entry in value.items():
            self.fields.get(key, self.others).check(entry, _join(where, key))


def _join(where, key):
    return f"{where}.{key}" if where else str(key)


def _plural(expected):
    for single, many in (("a number", "numbers"), ("a whole number", "whole numbers"), ("text", "texts"),
                         ("a list of", "lists of"), ("a table", "tables"), ("true or false", "flags")):
        if expected.startswith(single):
            return many + expected[len(single):]
    return expected


NUMBER, WHOLE, TEXT, FLAG = Scalar("number"), Scalar("whole"), Scalar("text"), Scalar("flag")
NUMBERS = ListOf(NUMBER)
ROWS = ListOf(NUMBERS)
TEXTS = ListOf(TEXT)
# A JSON value a setting may hold: a word, a number, a flag, none, or a list of numbers (widths).
SETTING = OneOf((TEXT, NUMBER, FLAG, NUMBERS))

# robocal.estimation.metrics.ErrorStats.to_dict (mm); the constraint calibration adds its
# socket distances (robocal.estimation.constraint.metrics).
ERROR_STATS = Table({"n": WHOLE, "socket_distance": Table({"n": WHOLE}, others=NUMBER)}, others=NUMBER)
PARAMETER = Table({"deviation": NUMBER, "std_error": Maybe(NUMBER), "prior_std": Maybe(NUMBER),
                   "data_share": Maybe(NUMBER)}, required=("deviation", "std_error"))
IDENTIFIABILITY = Table({"identified": TEXTS, "fixed": Table(others=TEXT), "rank": WHOLE, "rows": WHOLE,
                         "condition_number": Maybe(NUMBER), "o1": Maybe(NUMBER), "o3": Maybe(NUMBER),
                         "noise_amplification": Maybe(NUMBER)})
CALIBRATION = Table({"parameters": Table(others=PARAMETER), "units": TEXT,
                     "correlated_pairs": ListOf(ListOf(Anything())),
                     "identifiability": IDENTIFIABILITY, "residual_before": ERROR_STATS,
                     "residual_after": ERROR_STATS, "iterations": WHOLE, "converged": FLAG,
                     "orientation_rms_deg": Maybe(NUMBER), "outliers": ListOf(WHOLE), "outlier_rows": ListOf(WHOLE),
                     "unobservable": TEXTS, "pairs": Table(others=Anything())},
                    required=("parameters", "units", "correlated_pairs", "identifiability", "residual_before",
                              "residual_after", "iterations", "converged"))
PREDICTED_ERROR = Table({"where": TEXT, "poses": WHOLE}, others=Maybe(NUMBER))
# robocal.methods.records.FitRecord.to_dict, beside what the data were (file, poses, kind).
FINGERPRINT = Table({"resolution": NUMBER, "tolerance": NUMBER, "n_joints": WHOLE, "joints": TEXT, "grids": TEXTS})
TRAINING = Table({"file": TEXT, "n_poses": WHOLE, "kind": TEXT, "fixture_file": Maybe(TEXT),
                  "fingerprint": FINGERPRINT, "reregistration_fingerprint": FINGERPRINT,
                  "residual_before": Maybe(ERROR_STATS), "residual_after_training": Maybe(ERROR_STATS),
                  "nominal_in_given_frame": Maybe(ERROR_STATS), "registered": Maybe(FLAG),
                  "iterations": Maybe(WHOLE), "calibration": Maybe(CALIBRATION), "diagnostics": Maybe(TEXTS),
                  "predicted_error": Maybe(PREDICTED_ERROR), "comparison": Maybe(Table()),
                  "base_model": Maybe(TEXT), "network": Maybe(Table()), "reregistration": Maybe(Table()),
                  "reregistered_from": TEXT, "reregistration_file": TEXT, "reregistration_poses": WHOLE,
                  "fixture": Maybe(Table({"name": TEXT, "sockets": Table(others=NUMBERS)}))})
# robocal.methods.domain.Domain.to_dict (deg, mm).
DOMAIN = Table({"n_poses": WHOLE,
                "joints": Table({"min": NUMBERS, "max": NUMBERS, "margin": NUMBERS}, required=("min", "max", "margin")),
                "branches": Maybe(Table({"kind": TEXT, "seen": Table(others=ListOf(WHOLE))},
                                        required=("kind", "seen"))),
                "box": Maybe(Table({"min": NUMBERS, "max": NUMBERS, "margin": NUMBER})),
                "placements": Maybe(TEXTS),
                "neighbours": Maybe(Table({"joints": ROWS, "radius": NUMBER}))},
               required=("n_poses", "joints", "branches"))
# robocal.methods.bound.PositionBound.to_dict; its fallback is a bound of the same kind.
BOUND = Table({"coverage": NUMBER, "residual_mm": NUMBER, "inside_factor": NUMBER, "growth_per_rad": Maybe(NUMBER),
               "sigma_growth_per_rad": Maybe(NUMBER),
               "posterior": Maybe(Table({"names": TEXTS, "covariance_mm_rad": ROWS},
                                        required=("names", "covariance_mm_rad"))),
               "training_joints_rad": ROWS, "set_up_factor": NUMBER,
               # How it was calibrated: each part's held-out poses, folds and share covered;
               # what it bounds (kind, note: a ball-in-socket model's), which model it is
               # (label: a fallback's), and a re-registration's check on the new set-up.
               "calibration": Maybe(Table({"kind": TEXT, "note": TEXT, "label": TEXT, "scores": TEXT, "folds": WHOLE,
                                           "new_set_up": Table({"poses": WHOLE, "covered": Maybe(NUMBER),
                                                                "factor": NUMBER})},
                                          others=Table({"poses": WHOLE, "folds": WHOLE,
                                                        "covered": Maybe(NUMBER)})))},
              required=("coverage", "residual_mm", "inside_factor", "growth_per_rad", "sigma_growth_per_rad",
                        "posterior", "training_joints_rad"))
BOUND.fields["fallback"] = Maybe(BOUND)
BOUND.fields["alternative"] = Maybe(BOUND)
# robocal.estimation.kriging's document (the other error models' are checked by their own
# from_dict, and a re-registered model's is a wrapper around one of these).
KRIGING = Table({"format": TEXT, "version": WHOLE, "settings": Table(), "y_is_vector": FLAG, "X": ROWS, "Y": ROWS,
                 "theta": OneOf((ROWS, NUMBERS)), "nugget": OneOf((NUMBERS, NUMBER)),
                 "jitter": OneOf((NUMBERS, NUMBER)), "diagnostics": TEXTS})
ERROR_MODEL = Table({"type": TEXT, "input": TEXT, "parameters": Table({"format": TEXT})})
CHAINS = Table({"label": TEXT, "kinematics": Table(), "reference": Table(), "joint_compliance": Table()},
               required=("label", "kinematics", "reference"))
# outside_domain's alternative (calibrate --method auto): a parametric model of the same form.
CHAINS.fields["alternative"] = CHAINS
MODEL_SCHEMA = Table({"schema": TEXT, "schema_version": WHOLE, "software_version": TEXT, "created": TEXT,
                      "method": TEXT, "robot": Table({"name": TEXT, "hash": TEXT, "model": Table()},
                                                     required=("name", "hash", "model")),
                      "kinematics": Table(), "reference": Maybe(Table()), "joint_compliance": Table(),
                      "error_model": Maybe(ERROR_MODEL), "training": Maybe(TRAINING),
                      "options": Maybe(Table(others=Maybe(SETTING))), "domain": Maybe(DOMAIN),
                      "bound": Maybe(BOUND), "outside_domain": CHAINS, "checksum": TEXT},
                     required=("schema_version", "method", "robot", "kinematics", "checksum"))


def check_document(document, path):
    """FileFormatError, in one line naming the entry, when an entry of the model-file
    ``document`` (parsed JSON) has the wrong type; ``path`` names the file."""
    try:
        MODEL_SCHEMA.check(document, "")
        model = document.get("error_model")
        if isinstance(model, dict) and isinstance(model.get("parameters"), dict) \
                and model["parameters"].get("format") == "robocal.kriging":
            KRIGING.check(model["parameters"], "error_model.parameters")
    except Wrong as wrong:
        if wrong.expected == "present":
            raise FileFormatError(f"{path}: the model file has no '{wrong.where}': the file is truncated or was "
                                  "edited; regenerate it with 'robocal calibrate'") from None
        raise FileFormatError(f"{path}: '{wrong.where}' has the wrong type ({wrong.expected} expected, got "
                              f"{_kind(wrong.value)}); regenerate the file with 'robocal calibrate'") from None
