"""The ``robocal`` command line.

Every error a user can cause is a :class:`~robocal.errors.RobocalError`; it is printed as one
line and the command exits with status 2.  ``--debug`` (before or after the command) shows the
traceback instead.  A value the command line itself refuses (a wrong choice, a bad number, a
missing argument) is also one line and status 2.  Ctrl-C and SIGTERM stop a command cleanly
(no half-written file, see :mod:`robocal.io.atomic`), print one line and exit with status 130
and 143.
"""
import contextlib
import functools
import inspect
import json
import math
import os
import re
import signal
import sys
import warnings
from pathlib import Path

import numpy as np
import typer
from rich.console import Console
from rich.table import Table
from rich.text import Text
from typer.core import TyperCommand, TyperGroup

from .. import __version__, parallel
from ..errors import InputError, RobocalError, RobocalWarning
from ..estimation.calibration import LOSSES, PARAMETER_SETS
from ..estimation.constraint import PAIRINGS
from ..estimation.kriging import APPROXIMATIONS, AUTO_VECCHIA_ABOVE, CORRELATIONS, REGRESSIONS
from ..kinematics.chain import CONVENTIONS
from ..methods import DEFAULT_METHOD, get_method, make_method, method_names
from ..methods.ann import BASE_MODELS, REFINERS, TRAINERS
from ..methods.base import ERROR_MODEL_INPUTS, REGISTER_CHOICES, option_of
from ..methods.reregistration import PARAMETER_CHOICES as FRAME_PARAMETERS
from .jobs import (AUTO, DATASETS, EXPORT_FORMATS, FRAMES, SAMPLINGS, calibrate_job, compare_job, reregister_job, compensate_job, dataset_job, evaluate_job, export_job,
                   simulate_job, validate_job)
from .filter import filter_job

# The sampling plans simulate_job draws (it owns no list of them to import).

# typer.BadParameter is click's; its bases are the errors click raises while parsing.
UsageError = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")


def _plain_flags(params):
    """Show on/off options as flags (``--json``), not with a value type (``--json <bool>``)."""
    for param in params:
        if getattr(param, "is_flag", False) and getattr(param, "metavar", None) is None:
            param.metavar = ""
    return params


class _Command(TyperCommand):
    def get_params(self, ctx):
        return _plain_flags(super().get_params(ctx))


class _App(TyperGroup):
    """The ``robocal`` group: usage errors (a wrong choice, a missing argument) are one line."""

    def get_params(self, ctx):
        return _plain_flags(super().get_params(ctx))

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except UsageError as exc:
            if not standalone_mode:
                raise
            _usage_error(exc)
            sys.exit(exc.exit_code)
        except typer.Abort:
            if not standalone_mode:
                raise
            err.print("aborted")
            sys.exit(1)
        if not standalone_mode:
            return code
        sys.exit(code if isinstance(code, int) else 0)


def _usage_error(exc):
    """One line: the option or argument, what it must be; other usage errors add the usage."""
    if type(exc).__name__ == "NoArgsIsHelpError":  # the help has been shown
        return
    param = getattr(exc, "param", None)
    if isinstance(exc, _Refused) and param is not None:
        _say("error", "red", f"{_param_label(param)} {exc.message}")
        return
    if isinstance(exc, typer.BadParameter) and param is not None and type(exc) is typer.BadParameter:
        message = exc.message[:1].lower() + exc.message[1:]
        _say("error", "red", f"{_param_label(param)}: {message.rstrip('.')}")
        return
    message = exc.format_message()
    _say("error", "red", message[:1].lower() + message[1:].rstrip("."))
    ctx = getattr(exc, "ctx", None)
    if ctx is not None:
        err.print(f"{ctx.get_usage()}  (see '{ctx.command_path} --help')")


def _param_label(param):
    """How the user wrote it: the long option, or the argument's name."""
    names = [opt for opt in param.opts if opt.startswith("--")] or list(param.opts)
    if getattr(param, "param_type_name", "") == "option" and names:
        return names[0]
    return param.name or "the value"


app = typer.Typer(
    cls=_App,
    help="robocal: calibrate industrial robots and compensate their positioning errors.\n\n"
         "Try: robocal demo; robocal calibrate ur5 meas.csv --out model.json; "
         "robocal report model.json test.csv --out report.html",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="markdown",  # reflow docstring paragraphs in --help
)
command = functools.partial(app.command, cls=_Command)
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


# --------------------------------------------------------------------------- option values
class _Refused(typer.BadParameter):
    """A value the command line refuses; the message follows the option's name."""


def _choice(choices, *, or_file=None):
    """Parser and help of an option that takes one of ``choices`` (or, with ``or_file``, the
    name of a file ending so).  None (the option not given) passes untouched."""
    choices = tuple(choices)

    def parse(value):
        if value in choices or (or_file and str(value).endswith(or_file)):
            return value
        alternative = f", or a {or_file} file" if or_file else ""
        raise _Refused(f"must be one of {', '.join(choices)}{alternative}: {value!r} is not available")

    metavar = "|".join(choices) + (f"|FILE{or_file}" if or_file else "")
    return {"parser": parse, "metavar": f"<{metavar}>"}


# A whole number beyond this is a typo (a count, a size, a seed), and beyond 64 bits it would
# reach NumPy as an object it cannot take.
LARGEST_WHOLE = 10**9
# simulate --n: beyond this a file is no measurement series anyone makes, and the run would
# take minutes and gigabytes.
MOST_SIMULATED_POSES = 1_000_000
# simulate --noise: an instrument this noisy (a metre) measures nothing about a robot.
LARGEST_NOISE_MM = 1000


def _number(*, whole=False, at_least=None, between=None, at_most=None):
    """Parser of a number option: a whole number, ``>= at_least``, ``<= at_most`` (whole
    numbers: LARGEST_WHOLE unless told), or strictly ``between``."""
    kind = "a whole number" if whole else "a number"
    if whole and at_most is None:
        at_most = LARGEST_WHOLE
    if at_least is not None:
        kind += f" >= {at_least}"
    if between is not None:
        kind += f" between {between[0]} and {between[1]} (exclusive)"

    def parse(value):
        text = str(value).strip()
        try:
            number = int(text) if whole else float(text)
        except ValueError:
            raise _Refused(f"must be {kind}, got {value!r}") from None
        if at_most is not None and number > at_most:
            raise _Refused(f"must be {kind} and <= {at_most:,}, got {value!r}")
        if (not math.isfinite(number) or (at_least is not None and number < at_least)
                or (between is not None and not between[0] < number < between[1])):
            raise _Refused(f"must be {kind}, got {value!r}")
        return number

    return {"parser": parse, "metavar": "<int>" if whole else "<float>"}


def _numbers(*, count=0, whole=False, at_least=None, at_least_count=0, example=""):
    """Parser of comma-separated numbers: ``count`` of them (any number when 0)."""
    what = ("whole numbers" if whole else "numbers") + (f" >= {at_least}" if at_least is not None else "")
    how_many = f"{count} comma-separated {what}" if count else (
        f"at least {at_least_count} comma-separated {what}" if at_least_count else f"comma-separated {what}")
    hint = f", e.g. {example}" if example else ""

    def parse(value):
        if not isinstance(value, str):
            return value
        try:
            values = [(int if whole else float)(v.strip()) for v in value.split(",")]
        except ValueError:
            raise _Refused(f"must be {how_many}{hint}, got {value!r}") from None
        if whole and max(values, default=0) > LARGEST_WHOLE:
            raise _Refused(f"must be {how_many} <= {LARGEST_WHOLE:,}{hint}, got {value!r}")
        if ((count and len(values) != count) or len(values) < at_least_count
                or not all(math.isfinite(v) and (at_least is None or v >= at_least) for v in values)):
            raise _Refused(f"must be {how_many}{hint}, got {value!r}")
        return values

    return {"parser": parse, "metavar": "<" + ",".join(["x"] * count) + ">" if count else "<x,y,...>"}


