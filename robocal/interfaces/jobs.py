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
)
from ..errors import FileFormatError, InputError, RobocalWarning
from ..estimation.metrics import error_stats
from ..io.library import load_robot
from ..io.tables import read_measurements, read_targets, write_commands, write_measurements
from ..spatial import compose_pose, pose_to_xyz_rpy, rpy_to_matrix
from .model_file import ModelFile, load_model, save_model

IMPLEMENTED_METHODS = ("kinematic", "kriging", "hybrid")
# A calibrated model that still misses by this much is almost certainly the wrong robot,
# wrong units or a different measurement frame.
SUSPICIOUS_RESIDUAL_MM = 20.0


def _positions_required(data, method):
    if data.positions is None:
        raise InputError(f"{data.path} has no x, y, z columns: the {method} method needs measured positions")


def calibrate_job(robot, measurements, out, *, method="kinematic", register="auto", kriging=None,
                  parameters="full", loss="linear", root=None, tip=None):
    """Fit a method to a measurement file and save the model file."""
    if method not in IMPLEMENTED_METHODS:
        raise InputError(
            f"method {method!r} is not available in this version of robocal; available: "
            f"{', '.join(IMPLEMENTED_METHODS)}"
        )
    chain = load_robot(robot, root=root, tip=tip)
    data = read_measurements(measurements, n_joints=chain.n_joints)
    _positions_required(data, method)
    q = chain.joints_from_file(data.joints)
    if method == "kriging":
        compensator, reference, record = fit_kriging(chain, q, data.positions, register=register, kriging=kriging)
    else:
        rotations = None if data.orientations is None else rpy_to_matrix(np.radians(data.orientations))
        fit = fit_kinematic if method == "kinematic" else partial(fit_hybrid, kriging=kriging)
        compensator, reference, record = fit(chain, q, data.positions, orientations=rotations,
                                             sigmas=data.sigmas, parameters=parameters, loss=loss,
                                             register=register)
        outliers = record["calibration"]["outliers"]
        if outliers:
            record["calibration"]["outlier_rows"] = [int(data.rows[i]) for i in outliers]
    training = {"file": str(measurements), "n_poses": data.n_poses, "kind": data.kind, **record}
    model = ModelFile(method=method, nominal=chain, kinematics=compensator.chain, reference=reference,
                      error_model=error_model_to_dict(compensator.error_model), training=training,
                      options={"register": register, "parameters": parameters, "loss": loss})
    save_model(model, out)
    return {"method": method, "robot": chain.name, "out": str(out), **training}


def load_compensator(model_path, robot=None):
    """A model file -> (ModelFile, Compensator)."""
    model = load_model(model_path, robot=robot)
    try:
        error_model = error_model_from_dict(model.error_model)
    except (InputError, KeyError, TypeError, ValueError) as exc:
        raise FileFormatError(f"{model_path}: the error model is damaged ({exc}); "
                              "regenerate the file with 'robocal calibrate'") from None
    rigid = getattr(model.kinematics, "rigid", model.kinematics)
    return model, Compensator(model.kinematics, error_model, nominal=rigid)


def evaluation(model_path, measurements):
    """A model file on measured data: (model, compensator, data, q, before (N, 3), after
    (N, 3), statistics as ``evaluate --json`` prints them)."""
    import warnings

    model, compensator = load_compensator(model_path)
    data = read_measurements(measurements, n_joints=model.kinematics.n_joints)
    _positions_required(data, model.method)
    q = model.kinematics.joints_from_file(data.joints)
    before = data.positions - model.reference.fk_positions(q)
    after = data.positions - compensator.predict_positions(q)
    result = {**error_stats(after), "nominal": error_stats(before)}
    if result["mean_mm"] > SUSPICIOUS_RESIDUAL_MM:
        warnings.warn(RobocalWarning(
            f"the residual is {result['mean_mm']:.1f} mm mean after calibration: is {measurements} "
            f"from robot '{model.nominal.name}', in mm and degrees, in the frame the model was fitted in?"))
    stats = {"model": str(model_path), "method": model.method, "file": str(measurements), **result}
    return model, compensator, data, q, before, after, stats


def evaluate_job(model_path, measurements):
    """Residual of a model on measured data, and of the nominal robot."""
    return evaluation(model_path, measurements)[-1]


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


