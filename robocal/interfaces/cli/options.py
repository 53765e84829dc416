"""The command line's options: those generated from the methods' settings, and those several
commands share, each declared once.

A value is parsed by the constraint its :class:`~robocal.settings.Setting` (or the option)
declares (:mod:`robocal.settings`); a refusal is one line naming the option as the user
typed it (``--loss must be one of linear, huber, soft_l1: 'cauchy' is not available``).

Where a new option goes:

* a setting of a method: a :class:`~robocal.settings.Setting` in the method's module
  (``robocal/methods/<method>.py``), listed in its ``settings``; ``calibrate``, ``validate``
  and fleet files then take it (:func:`method_options`, :mod:`robocal.interfaces.fleet`), with
  nothing to add here;
* an option several commands share: below, once, used as a parameter's default;
* an option of one command: in its function's signature (``robocal/interfaces/cli/<group>.py``),
  its values parsed by :func:`parsed` (a :class:`~robocal.settings.Constraint`); or, for a
  command of many options (simulate, design), a :class:`~robocal.settings.Setting` in the
  module's table and a keyword-only parameter of that name (:func:`declared`).
"""
import contextlib
import functools
import inspect
import re
from pathlib import Path

import typer

from ...errors import InputError
from ...methods import settings_by_option
from ...settings import Constraint, Flag, Number, Refusal, Setting, merged_constraint


class Refused(typer.BadParameter):
    """A value the command line refuses; the message follows the option's name."""


def parsed(constraint):
    """The ``parser`` and ``metavar`` of an option whose values ``constraint`` takes (None, the
    option not given, passes untouched)."""

    def parse(value):
        try:
            return constraint.parse(value)
        except Refusal as refusal:
            raise Refused(refusal.phrase) from None

    return {"parser": parse, "metavar": constraint.metavar}


# --------------------------------------------------------------------------- output files
# Files robocal writes, by suffix: an --out whose suffix names another of them would hold
# something else than its name says (calibrate --out m.csv would write JSON).
OUTPUT_KINDS = {".json": "JSON", ".csv": "CSV", ".toml": "robot TOML", ".urdf": "URDF", ".html": "HTML",
                ".pdf": "PDF"}


class Output(Constraint):
    """The path of a file of kind ``suffix``: refuses a name whose suffix is another kind
    robocal writes."""

    def __init__(self, suffix):
        self.suffix = suffix
        self.metavar = f"<FILE{suffix}>"

    def parse(self, text):
        given = Path(str(text)).suffix.lower()
        if given in OUTPUT_KINDS and given != self.suffix:
            raise Refused(f"writes {OUTPUT_KINDS[self.suffix]}, but {text!r} names a {OUTPUT_KINDS[given]} file: "
                          f"name it {Path(str(text)).with_suffix(self.suffix)}")
        return text

    check = parse


class Prefix(Constraint):
    """dataset --out: a prefix, to which robocal adds .toml, .csv, _train.csv ..."""

    metavar = "<PREFIX>"

    def parse(self, text):
        if Path(str(text)).suffix.lower() in OUTPUT_KINDS:
            raise Refused(f"is a prefix (PREFIX.toml and PREFIX.csv are written): give "
                          f"{str(Path(str(text)).with_suffix(''))!r}, not {text!r}")
        return text

    check = parse


def out_option(help, suffix=None, **extra):
    """The required ``--out`` of a command that writes ``help``'s file (of kind ``suffix``)."""
    return typer.Option(..., "--out", help=help, **(parsed(Output(suffix)) if suffix else {}), **extra)


# --------------------------------------------------------------------------- shared options
ROBOT = typer.Argument(..., help="Built-in name, robot .toml or .urdf file.")
MEASUREMENTS = typer.Argument(..., help="Measurement CSV (q1..qN, x, y, z, ...), or ball-in-socket data with "
                              "--fixture.")
MODEL = typer.Argument(..., help="Model file written by 'robocal calibrate'.")
JSON = typer.Option(False, "--json", help="Print one JSON object.")
TIP = typer.Option(None, help="URDF only: the tip link.")
ROOT = typer.Option(None, help="URDF only: the root link.")
FIXTURE = typer.Option(None, help="Ball-in-socket data (the constraint method): the fixture TOML (socket centres, mm; "
                       "evaluate: default the one the model stores).")
BEYOND_LIMITS = typer.Option(False, "--beyond-limits", help="Accept joint values beyond the robot's limits (by more "
                             "than 0.5 deg) instead of refusing those rows.")
