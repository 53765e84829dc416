"""What each command does, as plain functions of parsed arguments that return JSON-ready
results; ``cli.py`` only parses, prints and maps errors to exit codes."""
from functools import partial

import numpy as np

from ..compensation import Compensator
from ..compensation.methods import (
    error_model_from_dict,
    error_model_to_dict,
    fit_hybrid,
    fit_kinematic,
    fit_kriging,
    fit_network,
    residuals,
)
from ..errors import FileFormatError, InputError, RobocalWarning
from ..estimation.calibration import PARAMETER_SETS, parameter_terms
from ..estimation.metrics import error_stats
from ..io.library import load_robot
from ..io.tables import read_measurements, read_targets, write_commands, write_measurements
from ..spatial import compose_pose, pose_to_xyz_rpy, rpy_to_matrix
from .model_file import ModelFile, load_model, save_model

IMPLEMENTED_METHODS = ("kinematic", "kriging", "hybrid", "constraint", "ann")
# A calibrated model that still misses by this much is almost certainly the wrong robot,
# wrong units or a different measurement frame.
SUSPICIOUS_RESIDUAL_MM = 20.0


def _positions_required(data, method):
    if data.positions is None:
        raise InputError(f"{data.path} has no x, y, z columns: the {method} method needs measured positions")


def _constraints_required(data, fixture_path=None):
    if data.fixture is None:
        raise InputError(f"{data.path} has no fixture and socket columns: the constraint method needs ball-in-socket "
                         "data (q1..qN, fixture, socket)")
    if data.positions is not None:
        raise InputError(f"{data.path} has x, y, z columns: that is instrument data; use --method kinematic, or "
                         "give only fixture and socket columns for the constraint method")


def fixture_document(fixture):
    return {"name": fixture.name, "sockets": {k: v.tolist() for k, v in fixture.sockets.items()}}


def fixture_from_document(doc, path):
    from ..io.fixtures import Fixture

    try:
        return Fixture(name=doc["name"], sockets=doc["sockets"])
    except (KeyError, TypeError, InputError) as exc:
        raise FileFormatError(f"{path}: the fixture stored in the model is damaged ({exc}); regenerate the file") from None


def constraint_calibration(pairs, parameters, payload):
    """The ConstraintCalibration that a --parameters set asks for (the full POE model, with
    compliance and gains as named)."""
    from ..estimation.constraint import ConstraintCalibration

    terms = parameter_terms(parameters)
    if not parameters.startswith("full"):
        raise InputError(f"the constraint method identifies the full POE model: --parameters "
                         f"{', '.join(p for p in PARAMETER_SETS if p.startswith('full'))}, got {parameters!r}")
    return ConstraintCalibration(pairs=pairs, compliance="compliance" in terms, gains="gains" in terms,
                                 payload=payload)


def _fit_constraint(chain, data, fixture_path, pairs, parameters, payload):
    from ..io.fixtures import read_fixture

    if fixture_path is None:
        raise InputError("the constraint method needs the fixture: --fixture FIX.toml (socket centres in mm)")
    _constraints_required(data)
    fixture = read_fixture(fixture_path)
    q = chain.joints_from_file(data.joints)
    calibration = constraint_calibration(pairs, parameters, payload).fit(
        chain, q, data.fixture, data.socket, fixture)
    result = calibration.result_
    record = {"calibration": result.to_dict(calibration.chain_), "fixture": fixture_document(fixture),
              "fixture_file": str(fixture_path), "residual_before": result.residual_before,
              "residual_after_training": result.residual_after}
    return Compensator(calibration.chain_, None, nominal=chain), chain, record


