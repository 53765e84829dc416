"""What each command does, as plain functions of parsed arguments that return the command's
result (a type of :mod:`.results` with ``to_dict()``): read
the files, call the method registry, write the files.  ``cli/`` only parses, renders
(``cli/rendering.py``) and maps errors to exit codes."""
import os
from dataclasses import replace

import numpy as np

from ..errors import FileFormatError, InputError
from ..estimation.metrics import error_stats
from ..io.atomic import check_outputs
from ..io.csv_writing import write_per_pose
from ..io.fingerprint import of_observations, seen_by_model
from ..io.library import load_robot
from ..io.model_file import load_model, save_model
from ..io.observations import read_observations, read_target_poses, write_joint_commands
from ..io.tables import write_measurements
from ..methods import DEFAULT_METHOD, REGISTRY, fitted_from_model_file, make_method
from ..methods.evaluation import position_scores, socket_scores, with_fixture
from ..methods.base import option_of
from ..methods.bound import NO_BOUND, bound_of_model
from ..methods.socket_bound import fit_model_bound
from ..methods.moved_bound import reregistered_bound
from ..estimation.plausibility import check_model_data
from ..methods.expectation import expected_error, fall_back_outside_if_worse, refuse_if_worse_than_nominal
from ..methods.reregistration import FRAMES  # noqa: F401  (the command line and fleet files name it here)
from ..methods.selection import AUTO, choose, compare
from ..methods.validation import cross_validate
from .results import Calibrated, Compensated, DatasetWritten, Evaluated, Exported, Simulated, Validated


def calibrate_job(robot, measurements, out, *, method=DEFAULT_METHOD, settings=None, fixture=None, progress=None,
                  root=None, tip=None, beyond_limits=False, accept_extrapolation=False, folds=None):
    """Fit a method (an unfitted :class:`~robocal.methods.Method`, or a registered name with
    its ``settings``) to a measurement file and save the model file.  ``progress(**info)`` is
    called as the method reports its steps.  The error to expect where the robot will work is
    kept in the record; a model predicted to do worse there than the registered nominal robot
    answers outside its training domain with the rigid kinematic calibration if that is not
    predicted worse (:func:`~robocal.methods.expectation.fall_back_outside_if_worse`), else is
    refused, unless ``accept_extrapolation``.  ``folds``: auto's comparison folds (default
    5; leave-one-out on a small campaign)."""
    auto = method == AUTO
    if folds is not None and not auto:
        raise InputError(f"--folds sets the folds of --method auto's comparison: leave it out for the "
                         f"{getattr(method, 'name', method)} "
                         "method (robocal validate --folds cross-validates one method)")
    if auto and settings:
        raise InputError(f"--method auto chooses the method and its settings by comparing them: leave out "
                         f"{', '.join(option_of(name) for name in settings)}, or name a method")
    fitter = None if auto else make_method(method, **(settings or {})) if isinstance(method, str) else method
    check_outputs([out], [measurements, fixture, robot])
    chain = load_robot(robot, root=root, tip=tip)
    observations = read_observations(measurements, chain, fixture, beyond_limits=beyond_limits)
    training = {"file": str(measurements), "n_poses": observations.n_poses, "kind": observations.kind,
                "fingerprint": of_observations(chain, observations)}
    if fixture is not None:
        training["fixture_file"] = str(fixture)
    if auto:
        fitter, comparison = choose(chain, observations, folds=folds, on_fit=progress)
        training["comparison"] = comparison.to_dict()
    else:
        fitter.fit(chain, observations, progress=progress)
    predicted = expected_error(fitter, chain, observations)
    if not accept_extrapolation:
        predicted = fall_back_outside_if_worse(fitter, chain, observations, predicted)
        refuse_if_worse_than_nominal(predicted, getattr(fitter, "domain_", None))
    if predicted is not None:
        fitter.record_ = fitter.record_.replace(predicted_error=predicted.to_dict())
    document = fitter.to_model_file(chain, training)
    # The 95 % bound of the fitted model (robocal.methods.bound), computed here only: the fold
    # fits of compare and auto's comparison do not pay for it.
    fitter.bound_ = fit_model_bound(fitter, chain, observations)
    document = replace(document, bound=None if fitter.bound_ is None else fitter.bound_.to_dict())
    save_model(document, out)
    return Calibrated(fitter.name, chain.name, str(out), training, fitter.record_, fitter.compensator_.chain)