ACCEPT_EXTRAPOLATION = typer.Option(False, "--accept-extrapolation", help="Keep a model predicted to miss by more "
                                    "than the registered nominal robot over the working range (poses that cover too "
                                    "little of it) as fitted: without it an error model answers beyond its poses "
                                    "with the kinematic calibration, or is refused; filter: compensate targets "
                                    "outside its domain of validity too.")
ITERATE = typer.Option(False, "--iterate", help="Solve c = P - e(c) to a fixed point.")
JOBS = typer.Option(None, help="Run the independent fits (the folds of a comparison or a cross-validation, each "
                    "error component's likelihood search of kriging and hybrid, the robots of a fleet) on a local "
                    "Dask cluster of this many workers, listening on 127.0.0.1 (needs pip install "
                    "'robocal[fleet]'); default: one after the other here (fleet: one worker per CPU core).",
                    **parsed(Number(whole=True, at_least=1, at_most=1024,
                                    advice="more workers than CPU cores only wait for each other")))
SCHEDULER = typer.Option(None, metavar="<tcp://HOST:PORT>", help="Run them on the workers of a running Dask "
                         "scheduler instead (they must run this robocal version and see the files at the same paths).")
SEED = typer.Option(0, help="Random seed (of the poses drawn, the folds, the split).",
                    **parsed(Number(whole=True, at_least=0)))
METHOD_HELP = "The method; 'robocal methods' describes them and lists their options."


# --------------------------------------------------------------------------- options from settings
def typer_option(setting, help=None):
    """The typer option of a :class:`~robocal.settings.Setting`: its option name(s), default
    (``...``: required), help (or ``help``) and the parser and metavar of its constraint."""
    help = setting.help if help is None else help
    if setting.constraint is None or isinstance(setting.constraint, Flag):
        return typer.Option(setting.default, setting.option, help=help)
    return typer.Option(setting.default, setting.option, help=help, **parsed(setting.constraint))


def declared(settings):
    """Decorator: each keyword-only parameter of a command without a default takes its option
    from the setting of its name among ``settings`` (:func:`typer_option`)."""
    by_name = {setting.name: setting for setting in settings}

    def decorate(func):
        signature = inspect.signature(func)
        undeclared = inspect.Parameter.empty
        parameters = [parameter.replace(default=typer_option(by_name[parameter.name]))
                      if parameter.kind is inspect.Parameter.KEYWORD_ONLY and parameter.default is undeclared
                      else parameter for parameter in signature.parameters.values()]
        func.__signature__ = signature.replace(parameters=parameters)
        return func

    return decorate


# --------------------------------------------------------------------------- method settings
def _shown(value):
    return ",".join(map(str, value)) if isinstance(value, tuple) else str(value)


def _help(entries):
    """One help for an option several methods take: per setting, the methods that take it."""
    takers = {}
    for name, setting in entries:
        takers.setdefault(setting, []).append(name)
    parts = []
    for setting, names in takers.items():
        default = "" if setting.default is None or isinstance(setting.constraint, Flag) else \
            f" (default {_shown(setting.default)})"
        # Methods joined with spaces: one long word would push --help's columns out of shape.
        parts.append(f"{', '.join(names)}: {setting.help}{default}.")
    return " ".join(parts)


def method_options(*, frames=False, skip=()):
    """Decorator: the command takes every method's settings as options, generated from the
    registry (:func:`robocal.methods.settings_by_option`) in place of its ``settings``
    parameter, which receives those given, by keyword (lists as tuples; a flag only when on)."""
    options = settings_by_option(frames=frames, skip=skip)

    def decorate(func):
        generated, names = [], []
        for option, entries in options.items():
            name = entries[0][1].name
            flag = isinstance(entries[0][1].constraint, Flag)
            # Not given: None (False for a flag), so that the method's own default applies.
            merged = Setting(name, False if flag else None, option, "", merged_constraint([s for _, s in entries]))
            info = typer_option(merged, help=_help(entries))
            generated.append(inspect.Parameter(name, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=info,
                                               annotation=bool if flag else str))
            names.append(name)

        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            given = {name: kwargs.pop(name) for name in names}
            settings = {name: tuple(value) if isinstance(value, list) else value
                        for name, value in given.items() if value is not None and value is not False}
            return func(*args, settings=settings, **kwargs)

        signature = inspect.signature(func)
        parameters = []
        for parameter in signature.parameters.values():
            parameters += generated if parameter.name == "settings" else [parameter]
        wrapper.__signature__ = signature.replace(parameters=parameters)
        wrapper.__annotations__ = {**{k: v for k, v in func.__annotations__.items() if k != "settings"},
                                   **{p.name: p.annotation for p in generated}}
        return wrapper

    return decorate


@contextlib.contextmanager
def options_named(names):
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
