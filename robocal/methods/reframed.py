"""An error model learned in one measurement frame, predicting in another: how a re-registered
model (:mod:`robocal.methods.reregistration`) keeps its error model, and how the model file
writes it.

A Cartesian model ê(p) learned in the old measurement frame predicts, in the new frame related
to the old one by T (old → new, rotation R), the error R·ê(T⁻¹p); a joint-space model
predicts R·ê(q), at the joint readings the old model knew (shifted when the joint offsets
changed).
"""
from __future__ import annotations

import copy

import numpy as np

from ..compensation import Compensator
from ..errors import FileFormatError, InputError

DOCUMENT_TYPE = "reframed"


# ------------------------------------------------------------ the error model
class ReframedErrorModel:
    """An error model learned in one measurement frame, predicting in another: an
    :class:`~robocal.compensation.ErrorModel`.

    Parameters
    ----------
    error_model : object
        The model as it was fitted: ``predict(X)`` → (N, 3) mm, measured minus model, in the
        old measurement frame (Kriging, the network, ...).
    frame : (4, 4) array
        T, old measurement frame → new one (mm): a point p_old is T·p_old in the new frame.
    error_input : str
        'position' (X is the TCP position, (N, 3) mm) or 'joints' (X is the joint vector,
        (N, n) rad or mm).
    joint_shift : (n,) array or None
        Joint-space models only: what to add to a new joint reading to get the reading the
        old model knew for the same configuration (rad, mm; the joint offsets' change).
    """

    def __init__(self, error_model, frame, error_input="position", joint_shift=None):
        if error_input not in ("position", "joints"):
            raise InputError(f"error_input must be 'position' or 'joints', got {error_input!r}")
        frame = np.asarray(frame, dtype=float)
        if frame.shape != (4, 4) or not np.all(np.isfinite(frame)):
            raise InputError(f"the frame must be a finite 4x4 transform, got shape {frame.shape}")
        rotation = frame[:3, :3]
        if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6) or np.linalg.det(rotation) < 0:
            raise InputError("the frame's rotation is not a rotation matrix")
        if joint_shift is not None and error_input != "joints":
            raise InputError("a joint shift applies to a joint-space error model only")
        self.error_model = error_model
        self.frame = frame
        self.error_input = error_input
        self.joint_shift = None if joint_shift is None else np.asarray(joint_shift, dtype=float).reshape(-1)

    # What the report reads of a fitted error model is the wrapped model's: the reframing
    # changes where the model is used, not what it learned.  A model without one (a
    # network has no diagnostics_, a Kriging no history_) raises AttributeError, as it would.
    @property
    def diagnostics_(self):
        """The wrapped model's fit diagnostics (Kriging: list of str)."""
        return self.error_model.diagnostics_

    @property
    def history_(self):
        """The wrapped model's training history (the network's best fitness per generation)."""
        return self.error_model.history_

    def inputs(self, X):
        """The wrapped model's input for X: T⁻¹·p for positions (N, 3) mm, the shifted
        readings for joints (N, n)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if self.error_input == "position":
            return (X - self.frame[:3, 3]) @ self.frame[:3, :3]
        return X if self.joint_shift is None else X + self.joint_shift

    def predict(self, X, return_mse=False, **options):
        """The error (N, 3) mm in the new frame at X (see :meth:`inputs`); with
        ``return_mse`` also its mean squared error per new axis (N, 3) mm², the diagonal of
        R·diag(mse)·Rᵀ (the wrapped model's components taken as independent).  Other keywords
        go to the wrapped model."""
        rotation = self.frame[:3, :3]
        if return_mse:
            mean, mse = self.error_model.predict(self.inputs(X), return_mse=True, **options)
            mean = np.asarray(mean, dtype=float).reshape(-1, 3)
            return mean @ rotation.T, np.asarray(mse, dtype=float).reshape(-1, 3) @ (rotation ** 2).T
        mean = np.asarray(self.error_model.predict(self.inputs(X), **options), dtype=float).reshape(-1, 3)
        return mean @ rotation.T

    def moved(self, frame, joint_shift=None):
        """This model carried on by ``frame`` (current frame → a newer one) and a further
        joint shift: one wrapper around the original model, not a wrapper of wrappers."""
        shift = self.joint_shift
        if joint_shift is not None:
            shift = np.asarray(joint_shift, dtype=float) + (0.0 if shift is None else shift)
        return ReframedErrorModel(self.error_model, np.asarray(frame, dtype=float) @ self.frame,
                                  self.error_input, shift)

    def to_dict(self, inner_document, revolute=None):
        """The model file's ``error_model`` entry: {"type": "reframed", "frame": 4x4 (mm),
        "error_input" ('position' or 'joints'), "error_model": ``inner_document`` (the wrapped
        model's own entry)}; "input" repeats the inner entry's, so that a reader checking what
        a model is over finds it where it always was; "joint_shift" in file units (deg for
        revolute joints, mm for prismatic ones, as ``revolute`` (n,) bool says) and
        "joint_units" when there is a joint shift."""
        doc = {"type": DOCUMENT_TYPE, "frame": self.frame.tolist(), "error_input": self.error_input,
               "error_model": inner_document}
        if isinstance(inner_document, dict) and "input" in inner_document:
            doc["input"] = inner_document["input"]
        if self.joint_shift is not None:
            revolute = np.ones(len(self.joint_shift), bool) if revolute is None else np.asarray(revolute, bool)
            doc["joint_shift"] = np.where(revolute, np.degrees(self.joint_shift), self.joint_shift).tolist()
            doc["joint_units"] = ["deg" if r else "mm" for r in revolute]
        return doc

    @classmethod
    def from_dict(cls, document, inner_loader):
        """The wrapper back from :meth:`to_dict`; ``inner_loader(inner document)`` returns
        (wrapped model, its input).  FileFormatError, in one line, if the document is damaged."""
        where = "the reframed error model"
        if not isinstance(document, dict) or document.get("type") != DOCUMENT_TYPE:
            raise FileFormatError(f"{where}: not a reframed error model (no \"type\": \"{DOCUMENT_TYPE}\"); "
                                  "regenerate the file")
        try:
            inner, error_input = inner_loader(document["error_model"])
            if document["error_input"] != error_input:
                raise ValueError(f"error_input {document['error_input']!r} but the wrapped model takes {error_input!r}")
            shift = None
            if "joint_shift" in document:
                values = np.asarray(document["joint_shift"], dtype=float)
                units = np.asarray(document["joint_units"])
                if units.shape != values.shape or not set(units.tolist()) <= {"deg", "mm"}:
                    raise ValueError("joint_units must name 'deg' or 'mm' for each joint_shift value")
                shift = np.where(units == "deg", np.radians(values), values)
            return cls(inner, document["frame"], error_input, shift)
        except FileFormatError:
            raise
        except (KeyError, TypeError, ValueError, InputError) as exc:
            raise FileFormatError(f"{where} is damaged ({exc}); regenerate the file") from None


def reframed_document(fitted):
    """The ``error_model`` entry of a re-registered method whose error model is a
    :class:`ReframedErrorModel`: the wrapper around the method's own entry for the wrapped
    model (the method writes that one as it always does)."""
    wrapper = fitted.compensator_.error_model
    plain = copy.copy(fitted)
    plain.compensator_ = Compensator(fitted.compensator_.chain, wrapper.error_model,
                                     nominal=fitted.compensator_.nominal, error_input=wrapper.error_input,
                                     controller=fitted.compensator_.controller,
                                     reference=fitted.compensator_.reference)
    return wrapper.to_dict(plain.error_model_document(), fitted.compensator_.chain.revolute)


def is_reframed(document):
    """True for a model file's ``error_model`` entry written by :func:`reframed_document`."""
    return isinstance(document, dict) and document.get("type") == DOCUMENT_TYPE


def reframed_from_document(document, inner_loader):
    """(ReframedErrorModel, its input) from a model file's entry; ``inner_loader(document)``
    gives (model, input) for the wrapped model's entry (the method's
    ``error_model_from_document``)."""
    model = ReframedErrorModel.from_dict(document, inner_loader)
    return model, model.error_input
