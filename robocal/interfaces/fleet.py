"""robocal fleet: calibrate, evaluate and report many robots, one task per robot on Dask.

A fleet file (TOML) lists the robots, paths relative to it::

    [[robot]]
    name = "line1-r01"              # names the folder DIR/line1-r01: letters, digits, . _ -
    robot = "ur5"                   # a built-in name, or a robot .toml / .urdf file
    train = "r01/train.csv"         # measurements to calibrate on
    test = "r01/test.csv"           # optional: held-out measurements to evaluate on
    method = "auto"                 # optional: any method, or auto (default kinematic)
    fixture = "plate.toml"          # optional: ball-in-socket data
    options = { parameters = "full+gains", seed = 3 }   # optional: calibrate's options

The whole file is checked before any work is submitted: a mistake in it (an unknown key, a
missing name, robot or train, two robots of one name, a name that is not a plain file name,
an option calibrate does not have or a value it refuses: each parsed by its setting's
constraint, as the option is) is one line and nothing runs.  What
can only be found by reading a robot's data (a missing or damaged file, too few poses) fails
that robot alone: its line in the summary says why, and the others finish.

Each robot is one task (:func:`run_robot`): ``calibrate_job``, ``evaluate_job`` on the test
file, ``report_job``, exactly as ``robocal calibrate``, ``evaluate`` and ``report`` run them.
Only plain data travel: the task is a dict of names and paths, and its result a dict of
numbers and text; the worker writes the model file (JSON) and the report into the robot's own
folder, so workers of a cluster given by address must see the fleet's files and DIR at the
same paths (one machine, or a shared file system).  The model file is written under a
temporary name and takes its final name only once the evaluation has succeeded, so that a
robot whose test file is bad leaves the files of an earlier run as they were.
"""
from __future__ import annotations

import contextlib
import html
import os
import re
import secrets
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from .. import parallel
from ..errors import FileFormatError, InputError, RobocalError, RobocalWarning
from ..io.csv_writing import csv_text
from ..io.atomic import make_directory, outputs_together, promote, write_text_atomic
from ..io import schema
from ..io.reading import load_json
from ..methods import DEFAULT_METHOD, FRAMES, make_method, method_names, settings_by_option
from ..methods.base import option_of
from ..methods.reregistration import PARAMETER_CHOICES as FRAME_PARAMETERS
from ..settings import Choice, Flag, Refusal, merged_constraint
from .jobs import AUTO, calibrate_job, evaluate_job
from .results import FleetRun

MODEL_FILE = "model.json"
REPORT_FILE = "report.html"
SUMMARY_CSV = "summary.csv"
SUMMARY_HTML = "summary.html"
SUMMARY_COLUMNS = ("name", "status", "method", "n_train", "n_test", "mean_mm", "max_mm", "message")
OK, FAILED = "ok", "failed"

# The keys of a [[robot]] table; the first three are required.
REQUIRED_KEYS = ("name", "robot", "train")
OPTIONAL_KEYS = ("test", "method", "fixture", "options")
# calibrate's options that go to calibrate_job itself (flags but root and tip); the others a
# robot's options take are the methods' settings.  Its files, its method and its fixture have
# keys of their own, the fleet decides what is written and printed, and --jobs and
# --scheduler are the fleet's own (a robot's fits run on its worker); --folds (auto's
# comparison) is not offered in fleet files.
JOB_OPTIONS = {"root": None, "tip": None, "beyond_limits": Flag(), "accept_extrapolation": Flag()}
# A robot's name names its folder: a plain file name, nothing a file system reads as a path.
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}\Z")
ROBOT_FILE_SUFFIXES = (".toml", ".urdf")


@dataclass(frozen=True)
class FleetRobot:
    """One [[robot]] table, checked: paths absolute, the method's ``settings`` as its
    keywords, ``job_options`` (root, tip, beyond_limits) as calibrate_job's."""

    name: str
    robot: str
    train: str
    test: str | None
    method: str
    fixture: str | None
    settings: dict = field(default_factory=dict)
    job_options: dict = field(default_factory=dict)

    def task(self, folder):
        """What the worker gets (:func:`run_robot`): plain data only."""
        return {"name": self.name, "robot": self.robot, "train": self.train, "test": self.test,
                "method": self.method, "fixture": self.fixture, "settings": dict(self.settings),
                "folder": str(folder), **self.job_options}


