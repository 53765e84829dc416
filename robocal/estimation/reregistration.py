"""Re-registration's estimator: a calibrated model's frames (base, tool; optionally the joint
offsets) identified again from a few poses of a new set-up, everything else kept
(:func:`robocal.methods.reregistration.reregister` is the method around it).

* :class:`ReframedErrorModel`: an error model learned in one measurement frame predicting in
  another.  A Cartesian model ê(p) learned in the old frame predicts, in the new frame related
  to the old one by T (old → new, rotation R), the error R·ê(T⁻¹p): T⁻¹p is the old frame's
  name for the same point of the robot and R turns the predicted vector into the new axes.  A
  joint-space model predicts R·ê(q), at the joint readings the old model knew (shifted when
  the joint offsets changed).
* :class:`FrameProblem`: what the model with a candidate chain predicts at the poses, the
  weighted residual, and its analytic Jacobian, as the steps of
  :func:`~robocal.estimation.identification.identify`.  The frames are fitted to what the
  whole model predicts (kinematics plus the moved error model), so that a residual model's
  mean correction is not counted twice; the error model's own change with the frames is left
  out of the Jacobian (a rotation ω of the base moves the predicted error by ω × ê, a
  thousandth of what it moves the TCP at a metre's reach), which slows the steps a little but
  leaves the residual they minimise exact.
"""
from __future__ import annotations

import numpy as np

from ..errors import FileFormatError, InputError
from ..spatial import invert, so3_log
from .identifiability import analyse
from .identification import Analysis
from .least_squares import damped_least_squares

# The error_model entry of a re-registered model file names its wrapper so.
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



# ----------------------------------------------------------------- the problem
class FrameProblem:
    """The re-registration of one model on one set of poses: what it predicts for a
    candidate chain and the weighted residual the fit minimises.

    A model of ``calibrate --method auto`` that answers with a fallback outside its training
    domain (:class:`~robocal.methods.fallback.DomainFallback`) moves as one: the fallback's
    chain takes the same change of frames (and joint offsets) as the chosen model's, and each
    pose is predicted by the model that answers for it."""

    def __init__(self, compensator, joints, positions, rotations, weights, *, max_iterations=50):
        self.old = compensator.chain
        self.error_model = compensator.error_model
        self.error_input = compensator.error_input
        self.q = joints
        self.max_iterations = max_iterations
        self.positions = positions
        self.rotations = rotations
        self.weights = weights
        self.rows = weights.shape[1]
        self.offsets = [self.old.rigid.offset_parameter(k) for k in range(self.old.n_joints)]
        fallback = getattr(compensator, "outside", None)
        self.fallback = None if fallback is None else fallback.chain
        self.answered_outside = (np.zeros(len(joints), dtype=bool) if fallback is None
                                 else compensator.outside_mask(joints))

    def moved_fallback(self, chain):
        """The fallback's chain with the change of frames (and joint offsets) that takes the
        chosen model's chain to ``chain``: the same new base, and the same change of the tool
        in the flange frame (the fallback keeps its own calibrated TCP offset)."""
        frame = self.frame(chain)
        turn = chain.tool @ invert(self.old.tool)
        moved = self.fallback.replace(base=frame @ self.fallback.base, tool=turn @ self.fallback.tool)
        change = chain.parameter_values(self.offsets) - self.old.parameter_values(self.offsets)
        return moved.perturbed(self.offsets, change) if np.any(change) else moved

    def frame(self, chain):
        """T, old measurement frame → the one of ``chain``: the robot base stays put."""
        return chain.base @ invert(self.old.base)

    def joint_shift(self, chain):
        """The change of the old readings for the same configuration when ``chain``'s joint
        offsets differ from the old model's (rad, mm), or None when they do not."""
        change = chain.parameter_values(self.offsets) - self.old.parameter_values(self.offsets)
        if not np.any(change):
            return None
        return np.linalg.solve(chain.joint_map, change)

    def moved_error_model(self, chain):
        """The error model as ``chain``'s frame sees it (None without one)."""
        if self.error_model is None:
            return None
        shift = self.joint_shift(chain) if self.error_input == "joints" else None
        frame = self.frame(chain)
        if isinstance(self.error_model, ReframedErrorModel):
            return self.error_model.moved(frame, shift)
        return ReframedErrorModel(self.error_model, frame, self.error_input, shift)

    def predicted(self, chain):
        """(positions (N, 3) mm, rotations (N, 3, 3) or None) that the model with ``chain``'s
        frames predicts at the poses."""
        if self.rotations is None:
            pose_positions, pose_rotations = chain.fk_positions(self.q), None
        else:
            pose = chain.fk(self.q)
            pose_positions, pose_rotations = pose[:, :3, 3], pose[:, :3, :3]
        model = self.moved_error_model(chain)
        if model is not None:
            inputs = pose_positions if self.error_input == "position" else self.q
            pose_positions = pose_positions + model.predict(inputs)
        out = self.answered_outside
        if out.any():
            fallback = self.moved_fallback(chain)
            pose_positions = pose_positions.copy()
            if pose_rotations is None:
                pose_positions[out] = fallback.fk_positions(self.q[out])
            else:
                pose = fallback.fk(self.q[out])
                pose_positions[out], pose_rotations = pose[:, :3, 3], pose_rotations.copy()
                pose_rotations[out] = pose[:, :3, :3]
        return pose_positions, pose_rotations

    def residual(self, chain):
        """Measured minus predicted, (N, 3) mm, or (N, 6) with the rotation vector (rad)."""
        positions, rotations = self.predicted(chain)
        out = self.positions - positions
        if self.rotations is not None:
            out = np.hstack([out, so3_log(self.rotations @ np.swapaxes(rotations, 1, 2))])
        return out

    def jacobian(self, chain, names):
        """The weighted derivative of the prediction, (N·rows, P): the chain's analytic
        identification Jacobian (the error model's change is second order, see the module notes)."""
        jac = chain.identification_jacobian(self.q, names)[:, :self.rows, :]
        out = self.answered_outside
        if out.any():
            jac[out] = self.moved_fallback(chain).identification_jacobian(self.q[out], names)[:, :self.rows, :]
        return (jac * self.weights[:, :, None]).reshape(-1, len(names))

    def steps(self, prior=None):
        """The analyse / fit / linearise steps :func:`~robocal.estimation.identification.identify`
        takes; ``prior``: the joint offsets' tolerances (frames have none)."""

        def weighted(chain):
            return (self.residual(chain) * self.weights).reshape(-1)

        def analyse_at(chain, candidates):
            scaled = self.jacobian(chain, candidates)
            _, report = analyse(chain, scaled, candidates, explain=False)
            return Analysis(report.identified, lambda: analyse(chain, scaled, candidates)[1])

        def fit(chain, names):
            return damped_least_squares(chain, names, lambda c: (weighted(c), -self.jacobian(c, names)), weighted,
                                        max_iterations=self.max_iterations, tolerance=1e-10,
                                        prior=prior)

        def linearise(found, names):
            return weighted(found.chain), -self.jacobian(found.chain, names)

        return {"analyse": analyse_at, "fit": fit, "linearise": linearise}
