"""The command line's conventions: flags are flags, choices are listed and checked where they
are parsed, every message names the option the user typed, usage errors are one line, and
Ctrl-C / SIGTERM leave no half-written file behind."""
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from robocal.estimation.calibration import LOSSES, PARAMETER_SETS
from robocal.estimation.constraint import PAIRINGS
from robocal.estimation.kriging import CORRELATIONS, REGRESSIONS
from robocal.interfaces.cli import app
from robocal.interfaces.jobs import DATASETS, EXPORT_FORMATS
from robocal.kinematics.chain import CONVENTIONS
from robocal.methods import method_names
from robocal.methods.ann import BASE_MODELS, REFINERS, TRAINERS
from robocal.methods.base import REGISTER_CHOICES

runner = CliRunner()
# COLUMNS only: typer reads TERMINAL_WIDTH once, when its help module is first imported, so a
# TERMINAL_WIDTH set here would fix every later help in the run at this width.
WIDE = {"COLUMNS": "250"}
COMMANDS = sorted(typer.main.get_command(app).commands)
ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def _one_line_error(result, *fragments):
    """Exit 2, one line on the console, no traceback and no box, naming every fragment."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and "╭" not in result.output, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    return lines[0]


# --------------------------------------------------------------------------- help
@pytest.mark.parametrize("name", COMMANDS)
def test_help_shows_flags_as_flags(name):
    result = runner.invoke(app, [name, "--help"], env=WIDE)
    assert result.exit_code == 0, result.output
    assert "<bool>" not in result.output
    assert "--debug" in result.output and "--help" in result.output


def test_main_help_shows_flags_as_flags():
    result = runner.invoke(app, ["--help"], env=WIDE)
    assert result.exit_code == 0 and "<bool>" not in result.output and "--version" in result.output


@pytest.mark.parametrize("name, choices", [
    ("calibrate", [method_names() + ("auto", "frames"), REGISTER_CHOICES, REGRESSIONS, CORRELATIONS,
                   PARAMETER_SETS + ("frames", "frames+offsets"), LOSSES, TRAINERS, REFINERS, BASE_MODELS, PAIRINGS]),
    ("validate", [method_names(), REGISTER_CHOICES, PARAMETER_SETS, LOSSES, PAIRINGS]),
    ("export", [EXPORT_FORMATS, CONVENTIONS]),
    ("simulate", [("joint", "lhs", "grid", "sockets")]),
])
def test_help_lists_the_choices(name, choices):
    result = runner.invoke(app, [name, "--help"], env=WIDE)
    assert result.exit_code == 0, result.output
    for values in choices:
        assert "<" + " | ".join(values) + ">" in result.output, values


# --------------------------------------------------------------------------- flags and --debug anywhere
def test_json_flag_after_the_arguments(ur5_files, tmp_path):
    out = tmp_path / "m.json"
    result = runner.invoke(app, ["calibrate", "ur5", str(ur5_files / "meas.csv"), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["method"] == "kinematic"
    result = runner.invoke(app, ["evaluate", str(out), str(ur5_files / "meas.csv"), "--json"])
    assert result.exit_code == 0 and "nominal" in json.loads(result.output)


def test_a_flag_takes_no_value(ur5_files, tmp_path):
    result = runner.invoke(app, ["evaluate", str(ur5_files / "model.json"), str(ur5_files / "meas.csv"), "--json",
                                 "true"])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) <= 2


@pytest.mark.parametrize("where", ["before", "after"])
def test_debug_before_or_after_the_command_shows_the_traceback(where):
    args = ["--debug", "show", "kr16"] if where == "before" else ["show", "kr16", "--debug"]
    result = runner.invoke(app, args)
    assert result.exit_code == 1 and result.exception is not None
    assert "no built-in robot named 'kr16'" in str(result.exception)
    plain = runner.invoke(app, ["show", "kr16"])  # and the next command is not in debug mode
    _one_line_error(plain, "no built-in robot named 'kr16'")


# --------------------------------------------------------------------------- wrong choices
CHOICE_CASES = [
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "magic"], "--method", method_names()),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--register", "maybe"], "--register", REGISTER_CHOICES),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "kriging", "--trend", "cubic"], "--trend",
     REGRESSIONS),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "kriging", "--correlation", "exp"], "--correlation",
     CORRELATIONS),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--parameters", "some"], "--parameters", PARAMETER_SETS),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--loss", "cauchy"], "--loss", LOSSES),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "ann", "--trainer", "sgd"], "--trainer", TRAINERS),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "ann", "--refine", "adam"], "--refine", REFINERS),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "ann", "--base-model", "x"], "--base-model",
     BASE_MODELS),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--pairs", "some"], "--pairs", PAIRINGS),
    (["validate", "ur5", "{meas}", "--method", "magic"], "--method", method_names()),
    (["validate", "ur5", "{meas}", "--loss", "cauchy"], "--loss", LOSSES),
    (["export", "{model}", "--out", "{out}", "--format", "xml"], "--format", EXPORT_FORMATS),
    (["export", "{model}", "--out", "{out}", "--convention", "sdh"], "--convention", CONVENTIONS),
    (["simulate", "ur5", "--out", "{out}", "--sampling", "sobol"], "--sampling", ("joint", "lhs", "grid", "sockets")),
    (["simulate", "ur5", "--out", "{out}", "--errors", "huge"], "--errors", ("none", "typical", "liu2022")),
    (["dataset", "kuka-secret", "--out", "{out}"], "dataset", tuple(DATASETS)),
]


def _fill(args, folder, out):
    return [a.format(meas=folder / "meas.csv", model=folder / "model.json", out=out) for a in args]


@pytest.mark.parametrize("args, option, allowed", CHOICE_CASES, ids=[c[1] + "-" + c[0][0] for c in CHOICE_CASES])
def test_a_wrong_choice_is_one_line_naming_the_option_and_the_choices(ur5_files, tmp_path, args, option, allowed):
    out = tmp_path / "out"
    line = _one_line_error(runner.invoke(app, _fill(args, ur5_files, out)), f"{option} must be one of",
                           ", ".join(allowed), "is not available")
    assert not line.startswith("error: Invalid")
    assert os.listdir(tmp_path) == []


def test_a_truth_file_is_still_accepted_by_errors(tmp_path):
    truth, meas = tmp_path / "truth.json", tmp_path / "meas.csv"
    assert runner.invoke(app, ["simulate", "ur5", "--n", "10", "--out", str(meas), "--truth",
                               str(truth)]).exit_code == 0
    result = runner.invoke(app, ["simulate", "ur5", "--n", "10", "--errors", str(truth), "--out",
                                 str(tmp_path / "again.csv")])
    assert result.exit_code == 0, result.output


# --------------------------------------------------------------------------- bad numbers
NUMBER_CASES = [
    (["validate", "ur5", "{meas}", "--folds", "1"], "--folds must be a whole number >= 2, got '1'"),
    (["validate", "ur5", "{meas}", "--folds", "abc"], "--folds must be a whole number >= 2, got 'abc'"),
    (["validate", "ur5", "{meas}", "--folds", "100"], "--folds 100 folds need at least 100 poses"),
    (["validate", "ur5", "{meas}", "--sizes", "10,2.5"], "--sizes must be comma-separated whole numbers"),
    (["validate", "ur5", "{meas}", "--seed", "-1"], "--seed must be a whole number >= 0"),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "kriging", "--nugget", "abc"],
     "--nugget must be 'estimate' or a number >= 0, got 'abc'"),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "kriging", "--nugget", "-1"],
     "--nugget must be 'estimate' or a number >= 0"),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "kriging", "--seed", "-1"],
     "--seed must be a whole number >= 0"),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--parameters", "full+compliance", "--payload", "-2"],
     "--payload must be a number >= 0"),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "ann", "--hidden", "16"],
     "--hidden must be at least 2 comma-separated whole numbers >= 1"),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "ann", "--hidden", "16,x"], "--hidden must be"),
    (["calibrate", "ur5", "{meas}", "--out", "{out}", "--method", "ann", "--generations", "-1"],
     "--generations must be a whole number >= 0"),
    (["simulate", "ur5", "--out", "{out}", "--n", "0"], "--n must be a whole number >= 1"),
    (["simulate", "ur5", "--out", "{out}", "--noise", "nan"], "--noise must be a number >= 0"),
    (["simulate", "ur5", "--out", "{out}", "--box", "1,2"], "--box must be 6 comma-separated numbers, got '1,2'"),
    (["simulate", "ur5", "--out", "{out}", "--joint-noise", "-1"], "--joint-noise must be a number >= 0"),
    (["simulate", "ur5", "--out", "{out}", "--per-socket", "1"], "--per-socket must be a whole number >= 2"),
    (["dataset", "ur5-tsinghua", "--out", "{out}", "--split", "1.5"], "--split must be a number between 0 and 1"),
]


@pytest.mark.parametrize("args, message", NUMBER_CASES, ids=[m.split()[0] + "-" + a[-1] for a, m in NUMBER_CASES])
def test_a_bad_number_is_one_line_naming_the_option(ur5_files, tmp_path, args, message):
    _one_line_error(runner.invoke(app, _fill(args, ur5_files, tmp_path / "out")), message)
    assert os.listdir(tmp_path) == []


# --------------------------------------------------------------------------- usage errors
@pytest.mark.parametrize("args, message", [
    (["calibrate", "ur5"], "missing argument"),
    (["calibrate", "ur5", "meas.csv"], "missing option '--out'"),
    (["calibrate", "ur5", "meas.csv", "--out", "m.json", "--colour", "red"], "--colour"),
    (["calibrat"], "calibrate"),
])
def test_usage_errors_are_one_line_and_the_usage(args, message):
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and "╭" not in result.output, result.output
    lines = result.output.strip().splitlines()
    assert 1 <= len(lines) <= 2 and lines[0].startswith("error: ") and message in lines[0], result.output


# --------------------------------------------------------------------------- interrupted writes
def _child_env():
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}


def _default_sigint():  # as on a terminal, even if the test runner's parent ignores Ctrl-C
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(args, cwd):
    return subprocess.Popen([sys.executable, *args], cwd=cwd, env=_child_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_default_sigint)


def _wait_for_temporary(process, folder, name, timeout=60.0):
    """The temporary file of an atomic write of ``name``, once it appears (None if the process
    ended first)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = [p for p in folder.iterdir() if p.name.startswith(f".{name}.") and p.name.endswith(".tmp")]
        if found:
            return found[0]
        if process.poll() is not None:
            return None
        time.sleep(0.001)
    process.kill()
    pytest.fail(f"no temporary file for {name} within {timeout} s")