def export_job(model_path, out, *, fmt="toml"):
    """The calibrated kinematics of a model file as a robot TOML or a URDF, for a controller
    that accepts new parameters (direct compensation) or for ROS."""
    from ..io.robot_file import write_robot
    from ..io.urdf import write_urdf

    if fmt not in EXPORT_FORMATS:
        raise InputError(f"format must be one of {', '.join(EXPORT_FORMATS)}, got {fmt!r}")
    model = load_model(model_path)
    chain = getattr(model.kinematics, "rigid", model.kinematics)
    left_out = []
    if chain is not model.kinematics:
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
        write_urdf(chain, out, allow_coupled=True)
    return {"model": str(model_path), "format": fmt, "out": str(out), "robot": chain.name,
            "convention": chain.convention, "left_out": left_out}


def simulate_job(robot, out, *, n=None, sampling="joint", errors="typical", noise=None, seed=0,
                 truth=None, orientation=False, box=None, rpy=None, hint=None, root=None, tip=None):
    """Measurements of a simulated "true" robot, in the order the robot visits the poses."""
    from dataclasses import replace

    from ..simulation import grid, latin_hypercube_box, liu2022_plan, make_true_robot, uniform_joints, write_truth
    from ..spatial import rpy_to_matrix

    chain = load_robot(robot, root=root, tip=tip)
    rng = np.random.default_rng(seed)
    true_robot = make_true_robot(chain, errors, seed=seed)
    if noise is not None:
        if noise < 0:
            raise InputError(f"--noise must be >= 0 mm, got {noise}")
        true_robot = replace(true_robot, noise=float(noise))
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
        raise InputError(f"--sampling {sampling} is not available in this version; use joint, lhs or grid")
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
}


def dataset_job(name, prefix, *, split=None, seed=0):
    """Write a shared dataset as robocal files: PREFIX.toml (the robot model the data were
    taken against) and PREFIX.csv, or PREFIX_train.csv / PREFIX_test.csv with ``split`` the
    training fraction of a random split."""
    from ..io import datasets
    from ..io.robot_file import write_robot

    if name not in DATASETS:
        raise InputError(f"unknown dataset {name!r}; available: {', '.join(DATASETS)}")
    loader, kwargs = DATASETS[name]
    chain, data = getattr(datasets, loader)(**kwargs)
    write_robot(chain, f"{prefix}.toml", description=f"robot model of the {name} dataset")
    written = {"robot": f"{prefix}.toml"}
    if split is None:
        write_measurements(f"{prefix}.csv", data)
        written["measurements"] = f"{prefix}.csv"
    else:
        if not 0.0 < split < 1.0:
            raise InputError(f"--split is the training fraction and must lie between 0 and 1, got {split}")
        order = np.random.default_rng(seed).permutation(data.n_poses)
        cut = int(round(split * data.n_poses))
        write_measurements(f"{prefix}_train.csv", data.subset(np.sort(order[:cut])))
        write_measurements(f"{prefix}_test.csv", data.subset(np.sort(order[cut:])))
        written.update(train=f"{prefix}_train.csv", test=f"{prefix}_test.csv", train_poses=cut,
                       test_poses=data.n_poses - cut)
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
            fit_method = fit_kinematic if method == "kinematic" else partial(fit_hybrid, kriging=kriging)
            compensator = fit_method(chain, q[train], data.positions[train], orientations=take(rotations, train),
                                     sigmas=take(data.sigmas, train), parameters=parameters, loss=loss,
                                     register=register)[0]
        return lambda test: compensator.predict_positions(q[test])

    return fit


def validate_job(robot, measurements, *, method="kinematic", folds=5, sizes=None, seed=0, register="auto",
                 parameters="full", loss="linear", root=None, tip=None, on_fit=None):
    """k-fold cross-validation (and a learning curve) of a method, beside the nominal robot
    registered on the same training folds.  ``on_fit()`` is called after every fit."""
    from ..estimation.validation import k_fold, learning_curve

    if method not in IMPLEMENTED_METHODS:
        raise InputError(f"method {method!r} is not available; available: {', '.join(IMPLEMENTED_METHODS)}")
    chain = load_robot(robot, root=root, tip=tip)
    data = read_measurements(measurements, n_joints=chain.n_joints)
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
