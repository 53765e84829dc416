"""The ``robocal`` command line.

Every error a user can cause is a :class:`~robocal.errors.RobocalError`; it is printed as one
line and the command exits with status 2.  ``--debug`` shows the traceback instead.
"""
import functools
import json
import sys
import warnings

import numpy as np
import typer
from rich.console import Console
from rich.table import Table
from rich.text import Text

from .. import __version__
from ..errors import InputError, RobocalError, RobocalWarning
from ..methods import DEFAULT_METHOD, get_method, make_method, method_names
from .jobs import calibrate_job, compensate_job, dataset_job, evaluate_job, export_job, simulate_job, validate_job

app = typer.Typer(
    help="robocal: calibrate industrial robots and compensate their positioning errors.\n\n"
         "Try: robocal demo; robocal calibrate ur5 meas.csv --out model.json; "
         "robocal report model.json test.csv --out report.html",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="markdown",  # reflow docstring paragraphs in --help
)
# No markup: messages and tables carry users' text (file names, "[sockets]") that must print as is.
out = Console(highlight=False, soft_wrap=True, markup=False)
err = Console(stderr=True, highlight=False, soft_wrap=True, markup=False)


def _say(label, style, message):
    """One line on stderr: a coloured ``label:`` and the message, verbatim."""
    err.print(Text(f"{label}:", style=style) + Text(f" {message}"))
_state = {"debug": False}


def _show_warning(message, category, filename, lineno, file=None, line=None):
    if issubclass(category, RobocalWarning):
        _say("warning", "yellow", message)
    else:
        err.print(f"warning: {category.__name__}: {message}")