# What a re-registered model file keeps of the original's training entry (the data it was
# fitted on), beside the re-registration record.
KEPT_TRAINING = ("file", "n_poses", "kind", "fixture_file", "comparison", "fingerprint")


def reregister_job(model_path, measurements, out, *, parameters=None, beyond_limits=False,
                   accept_extrapolation=False):
    """A model file carried to a new set-up (robocal.methods.reregistration): its base and
    tool (and with ``parameters='frames+offsets'`` its joint offsets) identified again from the
    poses of ``measurements``, everything else kept; saved to ``out``."""
    from ..methods.reregistration import reregister

    check_outputs([out], [model_path, measurements])
    model, fitted = load_fitted(model_path)
    observations = read_observations(measurements, model.nominal, beyond_limits=beyond_limits)
    moved = reregister(fitted, observations, parameters or "frames", robot=model.nominal)
    predicted = expected_error(moved, model.nominal, observations)
    if not accept_extrapolation:
        refuse_if_worse_than_nominal(predicted)
    if predicted is not None:
        moved.record_ = moved.record_.replace(predicted_error=predicted.to_dict())
    training = {key: model.training[key] for key in KEPT_TRAINING if key in model.training}
    # The new set-up's poses are poses the model was fitted to (its frames come from them):
    # fingerprinted as a calibration's are (robocal.io.fingerprint), so that a score on them
    # is not called held out.
    training.update(reregistered_from=str(model_path), reregistration_file=str(measurements),
                    reregistration_poses=observations.n_poses,
                    reregistration_fingerprint=of_observations(model.nominal, observations))
    document = moved.to_model_file(model.nominal, training)
    if fitted.bound_ is not None:
        # The original's bound, checked (and widened where needed) on the new set-up's poses.
        moved.bound_ = reregistered_bound(fitted.bound_, fitted, moved, observations, parameters or "frames",
                                          robot=model.nominal)
        document = replace(document, bound=moved.bound_.to_dict())
    save_model(document, out)
    return Calibrated(moved.name, model.nominal.name, str(out), training, moved.record_, moved.compensator_.chain)


def load_fitted(model_path, robot=None):
    """A model file -> (ModelFile, the fitted method it holds, with ``bound_``: its 95 %
    bound, None when the file stores none)."""
    model = _with_checked_options(load_model(model_path, robot=robot), model_path)
    fitted = fitted_from_model_file(model, model_path)
    fitted.bound_ = bound_of_model(model, fitted, model_path)
    return model, fitted


def read_model_data(model, model_path, measurements, fixture=None, beyond_limits=False):
    """The observations of the file ``measurements`` for scoring the model ``model`` (read
    from ``model_path``), refused when the model cannot be scored on them
    (:func:`robocal.estimation.plausibility.check_model_data`): every reader of data for a
    fitted model (``evaluate``, ``report``) reads them here."""
    observations = read_observations(measurements, model.kinematics, fixture, beyond_limits=beyond_limits)
    check_model_data(model, observations, model_path)
    return observations


def _with_checked_options(model, path):
    """``model`` if its settings pass their constraints (an unknown method is the registry's
    to refuse); otherwise a FileFormatError naming the entry.  The settings were checked when
    the model was fitted: one edited since, its checksum recomputed, is refused here, before
    anything acts on it."""
    for setting in getattr(REGISTRY.get(model.method), "settings", ()):
        if setting.name in model.options:
            try:
                setting.check(model.options[setting.name])
            except InputError as exc:
                raise FileFormatError(f"{path}: 'options.{setting.name}' in the model file is not a value robocal "
                                      f"writes ({exc}); regenerate the file with 'robocal calibrate'") from None
    return model


# What evaluate and compensate say of a model file written before domains were recorded.
NO_DOMAIN = "this model file records no domain of validity"


def _answered(fitted, check):
    """The domain check's summary, saying what answered outside when the model falls back
    to another there (calibrate --method auto, robocal.methods.fallback)."""
    label = getattr(fitted.compensator_, "label", None)
    if label is None or not check.n_outside:
        return check.summary
    return f"{check.summary}; those outside were answered by {label}"


def _uncertainty(fitted, joints, known):
    """The error model's predicted standard deviation (N,) mm where ``known`` (NaN elsewhere),
    or None for a method without one."""
    sigma = fitted.uncertainty(joints[known])
    if sigma is None:
        return None
    out = np.full(len(joints), np.nan)
    out[known] = sigma
    return out


