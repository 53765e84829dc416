"""Fitting each compensation method from measurements, and rebuilding it from a model file.

A method takes the robot, recorded joints (rad) and measured TCP positions (mm, measurement
frame) and returns a :class:`Compensator`, the reference chain (nominal geometry in the
measurement frame: what "before" means) and a JSON-ready record of what was done.
"""
from ..errors import InputError
from ..estimation.kriging import Kriging
from ..estimation.metrics import error_stats
from ..estimation.calibration import KinematicCalibration
from ..estimation.registration import register_base_and_tool

# With the right robot and unit, nominal FK lands within a few mm of a tracker reading in the
# robot base frame; tens of mm mean the readings are in another frame (tracker, world).
REGISTER_ABOVE_RMS_MM = 25.0


def prepare_frame(chain, joints, positions, register="auto"):
    """Register base and tool when the data are not in the robot base frame.

    register: 'auto' (when the nominal RMS error exceeds REGISTER_ABOVE_RMS_MM), 'yes', 'no'.
    Returns (chain in the measurement frame, record dict).
    """
    if register not in ("auto", "yes", "no"):
        raise InputError(f"register must be 'auto', 'yes' or 'no', got {register!r}")
    before = error_stats(positions - chain.fk_positions(joints))
    do_it = register == "yes" or (register == "auto" and before["rms_mm"] > REGISTER_ABOVE_RMS_MM)
    record = {"registered": bool(do_it), "nominal_in_given_frame": before}
    if do_it:
        chain, report = register_base_and_tool(chain, joints, positions)
        record["iterations"] = report.iterations
    return chain, record


def fit_kriging(chain, joints, positions, *, register="auto", kriging=None):
    """Method 1: Kriging of the Cartesian error e = measured − FK(q) over nominal positions.

    ``kriging`` is an unfitted :class:`Kriging` (defaults: constant trend, Gaussian
    correlation, estimated nugget so real, noisy data do not break it).
    """
    from . import Compensator

    chain, record = prepare_frame(chain, joints, positions, register)
    nominal_positions = chain.fk_positions(joints)
    errors = positions - nominal_positions
    model = kriging if kriging is not None else Kriging(nugget="estimate", random_state=0)
    model.fit(nominal_positions, errors)
    record["residual_before"] = error_stats(errors)
    record["residual_after_training"] = error_stats(errors - model.predict(nominal_positions))
    record["diagnostics"] = list(getattr(model, "diagnostics_", []))
    return Compensator(chain, model, nominal=chain), chain, record


def fit_kinematic(chain, joints, positions, *, orientations=None, sigmas=None, parameters="full",
                  loss="linear", register="auto", payload=None):
    """Parametric calibration: identify link parameters, base and tool by Levenberg–Marquardt.

    Returns (Compensator with the calibrated chain, record).  The record's "reference" is
    the nominal geometry registered in the measurement frame, the honest "before".
    """
    from . import Compensator

    if register not in ("auto", "yes", "no"):
        raise InputError(f"register must be 'auto', 'yes' or 'no', got {register!r}")
    calibration = KinematicCalibration(parameters=parameters, loss=loss, register=register != "no", payload=payload)
    calibration.fit(chain, joints, positions, orientations=orientations, sigmas=sigmas)
    reference, _ = register_base_and_tool(chain, joints, positions)
    record = {
        "registered": register != "no",
        "calibration": calibration.result_.to_dict(calibration.chain_),
        "residual_before": error_stats(positions - reference.fk_positions(joints)),
        "residual_after_training": error_stats(positions - calibration.chain_.fk_positions(joints)),
    }
    return Compensator(calibration.chain_, None, nominal=chain), reference, record