def user_errors(func):
    """Turn RobocalError (and a system's refusal of a file) into one line on stderr and exit
    status 2."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except RobocalError as exc:
            if _state["debug"]:
                raise
            _say("error", "red", exc)
            raise typer.Exit(2) from None
        except OSError as exc:  # a file the system would not read or write: the user's to fix
            if _state["debug"]:
                raise
            where = f" {exc.filename}" if exc.filename else ""
            _say("error", "red", f"cannot use{where}: {exc.strerror or exc}; check the path and its permissions")
            raise typer.Exit(2) from None

    return wrapper


def _print_version(value: bool):
    if value:
        out.print(f"robocal {__version__}")
        raise typer.Exit()


@app.callback()
def _main(debug: bool = typer.Option(False, "--debug", help="Show tracebacks of errors."),
          version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                       help="Print the version and exit.")):
    _state["debug"] = debug


@app.command()
@user_errors
def robots():
    """List the built-in robots.

    Example: robocal robots
    """
    from ..io.library import builtin, builtin_description, builtin_names

    table = Table("name", "joints", "model", "description")
    for name in builtin_names():
        chain = builtin(name)
        table.add_row(name, str(chain.n_joints), chain.convention.upper(), builtin_description(name))
    out.print(table)


@app.command()
@user_errors
def show(
    robot: str = typer.Argument(..., help="Built-in name, robot .toml or .urdf file."),
    tip: str = typer.Option(None, help="URDF only: the tip link."),
    root: str = typer.Option(None, help="URDF only: the root link."),
):
    """Print a robot's parameter table (mm, deg), frames and joint limits.

    Example: robocal show kr150-2
    """
    from ..io.library import load_robot
    from .tables import robot_tables

    chain = load_robot(robot, root=root, tip=tip)
    for renderable in robot_tables(chain):
        out.print(renderable)


def _print_result(result, as_json, title):
    if as_json:
        print(json.dumps(result, indent=2))
        return
    table = Table(title=title, show_header=False)
    for key, value in result.items():
        if isinstance(value, dict) and "mean_mm" not in value:
            continue  # nested records are in --json and in the model file
        if isinstance(value, dict):
            value = (f"mean {value['mean_mm']:.4f} mm, RMS {value['rms_mm']:.4f} mm, "
                     f"max {value['max_mm']:.4f} mm (n = {value['n']})")
        elif isinstance(value, float):
            value = f"{value:.4f}"
        table.add_row(key, str(value))
    out.print(table)


def _print_calibration(calibration):
    """Identified parameters with standard errors, and what could not be identified
    (a :class:`~robocal.methods.CalibrationRecord`)."""
    ident = calibration.identifiability
    table = Table(title=f"identified parameters ({ident.rank}; {calibration.units})")
    for col in ("parameter", "deviation", "std. error"):
        table.add_column(col, justify="right")
    for name, value in calibration.parameters.items():
        table.add_row(name, f"{value.deviation:.6g}", f"{value.std_error:.2g}")
    out.print(table)
    out.print(f"condition number {ident.condition_number:.3g}, O1 {ident.o1:.3g}, O3 {ident.o3:.3g}, "
              f"noise amplification {ident.noise_amplification:.3g}")
    for name, reason in ident.fixed.items():
        out.print(f"fixed {name}: {reason}")
    for a, b, r in calibration.correlated_pairs:
        out.print(f"strongly correlated: {a} and {b} ({r:+.3f})")
    if calibration.outlier_rows:
        out.print(f"down-weighted as outliers: rows {', '.join(map(str, calibration.outlier_rows))}")


def _floats(text, count, name):
    """``count`` comma-separated numbers (any number of them when count is 0)."""
    if text is None:
        return None
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        how_many = f"{count} " if count else ""
        raise InputError(f"{name} must be {how_many}comma-separated numbers, got {text!r}") from None
    if count and len(values) != count:
        raise InputError(f"{name} must be {count} comma-separated numbers, got {len(values)}")
    return values


@app.command()
@user_errors
def simulate(
    robot: str = typer.Argument(..., help="Built-in name or robot file."),
    out_file: str = typer.Option(..., "--out", help="Measurement CSV to write."),
    n: int = typer.Option(None, "--n", help="Number of poses (default 200; liu2022: 150)."),
    sampling: str = typer.Option("joint", help="joint (uniform in the limits), lhs (Latin hypercube in --box), grid (n^(1/3) per axis in --box) or sockets (ball in the sockets of --fixture, joint angles only)."),
    errors: str = typer.Option("typical", help="none, typical, liu2022 (KR150-2 only), or a truth file (JSON, as --truth writes it) whose deviations you edit, e.g. joint gains in ppm."),
    noise: float = typer.Option(None, help="Measurement noise sigma in mm (overrides the preset); sockets: the ball's seating error."),
    seed: int = typer.Option(0, help="Random seed."),
    truth: str = typer.Option(None, help="Also write the hidden truth (JSON) here."),
    orientation: bool = typer.Option(False, "--orientation", help="Also write measured rx, ry, rz."),
    box: str = typer.Option(None, help="lhs box: xmin,xmax,ymin,ymax,zmin,zmax in mm."),
    rpy: str = typer.Option(None, help="lhs tool orientation rx,ry,rz in deg (default 180,0,0)."),
    hint: str = typer.Option(None, help="lhs posture hint q1,...,qn in deg (picks the IK branch)."),
    fixture: str = typer.Option(None, help="sockets: fixture TOML (socket centres, mm)."),
    placements: int = typer.Option(4, help="sockets: number of fixture placements."),
    per_socket: int = typer.Option(10, "--per-socket", help="sockets: configurations per socket and placement."),
    joint_noise: float = typer.Option(0.0, "--joint-noise", help="sockets: noise of the joint readings (deg)."),
    tip: str = typer.Option(None, help="URDF only: the tip link."),
    root: str = typer.Option(None, help="URDF only: the root link."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Measure a simulated robot with known errors and write a measurement CSV.

    Example: robocal simulate kr150-2 --errors liu2022 --sampling lhs --out meas.csv

    Ball in sockets: robocal simulate kr150-2 --sampling sockets --fixture fix.toml --placements 6 --per-socket 20 --out sockets.csv
    """
    result = simulate_job(robot, out_file, n=n, sampling=sampling, errors=errors, noise=noise, seed=seed,
                          truth=truth, orientation=orientation, box=_floats(box, 6, "--box"),
                          rpy=_floats(rpy, 3, "--rpy"), hint=_floats(hint, 0, "--hint"), root=root, tip=tip,
                          fixture=fixture, placements=placements, per_socket=per_socket, joint_noise=joint_noise)
    _print_result(result, as_json, f"simulated {result['poses']} poses -> {out_file}")


def _method_settings(method, *, seed=None, nugget=None, hidden=None, shared_theta=False, **given):
    """The settings a user gave on the command line, as the method's keywords (an option left
    at None was not given; the method refuses those it does not take)."""
    settings = {name: value for name, value in given.items() if value is not None}
    if nugget is not None:
        settings["nugget"] = nugget if nugget == "estimate" else _floats(nugget, 1, "--nugget")[0]
    if hidden is not None:
        settings["hidden"] = tuple(int(w) for w in _floats(hidden, 0, "--hidden"))
    if shared_theta:
        settings["shared_theta"] = True
    if seed is not None:
        settings["random_state"] = seed
    return settings