def calibrate_job(robot, measurements, out, *, method="kinematic", register="auto", kriging=None,
                  parameters="full", loss="linear", fixture=None, pairs="all", network=None, base_model="nominal",
                  payload=None, progress=None, root=None, tip=None):
    """Fit a method to a measurement file and save the model file."""
    if method not in IMPLEMENTED_METHODS:
        raise InputError(
            f"method {method!r} is not available in this version of robocal; available: "
            f"{', '.join(IMPLEMENTED_METHODS)}"
        )
    chain = load_robot(robot, root=root, tip=tip)
    data = read_measurements(measurements, n_joints=chain.n_joints)
    if method == "constraint":
        compensator, reference, record = _fit_constraint(chain, data, fixture, pairs, parameters, payload)
    else:
        _positions_required(data, method)
        q = chain.joints_from_file(data.joints)
        if method == "kriging":
            compensator, reference, record = fit_kriging(chain, q, data.positions, register=register, kriging=kriging)
        else:
            rotations = None if data.orientations is None else rpy_to_matrix(np.radians(data.orientations))
            fit = {"kinematic": fit_kinematic, "hybrid": partial(fit_hybrid, kriging=kriging),
                   "ann": partial(fit_network, network=network, base=base_model, progress=progress)}[method]
            compensator, reference, record = fit(chain, q, data.positions, orientations=rotations,
                                                 sigmas=data.sigmas, parameters=parameters, loss=loss,
                                                 register=register, payload=payload)
            outliers = record["calibration"]["outliers"] if "calibration" in record else []
            if outliers:
                record["calibration"]["outlier_rows"] = [int(data.rows[i]) for i in outliers]
    training = {"file": str(measurements), "n_poses": data.n_poses, "kind": data.kind, **record}
    options = ({"pairs": pairs, "parameters": parameters} if method == "constraint"
               else {"register": register, "parameters": parameters, "loss": loss})
    if "compliance" in parameter_terms(parameters):
        options["payload_kg"] = payload
    if method == "ann":
        options["base_model"] = base_model
    model = ModelFile(method=method, nominal=chain, kinematics=compensator.chain, reference=reference,
                      error_model=error_model_to_dict(compensator.error_model), training=training,
                      options=options)
    save_model(model, out)
    return {"method": method, "robot": chain.name, "out": str(out), **training}


def load_compensator(model_path, robot=None):
    """A model file -> (ModelFile, Compensator)."""
    model = load_model(model_path, robot=robot)
    try:
        error_model, error_input = error_model_from_dict(model.error_model)
    except (InputError, FileFormatError, KeyError, TypeError, ValueError) as exc:
        raise FileFormatError(f"{model_path}: the error model is damaged ({exc}); "
                              "regenerate the file with 'robocal calibrate'") from None
    rigid = getattr(model.kinematics, "rigid", model.kinematics)
    return model, Compensator(model.kinematics, error_model, nominal=rigid, error_input=error_input)


def load_model_and_data(model_path, measurements):
    """(model, compensator, measurements, joints in rad) for a model file and a CSV."""
    model, compensator = load_compensator(model_path)
    data = read_measurements(measurements, n_joints=model.kinematics.n_joints)
    return model, compensator, data, model.kinematics.joints_from_file(data.joints)


def position_evaluation(model, compensator, data, q, model_path):
    """(before (N, 3), after (N, 3), statistics as ``evaluate --json`` prints them) on measured positions."""
    import warnings

    _positions_required(data, model.method)
    before, after = residuals(compensator, model.reference, q, data.positions)
    result = {**error_stats(after), "nominal": error_stats(before)}
    if result["mean_mm"] > SUSPICIOUS_RESIDUAL_MM:
        warnings.warn(RobocalWarning(
            f"the residual is {result['mean_mm']:.1f} mm mean after calibration: is {data.path} "
            f"from robot '{model.nominal.name}', in mm and degrees, in the frame the model was fitted in?"))
    return before, after, {"model": str(model_path), "method": model.method, "file": str(data.path), **result}


def socket_evaluation(model, data, q, model_path, fixture_path):
    """(fixture, statistics) on ball-in-socket data: the socket consistency (distance of each
    ball centre from the mean of its socket group) at the top level, the socket-distance
    error under ``socket_distance``, and the same for the nominal robot under ``nominal``."""
    from ..estimation.constraint import socket_errors
    from ..io.fixtures import read_fixture

    _constraints_required(data)
    if fixture_path is not None:
        fixture = read_fixture(fixture_path)
    elif "fixture" in model.training:
        fixture = fixture_from_document(model.training["fixture"], model_path)
    else:
        raise InputError(f"{data.path} is ball-in-socket data and {model_path} stores no fixture: "
                         "give --fixture FIX.toml")
    result = socket_errors(model.kinematics, q, data.fixture, data.socket, fixture)
    result["nominal"] = socket_errors(model.reference, q, data.fixture, data.socket, fixture)
    return fixture, {"model": str(model_path), "method": model.method, "file": str(data.path),
                     "metric": "socket consistency: distance of each ball centre from the mean of its socket group",
                     **result}