# Files robocal writes, by suffix: an --out whose suffix names another of them would hold
# something else than its name says (calibrate --out m.csv would write JSON).
OUTPUT_KINDS = {".json": "JSON", ".csv": "CSV", ".toml": "robot TOML", ".urdf": "URDF", ".html": "HTML",
                ".pdf": "PDF"}


def _output(suffix):
    """Parser of an output path: refuses a name whose suffix is another kind robocal writes."""

    def parse(value):
        given = Path(str(value)).suffix.lower()
        if given in OUTPUT_KINDS and given != suffix:
            name = Path(str(value))
            raise _Refused(f"writes {OUTPUT_KINDS[suffix]}, but {value!r} names a {OUTPUT_KINDS[given]} file: "
                           f"name it {name.with_suffix(suffix)}")
        return value

    return {"parser": parse, "metavar": f"<FILE{suffix}>"}


def _prefix(value):
    """--out of dataset: a prefix, to which robocal adds .toml, .csv, _train.csv ..."""
    given = Path(str(value)).suffix.lower()
    if given in OUTPUT_KINDS:
        raise _Refused(f"is a prefix (PREFIX.toml and PREFIX.csv are written): give "
                       f"{str(Path(str(value)).with_suffix(''))!r}, not {value!r}")
    return value


def _nugget(value):
    if value == "estimate":
        return value
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = -1.0
    if not (math.isfinite(number) and number >= 0):
        raise _Refused(f"must be 'estimate' or a number >= 0, got {value!r}")
    return number


def _errors_preset(value):
    """--errors: a preset of robocal.simulation, or a truth file (JSON)."""
    from ..simulation.presets import PRESETS

    return _choice(PRESETS, or_file=".json")["parser"](value)


@contextlib.contextmanager
def _options_named(names):
    """Re-raise an InputError that names a setting by its keyword (``k = 9 folds ...``, from
    code that knows no command line) with the option the user typed (``--folds 9 ...``)."""
    try:
        yield
    except InputError as exc:
        message = str(exc)
        for keyword, option in names.items():
            message = re.sub(rf"(?<![\w-]){re.escape(keyword)} (= )?(?=<=|>=|must|\d)", f"{option} ", message)
        if message == str(exc):
            raise
        raise InputError(message) from None


# --------------------------------------------------------------------------- errors and interruptions
DEBUG_OPTION = typer.Option(False, "--debug", help="Show tracebacks of errors.")


def user_errors(func):
    """Turn RobocalError (and a system's refusal of a file) into one line on stderr and exit
    status 2; add ``--debug`` to the command (it is also accepted before the command)."""

    @functools.wraps(func)
    def wrapper(*args, debug=False, **kwargs):
        if debug:
            _state["debug"] = True
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

    signature = inspect.signature(func)
    debug = inspect.Parameter("debug", inspect.Parameter.KEYWORD_ONLY, default=DEBUG_OPTION, annotation=bool)
    wrapper.__signature__ = signature.replace(parameters=[*signature.parameters.values(), debug])
    wrapper.__annotations__ = {**func.__annotations__, "debug": bool}
    return wrapper


class Interrupted(SystemExit):
    """SIGINT (Ctrl-C) or SIGTERM: raised in the running code so that it unwinds like any
    error (an atomic write removes its temporary file); exit status 128 + the signal."""

    def __init__(self, signum):
        super().__init__(128 + signum)
        self.signum = signum


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


@contextlib.contextmanager
def interruptible():
    """Run the body with SIGINT and SIGTERM turned into :class:`Interrupted`; on one, print
    one line (which file was left as it was) and exit with status 130 (SIGINT) / 143 (SIGTERM)."""
    # A signal the parent ignores (Ctrl-C for a background job of a script) stays ignored.
    signals = [s for s in (signal.SIGINT, signal.SIGTERM) if signal.getsignal(s) is not signal.SIG_IGN]
    previous = {s: signal.signal(s, _raise_interrupted) for s in signals}
    try:
        yield
    except (Interrupted, KeyboardInterrupt) as exc:
        for s in signals:  # a second signal while reporting the first just ends the process
            signal.signal(s, signal.SIG_DFL)
        unwritten = getattr(exc, "unwritten_file", None)
        if unwritten is None:
            err.print("interrupted")
        elif unwritten.exists():
            _say("interrupted", "yellow", f"{unwritten} was left as it was")
        else:
            _say("interrupted", "yellow", f"nothing was written to {unwritten}")
        sys.exit(exc.code if isinstance(exc, Interrupted) else 128 + signal.SIGINT)
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _print_version(value: bool):
    if value:
        out.print(f"robocal {__version__}")
        raise typer.Exit()


@app.callback()
def _main(debug: bool = typer.Option(False, "--debug", help="Show tracebacks of errors."),
          version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                       help="Print the version and exit.")):
    _state["debug"] = debug


@command()
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


@command()
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
        table.add_row(key.replace("_", " "), _cell(value))
    out.print(table)


def _cell(value):
    """A value as a person reads it: statistics in a sentence, lists joined, no Python reprs."""
    if isinstance(value, dict) and "nominal_mean_mm" in value:
        return (f"mean {value['mean_mm']:.4f} mm, 95 % {value['p95_mm']:.4f} mm over {value['where']} "
                f"(registered nominal robot: mean {value['nominal_mean_mm']:.4f} mm, 95 % "
                f"{value['nominal_p95_mm']:.4f} mm)")
    if isinstance(value, dict):
        if not value.get("n"):
            return "none"
        return (f"mean {value['mean_mm']:.4f} mm, RMS {value['rms_mm']:.4f} mm, "
                f"max {value['max_mm']:.4f} mm (n = {value['n']})")
    if isinstance(value, float):
        return f"{value:.4f}"
    if isinstance(value, (list, tuple)):
        return ", ".join(map(str, value)) or "none"
    return "-" if value is None else str(value)


def _print_calibration(calibration, chain):
    """Identified parameters with standard errors and units, and what could not be identified
    (a :class:`~robocal.methods.CalibrationRecord`; ``chain``, the calibrated model, names the
    units)."""
    from .tables import parameter_notes, parameter_rows

    ident = calibration.identifiability
    table = Table(title=f"identified parameters ({ident.rank})")
    rows = parameter_rows(calibration, chain)
    columns = ("parameter", "deviation", "std. error", "unit", "prior", "from data")
    for col in columns[:max((len(row) for row in rows), default=4)]:
        table.add_column(col, justify="right")
    for row in rows:
        table.add_row(*row)
    out.print(table)
    for note in parameter_notes(calibration, chain):
        out.print(f"{note}.")
    out.print(f"condition number {ident.condition_number:.3g}, O1 {ident.o1:.3g}, O3 {ident.o3:.3g}, "
              f"noise amplification {ident.noise_amplification:.3g}")
    for name, reason in ident.fixed.items():
        out.print(f"fixed {name}: {reason}")
    for a, b, r in calibration.correlated_pairs:
        out.print(f"strongly correlated: {a} and {b} ({r:+.3f})")
    if calibration.outlier_rows:
        out.print(f"down-weighted as outliers: rows {', '.join(map(str, calibration.outlier_rows))}")