METHOD_HELP = f"One of {', '.join(method_names())}; 'robocal methods' describes them and lists their options."
SEED_HELP = "Seed of the Kriging multi-start search and of the network's training (kriging, hybrid, ann)."


@app.command()
@user_errors
def methods():
    """List the calibration and compensation methods and the options each takes.

    Example: robocal methods
    """
    table = Table("method", "description", "options")
    for name in method_names():
        method = get_method(name)
        table.add_row(name, method.description, ", ".join(s.option for s in method.settings) or "-")
    out.print(table)


@app.command()
@user_errors
def calibrate(
    robot: str = typer.Argument(..., help="Built-in name, robot .toml or .urdf file."),
    measurements: str = typer.Argument(..., help="Measurement CSV (q1..qN, x, y, z, ...)."),
    out_file: str = typer.Option(..., "--out", help="Model file (JSON) to write."),
    method: str = typer.Option(DEFAULT_METHOD, help=METHOD_HELP),
    register: str = typer.Option(None, help="Register base and tool first: auto (default), yes or no."),
    trend: str = typer.Option(None, help="kriging/hybrid: trend, constant (default), linear or quadratic."),
    correlation: str = typer.Option(None, help="kriging/hybrid: correlation, gaussian (default) or matern52."),
    nugget: str = typer.Option(None, help="kriging/hybrid: nugget, 'estimate' (default) or a number."),
    shared_theta: bool = typer.Option(False, "--shared-theta", help="kriging/hybrid: one theta for the three outputs."),
    parameters: str = typer.Option(None, help="kinematic/hybrid/constraint (ann with --base-model kinematic): parameter set, offsets, full (default), full+gains (plus a scale error of each joint reading), full+compliance (plus the stiffness of every joint gravity loads) or full+compliance+gains."),
    loss: str = typer.Option(None, help="kinematic/hybrid: linear (default), huber or soft_l1 (robust)."),
    payload: float = typer.Option(None, help="full+compliance: mass at the TCP in kg (default: 0 if the robot file gives link masses, else the rated payload of a robot of that size)."),
    seed: int = typer.Option(None, help=SEED_HELP + " Default 0."),
    hidden: str = typer.Option(None, help="ann: hidden layer widths, at least two (default 16,16)."),
    generations: int = typer.Option(None, help="ann: generation limit of the genetic algorithm (default 300)."),
    trainer: str = typer.Option(None, help="ann: ga (genetic algorithm, default) or lbfgs (gradient from random starts)."),
    refine: str = typer.Option(None, help="ann: refine the GA's best network by lbfgs (default), or none."),
    base_model: str = typer.Option(None, "--base-model", help="ann: the network learns the error of the nominal robot (default) or of the kinematic calibration."),
    fixture: str = typer.Option(None, help="Fixture TOML (constraint method)."),
    pairs: str = typer.Option(None, help="constraint: all pairs of configurations (default), or spanning (fewer, faster)."),
    tip: str = typer.Option(None, help="URDF only: the tip link."),
    root: str = typer.Option(None, help="URDF only: the root link."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Fit a calibration / error model to measurements and save it as a model file.

    Options that do not apply to the chosen method are refused ('robocal methods' lists
    which method takes which).

    Example: robocal calibrate ur5 meas.csv --method kinematic --out model.json
    """
    from .progress import progress

    fitter = make_method(method, **_method_settings(
        method, seed=seed, nugget=nugget, hidden=hidden, shared_theta=shared_theta, register=register, trend=trend,
        correlation=correlation, parameters=parameters, loss=loss, payload=payload, generations=generations,
        trainer=trainer, refine=refine, base_model=base_model, pairs=pairs))
    label = fitter.progress_label if fitter.progress_total() else f"fitting the {method} model"
    with progress(label, fitter.progress_total(), enabled=not as_json) as advance:
        result = calibrate_job(robot, measurements, out_file, method=fitter, fixture=fixture, progress=advance,
                               root=root, tip=tip)
    if not as_json and result.record.calibration is not None:
        _print_calibration(result.record.calibration)
    _print_result(result.to_dict(), as_json, f"{method} model -> {out_file}")


@app.command()
@user_errors
def evaluate(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    measurements: str = typer.Argument(..., help="Measurement CSV (use poses the model was not trained on)."),
    fixture: str = typer.Option(None, help="Ball-in-socket data: the fixture TOML (default: the one the model stores)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Residual of a model on measured data, beside the nominal robot's.

    On ball-in-socket data: the socket consistency (distance of each ball centre from the
    mean of its socket group) and the socket-distance error.

    Example: robocal evaluate model.json test.csv --json
    """
    result = evaluate_job(model, measurements, fixture=fixture)
    _print_result(result, as_json, f"{result['method']} model on {measurements}")


@app.command()
@user_errors
def compensate(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    targets: str = typer.Argument(..., help="Targets CSV: x, y, z, rx, ry, rz (+ optional q1..qN hint)."),
    out_file: str = typer.Option(..., "--out", help="Commands CSV to write."),
    iterate: bool = typer.Option(False, "--iterate", help="Solve c = P - e(c) to a fixed point."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Joint commands and corrected Cartesian targets that make the real robot hit the targets.

    Targets are in the measurement frame (the frame of the data the model was fitted to).
    In the commands file, q1..qN are the joint commands; x, y, z, rx, ry, rz are the target
    to send instead to a controller that keeps its nominal model: its forward kinematics of
    those joints, in the robot's base frame with the tool of the robot file (a base and tool
    registered to the data are part of the calibrated model, not of these columns).

    Example: robocal compensate model.json targets.csv --out commands.csv
    """
    result = compensate_job(model, targets, out_file, iterate=iterate)
    if result["unreachable_rows"]:
        rows = ", ".join(str(r) for r in result["unreachable_rows"][:10])
        more = " ..." if len(result["unreachable_rows"]) > 10 else ""
        _say("warning", "yellow", f"{len(result['unreachable_rows'])} target(s) cannot be reached "
                  f"(rows {rows}{more}): their joint cells are empty and reachable = 0")
    _print_result(result, as_json, f"commands -> {out_file}")


@app.command()
@user_errors
def report(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    measurements: str = typer.Argument(..., help="Measurement CSV to score (held-out poses, ideally)."),
    out_file: str = typer.Option(..., "--out", help="HTML report to write (one self-contained file)."),
    pdf: str = typer.Option(None, "--pdf", help="Also write the tables and figures as a PDF."),
    validation: str = typer.Option(None, "--validation",
                                   help="JSON of 'robocal validate --json': adds cross-validation and the learning curve."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Accuracy report in one HTML file that opens offline: data, parameters, errors, plots.

    For a customer or a file: the data summary, the identified parameters with their standard
    errors and what could not be identified, the error before and after (mean, RMS, max, 95 %,
    per axis, ISO 9283-style AP/RP), and plots of where the error is.

    Example: robocal report model.json test.csv --out report.html
    """
    from .report import report_job

    result = report_job(model, measurements, out_file, validation=validation, pdf=pdf)
    _print_result(result, as_json, f"report -> {out_file}")


@app.command()
@user_errors
def export(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    fmt: str = typer.Option("toml", "--format", help="toml (robot file) or urdf."),
    out_file: str = typer.Option(..., "--out", help="Robot file to write."),
    convention: str = typer.Option(None, help="Convert first, exactly: dh, mdh or poe (default: as calibrated)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Calibrated kinematics as a robot TOML or URDF (direct compensation, or ROS).

    For a controller that accepts new parameters, or a simulator; the base is the measurement
    frame -> robot base the calibration found.

    Example: robocal export model.json --format urdf --out calibrated.urdf
    """
    result = export_job(model, out_file, fmt=fmt, convention=convention)
    for what in result["left_out"]:
        _say("note", "yellow", f"left out of the {result['format'].upper()} file: {what}")
    _print_result(result, as_json, f"{result['convention']} robot -> {out_file}")


@app.command()
@user_errors
def validate(
    robot: str = typer.Argument(..., help="Built-in name, robot .toml or .urdf file."),
    measurements: str = typer.Argument(..., help="Measurement CSV (q1..qN, x, y, z, ...)."),
    method: str = typer.Option(DEFAULT_METHOD, help=METHOD_HELP + " Ball-in-socket data (constraint) are validated one fixture placement left out at a time."),
    folds: int = typer.Option(5, help="Number of cross-validation folds."),
    sizes: str = typer.Option(None, help="Learning curve: training sizes, e.g. 20,50,100,200."),
    seed: int = typer.Option(0, help="Seed of the fold assignment, and of the method's random search where it has one."),
    register: str = typer.Option(None, help="Register base and tool first: auto (default), yes or no."),
    parameters: str = typer.Option(None, help="kinematic/hybrid/constraint: parameter set, offsets, full (default), full+gains (plus a scale error of each joint reading), full+compliance (plus the stiffness of every joint gravity loads) or full+compliance+gains."),
    loss: str = typer.Option(None, help="kinematic/hybrid: linear (default), huber or soft_l1."),
    fixture: str = typer.Option(None, help="constraint: the fixture TOML."),
    pairs: str = typer.Option(None, help="constraint: all pairs (default) or spanning."),
    payload: float = typer.Option(None, help="full+compliance: mass at the TCP in kg."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Held-out accuracy of a method: k-fold cross-validation and an optional learning curve.

    Every pose is predicted by a model that did not see it; the nominal robot, registered on
    the same folds, is the baseline.

    Example: robocal validate ur5 meas.csv --method kinematic --folds 5 --sizes 20,50,100,200
    """
    from .progress import progress

    takes_seed = any(s.name == "random_state" for s in get_method(method).settings)
    settings = _method_settings(method, seed=seed if takes_seed else None, register=register,
                                parameters=parameters, loss=loss, payload=payload, pairs=pairs)
    size_list = None if sizes is None else [int(v) for v in _floats(sizes, 0, "--sizes")]
    by_placement = get_method(method).data_kind == "sockets"
    # Each fold fits the method and the registered nominal; each size of the curve 3 times.
    fits = None if by_placement else 2 * folds + 3 * len(size_list or [])
    with progress("fitting", fits, enabled=not as_json) as advance:
        result = validate_job(robot, measurements, method=method, settings=settings, folds=folds, sizes=size_list,
                              seed=seed, fixture=fixture, on_fit=advance)
    if as_json:
        print(json.dumps(result, indent=2))
        return
    kind = ("leave-one-placement-out socket consistency" if by_placement
            else f"{result['folds']}-fold cross-validation")
    table = Table(title=f"{method}, {kind} on {result['poses']} poses (mm)")
    for col in ("model", "mean", "RMS", "max"):
        table.add_column(col, justify="right")
    nominal = "nominal" if by_placement else "nominal, registered"
    for label, key in ((method, "cross_validation"), (nominal, "nominal_cross_validation")):
        stats = result[key].get("pooled", result[key])
        table.add_row(label, f"{stats['mean_mm']:.4f}", f"{stats['rms_mm']:.4f}", f"{stats['max_mm']:.4f}")
    out.print(table)
    if "learning_curve" in result:
        curve = Table(title="learning curve: held-out error against training poses (mm)")
        for col in ("training poses", "mean", "RMS", "max"):
            curve.add_column(col, justify="right")
        for point in result["learning_curve"]:
            stats = point["held_out"]
            curve.add_row(str(point["n_train"]), f"{stats['mean_mm']:.4f}", f"{stats['rms_mm']:.4f}",
                          f"{stats['max_mm']:.4f}")
        out.print(curve)


@app.command()
@user_errors
def dataset(
    name: str = typer.Argument(..., help="ur5-tsinghua, ipa-ur10-a, ipa-ur10-b (laser tracker) or mukca-panda-1/2/3 "
                                         "(ball in sockets; split by fixture placement)."),
    prefix: str = typer.Option(..., "--out", help="Prefix of the files to write (PREFIX.toml, PREFIX*.csv)."),
    split: float = typer.Option(None, help="Training fraction of a random train/test split, e.g. 0.5."),
    seed: int = typer.Option(0, help="Seed of the split."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Export a real dataset shipped with robocal as a robot file and measurement CSVs.

    Example: robocal dataset ur5-tsinghua --out ur5 --split 0.5
    """
    result = dataset_job(name, prefix, split=split, seed=seed)
    _print_result(result, as_json, f"dataset {name}")


@app.command()
@user_errors
def demo(as_json: bool = typer.Option(False, "--json", help="Print one JSON object instead of tables.")):
    """Run the reference Kriging experiment on built-in data and print what it measured.

    KUKA KR 150-2 with the liu2022 geometric errors: 50 Latin-hypercube points train a Kriging
    model of the position error, 100 held-out targets are compensated and measured, beside
    the published figures (Liu et al. 2022: 1.68 mm before, 0.0018 mm mean / 0.0084 mm max after).

    Example: robocal demo --json
    """
    from .demo import demo_tables, run_demo

    result = run_demo()
    if as_json:
        print(json.dumps(result, indent=2))
    else:
        for renderable in demo_tables(result):
            out.print(renderable)


def main():
    """Console entry point."""
    warnings.showwarning = _show_warning
    np.seterr(all="ignore")  # NaNs are checked explicitly where they matter
    try:
        app()
    except KeyboardInterrupt:
        err.print("interrupted")
        sys.exit(130)


if __name__ == "__main__":
    main()