def evaluate_job(model_path, measurements, fixture=None):
    """Residual of a model on measured positions, and of the nominal robot; on ball-in-socket
    data the socket consistency and socket-distance errors."""
    model, compensator, data, q = load_model_and_data(model_path, measurements)
    if data.positions is None:
        return socket_evaluation(model, data, q, model_path, fixture)[-1]
    return position_evaluation(model, compensator, data, q, model_path)[-1]


def compensate_job(model_path, targets_path, out, *, iterate=False):
    """Joint commands and corrected Cartesian targets for a targets file."""
    model, compensator = load_compensator(model_path)
    chain = model.kinematics
    targets = read_targets(targets_path, n_joints=chain.n_joints)
    poses = compose_pose(targets.positions, np.radians(targets.orientations))
    hint = None if targets.hints is None else chain.joints_from_file(targets.hints)
    result = compensator.commands(poses, hint=hint, iterate=iterate)
    xyz, rpy = pose_to_xyz_rpy(result.corrected)
    joints = chain.joints_to_file(np.where(result.success[:, None], result.q, 0.0))
    write_commands(out, joints, xyz, np.degrees(rpy), joint_ok=result.success)
    unreachable = [int(r) for r in np.asarray(targets.rows)[~result.success]]
    return {"targets": int(len(poses)), "reachable": int(result.success.sum()),
            "unreachable_rows": unreachable, "out": str(out),
            "predicted_error": error_stats(result.predicted_error)}


EXPORT_FORMATS = ("toml", "urdf")


def export_job(model_path, out, *, fmt="toml", convention=None):
    """The calibrated kinematics of a model file as a robot TOML or a URDF, for a controller
    that accepts new parameters (direct compensation) or for ROS; ``convention`` (dh, mdh,
    poe) converts it exactly first (a calibrated model may have no exact DH form)."""
    from ..io.robot_file import write_robot
    from ..io.urdf import write_urdf
    from ..kinematics import to_dh, to_mdh, to_poe

    if fmt not in EXPORT_FORMATS:
        raise InputError(f"format must be one of {', '.join(EXPORT_FORMATS)}, got {fmt!r}")
    converters = {"dh": to_dh, "mdh": to_mdh, "poe": to_poe}
    if convention is not None and convention not in converters:
        raise InputError(f"convention must be one of dh, mdh, poe, got {convention!r}")
    model = load_model(model_path)
    rigid = getattr(model.kinematics, "rigid", model.kinematics)
    chain = rigid if convention is None else converters[convention](rigid)
    left_out = []
    if rigid is not model.kinematics:
        left_out.append("the joint compliance (robocal compensate applies it)")
    if model.error_model is not None:
        left_out.append(f"the {model.error_model.get('type', 'error')} model of the residual error "
                        "(robocal compensate applies it)")
    chain = chain.replace(name=f"{model.nominal.name} (calibrated, {model.method})")
    description = (f"Calibrated by robocal from {model.training.get('file', 'measurements')}; "
                   "[base] is the measurement frame -> robot base.")
    if fmt == "toml":
        write_robot(chain, out, description=description)
    else:
        if not np.array_equal(np.abs(chain.joint_map), np.eye(chain.n_joints)):
            left_out.append("the joint map (a coupling, or calibrated joint gains): the URDF's joint values are "
                            "the model variables joint_map·q, not the controller's readings (a robot file keeps it)")
        write_urdf(chain, out, allow_coupled=True)
    return {"model": str(model_path), "format": fmt, "out": str(out), "robot": chain.name,
            "convention": chain.convention, "left_out": left_out}