# --------------------------------------------------------------------------- the fleet file
def read_fleet(path):
    """The robots of a fleet file, every one checked (see the module docstring); InputError
    or FileFormatError in one line, naming the file, the robot and what to do."""
    from ..io.reading import load_toml

    path = Path(path)
    if not path.exists():
        raise FileFormatError(f"{path} does not exist: give the fleet file (TOML, one [[robot]] table per robot)")
    # A folder, a pipe or a device: the one bounded reader says which, in one line.
    document = load_toml(path, "fleet file", "fix that line", reader="fleet")
    unknown = sorted(set(document) - {"robot"})
    if unknown:
        raise InputError(f"{path}: unknown key {unknown[0]!r} at the top: a fleet file holds [[robot]] tables only")
    tables = document.get("robot")
    if not tables:
        raise InputError(f"{path} lists no robots: add a [[robot]] table with name, robot and train for each")
    schema.tables(tables, f"{path}: 'robot'", "[[robot]] tables (double brackets), one per robot")
    folder = path.resolve().parent
    robots = [_robot(table, k + 1, path, folder) for k, table in enumerate(tables)]
    seen = {}
    for k, robot in enumerate(robots):
        other = seen.setdefault(robot.name.lower(), k)
        if other != k:
            raise InputError(f"{path}: robots {other + 1} and {k + 1} are both named {robots[other].name!r}"
                             f"{'' if robots[other].name == robot.name else f' / {robot.name!r}'}: give each robot "
                             "its own name (it names the robot's folder)")
    return robots


def _robot(table, number, path, folder):
    """One [[robot]] table -> FleetRobot, or a one-line refusal."""
    raw_name = table.get("name")
    where = f"{path}: robot {number}" + (f" ({raw_name})" if isinstance(raw_name, str) and raw_name else "")
    unknown = sorted(set(table) - set(REQUIRED_KEYS) - set(OPTIONAL_KEYS))
    if unknown:
        raise InputError(f"{where}: unknown key {unknown[0]!r}; a [[robot]] table takes "
                         f"{', '.join(REQUIRED_KEYS + OPTIONAL_KEYS)} (calibrate's options go in options = {{...}})")
    for key in REQUIRED_KEYS:
        if key not in table:
            raise InputError(f"{where}: no {key}; every [[robot]] needs name, robot (a built-in name or a robot "
                             "file) and train (its measurement CSV)")
    for key in REQUIRED_KEYS + ("test", "method", "fixture"):
        if key in table:
            schema.text(table[key], f"{where}: {key}")
    name = table["name"]
    if not NAME.match(name) or name.lower() in (SUMMARY_CSV, SUMMARY_HTML):
        raise InputError(f"{where}: name {name!r} is not a plain file name (it names the robot's folder in the "
                         "output): use letters, digits, '.', '_' and '-', starting with a letter or digit, and not "
                         f"{SUMMARY_CSV} or {SUMMARY_HTML}, e.g. 'line1-r07'")
    options = schema.table(table.get("options", {}), f"{where}: options", "a table of calibrate's options, e.g. "
                           "options = { parameters = \"full+gains\", seed = 3 }")
    method, settings, job_options = _calibrate_options(table.get("method", DEFAULT_METHOD), options, where)
    robot = table["robot"]
    if Path(robot).suffix.lower() in ROBOT_FILE_SUFFIXES:
        robot = _resolved(folder, robot)
    else:
        from ..io.library import builtin_names

        if robot not in builtin_names():
            raise InputError(f"{where}: robot {robot!r} is neither a built-in robot ({', '.join(builtin_names())}) "
                             "nor a robot file (.toml or .urdf)")
    optional = {key: _resolved(folder, table[key]) if key in table else None for key in ("test", "fixture")}
    return FleetRobot(name=name, robot=robot, train=_resolved(folder, table["train"]), method=method,
                      settings=settings, job_options=job_options, **optional)


def _resolved(folder, given):
    """A path of the fleet file, relative to its folder, made absolute (for every worker)."""
    return os.path.abspath(folder / Path(given).expanduser())


