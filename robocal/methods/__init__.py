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
from .reregistration import FRAME_PARAMETERS

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


# calibrate's pseudo-method that re-registers a model file on a new set-up, and its settings.
FRAMES = "frames"
REREGISTRATION_SETTINGS = (FRAME_PARAMETERS,)


def settings_by_option(*, frames=False, skip=()):
    """{option: [(method name, Setting), ...]}: every registered method's settings by
    command-line option, in the order they first appear (with ``frames``, also
    re-registration's); ``skip``: options left out.  What calibrate, validate and fleet files
    take is generated from this."""
    methods = [(name, cls.settings) for name, cls in REGISTRY.items()]
    by_option = {}
    for name, settings in methods + ([(FRAMES, REREGISTRATION_SETTINGS)] if frames else []):
        for setting in settings:
            if setting.option not in skip:
                by_option.setdefault(setting.option, []).append((name, setting))
    return by_option


def fitted_from_model_file(model, path):
    """The fitted method a :class:`~robocal.io.model_file.ModelFile` read from ``path`` holds."""
    if model.method not in REGISTRY:
        raise FileFormatError(f"{path}: unknown method {model.method!r} (this robocal knows "
                              f"{', '.join(REGISTRY)}): upgrade robocal or regenerate the file")
    return REGISTRY[model.method].from_model_file(model, path)


__all__ = ["DEFAULT_METHOD", "REGISTRY", "CalibrationRecord", "ConstraintMethod", "FitRecord", "HybridMethod",
           "KinematicMethod", "KrigingMethod", "Method", "NetworkMethod", "ReportFigure", "Setting",
           "fitted_from_model_file", "get_method", "make_method", "method_names", "settings_by_option"]