def _bound_summary(error, bound, inside):
    """``evaluate --json``'s ``bound95`` entry: the share of poses whose error (N,) mm lies
    within their 95 % bound (N,) mm, overall and inside / outside the training domain
    (``inside`` (N,) bool), and the median bound beside the median error."""
    def share(mask):
        count = int(np.count_nonzero(mask))
        return {"poses": count, "within_share": float(np.mean(error[mask] <= bound[mask])) if count else None,
                "median_bound_mm": float(np.median(bound[mask])) if count else None,
                "median_error_mm": float(np.median(error[mask])) if count else None}

    everything = np.ones(len(error), dtype=bool)
    return {**share(everything), "inside": share(inside), "outside": share(~inside)}


def _training_poses(model, observations, where):
    """How many of ``observations`` the model was fitted to, by content (None: the model
    file keeps no fingerprint of its training rows, written before it did)."""
    seen = seen_by_model(model.training, model.kinematics, observations, where=str(where))
    return None if seen is None else int(seen.sum())


def evaluate_job(model_path, measurements, fixture=None, beyond_limits=False, per_pose=None):
    """Residual of a model on measured positions, and of the nominal robot; on ball-in-socket
    data the socket consistency and socket-distance errors.  Each pose is checked against the
    model's domain of validity: ``outside_domain`` counts those outside, ``domain_summary``
    says why in one line, and on position data ``in_domain`` / ``out_of_domain`` are the
    error statistics of each part.  On position data ``bound95`` is the share of poses whose
    error lies within the model's 95 % bound (robocal.methods.bound; None, with ``bound_note``
    saying why, for a model file without one), and ``per_pose`` (a path) writes one CSV line
    per pose (:func:`robocal.io.csv_writing.write_per_pose`).  ``training_poses`` counts the
    poses the model was fitted to, by content (the model file's fingerprints: its calibration's
    and a re-registration's poses; None for a file without one): a score of them is not held
    out.  Returns an :class:`.results.Evaluated`."""
    if per_pose is not None:
        check_outputs([per_pose], [model_path, measurements, fixture])
    model, fitted = load_fitted(model_path)
    observations = read_model_data(model, model_path, measurements, fixture, beyond_limits)
    head = {"model": str(model_path), "method": model.method, "file": str(measurements),
            "training_poses": _training_poses(model, observations, model_path)}
    if observations.positions is None:
        if per_pose is not None:
            raise InputError(f"{measurements} is ball-in-socket data: --per-pose writes each pose's position error "
                             "and needs measured x, y, z columns")
        scores = socket_scores(fitted, with_fixture(fitted, observations, model_path))
        after = None
    else:
        _, after, scores = position_scores(fitted, observations, model.nominal.name)
    q = observations.joints
    parts = {}
    if fitted.domain_ is None:
        outside, summary, inside = None, NO_DOMAIN, None
    else:
        check = fitted.domain_.check(q, observations.positions, observations.placement,
                                     _uncertainty(fitted, q, np.ones(len(q), dtype=bool)), what="poses")
        outside, summary, inside = check.n_outside, _answered(fitted, check), check.inside
        if after is not None:
            parts.update(in_domain=error_stats(after[inside]), out_of_domain=error_stats(after[~inside]))
    if after is not None:
        error = np.linalg.norm(after, axis=1)
        bound = None if fitted.bound_ is None else fitted.bound_.predict(q, inside=inside)
        if bound is None:
            parts["bound_note"] = NO_BOUND
        else:
            parts["bound95"] = _bound_summary(error, bound, np.ones(len(q), dtype=bool) if inside is None else inside)
        if per_pose is not None:
            write_per_pose(per_pose, observations.rows, observations.positions, observations.positions - after, error,
                           bound, inside)
            parts["per_pose"] = str(per_pose)
    return Evaluated(**head, scores=scores, outside_domain=outside, domain_summary=summary, **parts)