def _calibrate_options(method, options, where):
    """(method, settings, job options) from a robot's method and options.  The keys are
    calibrate's options (keyed as ``seed`` or ``shared_theta``): the methods' settings, read
    from the registry, and :data:`JOB_OPTIONS`; a value is parsed by its setting's constraint
    (:mod:`robocal.settings`), so it means and refuses exactly what the option does."""
    by_key = {option[2:].replace("-", "_"): entries for option, entries in settings_by_option(frames=True).items()}
    methods = Choice(method_names() + (AUTO, FRAMES))
    try:
        method = methods.parse(method)
    except Refusal as refusal:
        raise InputError(f"{where}: method {refusal.phrase}") from None
    settings, job_options = {}, {}
    for key, value in options.items():
        name = key.replace("-", "_")
        entries = by_key.get(name)
        if entries is None and name not in JOB_OPTIONS:
            keys = sorted({k.replace("_", "-") for k in by_key} | {k.replace("_", "-") for k in JOB_OPTIONS})
            raise InputError(f"{where}: calibrate has no option --{key.replace('_', '-')}; options takes "
                             f"{', '.join(keys)} ('robocal calibrate --help' says what each does)")
        constraint = JOB_OPTIONS[name] if entries is None else merged_constraint([setting for _, setting in entries])
        if isinstance(constraint, Flag):
            if not isinstance(value, bool):
                raise InputError(f"{where}: options.{key} is on or off: write {key} = true or {key} = false")
        elif isinstance(value, (str, int, float)) and not isinstance(value, bool):
            value = str(value) if constraint is None else _parsed(constraint, str(value), where, key)
        elif (isinstance(value, list) and constraint is not None
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
            value = _parsed(constraint, ",".join(map(str, value)), where, key)
        else:
            raise InputError(f"{where}: options.{key} must be a text, a number or a list of numbers, got {value!r}")
        if entries is None:
            job_options[name] = value
        elif value is not False:  # a flag off is a setting left at its default
            settings[entries[0][1].name] = tuple(value) if isinstance(value, list) else value
    if method == FRAMES or settings.get("parameters") in FRAME_PARAMETERS:
        raise InputError(f"{where}: a fleet calibrates from robot files; re-registering a model file (method "
                         f"{FRAMES}, parameters {' / '.join(FRAME_PARAMETERS)}) is 'robocal calibrate MODEL.json "
                         f"NEW.csv --method {FRAMES}'")
    if method == AUTO and settings:
        raise InputError(f"{where}: method auto chooses the method and its settings by comparing them: leave "
                         f"{', '.join(sorted(option_of(name)[2:] for name in settings))} out of options, or name a "
                         "method")
    if method != AUTO:
        try:
            make_method(method, **settings)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
    return method, settings, job_options


def _parsed(constraint, text, where, key):
    try:
        return constraint.parse(text)
    except Refusal as refusal:
        raise InputError(f"{where}: options.{key} {refusal.phrase}") from None


# --------------------------------------------------------------------------- one robot (worker side)
def failed_row(task):
    """The summary row of a robot that has not (yet) succeeded."""
    return {"name": task["name"], "status": FAILED, "method": task["method"], "n_train": None, "n_test": None,
            "mean_mm": None, "max_mm": None, "message": "", "seconds": None}


def run_robot(task):
    """Calibrate one robot, evaluate it on its test file, write its report: the task of a
    fleet, run on a worker.  ``task`` is :meth:`FleetRobot.task`; returns its summary row
    (SUMMARY_COLUMNS, and ``seconds``), with status ``failed`` and why in ``message`` when
    the robot's files are bad (nothing raised: the other robots go on)."""
    start = time.perf_counter()
    folder = Path(task["folder"])
    model_path, report_path = folder / MODEL_FILE, folder / REPORT_FILE
    staged = folder / f".{MODEL_FILE}.{secrets.token_hex(4)}.partial"
    row = failed_row(task)
    notes, promoted = [], False
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RobocalWarning)
            calibrated = calibrate_job(task["robot"], task["train"], staged, method=task["method"],
                                       settings=task["settings"], fixture=task["fixture"], root=task.get("root"),
                                       tip=task.get("tip"), beyond_limits=task.get("beyond_limits", False),
                                       accept_extrapolation=task.get("accept_extrapolation", False))
            row.update(method=calibrated.method, n_train=calibrated.data["n_poses"])
            if "comparison" in calibrated.data:
                notes.append(f"auto chose {calibrated.data['comparison']['recommended']['label']}")
            if task["test"] is None:
                stats = calibrated.record.residual_after_training
                notes.append("no test file: mean and max are on the training poses")
            else:
                stats = evaluate_job(staged, task["test"], beyond_limits=task.get("beyond_limits", False)).to_dict()
                row["n_test"] = stats["n"]
                if stats.get("outside_domain"):
                    notes.append(stats["domain_summary"])
            row.update(mean_mm=stats["mean_mm"], max_mm=stats["max_mm"])
            promote(staged, model_path)
            promoted = True
            _report(model_path, task["test"] or task["train"], report_path, task.get("beyond_limits", False))
        notes += list(dict.fromkeys(str(w.message) for w in caught if issubclass(w.category, RobocalWarning)))
        row["status"] = OK
    except Exception as exc:  # noqa: BLE001 - any failure is this robot's alone
        notes.insert(0, _failure(exc, promoted))
        if not promoted and model_path.exists():
            notes.append(f"{folder} keeps the files of an earlier run")
    finally:
        staged.unlink(missing_ok=True)
    row["message"] = "; ".join(notes)
    row["seconds"] = time.perf_counter() - start
    return row