SLOW_WRITER = textwrap.dedent("""
    import sys, time
    from robocal.interfaces.cli import interruptible
    from robocal.io.atomic import write_bytes_atomic

    def chunks():  # a write that would never end: only a signal stops it
        while True:
            yield b"x" * 65536
            time.sleep(0.005)

    with interruptible():
        write_bytes_atomic(sys.argv[1], chunks())
""")

posix_only = pytest.mark.skipif(os.name != "posix", reason="sends POSIX signals")


@posix_only
@pytest.mark.parametrize("signum, status", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
@pytest.mark.parametrize("previous", [None, "old content\n"])
def test_an_interrupted_write_leaves_nothing_and_says_so(tmp_path, signum, status, previous):
    script, target = tmp_path / "writer.py", tmp_path / "big.csv"
    script.write_text(SLOW_WRITER)
    if previous is not None:
        target.write_text(previous)
    process = _start([str(script), str(target)], tmp_path)
    temporary = _wait_for_temporary(process, tmp_path, "big.csv")
    assert temporary is not None, process.communicate()
    time.sleep(0.05)  # a few chunks in
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == status, stderr
    assert stderr.strip().splitlines() == [
        f"interrupted: {target} was left as it was" if previous else f"interrupted: nothing was written to {target}"]
    assert sorted(p.name for p in tmp_path.iterdir()) == (["big.csv", "writer.py"] if previous else ["writer.py"])
    if previous:
        assert target.read_text() == previous


@posix_only
def test_sigterm_during_simulate_writes_nothing_half(tmp_path):
    """The real command: SIGTERM while simulate writes a large measurement file."""
    target = tmp_path / "big.csv"
    process = _start(["-m", "robocal.interfaces.cli", "simulate", "kr150-2", "--n", "60000", "--out", str(target)],
                     tmp_path)
    temporary = _wait_for_temporary(process, tmp_path, "big.csv")
    if temporary is None:  # the write was over before the poll saw it: nothing to interrupt
        process.communicate(timeout=60)
        assert process.returncode == 0
        pytest.skip("the write finished between two polls")
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 143, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("interrupted"), stderr
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    if lines[0] == f"interrupted: nothing was written to {target}":
        assert not target.exists()
    else:  # the signal came after the rename: the whole file is there
        assert lines[0] == "interrupted" and len(target.read_text().splitlines()) == 60001


def _catches_sigterm(pid):
    """Whether the process has installed a SIGTERM handler (Linux: /proc/PID/status)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("SigCgt:"):
            return bool(int(line.split()[1], 16) >> (signal.SIGTERM - 1) & 1)
    return False


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads /proc/PID/status")
def test_ctrl_c_before_any_write_says_interrupted(tmp_path):
    """Ctrl-C while a command parses or computes: one line and status 130, no file."""
    target = tmp_path / "big.csv"
    process = _start(["-m", "robocal.interfaces.cli", "simulate", "kr150-2", "--n", "300000", "--out",
                      str(target)], tmp_path)
    deadline = time.monotonic() + 60
    while not _catches_sigterm(process.pid):  # robocal's handlers are installed
        assert process.poll() is None and time.monotonic() < deadline, process.communicate()
        time.sleep(0.01)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    assert stderr.strip().splitlines() in (["interrupted"], [f"interrupted: nothing was written to {target}"])
    assert list(tmp_path.iterdir()) == []


def test_terminal_tables_show_no_python_reprs(tmp_path, monkeypatch):
    # The output named relative to the folder: an absolute temporary path of 70 characters
    # leaves the table's labels too little of 80 columns, and they wrap ("unreachable / rows").
    monkeypatch.chdir(tmp_path)
    meas = tmp_path / "m.csv"
    result = runner.invoke(app, ["simulate", "ur5", "--n", "30", "--out", str(meas)])
    assert result.exit_code == 0 and "None" not in result.output and "true error" in result.output
    model = tmp_path / "m.json"
    assert runner.invoke(app, ["calibrate", "ur5", str(meas), "--out", str(model)]).exit_code == 0
    result = runner.invoke(app, ["compensate", str(model), str(EXAMPLES / "ur5-targets.csv"), "--out",
                                 "c.csv"])
    assert result.exit_code == 0 and "[]" not in result.output and "unreachable rows" in result.output