@command()
@user_errors
def simulate(
    robot: str = typer.Argument(..., help="Built-in name or robot file."),
    out_file: str = typer.Option(..., "--out", help="Measurement CSV to write.", **_output(".csv")),
    n: int = typer.Option(None, "--n", help="Number of poses (default 200; liu2022: 150).", **_number(whole=True, at_least=1, at_most=MOST_SIMULATED_POSES)),
    sampling: str = typer.Option("joint", help="joint (uniform in the limits), lhs (Latin hypercube in --box), grid (n^(1/3) per axis in --box) or sockets (ball in the sockets of --fixture, joint angles only).", **_choice(SAMPLINGS)),
    errors: str = typer.Option("typical", parser=_errors_preset, help="none, typical, liu2022 (KR150-2 only), or a truth file (JSON, as --truth writes it) whose deviations you edit, e.g. joint gains in ppm."),
    noise: float = typer.Option(None, help="Measurement noise sigma in mm (overrides the preset); sockets: the ball's seating error.", **_number(at_least=0, at_most=LARGEST_NOISE_MM)),
    seed: int = typer.Option(0, help="Random seed.", **_number(whole=True, at_least=0)),
    truth: str = typer.Option(None, help="Also write the hidden truth (JSON) here.", **_output(".json")),
    orientation: bool = typer.Option(False, "--orientation", help="Also write measured rx, ry, rz."),
    box: str = typer.Option(None, help="lhs box: xmin,xmax,ymin,ymax,zmin,zmax in mm.", **_numbers(count=6)),
    rpy: str = typer.Option(None, help="lhs tool orientation rx,ry,rz in deg (default 180,0,0).", **_numbers(count=3)),
    hint: str = typer.Option(None, help="lhs posture hint q1,...,qn in deg (picks the IK branch).", **_numbers()),
    fixture: str = typer.Option(None, help="sockets: fixture TOML (socket centres, mm)."),
    placements: int = typer.Option(None, help="sockets: number of fixture placements (default 4).", **_number(whole=True, at_least=1)),
    per_socket: int = typer.Option(None, "--per-socket", help="sockets: configurations per socket and placement (default 10).", **_number(whole=True, at_least=2)),
    joint_noise: float = typer.Option(None, "--joint-noise", help="sockets: noise of the joint readings (deg, default 0).", **_number(at_least=0)),
    tip: str = typer.Option(None, help="URDF only: the tip link."),
    root: str = typer.Option(None, help="URDF only: the root link."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Measure a simulated robot with known errors and write a measurement CSV.

    Example: robocal simulate kr150-2 --errors liu2022 --sampling lhs --out meas.csv

    Ball in sockets: robocal simulate kr150-2 --sampling sockets --fixture fix.toml --placements 6 --per-socket 20 --out sockets.csv
    """
    result = simulate_job(robot, out_file, n=n, sampling=sampling, errors=errors, noise=noise, seed=seed,
                          truth=truth, orientation=orientation, box=box, rpy=rpy, hint=hint, root=root, tip=tip,
                          fixture=fixture, placements=placements, per_socket=per_socket, joint_noise=joint_noise)
    _print_result(result, as_json, f"simulated {result['poses']} poses -> {out_file}")


def _method_settings(method, *, seed=None, nugget=None, hidden=None, shared_theta=False, **given):
    """The settings a user gave on the command line, as the method's keywords (an option left
    at None was not given; the method refuses those it does not take)."""
    settings = {name: value for name, value in given.items() if value is not None}
    if nugget is not None:
        settings["nugget"] = nugget
    if hidden is not None:
        settings["hidden"] = tuple(hidden)
    if shared_theta:
        settings["shared_theta"] = True
    if seed is not None:
        settings["random_state"] = seed
    return settings


METHOD_HELP = "The method; 'robocal methods' describes them and lists their options."
BEYOND_LIMITS_HELP = "Accept joint values beyond the robot's limits (by more than 0.5 deg) instead of refusing those rows."
JOBS_HELP = ("Run the independent fits (the folds) on a local Dask cluster of this many workers, "
             "listening on 127.0.0.1 (needs pip install 'robocal[fleet]'); default: one after the other here.")
SCHEDULER_HELP = ("Run the independent fits on the workers of a running Dask scheduler instead (they must run this "
                  "robocal version).")
SEED_HELP = "Seed of the Kriging multi-start search and of the network's training (kriging, hybrid, ann)."


@command()
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


@command()
@user_errors
def calibrate(
    robot: str = typer.Argument(..., help="Built-in name, robot .toml or .urdf file (--method frames: a model file)."),
    measurements: str = typer.Argument(..., help="Measurement CSV (q1..qN, x, y, z, ...)."),
    out_file: str = typer.Option(..., "--out", help="Model file (JSON) to write.", **_output(".json")),
    method: str = typer.Option(DEFAULT_METHOD, help=METHOD_HELP + " auto: the model 'robocal compare' recommends, with the comparison kept in the model file. frames: ROBOT is a model file, re-registered on a new set-up (base and tool; --parameters frames+offsets adds the joint offsets).", **_choice(method_names() + (AUTO, FRAMES))),
    register: str = typer.Option(None, help="Register base and tool first (default auto: when the data are not in the robot base frame).", **_choice(REGISTER_CHOICES)),
    trend: str = typer.Option(None, help="kriging/hybrid: the trend (default constant).", **_choice(REGRESSIONS)),
    correlation: str = typer.Option(None, help="kriging/hybrid: the correlation function (default gaussian).", **_choice(CORRELATIONS)),
    nugget: str = typer.Option(None, parser=_nugget, metavar="<estimate|float>", help="kriging/hybrid: nugget, 'estimate' (default) or a number >= 0."),
    shared_theta: bool = typer.Option(False, "--shared-theta", help="kriging/hybrid: one theta for the three outputs."),
    inputs: str = typer.Option(None, help="kriging/hybrid: what the error is modelled over: position (the TCP position, default), joints, or sincos (the sines and cosines of the joints).", **_choice(ERROR_MODEL_INPUTS)),
    kriging: str = typer.Option(None, help=f"kriging/hybrid: exact Kriging, or vecchia (its nearest-neighbour approximation, for large data); auto (default) is exact up to {AUTO_VECCHIA_ABOVE:,} training poses.", **_choice(APPROXIMATIONS)),
    parameters: str = typer.Option(None, help="kinematic/hybrid/constraint (ann with --base-model kinematic): parameter set, offsets, full (default), full+gains (plus a scale error of each joint reading), full+compliance (plus the stiffness of every joint gravity loads) or full+compliance+gains; frames: frames (default) or frames+offsets.", **_choice(PARAMETER_SETS + FRAME_PARAMETERS)),
    loss: str = typer.Option(None, help="kinematic/hybrid: the loss (default linear; the others are robust to outliers).", **_choice(LOSSES)),
    payload: float = typer.Option(None, help="full+compliance: mass at the TCP in kg (default: 0 if the robot file gives link masses, else the rated payload of a robot of that size).", **_number(at_least=0)),
    prior: str = typer.Option(None, help="kinematic/hybrid/constraint: tolerances (default: each parameter weighed against its manufacturing tolerance, maximum a posteriori; one the poses cannot pin stays near nominal) or none (plain least squares).", **_choice(("tolerances", "none"))),
    tolerance_scale: float = typer.Option(None, "--tolerance-scale", help="kinematic/hybrid/constraint: multiply every tolerance (the robot file's [tolerances] or the defaults) by this, for a robot known to lie further from its drawing.", **_number(between=(0, 1e6))),
    seed: int = typer.Option(None, help=SEED_HELP + " Default 0.", **_number(whole=True, at_least=0)),
    hidden: str = typer.Option(None, help="ann: hidden layer widths, at least two (default 16,16).", **_numbers(whole=True, at_least=1, at_least_count=2, example="16,16")),
    generations: int = typer.Option(None, help="ann: generation limit of the genetic algorithm (default 300).", **_number(whole=True, at_least=0)),
    trainer: str = typer.Option(None, help="ann: ga (genetic algorithm, default) or lbfgs (gradient from random starts).", **_choice(TRAINERS)),
    refine: str = typer.Option(None, help="ann: refine the GA's best network by lbfgs (default), or none.", **_choice(REFINERS)),
    base_model: str = typer.Option(None, "--base-model", help="ann: the network learns the error of the nominal robot (default) or of the kinematic calibration.", **_choice(BASE_MODELS)),
    fixture: str = typer.Option(None, help="Fixture TOML (constraint method)."),
    pairs: str = typer.Option(None, help="constraint: all pairs of configurations (default), or spanning (fewer, faster).", **_choice(PAIRINGS)),
    tip: str = typer.Option(None, help="URDF only: the tip link."),
    root: str = typer.Option(None, help="URDF only: the root link."),
    beyond_limits: bool = typer.Option(False, "--beyond-limits", help=BEYOND_LIMITS_HELP),
    accept_extrapolation: bool = typer.Option(False, "--accept-extrapolation", help="Keep a model predicted to miss by more than the registered nominal robot over the working range (poses that cover too little of it)."),
    jobs: int = typer.Option(None, help="kriging, hybrid, auto: " + JOBS_HELP.replace("the independent fits (the folds)", "the independent fits (each error component's likelihood search; auto's comparison)"), **_number(whole=True, at_least=1, at_most=1024)),
    scheduler: str = typer.Option(None, metavar="<tcp://HOST:PORT>", help="kriging, hybrid, auto: " + SCHEDULER_HELP),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Fit a calibration / error model to measurements and save it as a model file.

    Options that do not apply to the chosen method are refused ('robocal methods' lists
    which method takes which).

    Example: robocal calibrate ur5 meas.csv --method kinematic --out model.json
    """
    from .progress import progress

    settings = _method_settings(
        method, seed=seed, nugget=nugget, hidden=hidden, shared_theta=shared_theta, register=register, trend=trend,
        correlation=correlation, inputs=inputs, kriging=kriging, parameters=parameters, loss=loss, payload=payload,
        generations=generations, trainer=trainer, refine=refine, base_model=base_model, pairs=pairs, prior=prior,
        tolerance_scale=tolerance_scale)
    if method == FRAMES:
        return _reregister(robot, measurements, out_file, settings, beyond_limits, as_json, root=root, tip=tip,
                           fixture=fixture, accept_extrapolation=accept_extrapolation)
    if parameters in FRAME_PARAMETERS:
        raise InputError(f"--parameters {parameters} re-registers a model file: give --method frames and the model "
                         "file in place of the robot")
    if (jobs is not None or scheduler is not None) and method != AUTO and not get_method(method).spreads_work:
        given = "--jobs" if jobs is not None else "--scheduler"
        raise InputError(f"{given} spreads Kriging's likelihood searches and auto's comparison over workers: the "
                         f"{method} method has none; leave {given} out")
    if method == AUTO:
        fitter, label, total = AUTO, "comparing the methods, fit", None
    else:
        fitter = make_method(method, **settings)
        label = fitter.progress_label if fitter.progress_total() else f"fitting the {method} model"
        total = fitter.progress_total()
    with parallel.executor(jobs=jobs, scheduler=scheduler), progress(label, total, enabled=not as_json) as advance:
        result = calibrate_job(robot, measurements, out_file, method=fitter, settings=settings if method == AUTO else None,
                               fixture=fixture, progress=advance, beyond_limits=beyond_limits, root=root, tip=tip,
                               accept_extrapolation=accept_extrapolation)
    if method == AUTO and not as_json:
        _print_comparison(result.data["comparison"])
    if not as_json and result.record.calibration is not None:
        _print_calibration(result.record.calibration, result.kinematics)
    shown = {k: v for k, v in result.to_dict().items() if k != "comparison"}
    _print_result(result.to_dict() if as_json else shown, as_json, f"{result.method} model -> {out_file}")


def _without_domain(result):
    """The result without the domain's line, which :func:`_say_domain` prints below the table."""
    return {key: value for key, value in result.items() if key != "domain_summary"}


def _say_domain(result):
    """The domain of validity's one line: a warning when targets lie outside it."""
    summary = result.get("domain_summary")
    if summary:
        _say("warning" if result.get("outside_domain") else "note", "yellow", summary)


@command()
@user_errors
def evaluate(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    measurements: str = typer.Argument(..., help="Measurement CSV (use poses the model was not trained on)."),
    fixture: str = typer.Option(None, help="Ball-in-socket data: the fixture TOML (default: the one the model stores)."),
    beyond_limits: bool = typer.Option(False, "--beyond-limits", help=BEYOND_LIMITS_HELP),
    per_pose: str = typer.Option(None, "--per-pose", help="Write one CSV line per pose: row, measured and model "
                                 "x, y, z, error_mm, bound95_mm (the model's 95 % bound) and in_domain.",
                                 **_output(".csv")),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Residual of a model on measured data, beside the nominal robot's.

    On ball-in-socket data: the socket consistency (distance of each ball centre from the
    mean of its socket group) and the socket-distance error.  On position data, bound95
    says which share of the poses lie within the model's 95 % bound.

    Example: robocal evaluate model.json test.csv --json --per-pose poses.csv
    """
    result = evaluate_job(model, measurements, fixture=fixture, beyond_limits=beyond_limits, per_pose=per_pose)
    _print_result(result if as_json else _without_domain(result), as_json, f"{result['method']} model on {measurements}")
    if not as_json:
        _say_domain(result)
        bound = result.get("bound95")
        if bound:
            _say("note", "yellow", f"{bound['within_share']:.1%} of the {bound['poses']} poses lie within their 95 % "
                 f"bound (median bound {bound['median_bound_mm']:.4g} mm, median error {bound['median_error_mm']:.4g} mm)")


@command()
@user_errors
def compensate(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    targets: str = typer.Argument(..., help="Targets CSV: x, y, z, rx, ry, rz (+ optional q1..qN hint)."),
    out_file: str = typer.Option(..., "--out", help="Commands CSV to write.", **_output(".csv")),
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
    _print_result(result if as_json else _without_domain(result), as_json, f"commands -> {out_file}")
    if not as_json:
        _say_domain(result)


@command(name="filter")
@user_errors
def filter_programs(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    programs: list[str] = typer.Argument(..., help="Robot programs: KRL .src (its .dat comes along), RAPID "
                                                   ".mod/.modx/.prg, URScript .script."),
    out_dir: str = typer.Option(..., "--out", help="Directory to write the filtered programs (same names) and "
                                                   "filter-summary.csv into."),
    language: str = typer.Option(None, "--language", help="krl, rapid or urscript (default: by extension)."),
    config: str = typer.Option(None, "--config", help="KRL: the robot's $config.dat, for TOOL_DATA and BASE_DATA "
                                                      "(default: the robot's base and the model's tool)."),
    allow_unfiltered: bool = typer.Option(False, "--allow-unfiltered",
                                          help="Write the program even if some motions are computed at run time "
                                               "(they stay as they are and are listed)."),
    accept_extrapolation: bool = typer.Option(False, "--accept-extrapolation",
                                              help="Filter targets outside the model's domain of validity too."),
    iterate: bool = typer.Option(False, "--iterate", help="Solve c = P - e(c) to a fixed point, as compensate does."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Robot programs in, compensated robot programs out.

    Every Cartesian target of the programs becomes what 'robocal compensate' gives for it, in
    the program's own base and tool frames and for the posture the point names; every other
    byte stays as it was, and one comment line naming robocal and the model is added.

    Example: robocal filter model.json pallet_cell.src --out filtered/
    """
    result = filter_job(model, programs, out_dir, language=language, config=config,
                        allow_unfiltered=allow_unfiltered, accept_extrapolation=accept_extrapolation, iterate=iterate)
    for item in result["unfiltered"]:
        _say("warning", "yellow", f"not filtered (computed at run time): {item}")
    shown = result if as_json else {k: v for k, v in _without_domain(result).items() if k != "unfiltered"}
    _print_result(shown, as_json, f"filtered programs -> {out_dir}")
    if not as_json:
        _say_domain(result)


@command()
@user_errors
def serve(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    port: int = typer.Option(8765, "--port", min=0, max=65535, help="TCP port (0: any free port, printed)."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address to listen on."),
    line_format: str = typer.Option("json", "--format", help="Request and answer lines: json or csv."),
):
    """Answer a controller point by point over TCP: one target per line in, one command out.

    A request is one line, {"x","y","z","rx","ry","rz","q":[hint]} (mm, deg, the units and
    frames of a targets file); the answer is one line, {"q":[...],"x","y","z","rx","ry","rz",
    "in_domain","bound95_mm"}, what 'robocal compensate' writes for that target.  With
    --format csv: x,y,z,rx,ry,rz[,q1..qN] in, q1..qN,x,y,z,rx,ry,rz,in_domain,bound95_mm out.
    A bad request gets one {"error": "..."} line.  SIGTERM or Ctrl-C stops it (exit 0).

    Example: robocal serve model.json --port 8765
    """
    from .serve import FORMATS, serve as run_server

    if line_format not in FORMATS:
        raise InputError(f"--format must be one of {', '.join(FORMATS)}, got {line_format!r}")
    run_server(model, host=host, port=port, fmt=line_format)


@command()
@user_errors
def report(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    measurements: str = typer.Argument(..., help="Measurement CSV to score (held-out poses, ideally)."),
    out_file: str = typer.Option(..., "--out", help="HTML report to write (one self-contained file).", **_output(".html")),
    pdf: str = typer.Option(None, "--pdf", help="Also write the tables and figures as a PDF.", **_output(".pdf")),
    validation: str = typer.Option(None, "--validation",
                                   help="JSON of 'robocal validate --json': adds cross-validation and the learning curve."),
    beyond_limits: bool = typer.Option(False, "--beyond-limits", help=BEYOND_LIMITS_HELP),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Accuracy report in one HTML file that opens offline: data, parameters, errors, plots.

    For a customer or a file: the data summary, the identified parameters with their standard
    errors and what could not be identified, the error before and after (mean, RMS, max, 95 %,
    per axis, ISO 9283-style AP/RP), and plots of where the error is.

    Example: robocal report model.json test.csv --out report.html
    """
    from .report import report_job

    result = report_job(model, measurements, out_file, validation=validation, pdf=pdf, beyond_limits=beyond_limits)
    _print_result(result, as_json, f"report -> {out_file}")


@command()
@user_errors
def export(
    model: str = typer.Argument(..., help="Model file written by 'robocal calibrate'."),
    fmt: str = typer.Option(None, "--format", help="toml (robot file) or urdf (default: as --out ends, else toml).", **_choice(EXPORT_FORMATS)),
    out_file: str = typer.Option(..., "--out", help="Robot file to write (.toml or .urdf)."),
    convention: str = typer.Option(None, help="Convert first, exactly (default: as calibrated).", **_choice(CONVENTIONS)),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Calibrated kinematics as a robot TOML or URDF (direct compensation, or ROS).

    For a controller that accepts new parameters, or a simulator; the base is the measurement
    frame -> robot base the calibration found.

    Example: robocal export model.json --format urdf --out calibrated.urdf
    """
    suffix = Path(out_file).suffix.lower().lstrip(".")
    if fmt is None and "." + suffix in OUTPUT_KINDS and suffix not in EXPORT_FORMATS:
        raise InputError(f"export writes a robot TOML or a URDF, but --out {out_file} names a "
                         f"{OUTPUT_KINDS['.' + suffix]} file: name it {Path(out_file).with_suffix('.toml')} or "
                         f"{Path(out_file).with_suffix('.urdf')}")
    if fmt is None:
        fmt = suffix if suffix in EXPORT_FORMATS else "toml"
    elif "." + suffix in OUTPUT_KINDS and suffix != fmt:
        raise InputError(f"--format {fmt} writes a {OUTPUT_KINDS['.' + fmt]} file, but --out {out_file} names a "
                         f"{OUTPUT_KINDS['.' + suffix]} file: name it {Path(out_file).with_suffix('.' + fmt)} "
                         f"or drop --format")
    result = export_job(model, out_file, fmt=fmt, convention=convention)
    for what in result["left_out"]:
        _say("note", "yellow", f"left out of the {result['format'].upper()} file: {what}")
    _print_result(result, as_json, f"{result['convention']} robot -> {out_file}")


def _reregister(model, measurements, out_file, settings, beyond_limits, as_json, accept_extrapolation=False,
                **robot_options):
    """calibrate --method frames: the model file re-registered on the poses of a new set-up."""
    given = [option for option, value in robot_options.items() if value is not None]
    others = sorted(set(settings) - {"parameters"})
    if given or others:
        options = [option_of(name) for name in others] + ["--" + name for name in given]
        raise InputError(f"--method frames keeps everything the model file holds and re-identifies its frames: "
                         f"leave out {', '.join(options)} (--parameters frames or frames+offsets is its one option)")
    result = reregister_job(model, measurements, out_file, parameters=settings.get("parameters"),
                            beyond_limits=beyond_limits, accept_extrapolation=accept_extrapolation)
    if as_json:
        print(json.dumps(result.to_dict(), indent=2))
        return
    record = result.record.reregistration
    ident = record["identifiability"]
    table = Table(title=f"{result.method} model re-registered on {record['poses']} poses of {measurements} (mm)",
                  show_header=True)
    for col in ("model on these poses", "mean", "RMS", "max"):
        table.add_column(col, justify="left" if col.startswith("model") else "right")
    for label, key in (("as it stood", "residual_before"), ("re-registered", "residual_after"),
                       ("nominal, registered", "residual_reference")):
        stats = record[key]
        table.add_row(label, f"{stats['mean_mm']:.4f}", f"{stats['rms_mm']:.4f}", f"{stats['max_mm']:.4f}")
    out.print(table)
    out.print(f"tracker moved by {record['tracker_shift_mm']:.1f} mm and turned by {record['tracker_turn_deg']:.3f} deg; "
              f"tool changed by {np.linalg.norm(record['tool_change_mm']):.3f} mm")
    for name, change in record["offset_changes"].items():
        out.print(f"joint offset {name} changed by {change:+.4f}")
    out.print(f"identified {len(ident['identified'])} parameters (rank {ident['rank']}), condition number "
              f"{ident['condition_number']:.3g}")
    if result.record.predicted_error is not None:
        out.print(f"predicted error: {_cell(result.record.predicted_error)}")
    for name, reason in ident["fixed"].items():
        out.print(f"kept {name}: {reason}")
    out.print(f"-> {out_file}")


def _print_comparison(comparison):
    """The tables of a comparison (its JSON form): held-out error of every model on each
    split, then the recommendation and why."""
    for split in comparison["splits"]:
        kind = "a region left out at a time" if split["kind"] == "region" else "poses left out at random"
        table = Table(title=f"held-out error on {split['name']} ({kind}), mm")
        for col in ("model", "mean", "RMS", "max", "95 %", "fit s"):
            table.add_column(col, justify="left" if col == "model" else "right")
        best = min(m["scores"][split["name"]]["pooled"]["mean_mm"] for m in comparison["models"])
        for model in comparison["models"]:
            score = model["scores"][split["name"]]
            stats = score["pooled"]
            mark = " *" if model["label"] == comparison["recommended"]["label"] else ""
            table.add_row(model["label"] + mark, f"{stats['mean_mm']:.4f}" + ("<" if stats["mean_mm"] == best else " "),
                          f"{stats['rms_mm']:.4f}", f"{stats['max_mm']:.4f}", f"{stats['p95_mm']:.4f}",
                          f"{score['fit_seconds']:.2f}")
        out.print(table)
    out.print(f"recommended (*): {comparison['recommended']['label']}  (< marks the lowest mean of each split)")
    for line in comparison["reasons"] + comparison["dropped"] + comparison["notes"]:
        out.print(f"  {line}")


@command()
@user_errors
def compare(
    robot: str = typer.Argument(..., help="Built-in name, robot .toml or .urdf file."),
    measurements: str = typer.Argument(..., help="Measurement CSV (q1..qN, x, y, z, ...), or ball-in-socket data with --fixture."),
    folds: int = typer.Option(5, help="Folds of each split (random folds, and regions of joint space).", **_number(whole=True, at_least=2, at_most=20)),
    seed: int = typer.Option(0, help="Seed of the random folds and of the regions' clustering.", **_number(whole=True, at_least=0)),
    network: bool = typer.Option(None, "--network/--no-network", help="Include the ann method (default: when the training folds hold 500 poses or more)."),
    fixture: str = typer.Option(None, help="Ball-in-socket data: the fixture TOML."),
    tip: str = typer.Option(None, help="URDF only: the tip link."),
    root: str = typer.Option(None, help="URDF only: the root link."),
    beyond_limits: bool = typer.Option(False, "--beyond-limits", help=BEYOND_LIMITS_HELP),
    jobs: int = typer.Option(None, help=JOBS_HELP, **_number(whole=True, at_least=1, at_most=1024)),
    scheduler: str = typer.Option(None, metavar="<tcp://HOST:PORT>", help=SCHEDULER_HELP),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Which model to trust: every method and parameter set scored on poses it never saw.

    Two kinds of split: random folds, and regions of configuration space left out whole
    (clusters of joint configurations; one side of an arm branch when both were measured;
    the last 20 % in time when the file has a timestamp column; one fixture placement for
    ball-in-socket data).  The recommendation: the simplest model, unless a richer one is
    better on the random folds by more than its fold-to-fold spread and not worse on the
    held-out regions by more than theirs.  'calibrate --method auto' fits it, answering with
    the kinematic calibration outside its training domain.

    Example: robocal compare ur5 meas.csv
    """
    from .progress import progress

    with parallel.executor(jobs=jobs, scheduler=scheduler), \
            progress("comparing the methods, fit", None, enabled=not as_json) as advance:
        comparison = compare_job(robot, measurements, folds=folds, seed=seed, fixture=fixture, network=network,
                                 root=root, tip=tip, on_fit=advance, beyond_limits=beyond_limits)
    result = comparison.to_dict()
    if as_json:
        print(json.dumps(result, indent=2))
        return
    _print_comparison(result)


@command()
@user_errors
def validate(
    robot: str = typer.Argument(..., help="Built-in name, robot .toml or .urdf file."),
    measurements: str = typer.Argument(..., help="Measurement CSV (q1..qN, x, y, z, ...)."),
    method: str = typer.Option(DEFAULT_METHOD, help=METHOD_HELP + " Ball-in-socket data (constraint) are validated one fixture placement left out at a time.", **_choice(method_names())),
    folds: int = typer.Option(5, help="Number of cross-validation folds.", **_number(whole=True, at_least=2)),
    sizes: str = typer.Option(None, help="Learning curve: training sizes, e.g. 20,50,100,200.", **_numbers(whole=True, at_least=1, example="20,50,100,200")),
    seed: int = typer.Option(0, help="Seed of the fold assignment, and of the method's random search where it has one.", **_number(whole=True, at_least=0)),
    register: str = typer.Option(None, help="Register base and tool first (default auto: when the data are not in the robot base frame).", **_choice(REGISTER_CHOICES)),
    parameters: str = typer.Option(None, help="kinematic/hybrid/constraint: parameter set, offsets, full (default), full+gains (plus a scale error of each joint reading), full+compliance (plus the stiffness of every joint gravity loads) or full+compliance+gains.", **_choice(PARAMETER_SETS)),
    loss: str = typer.Option(None, help="kinematic/hybrid: the loss (default linear; the others are robust to outliers).", **_choice(LOSSES)),
    fixture: str = typer.Option(None, help="constraint: the fixture TOML."),
    pairs: str = typer.Option(None, help="constraint: all pairs (default) or spanning.", **_choice(PAIRINGS)),
    payload: float = typer.Option(None, help="full+compliance: mass at the TCP in kg.", **_number(at_least=0)),
    beyond_limits: bool = typer.Option(False, "--beyond-limits", help=BEYOND_LIMITS_HELP),
    jobs: int = typer.Option(None, help=JOBS_HELP, **_number(whole=True, at_least=1, at_most=1024)),
    scheduler: str = typer.Option(None, metavar="<tcp://HOST:PORT>", help=SCHEDULER_HELP),
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
    size_list = sizes
    by_placement = get_method(method).data_kind == "sockets"
    # Each fold fits the method and the registered nominal; each size of the curve 3 times.
    fits = None if by_placement else 2 * folds + 3 * len(size_list or [])
    with parallel.executor(jobs=jobs, scheduler=scheduler), progress("fitting", fits, enabled=not as_json) as advance, \
            _options_named({"k": "--folds"}):
        result = validate_job(robot, measurements, method=method, settings=settings, folds=folds, sizes=size_list,
                              beyond_limits=beyond_limits,
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


@command()
@user_errors
def dataset(
    dataset: str = typer.Argument(..., parser=_choice(DATASETS)["parser"], help="ur5-tsinghua, ipa-ur10-a, ipa-ur10-b (laser tracker) or mukca-panda-1/2/3 "
                                         "(ball in sockets; split by fixture placement)."),
    prefix: str = typer.Option(..., "--out", parser=_prefix, metavar="<PREFIX>", help="Prefix of the files to write (PREFIX.toml, PREFIX*.csv)."),
    split: float = typer.Option(None, help="Training fraction of a random train/test split, e.g. 0.5.", **_number(between=(0, 1))),
    seed: int = typer.Option(0, help="Seed of the split.", **_number(whole=True, at_least=0)),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Export a real dataset shipped with robocal as a robot file and measurement CSVs.

    Example: robocal dataset ur5-tsinghua --out ur5 --split 0.5
    """
    result = dataset_job(dataset, prefix, split=split, seed=seed)
    _print_result(result, as_json, f"dataset {dataset}")


@command()
@user_errors
def design(
    robot: str = typer.Argument(..., help="Built-in name, robot .toml or .urdf file."),
    n: int = typer.Option(..., "--n", help="Number of poses to measure.", **_number(whole=True, at_least=1, at_most=100_000)),
    out_file: str = typer.Option(..., "--out", help="Poses CSV to write: pose, q1..qN (deg, the joint columns of a measurement file), x_nominal, y_nominal, z_nominal.", **_output(".csv")),
    seed: int = typer.Option(0, help="Seed of the candidates drawn (and of the random selections the summary compares with).", **_number(whole=True, at_least=0)),
    criterion: str = typer.Option("prediction", help="prediction (default: the mean squared error of the calibrated TCP over the targets; what a calibration is for), d-optimal (log det of the parameters' information), space-filling (spread over configuration space) or variance (one pose at a time where a Gaussian-process prior over the joints' sines and cosines is least certain; hyperparameters from --existing measurements when given); the last two for the kriging, hybrid and ann residual models. With --fixture: prediction or d-optimal.", **_choice(("prediction", "d-optimal", "space-filling", "variance"))),
    parameters: str = typer.Option("full", help="The parameter set the calibration will identify (as calibrate --parameters).", **_choice(PARAMETER_SETS)),
    candidates: str = typer.Option(None, help="CSV of your own candidate configurations (q1..qN, deg): reachable poses of an offline program, or an earlier campaign's."),
    pool: int = typer.Option(10_000, help="Candidate configurations to draw (without --candidates).", **_number(whole=True, at_least=10, at_most=1_000_000)),
    sampling: str = typer.Option("uniform", help="How candidates are drawn in joint space: uniform or lhs (Latin hypercube).", **_choice(("uniform", "lhs"))),
    box: str = typer.Option(None, help="Restrict the candidates to a Cartesian box of the robot base frame: xmin,xmax,ymin,ymax,zmin,zmax in mm.", **_numbers(count=6)),
    rpy: str = typer.Option(None, help="With --box: the TCP orientation rx,ry,rz in deg (default 180,0,0).", **_numbers(count=3)),
    hint: str = typer.Option(None, help="With --box: a posture q1,...,qn in deg whose IK branch every candidate takes.", **_numbers()),
    tool: str = typer.Option(None, help="The TCP x,y,z in mm in the flange frame, in place of the robot file's tool.", **_numbers(count=3)),
    margin: float = typer.Option(5.0, help="Degrees the candidates keep from joint limits and singularities.", **_number(at_least=0, at_most=45)),
    existing: str = typer.Option(None, help="Measurement (or poses) CSV of poses measured before: design the --n poses that best complement them; with x, y, z their calibration's residual sets the noise unless --noise is given."),
    targets: str = typer.Option(None, help="Where the robot will work: a CSV of configurations (q1..qN, deg) or of targets (x, y, z, rx, ry, rz; mm, deg, robot base frame). Default: the candidates."),
    noise: float = typer.Option(None, help="Standard deviation of a reading per coordinate in mm (default 0.02): the tracker's noise, plus what the calibration will not explain if you know it (an earlier calibration's residual RMS / 1.73).", **_number(at_least=0, at_most=LARGEST_NOISE_MM)),
    tracker: str = typer.Option(None, help="The laser tracker's position x,y,z in mm (robot base frame): its noise then grows with distance.", **_numbers(count=3)),
    joint_noise: float = typer.Option(0.0, "--joint-noise", help="Standard deviation in deg of an error at every joint that the calibration does not model (gear backlash or play, e.g. the half-width of the gears' backlash): a pose then reads noisier the further the arm reaches, and the design and its predicted held-out error count it. Default 0: none.", **_number(at_least=0, at_most=1)),
    sag: float = typer.Option(0.0, "--sag", help="How far gravity bends the most loaded joint, in deg, when --parameters has no compliance (e.g. 0.01 for a counterbalanced 150 kg arm, 0.08 for a UR5): the design then also chooses poses whose sag the geometry absorbs as the targets' would be, and the predicted error counts what it leaves. Default 0: none.", **_number(at_least=0, at_most=1)),
    order: str = typer.Option("tour", help="The order to measure in: tour (short motions) or random (averages out gear backlash, which a tour approaches from one side).", **_choice(("tour", "random"))),
    payload: float = typer.Option(None, help="full+compliance: mass at the TCP in kg (as calibrate --payload).", **_number(at_least=0)),
    tip: str = typer.Option(None, help="URDF only: the tip link."),
    root: str = typer.Option(None, help="URDF only: the root link."),
    fixture: str = typer.Option(None, help="Ball in sockets: the fixture TOML file; the design then chooses placements and, per socket, configurations for the constraint calibration (the robot's tool is the ball centre), and --n counts configurations in all."),
    placements: str = typer.Option(None, help="With --fixture: CSV of candidate fixture placements, x,y,z (mm), rx,ry,rz (deg) of the fixture frame in the robot base frame, and optionally a fixture column naming them."),
    region: str = typer.Option(None, help="With --fixture, instead of --placements: where the fixture may stand level, xmin,xmax,ymin,ymax,zmin,zmax in mm (robot base frame).", **_numbers(count=6)),
    per_socket: int = typer.Option(None, "--per-socket", help="With --fixture: configurations per socket (default: --n spread over every reachable placement); fewer placements are then chosen.", **_number(whole=True, at_least=2)),
    max_tilt: float = typer.Option(None, "--max-tilt", help="With --fixture: the largest angle between the tool axis and the fixture normal, deg (default 30).", **_number(at_least=0, at_most=89)),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Choose which poses to measure for a calibration, and predict what they will give.

    From 10,000 candidate configurations (or --candidates), greedy selection and exchange
    choose --n poses for the criterion, ordered as a short tour in joint space; the summary
    gives the predicted standard error of every identifiable parameter and the predicted
    held-out position error, beside random poses of the same number.

    Example: robocal design kr150-2 --n 30 --out poses.csv

    Augment a campaign: robocal design ur5 --n 10 --existing measured.csv --out next.csv

    Ball in sockets: robocal design panda --fixture plate.toml --placements where.csv --n 72 --per-socket 8 --out plan.csv
    """
    from ..planning.job import design_job, socket_job

    if noise is not None and noise <= 0:
        raise InputError(f"--noise is a standard deviation and must be > 0 mm, got {noise}")
    socket_options = {"--placements": placements, "--region": region, "--per-socket": per_socket, "--max-tilt": max_tilt}
    if fixture is None and any(v is not None for v in socket_options.values()):
        given = [k for k, v in socket_options.items() if v is not None]
        raise InputError(f"{', '.join(given)} plan a ball-in-socket campaign: give --fixture too, or leave "
                         f"{'it' if len(given) == 1 else 'them'} out")
    if fixture is not None:
        pose_options = {"--candidates": candidates, "--box": box, "--rpy": rpy, "--hint": hint, "--existing": existing,
                        "--targets": targets, "--tracker": tracker, "--payload": payload,
                        "--joint-noise": joint_noise or None, "--sag": sag or None,
                        "--parameters": parameters if parameters != "full" else None,
                        "--order": order if order != "tour" else None}
        given = [k for k, v in pose_options.items() if v is not None]
        if given:
            raise InputError(f"{', '.join(given)} do not apply to a ball-in-socket design (--fixture): leave "
                             f"{'it' if len(given) == 1 else 'them'} out")
        if criterion not in ("prediction", "d-optimal"):
            raise InputError(f"--criterion {criterion} is for residual models over poses; a ball-in-socket design "
                             "takes prediction or d-optimal")
        result = socket_job(robot, out_file, fixture=fixture, n=n, placements=placements, region=region,
                            per_socket=per_socket, criterion=criterion, seed=seed, tool=tool, noise=noise,
                            margin=margin, max_tilt=max_tilt, root=root, tip=tip)
    else:
        result = design_job(robot, out_file, n=n, seed=seed, criterion=criterion, parameters=parameters,
                            candidates=candidates, pool=pool, sampling=sampling, box=box, rpy=rpy, hint=hint,
                            tool=tool, margin=margin, existing=existing, targets=targets, noise=noise,
                            tracker=tracker, payload=payload, order=order, root=root, tip=tip,
                            joint_noise=joint_noise, sag=sag)
    if as_json:
        print(json.dumps(result, indent=2))
        return
    predicted = result["predicted"]
    versus = predicted["random_model_rms_mm"]
    if fixture is not None:
        table = Table(title=f"{result['configurations']} configurations in {len(result['placements'])} placements of "
                            f"fixture {result['fixture']} ({result['criterion']}) -> {out_file}", show_header=False)
        for key, value in (("robot", result["robot"]), ("candidate placements", result["placements_from"]),
                           ("reachable placements", result["reachable_placements"]),
                           ("chosen placements", ", ".join(result["placements"])),
                           ("configurations per socket", result["per_socket"]),
                           ("candidate configurations", result["candidates"]),
                           ("ball-centre error after calibration", f"{predicted['model_rms_mm']:.4f} mm RMS predicted"
                            + ("" if versus is None else f" (random choices of the same number: {versus:.4f} mm)")),
                           ("identifiable parameters", len(result["identifiable"])),
                           ("exchanges", result["exchanges"])):
            table.add_row(key, str(value))
        out.print(table)
        return
    table = Table(title=f"{result['poses']} poses of {result['candidates']} candidates ({result['criterion']}) -> {out_file}",
                  show_header=False)
    for key, value in (("robot", result["robot"]), ("candidates", result["candidates_from"]),
                       ("targets", result["targets"]), ("measured before", result["existing"]),
                       ("noise", f"{result['noise_mm']:.4f} mm ({result['noise_from']})"
                        + (f", {result['joint_noise_deg']:g} deg at every joint" if result["joint_noise_deg"] else "")
                        + (f", sag {result['sag_deg']:g} deg left out" if result["sag_deg"] else "")),
                       ("calibrated TCP error at the targets", f"{predicted['model_rms_mm']:.4f} mm RMS predicted"
                        + ("" if versus is None else f" (random poses of the same number: {versus:.4f} mm)")),
                       ("held-out error with a reading's noise", f"mean {predicted['held_out_mean_mm']:.4f} mm, "
                                                                  f"RMS {predicted['held_out_rms_mm']:.4f} mm predicted"),
                       ("O1, noise amplification", f"{result['o1']:.4g}, {result['noise_amplification']:.4g}"),
                       ("condition number", f"{result['condition_number']:.4g}"),
                       ("motion", f"{result['tour_deg']:.0f} deg of the largest joint's motion "
                                f"({result['order_of_choice_deg']:.0f} in the order of choice)"),
                       ("exchanges after the greedy selection", str(result["exchanges"]))):
        table.add_row(key, str(value))
    if "variance" in result:
        table.add_row("largest predictive variance left", f"{result['variance']['max_relative']:.3g} of the prior's "
                                                            f"({result['variance']['prior']})")
    out.print(table)
    parameters_table = Table(title=f"predicted standard errors ({len(result['std_errors'])} identifiable parameters)")
    for column in ("parameter", "std. error", "unit"):
        parameters_table.add_column(column, justify="right")
    for name, entry in result["std_errors"].items():
        parameters_table.add_row(name, f"{entry['std_error']:.3g}", entry["unit"])
    out.print(parameters_table)
    for name, reason in result["fixed"].items():
        out.print(f"not identifiable from these candidates, {name}: {reason}")


@command()
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


@command()
@user_errors
def fleet(
    fleet_file: str = typer.Argument(..., help="Fleet file (TOML): one [[robot]] table per robot with name, robot, train, and optionally test, method, fixture, options (calibrate's options); paths relative to it."),
    out_dir: str = typer.Option(..., "--out", metavar="<DIR>", help="Folder to write: DIR/<name>/model.json and report.html per robot, DIR/summary.csv and DIR/summary.html (created if missing)."),
    scheduler: str = typer.Option(None, metavar="<tcp://HOST:PORT>", help="A running Dask scheduler to use (its workers must see the files at the same paths); default: a local cluster on 127.0.0.1."),
    jobs: int = typer.Option(None, help="Workers of the local cluster (default: one per CPU core).", **_number(whole=True, at_least=1, at_most=1024)),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
):
    """Calibrate, evaluate and report every robot of a fleet, in parallel on Dask.

    For each robot: calibrate on train, evaluate on test when given, write the report.  A
    mistake in the fleet file stops everything before any work starts; a robot whose data
    are bad fails alone (the summary says why) and the exit status is then 1.  Needs Dask:
    pip install 'robocal[fleet]'.

    Example: robocal fleet fleet.toml --out results --jobs 2
    """
    from .fleet import OK, SUMMARY_COLUMNS, default_workers, fleet_job
    from .progress import progress

    if jobs is None and scheduler is None:
        jobs = default_workers()
    with progress("robots", None, enabled=not as_json) as advance:
        result = fleet_job(fleet_file, out_dir, jobs=jobs, scheduler=scheduler,
                           on_robot=lambda row, done, total: advance(robots=f"{done} of {total}",
                                                                     last=f"{row['name']} {row['status']}"))
    if as_json:
        print(json.dumps(result, indent=2))
    else:
        columns = [c for c in SUMMARY_COLUMNS if c != "message"]
        table = Table(title=f"fleet of {len(result['robots'])} robots on {result['ran_on']} (mm)")
        for column in columns:
            table.add_column(column, justify="right" if column.endswith(("_mm", "train", "test")) else "left")
        for row in result["robots"]:
            table.add_row(*[_cell(row[c]) if row[c] is not None else "" for c in columns],
                          style=None if row["status"] == OK else "red")
        out.print(table)
        for row in result["robots"]:
            if row["message"]:
                out.print(Text(f"{row['name']}: {row['message']}", style="" if row["status"] == OK else "red"))
        out.print(f"-> {result['summary_csv']}, {result['summary_html']}")
    if result["failed"]:
        _say("error", "red", f"{result['failed']} of {len(result['robots'])} robots failed: the message column of "
                             f"{result['summary_csv']} says why")
        raise typer.Exit(1)


# Variables by which a user sets how many threads the linear algebra library runs.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


def _one_blas_thread():
    """Limit the linear algebra library (OpenBLAS, MKL) to one thread unless the user set how
    many it runs.  robocal's fits are many small solves (a Kriging search, one calibration per
    fold), which threads do not speed up, and on a machine whose cores are busy the library's
    threads wait for each other: ``compare`` on 200 UR5 poses took 137 s with OpenBLAS's
    default threads on a loaded 2-core machine and 8 s with one.  Parallel work is --jobs."""
    if any(name in os.environ for name in THREAD_VARIABLES):
        return None
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def main():
    """Console entry point."""
    warnings.showwarning = _show_warning
    np.seterr(all="ignore")  # NaNs are checked explicitly where they matter
    _one_blas_thread()
    with interruptible():
        app()


if __name__ == "__main__":
    main()