def _simulate_sockets(true_robot, out, fixture_path, placements, per_socket, noise, joint_noise, rng):
    """Ball-in-socket readings of a true robot; ``noise`` is the seating error (mm)."""
    from ..estimation.constraint import socket_errors
    from ..io.fixtures import read_fixture
    from ..simulation.sampling import socket_plan

    if fixture_path is None:
        raise InputError("--sampling sockets needs --fixture FIX.toml (socket centres in mm)")
    if placements < 1 or per_socket < 2:
        raise InputError(f"--placements must be >= 1 and --per-socket >= 2 (two configurations in a socket make "
                         f"a position constraint), got {placements} and {per_socket}")
    fixture = read_fixture(fixture_path)
    plan = socket_plan(true_robot, fixture, placements, per_socket, rng,
                       joint_noise_deg=joint_noise, seating_mm=0.0 if noise is None else noise)
    write_measurements(out, plan.measurements(true_robot.nominal))
    return {"poses": int(len(plan.joints)), "placements": placements, "per_socket": per_socket,
            "nominal_socket_consistency": socket_errors(true_robot.nominal, plan.joints, plan.fixture_ids,
                                                        plan.socket_ids, fixture)}


def _true_robot(chain, errors, seed):
    """The true robot of --errors: a preset, or a truth file (JSON) of this same robot."""
    from ..simulation import PRESETS, make_true_robot, read_truth, uniform_joints

    if errors in PRESETS or not errors.endswith(".json"):
        return make_true_robot(chain, errors, seed=seed)
    truth = read_truth(errors)
    q = uniform_joints(chain, 20, np.random.default_rng(0))
    if truth.nominal.n_joints != chain.n_joints or not np.allclose(truth.nominal.fk(q), chain.fk(q), atol=1e-6):
        raise InputError(f"{errors} describes the robot {truth.nominal.name!r}, not {chain.name!r}: simulate that "
                         "robot, or write a truth file of this one with --truth and edit it")
    return truth


def simulate_job(robot, out, *, n=None, sampling="joint", errors="typical", noise=None, seed=0,
                 truth=None, orientation=False, box=None, rpy=None, hint=None, root=None, tip=None,
                 fixture=None, placements=4, per_socket=10, joint_noise=0.0):
    """Measurements of a simulated "true" robot, in the order the robot visits the poses.

    ``--sampling sockets`` seats a ball (the tool) in the sockets of ``fixture`` at
    ``placements`` random fixture poses, ``per_socket`` configurations each, and records
    joint angles only (``noise`` is then the seating error, ``joint_noise`` in deg)."""
    from dataclasses import replace

    from ..simulation import grid, latin_hypercube_box, liu2022_plan, uniform_joints, write_truth
    from ..spatial import rpy_to_matrix

    chain = load_robot(robot, root=root, tip=tip)
    rng = np.random.default_rng(seed)
    true_robot = _true_robot(chain, errors, seed)
    if noise is not None:
        if noise < 0:
            raise InputError(f"--noise must be >= 0 mm, got {noise}")
        true_robot = replace(true_robot, noise=float(noise))
    if sampling == "sockets":
        result = _simulate_sockets(true_robot, out, fixture, placements, per_socket, noise, joint_noise, rng)
        if truth:
            write_truth(truth, true_robot)
        return {"robot": chain.name, "sampling": sampling, "errors": errors, "out": str(out),
                "truth": str(truth) if truth else None, **result}
    if sampling == "joint":
        q = uniform_joints(chain, n or 200, rng)
    elif sampling in ("lhs", "grid"):
        if box is None:
            if errors != "liu2022" or sampling == "grid":
                raise InputError(f"--sampling {sampling} needs --box xmin,xmax,ymin,ymax,zmin,zmax (mm); "
                                 "with --errors liu2022 and --sampling lhs the published box is used")
            q = liu2022_plan(chain)[0]
            q = q if n is None else q[:n]
        else:
            low, high = np.asarray(box[0::2], float), np.asarray(box[1::2], float)
            rotation = rpy_to_matrix(np.radians(rpy if rpy is not None else [180.0, 0.0, 0.0]))
            hint_rad = None if hint is None else chain.joints_from_file(np.asarray(hint, float))
            if sampling == "lhs":
                q = latin_hypercube_box(chain, n or 150, low, high, rotation, seed=seed, hint=hint_rad)[0]
            else:
                per_axis = max(2, int(round((n or 125) ** (1.0 / 3.0))))
                q = grid(chain, low, high, (per_axis,) * 3, rotation, hint=hint_rad)[0]
    else:
        raise InputError(f"--sampling {sampling} is not available; use joint, lhs, grid or sockets")
    data = true_robot.measurements(q, rng, orientation=orientation)
    write_measurements(out, data)
    if truth:
        write_truth(truth, true_robot)
    return {"robot": chain.name, "poses": int(len(q)), "sampling": sampling, "errors": errors,
            "out": str(out), "truth": str(truth) if truth else None,
            "true_error": error_stats(true_robot.error(q))}