def compensate_job(model_path, targets_path, out, *, iterate=False):
    """Joint commands and corrected Cartesian targets for a targets file.  The commands CSV
    says of each reachable target whether it lies in the model's domain of validity
    (``in_domain`` 1/0, ``domain_note`` why not), ``bound95_mm``: the 95 % bound on the
    position error there (robocal.methods.bound; every method; empty cells, and
    ``bound_note`` in the result, for a model file without one) and, for a method with an
    error model that predicts one, ``uncertainty_mm`` (that model's own standard deviation,
    kept for the files written before the bound); the result counts ``outside_domain`` and
    sums them up in ``domain_summary``."""
    check_outputs([out], [model_path, targets_path])
    model, fitted = load_fitted(model_path)
    targets = read_target_poses(targets_path, model.kinematics)
    result = fitted.compensator_.commands(targets.poses, hint=targets.hints, iterate=iterate)
    if not result.success.any():
        raise InputError(f"none of the {len(targets.poses)} targets in {targets_path} can be reached by the calibrated "
                         f"robot: are they in the measurement frame, in mm and degrees? nothing was written")
    reached = result.success
    sigma = _uncertainty(fitted, result.q, reached)
    extra = {}
    # Unreachable targets have no configuration to judge: NaN rows count as neither.
    q = np.where(reached[:, None], result.q, np.nan)
    inside = None
    if fitted.domain_ is None:
        outside, summary = None, NO_DOMAIN
    else:
        check = fitted.domain_.check(q, targets.poses[:, :3, 3], uncertainty=sigma)
        extra["in_domain"] = [("1" if inside else "0") if ok else "" for inside, ok in zip(check.inside, reached)]
        extra["domain_note"] = list(check.reasons)
        outside, summary = check.n_outside, _answered(fitted, check)
        inside = check.inside
    bound = None if fitted.bound_ is None else fitted.bound_.predict(q, inside=inside)
    extra["bound95_mm"] = ["" if bound is None or not ok else f"{b:.4f}" for b, ok in
                           zip(np.full(len(q), np.nan) if bound is None else bound, reached)]
    if sigma is not None:
        extra["uncertainty_mm"] = [f"{s:.4f}" if ok else "" for s, ok in zip(sigma, reached)]
    write_joint_commands(out, model.kinematics, result.q, result.corrected, reached, extra=extra)
    return Compensated(
        targets=int(len(targets.poses)), reachable=int(reached.sum()),
        unreachable_rows=[int(r) for r in targets.rows[~reached]], out=str(out),
        predicted_error=error_stats(result.predicted_error[np.isfinite(result.predicted_error).all(axis=1)]),
        outside_domain=outside, domain_summary=summary,
        bound95_median_mm=None if bound is None else float(np.nanmedian(bound[reached])),
        # A ball-in-socket model's bound says what it bounds (the socket consistency).
        bound_note=NO_BOUND if bound is None else fitted.bound_.calibration.get("note"))


EXPORT_FORMATS = ("toml", "urdf", "ur-yaml")


def export_job(model_path, out, *, fmt="toml", convention=None, original=None):
    """The calibrated kinematics of a model file as a robot TOML or a URDF, for a controller
    that accepts new parameters (direct compensation) or for ROS; ``convention`` (dh, mdh,
    poe) converts it exactly first (a calibrated model may have no exact DH form); ``original``
    (a URDF, with fmt urdf) is the robot's own file, rewritten only where the calibration
    changed it (robocal.io.urdf_update)."""
    from ..io.robot_file import write_robot
    from ..io.urdf import write_urdf
    from ..kinematics import to_dh, to_mdh, to_poe

    if fmt not in EXPORT_FORMATS:
        raise InputError(f"format must be one of {', '.join(EXPORT_FORMATS)}, got {fmt!r}")
    converters = {"dh": to_dh, "mdh": to_mdh, "poe": to_poe}
    if convention is not None and convention not in converters:
        raise InputError(f"convention must be one of dh, mdh, poe, got {convention!r}")
    check_outputs([out], [model_path, original])
    # Rebuilt whole, as every verb that reads a model does: a damaged entry export does not
    # use (an unknown method, a domain of the wrong shape) still says the file is not sound.
    model, _ = load_fitted(model_path)
    rigid = model.kinematics.rigid
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
    elif fmt == "ur-yaml":
        from ..io.ur_yaml import write_ur_yaml

        left_out += write_ur_yaml(out, model.nominal, chain)
    elif original is not None:
        from ..io.urdf_update import write_calibrated_urdf

        return Exported(model=str(model_path), format=fmt, out=str(out), robot=chain.name,
                        convention=chain.convention, left_out=left_out,
                        into_original=write_calibrated_urdf(original, model.nominal, rigid, out))
    else:
        if not np.array_equal(np.abs(chain.joint_map), np.eye(chain.n_joints)):
            left_out.append("the joint map (a coupling, or calibrated joint gains): the URDF's joint values are "
                            "the model variables joint_map·q, not the controller's readings (a robot file keeps it)")
        write_urdf(chain, out, allow_coupled=True)
    return Exported(model=str(model_path), format=fmt, out=str(out), robot=chain.name, convention=chain.convention,
                    left_out=left_out)