def _report(model_path, measurements, out, beyond_limits):
    """The HTML report of ``robocal report`` (imported here: it draws with matplotlib)."""
    from .report import report_job

    return report_job(str(model_path), measurements, str(out), beyond_limits=beyond_limits)


def _failure(exc, promoted):
    """A robot's failure in one line."""
    if isinstance(exc, RobocalError):
        text = str(exc)
    elif isinstance(exc, OSError):
        where = f" {exc.filename}" if exc.filename else ""
        text = f"cannot use{where}: {exc.strerror or exc}; check the path and its permissions"
    else:
        text = (f"internal error ({type(exc).__name__}: {exc}); run 'robocal calibrate' on this robot with --debug "
                "and report the traceback")
    return f"the model was written but the report failed: {text}" if promoted else text


# --------------------------------------------------------------------------- the fleet (client side)
def default_workers():
    """One worker per CPU core this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def fleet_job(fleet_file, out_dir, *, jobs=None, scheduler=None, on_robot=None):
    """Every robot of ``fleet_file`` (:func:`read_fleet`): its task run on a local Dask cluster
    of ``jobs`` workers, on the cluster at ``scheduler``, or (neither) on the active
    :func:`robocal.parallel.executor`, serially outside one.  Writes DIR/<name>/model.json and
    report.html, DIR/summary.csv and DIR/summary.html; ``on_robot(row, finished, total)`` is
    called as each robot finishes.  Returns a :class:`.results.FleetRun`: the rows and what was
    written; ``failed`` counts the failures."""
    # One unit: a fleet that fails as a whole (no scheduler, Ctrl-C) leaves no folder or file
    # it made; one that runs keeps every robot's, failed robots included.
    with outputs_together():
        return _run_fleet(fleet_file, out_dir, jobs, scheduler, on_robot)


def _run_fleet(fleet_file, out_dir, jobs, scheduler, on_robot):
    if jobs is not None or scheduler is not None:
        parallel.require_dask("robocal fleet")
    robots = read_fleet(fleet_file)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} is a file: give a folder (it is created if missing)")
    folders = [_robot_folder(out, robot.name) for robot in robots]
    _check_inputs_are_not_outputs(robots, folders, out, fleet_file)
    make_directory(out)
    created = [folder for folder in folders if not folder.exists()]
    for folder in folders:
        make_directory(folder)
    # Absolute: a worker of a cluster given by address runs in a folder of its own.
    tasks = [robot.task(os.path.abspath(folder)) for robot, folder in zip(robots, folders)]

    def lost(index, exc):  # the worker died under the robot, or could not run it at all
        return {**failed_row(tasks[index]), "message": f"its task did not finish: {type(exc).__name__}: {exc}"}

    finished = []

    def done(index, row):
        finished.append(index)
        if on_robot is not None:
            on_robot(row, len(finished), len(tasks))

    try:
        with parallel.executor(jobs=jobs, scheduler=scheduler) as chosen:
            rows = chosen.map(run_robot, tasks, on_done=done, on_error=lost)
            where, workers = chosen.description, chosen.workers
    finally:
        for folder in folders:  # what a worker killed in mid-write left
            for left in folder.glob(f".{MODEL_FILE}.*.partial"):
                left.unlink(missing_ok=True)
        for folder in created:  # a robot that failed before writing anything leaves no folder
            with contextlib.suppress(OSError):
                folder.rmdir()
    failed = sum(row["status"] != OK for row in rows)
    if rows and failed == len(rows):
        # No robot's work succeeded: nothing is written (outputs_together removes what was
        # made), and the one line says why, robot by robot.
        reasons = [f"{row['name']}: {row['message']}" for row in rows]
        more = f"; and {len(reasons) - 2} more" if len(reasons) > 2 else ""
        raise InputError(f"every robot of the fleet failed, nothing written ({'; '.join(reasons[:2])}{more})")
    summary_csv, summary_html = write_summary(out, rows, fleet_file)
    return FleetRun(fleet=str(fleet_file), out=str(out), ran_on=where, workers=workers, robots=rows,
                    ok=len(rows) - failed, failed=failed, summary_csv=summary_csv, summary_html=summary_html)



def _robot_folder(out, name):
    """DIR/<name>, refused when something there could lead writes out of DIR."""
    folder = out / name
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        raise InputError(f"{folder} is a symbolic link or a file: the fleet writes only into folders of its own "
                         f"inside {out}; remove it, or rename the robot")
    if folder.resolve().parent != out.resolve():  # cannot happen with a plain name; kept as the guarantee
        raise InputError(f"{folder} is not inside {out}: rename the robot")
    return folder


def _check_inputs_are_not_outputs(robots, folders, out, fleet_file):
    outputs = {Path(p).resolve() for p in (out / SUMMARY_CSV, out / SUMMARY_HTML)}
    for folder in folders:
        outputs |= {(folder / MODEL_FILE).resolve(), (folder / REPORT_FILE).resolve()}
    for robot in robots:
        for key in ("robot", "train", "test", "fixture"):
            given = getattr(robot, key)
            if given is not None and Path(given).resolve() in outputs:
                raise InputError(f"{fleet_file}: robot {robot.name}: {key} {given} is a file the fleet writes: "
                                 "move the input, or choose another --out")


def write_summary(out, rows, fleet_file):
    """DIR/summary.csv (SUMMARY_COLUMNS) and DIR/summary.html; returns their paths (str)."""
    text = csv_text(SUMMARY_COLUMNS, ([_cell(row[column]) for column in SUMMARY_COLUMNS] for row in rows),
                    "fleet-summary")
    csv_path, html_path = out / SUMMARY_CSV, out / SUMMARY_HTML
    write_text_atomic(csv_path, text)
    write_text_atomic(html_path, summary_html(rows, fleet_file))
    return str(csv_path), str(html_path)


def _cell(value):
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.4f}"
    return str(value)


def summary_html(rows, fleet_file):
    """The summary as one self-contained page: a row per robot, linking its report and model."""
    import datetime

    from .. import __version__
    from .report import STYLE

    failed = sum(row["status"] != OK for row in rows)
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    head = "".join(f"<th>{html.escape(column)}</th>" for column in SUMMARY_COLUMNS)
    body = []
    for row in rows:
        cells = []
        for column in SUMMARY_COLUMNS:
            text = html.escape(_cell(row[column]))
            if column == "name" and row["status"] == OK:
                folder = html.escape(row["name"], quote=True)
                text += (f" (<a href=\"{folder}/{REPORT_FILE}\">report</a>, "
                         f"<a href=\"{folder}/{MODEL_FILE}\">model</a>)")
            elif column == "status" and row["status"] != OK:
                text = f"<b style=\"color:#b00\">{text}</b>"
            numeric = column in ("n_train", "n_test", "mean_mm", "max_mm")
            cells.append(f"<td class=\"{'num' if numeric else ''}\">{text}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f"<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>robocal fleet</title><style>{STYLE}"
            f"</style></head><body><h1>Fleet summary</h1><p class=note>{html.escape(str(fleet_file))}: {len(rows)} "
            f"robots, {len(rows) - failed} ok, {failed} failed; mean and max are the error on the test file (mm), on "
            f"the training poses where a robot has none. Written {now} by robocal {html.escape(__version__)}.</p>"
            f"<table><tr>{head}</tr>{''.join(body)}</table></body></html>\n")


def fitted_content(model_path):
    """A model file's document without what differs between two runs of the same fit (when it
    was written, hence its checksum, and how long its steps took): a robot's model file is the
    same, so compared, whichever executor and worker fitted it."""
    def strip(value):
        if isinstance(value, dict):
            return {key: strip(entry) for key, entry in value.items() if not key.endswith("seconds")}
        return [strip(entry) for entry in value] if isinstance(value, list) else value

    document = load_json(model_path, "model file", "model", reader="model")
    return strip({key: value for key, value in document.items() if key not in ("created", "checksum")})
