"""Layer 7: the calibration and error-compensation methods, one class each, and their registry.

Every method follows the protocol of :class:`~robocal.methods.base.Method`: settings in the
constructor, ``fit(chain, observations)``, ``predict``, a model file, a report section.  The
command line, validation, evaluation, reports and model files look a method up here by
name and ask nothing else about it.  Adding a method is one module and one line below.
"""
from ..errors import FileFormatError, InputError
from .ann import NetworkMethod
from .base import Method, Setting
from .constraint import ConstraintMethod
from .hybrid import HybridMethod
from .kinematic import KinematicMethod
from .kriging import KrigingMethod
from .records import CalibrationRecord, FitRecord, ReportFigure

REGISTRY = {method.name: method for method in (
    KinematicMethod,
    KrigingMethod,
    HybridMethod,
    ConstraintMethod,
    NetworkMethod,
)}
# What calibrate and validate fit when no method is named.
DEFAULT_METHOD = KinematicMethod.name


def method_names():
    """The registered method names, in the order the help lists them."""
    return tuple(REGISTRY)


def get_method(name):
    """The method class registered as ``name``; an InputError listing the others if none is."""
    try:
        return REGISTRY[name]
    except (KeyError, TypeError):
        raise InputError(f"method {name!r} is not available in this version of robocal; available: "
                         f"{', '.join(REGISTRY)}") from None


def make_method(name, **settings):
    """An unfitted method from its name and settings (refusing settings it does not take)."""
    return get_method(name)(**settings)


def fitted_from_model_file(model, path):
    """The fitted method a :class:`~robocal.io.model_file.ModelFile` read from ``path`` holds."""
    if model.method not in REGISTRY:
        raise FileFormatError(f"{path}: unknown method {model.method!r} (this robocal knows "
                              f"{', '.join(REGISTRY)}): upgrade robocal or regenerate the file")
    return REGISTRY[model.method].from_model_file(model, path)


__all__ = ["DEFAULT_METHOD", "REGISTRY", "CalibrationRecord", "ConstraintMethod", "FitRecord", "HybridMethod", "KinematicMethod", "KrigingMethod",
           "Method", "NetworkMethod", "ReportFigure", "Setting", "fitted_from_model_file", "get_method",
           "make_method", "method_names"]