def _simulate_sockets(true_robot, out, fixture_path, placements, per_socket, noise, joint_noise, rng):
    """Ball-in-socket readings of a true robot; ``noise`` is the seating error (mm).  Returns
    the :class:`.results.Simulated` fields they fill."""
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

    # Any file is read as a truth file, so that another of robocal's files is named (file_kinds).
    if errors in PRESETS or not (errors.endswith(".json") or os.path.isfile(errors)):
        return make_true_robot(chain, errors, seed=seed)
    truth = read_truth(errors)
    q = uniform_joints(chain, 20, np.random.default_rng(0))
    if truth.nominal.n_joints != chain.n_joints or not np.allclose(truth.nominal.fk(q), chain.fk(q), atol=1e-6):
        raise InputError(f"{errors} describes the robot {truth.nominal.name!r}, not {chain.name!r}: simulate that "
                         "robot, or write a truth file of this one with --truth and edit it")
    return truth


SAMPLINGS = ("joint", "lhs", "grid", "sockets")


def _only_what_applies(sampling, socket_options, box_options):
    """Refuse simulate options the sampling plan would ignore (None: not given)."""
    given = {"sockets": box_options, "joint": {**socket_options, **box_options}}.get(sampling, socket_options)
    unused = [name for name, value in given.items() if value is not None]
    if unused:
        raise InputError(f"{', '.join(unused)} {'does' if len(unused) == 1 else 'do'} not apply to --sampling "
                         f"{sampling}: leave {'it' if len(unused) == 1 else 'them'} out, or choose the sampling "
                         "that uses it (lhs and grid: --box, --rpy, --hint; sockets: --fixture, --placements, "
                         "--per-socket, --joint-noise)")


def simulate_job(robot, out, *, n=None, sampling="joint", errors="typical", noise=None, seed=0,
                 truth=None, orientation=False, box=None, rpy=None, hint=None, root=None, tip=None,
                 fixture=None, placements=None, per_socket=None, joint_noise=None):
    """Measurements of a simulated "true" robot, in the order the robot visits the poses.

    ``--sampling sockets`` seats a ball (the tool) in the sockets of ``fixture`` at
    ``placements`` random fixture poses, ``per_socket`` configurations each, and records
    joint angles only (``noise`` is then the seating error, ``joint_noise`` in deg).  Returns a
    :class:`.results.Simulated`."""
    from ..simulation import grid, latin_hypercube_box, liu2022_plan, uniform_joints, write_truth
    from ..spatial import rpy_to_matrix

    if n is not None and n < 1:
        raise InputError(f"--n is the number of poses to simulate and must be at least 1, got {n}")
    _only_what_applies(sampling, {"--fixture": fixture, "--placements": placements, "--per-socket": per_socket,
                                  "--joint-noise": joint_noise}, {"--box": box, "--rpy": rpy, "--hint": hint})
    placements = 4 if placements is None else placements
    per_socket = 10 if per_socket is None else per_socket
    joint_noise = 0.0 if joint_noise is None else joint_noise
    check_outputs([out, truth], [fixture, robot, errors])
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
        return Simulated(chain.name, sampling, errors, str(out), str(truth) if truth else None, **result)
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
        raise InputError(f"--sampling {sampling} is not available; use {', '.join(SAMPLINGS)}")
    data = true_robot.measurements(q, rng, orientation=orientation)
    write_measurements(out, data)
    if truth:
        write_truth(truth, true_robot)
    return Simulated(chain.name, sampling, errors, str(out), str(truth) if truth else None, int(len(q)),
                     true_error=error_stats(true_robot.error(q)))


DATASETS = {
    "ur5-tsinghua": ("ur5_tsinghua", {}),
    "ipa-ur10-a": ("ipa_ur10", {"series": "A"}),
    "ipa-ur10-b": ("ipa_ur10", {"series": "B"}),
    "ipa-ur10-d": ("ipa_ur10", {"series": "D"}),
    "mukca-panda-1": ("mukca", {"unit": "panda_1"}),
    "mukca-panda-2": ("mukca", {"unit": "panda_2"}),
    "mukca-panda-3": ("mukca", {"unit": "panda_3"}),
}