DATASETS = {
    "ur5-tsinghua": ("ur5_tsinghua", {}),
    "ipa-ur10-a": ("ipa_ur10", {"series": "A"}),
    "ipa-ur10-b": ("ipa_ur10", {"series": "B"}),
    "mukca-panda-1": ("mukca", {"unit": "panda_1"}),
    "mukca-panda-2": ("mukca", {"unit": "panda_2"}),
    "mukca-panda-3": ("mukca", {"unit": "panda_3"}),
}


def dataset_job(name, prefix, *, split=None, seed=0):
    """Write a shared dataset as robocal files: PREFIX.toml (the robot model the data were
    taken against) and PREFIX.csv, or PREFIX_train.csv / PREFIX_test.csv with ``split`` the
    training fraction of a random split; ball-in-socket data also PREFIX_fixture.toml, and
    are split by whole fixture placements (held-out placements, as a user would test)."""
    from ..io import datasets
    from ..io.fixtures import write_fixture
    from ..io.robot_file import write_robot

    if name not in DATASETS:
        raise InputError(f"unknown dataset {name!r}; available: {', '.join(DATASETS)}")
    loader, kwargs = DATASETS[name]
    chain, data, *fixture = getattr(datasets, loader)(**kwargs)
    write_robot(chain, f"{prefix}.toml", description=f"robot model of the {name} dataset")
    written = {"robot": f"{prefix}.toml"}
    if fixture:
        write_fixture(f"{prefix}_fixture.toml", fixture[0])
        written["fixture"] = f"{prefix}_fixture.toml"
    if split is None:
        write_measurements(f"{prefix}.csv", data)
        written["measurements"] = f"{prefix}.csv"
        return {"dataset": name, "poses": data.n_poses, "source": data.path, **written}
    train, chosen = datasets.split_indices(data, split, seed)
    if chosen is not None:
        written["train_placements"] = chosen
    test = np.setdiff1d(np.arange(data.n_poses), train)
    write_measurements(f"{prefix}_train.csv", data.subset(train))
    write_measurements(f"{prefix}_test.csv", data.subset(test))
    written.update(train=f"{prefix}_train.csv", test=f"{prefix}_test.csv", train_poses=int(len(train)),
                   test_poses=int(len(test)))
    return {"dataset": name, "poses": data.n_poses, "source": data.path, **written}


def _fitter(method, chain, q, data, register, parameters, loss, kriging_seed):
    """fit(train_index) -> predict(test_index) for a method, on data already in memory."""
    from ..estimation.kriging import Kriging

    rotations = None if data.orientations is None else rpy_to_matrix(np.radians(data.orientations))

    def take(array, index):
        return None if array is None else array[index]

    def fit(train):
        if method == "nominal":
            from ..estimation.registration import register_base_and_tool

            registered, _ = register_base_and_tool(chain, q[train], data.positions[train])
            return lambda test: registered.fk_positions(q[test])
        kriging = Kriging(nugget="estimate", random_state=kriging_seed)
        if method == "kriging":
            compensator = fit_kriging(chain, q[train], data.positions[train], register=register, kriging=kriging)[0]
        else:
            from ..estimation.network import NetworkErrorModel

            fit_method = {"kinematic": fit_kinematic, "hybrid": partial(fit_hybrid, kriging=kriging),
                          "ann": partial(fit_network, network=NetworkErrorModel(seed=kriging_seed))}[method]
            compensator = fit_method(chain, q[train], data.positions[train], orientations=take(rotations, train),
                                     sigmas=take(data.sigmas, train), parameters=parameters, loss=loss,
                                     register=register)[0]
        return lambda test: compensator.predict_positions(q[test])

    return fit