def fit_hybrid(chain, joints, positions, *, orientations=None, sigmas=None, parameters="full",
               loss="linear", register="auto", payload=None, kriging=None):
    """Kinematic calibration, then Kriging of what the calibrated model still misses
    (compliance, backlash, other non-geometric errors) over the calibrated TCP position."""
    from . import Compensator

    calibrated, reference, record = fit_kinematic(
        chain, joints, positions, orientations=orientations, sigmas=sigmas, parameters=parameters,
        loss=loss, register=register, payload=payload)
    model_positions = calibrated.chain.fk_positions(joints)
    residual = positions - model_positions
    model = kriging if kriging is not None else Kriging(nugget="estimate", random_state=0)
    model.fit(model_positions, residual)
    record["residual_after_training"] = error_stats(residual - model.predict(model_positions))
    record["diagnostics"] = list(getattr(model, "diagnostics_", []))
    return Compensator(calibrated.chain, model, nominal=chain), reference, record


NETWORK_BASES = ("nominal", "kinematic")


def fit_network(chain, joints, positions, *, base="nominal", orientations=None, sigmas=None, parameters="full",
                loss="linear", register="auto", payload=None, network=None, progress=None):
    """Method 3: a network of the position error over the joint vector, trained by a genetic
    algorithm (then L-BFGS unless told otherwise), compensated in joint space.

    base: the kinematic model whose error the network learns: 'nominal' (registered in the
    measurement frame when needed, the method as specified) or 'kinematic' (the parametric
    calibration first; the network learns what it leaves).  progress(generation, fitness).
    """
    from ..estimation.network import NetworkErrorModel
    from . import Compensator

    if base not in NETWORK_BASES:
        raise InputError(f"the network's base model must be one of {', '.join(NETWORK_BASES)}, got {base!r}")
    if base == "kinematic":
        calibrated, reference, record = fit_kinematic(
            chain, joints, positions, orientations=orientations, sigmas=sigmas, parameters=parameters,
            loss=loss, register=register, payload=payload)
        model_chain = calibrated.chain
    else:
        model_chain, record = prepare_frame(chain, joints, positions, register)
        reference = model_chain
    errors = positions - model_chain.fk_positions(joints)
    model = network if network is not None else NetworkErrorModel(seed=0)
    model.fit(joints, errors, progress=progress)
    record["base_model"] = base
    record["residual_before"] = record.get("residual_before") or error_stats(errors)
    record["residual_after_training"] = error_stats(errors - model.predict(joints))
    record["network"] = model.training_
    return Compensator(model_chain, model, nominal=chain, error_input="joints"), reference, record


def error_model_to_dict(model):
    """Serialise an error model for a model file."""
    from ..estimation.network import NetworkErrorModel

    if model is None:
        return None
    if isinstance(model, Kriging):
        return {"type": "kriging", "parameters": model.to_dict()}
    if isinstance(model, NetworkErrorModel):
        return {"type": "network", "input": "joints", "parameters": model.to_dict()}
    raise InputError(f"cannot save an error model of type {type(model).__name__}")


def error_model_from_dict(document):
    """Rebuild an error model saved by :func:`error_model_to_dict`: (model, what it takes as
    input, 'position' or 'joints')."""
    from ..estimation.network import NetworkErrorModel

    if document is None:
        return None, "position"
    kind = document.get("type")
    if kind == "kriging":
        return Kriging.from_dict(document["parameters"]), "position"
    if kind == "network":
        return NetworkErrorModel.from_dict(document["parameters"]), "joints"
    raise InputError(f"unknown error model type {kind!r} in the model file")


def residuals(compensator, nominal_chain, joints, positions):
    """(before, after): measured minus the nominal chain, and minus the model, (N, 3) mm."""
    return positions - nominal_chain.fk_positions(joints), positions - compensator.predict_positions(joints)


def evaluate(compensator, nominal_chain, joints, positions):
    """Residual statistics of the model, and of the nominal chain under "nominal"."""
    before, after = residuals(compensator, nominal_chain, joints, positions)
    return {**error_stats(after), "nominal": error_stats(before)}