def dataset_job(name, prefix, *, split=None, seed=0):
    """Write a real dataset shipped with robocal as robocal files: PREFIX.toml (the robot model the data were
    taken against) and PREFIX.csv, or PREFIX_train.csv / PREFIX_test.csv with ``split`` the
    training fraction of a random split; ball-in-socket data also PREFIX_fixture.toml, and
    are split by whole fixture placements (held-out placements, as a user would test).
    Returns a :class:`.results.DatasetWritten`."""
    from ..io import datasets
    from ..io.fixtures import write_fixture
    from ..io.robot_file import write_robot

    if name not in DATASETS:
        raise InputError(f"unknown dataset {name!r}; available: {', '.join(DATASETS)}")
    # --out is a prefix of file names: a folder (or a name ending in a separator) would give
    # hidden files '.csv' and '.toml' in it.
    if str(prefix).endswith(("/", os.sep)) or os.path.isdir(str(prefix)) or not os.path.basename(str(prefix)):
        raise InputError(f"--out {prefix} is a folder: give a prefix of file names, e.g. --out "
                         f"{os.path.join(str(prefix), name)} writes {name}.toml and {name}.csv there")
    loader, kwargs = DATASETS[name]
    dataset = getattr(datasets, loader)(**kwargs)
    # The files are in file units: the dataset's measurements, not its observations.
    chain, data, fixture = dataset.chain, dataset.measurements, dataset.fixture
    # The split is checked before anything is written: a refused split leaves no files.
    train, chosen = (None, None) if split is None else datasets.split_indices(data, split, seed)
    write_robot(chain, f"{prefix}.toml", description=f"robot model of the {name} dataset")
    written = {"robot": f"{prefix}.toml"}
    if fixture is not None:
        write_fixture(f"{prefix}_fixture.toml", fixture)
        written["fixture"] = f"{prefix}_fixture.toml"
    if name == "ipa-ur10-d":  # the ISO cubes: also the ISO 9283 campaign, in the robot's base frame
        from ..io.ipa_iso import write_series_d_campaign

        written.update(write_series_d_campaign(f"{prefix}_iso.csv"))
    if split is None:
        write_measurements(f"{prefix}.csv", data)
        return DatasetWritten(name, data.n_poses, data.path, **written, measurements=f"{prefix}.csv")
    test = np.setdiff1d(np.arange(data.n_poses), train)
    write_measurements(f"{prefix}_train.csv", data.subset(train))
    write_measurements(f"{prefix}_test.csv", data.subset(test))
    return DatasetWritten(name, data.n_poses, data.path, **written, train=f"{prefix}_train.csv",
                          test=f"{prefix}_test.csv", train_poses=int(len(train)), test_poses=int(len(test)),
                          train_placements=chosen)


def validate_job(robot, measurements, *, method=DEFAULT_METHOD, settings=None, folds=5, sizes=None, seed=0,
                 fixture=None, root=None, tip=None, on_fit=None, beyond_limits=False):
    """Held-out accuracy of a method beside the registered nominal robot: k-fold
    cross-validation (and a learning curve) on position data, one fixture placement left out
    at a time on ball-in-socket data.  ``on_fit()`` is called after every fit.  Returns a
    :class:`.results.Validated`."""
    unfitted = make_method(method, **(settings or {}))
    chain = load_robot(robot, root=root, tip=tip)
    observations = read_observations(measurements, chain, fixture, beyond_limits=beyond_limits)
    result = cross_validate(unfitted, chain, observations, folds=folds, sizes=sizes, seed=seed, on_fit=on_fit)
    # The report checks a validation against its model's robot by this name.
    return Validated.of(chain.name, result)


def compare_job(robot, measurements, *, folds=None, seed=0, fixture=None, network=None, root=None, tip=None,
                on_fit=None, beyond_limits=False):
    """Every applicable method scored on held-out poses, split at random and by region, beside
    the registered nominal; the recommended model and why (:mod:`robocal.methods.selection`)."""
    chain = load_robot(robot, root=root, tip=tip)
    observations = read_observations(measurements, chain, fixture, beyond_limits=beyond_limits)
    return compare(chain, observations, folds=folds, seed=seed, network=network, on_fit=on_fit)