def _placement_validation(chain, data, fixture_path, pairs, parameters, payload, on_fit):
    """Leave one fixture placement out at a time: the constraint model fitted on the others,
    its socket consistency on the one left out, beside the nominal model's."""
    from ..estimation.constraint import socket_deviations
    from ..io.fixtures import read_fixture

    if fixture_path is None:
        raise InputError("the constraint method needs the fixture: --fixture FIX.toml (socket centres in mm)")
    _constraints_required(data)
    fixture = read_fixture(fixture_path)
    placements = sorted(set(data.fixture.tolist()))
    if len(placements) < 2:
        raise InputError(f"{data.path} has one fixture placement: leave-one-placement-out needs two or more")
    q = chain.joints_from_file(data.joints)
    folds, nominal_folds, deviations, nominal_deviations = [], [], [], []
    for placement in placements:
        test = data.fixture == placement
        calibration = constraint_calibration(pairs, parameters, payload).fit(
            chain, q[~test], data.fixture[~test], data.socket[~test], fixture)
        if on_fit is not None:
            on_fit()
        for model, fold_list, pooled in ((calibration.chain_, folds, deviations),
                                         (chain, nominal_folds, nominal_deviations)):
            held_out, _ = socket_deviations(model, q[test], data.fixture[test], data.socket[test], fixture)
            pooled.append(held_out)
            fold_list.append({"fold": placement, "n_train": int((~test).sum()), "held_out": error_stats(held_out)})
    return {"method": "constraint", "file": str(data.path), "poses": data.n_poses, "folds": len(placements),
            "metric": "socket consistency on the placement left out",
            "cross_validation": {"k": len(placements), "folds": folds,
                                 "pooled": error_stats(np.concatenate(deviations))},
            "nominal_cross_validation": {"k": len(placements), "folds": nominal_folds,
                                         "pooled": error_stats(np.concatenate(nominal_deviations))}}


def validate_job(robot, measurements, *, method="kinematic", folds=5, sizes=None, seed=0, register="auto",
                 parameters="full", loss="linear", fixture=None, pairs="all", payload=None, root=None, tip=None,
                 on_fit=None):
    """k-fold cross-validation (and a learning curve) of a method, beside the nominal robot
    registered on the same training folds; for the constraint method, leave one fixture
    placement out at a time.  ``on_fit()`` is called after every fit."""
    from ..estimation.validation import k_fold, learning_curve

    if method not in IMPLEMENTED_METHODS:
        raise InputError(f"method {method!r} is not available; available: {', '.join(IMPLEMENTED_METHODS)}")
    chain = load_robot(robot, root=root, tip=tip)
    data = read_measurements(measurements, n_joints=chain.n_joints)
    if method == "constraint":
        if sizes:
            raise InputError("--sizes (a learning curve) is for position data; the constraint method is "
                             "validated placement by placement")
        return _placement_validation(chain, data, fixture, pairs, parameters, payload, on_fit)
    _positions_required(data, method)
    q = chain.joints_from_file(data.joints)
    def counted(fit):
        def wrapped(train):
            predict = fit(train)
            if on_fit is not None:
                on_fit()
            return predict
        return wrapped

    fitter = counted(_fitter(method, chain, q, data, register, parameters, loss, seed))
    def summary(cv):  # the per-pose arrays stay out of the JSON
        return {key: cv[key] for key in ("k", "folds", "pooled")}

    result = {"method": method, "file": str(measurements), "poses": data.n_poses, "folds": folds,
              "cross_validation": summary(k_fold(data.n_poses, fitter, data.positions, k=folds, seed=seed)),
              "nominal_cross_validation": summary(k_fold(
                  data.n_poses, counted(_fitter("nominal", chain, q, data, register, parameters, loss, seed)),
                  data.positions, k=folds, seed=seed))}
    if sizes:
        result["learning_curve"] = learning_curve(data.n_poses, fitter, data.positions, sizes, seed=seed)
    return result
