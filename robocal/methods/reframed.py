"""How the model file writes and reads a re-registered model's error model: the
:class:`~robocal.estimation.reregistration.ReframedErrorModel` (an error model learned in one
measurement frame, predicting in another) around the method's own entry for the model it wraps.
"""
from __future__ import annotations

import copy

from ..compensation import Compensator
from ..estimation.reregistration import DOCUMENT_TYPE, ReframedErrorModel

__all__ = ["DOCUMENT_TYPE", "ReframedErrorModel", "is_reframed", "reframed_document", "reframed_from_document"]


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
