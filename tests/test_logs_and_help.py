"""What a user reads in a pipe or an 80-column log: a long command's progress as plain lines
on stderr (robocal.interfaces.progress), one every few seconds, no control characters, at
most 79 columns, a line that says nothing new printed once, a warning raised again printed
once; --help that breaks no choice list inside a word and cuts off no text; messages that
name only options robocal has."""
import io
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from robocal.interfaces import progress as plain
from robocal.interfaces.cli import rendering

ROOT = Path(__file__).resolve().parents[1]


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def _run(steps, seconds_each, **fields):
    clock, stream = Clock(), io.StringIO()
    writer = plain.PlainProgress("comparing the methods, fit", 40, stream, clock)
    for step in range(steps):
        clock.now += seconds_each
        writer.advance(**{k: v(step) for k, v in fields.items()})
    writer.finish()
    return stream.getvalue().splitlines()


def test_a_long_run_prints_one_plain_line_every_few_seconds():
    lines = _run(40, 1.0, best=lambda k: 1.0 / (k + 1), last=lambda k: f"\x1b[31mfold {k}\x1b[0m\r")
    # 40 s: the first line after 5 s, then one every 5 s, and the last.
    assert 7 <= len(lines) <= 9, lines
    assert lines[-1].startswith("comparing the methods, fit: 40 of 40")  # said already: no "done" line
    assert all(len(line) <= 79 and not re.search(r"[\x00-\x1f\x7f]", line) for line in lines), lines
    assert "fold 39" in lines[-1] and "best 0.025" in lines[-1]


def test_a_short_run_prints_nothing_and_a_quiet_one_repeats_no_line():
    assert _run(10, 0.1) == []
    assert _run(4, 1.9)[-1] == "comparing the methods, fit: 4 of 40 (8 s) done"  # moved since its last line
    # Nothing new for 100 s (the count does not move): once, then again only after a minute.
    clock, stream = Clock(), io.StringIO()
    writer = plain.PlainProgress("fitting", None, stream, clock)
    for _ in range(100):
        clock.now += 1.0
        writer.advance(steps=0, best=0.5)
    assert len(stream.getvalue().splitlines()) == 2


def test_the_heartbeat_writes_the_line_due_inside_a_long_step():
    clock, stream = Clock(), io.StringIO()
    writer = plain.PlainProgress("design", None, stream, clock)
    clock.now = 1.0
    writer.advance(steps=0, stage="choosing 30 of 100000")  # too early for a line
    clock.now = 7.0
    writer.tick()  # seven seconds into one step that reports nothing more
    clock.now = 8.0
    writer.tick()  # a line was written a second ago: none due
    assert stream.getvalue().splitlines() == ["design: stage choosing 30 of 100000 (7 s)"]


def test_a_line_too_long_for_80_columns_is_cut():
    lines = _run(10, 1.0, last=lambda k: "x" * 300)
    assert lines and all(len(line) <= 79 for line in lines)


class Pipe(io.StringIO):
    """A stream with a file descriptor that is no terminal, as a pipe or a log file is."""

    def fileno(self):
        return 99

    def isatty(self):
        return False


def test_the_command_lines_progress_writes_plain_lines_where_stderr_is_no_terminal(monkeypatch):
    stream = Pipe()
    clock = Clock()
    monkeypatch.setattr(sys, "stderr", stream)
    monkeypatch.setattr(plain.time, "monotonic", clock)
    monkeypatch.setattr(plain, "HEARTBEAT_SECONDS", 3600.0)  # this test's clock is its own
    with rendering.progress("robots", 3) as advance:
        for k in range(3):
            clock.now += 10.0
            advance(last=f"r{k} ok")
    lines = stream.getvalue().splitlines()
    assert lines == [f"robots: {k} of 3  last r{k - 1} ok ({10 * k} s)" for k in (1, 2, 3)], lines


@pytest.mark.parametrize("command", ["design", "simulate", "calibrate", "compare", "fleet"])
def test_help_in_80_columns_breaks_no_choice_inside_a_word(command):
    result = subprocess.run([sys.executable, "-m", "robocal", command, "--help"], capture_output=True, text=True,
                            cwd=ROOT, env={**os.environ, "COLUMNS": "80", "PYTHONPATH": str(ROOT)}, timeout=120)
    text = result.stdout
    assert result.returncode == 0 and all(len(line) <= 80 for line in text.splitlines())
    flat = " ".join(line.strip("│ ") for line in text.splitlines())
    for choice in ("space-filling", "d-optimal", "soft_l1", "full+gains", "matern52"):
        if choice in flat.replace(" ", ""):
            assert choice in flat, choice
    if command in ("design", "simulate"):
        assert "…" not in text


def test_a_warning_raised_again_is_printed_once(monkeypatch):
    import importlib

    from robocal.errors import RobocalWarning

    app_module = importlib.import_module("robocal.interfaces.cli.app")

    said = []
    monkeypatch.setattr(app_module, "say", lambda label, style, message: said.append(str(message)))
    monkeypatch.setattr(app_module, "_warned", set())
    for fold in range(5):
        app_module._show_warning(RobocalWarning("joint 6 barely moves the TCP"), RobocalWarning, "x.py", fold)
    app_module._show_warning(RobocalWarning("another"), RobocalWarning, "x.py", 1)
    assert said == ["joint 6 barely moves the TCP", "another"]

    def command():
        app_module._show_warning(RobocalWarning("another"), RobocalWarning, "x.py", 1)

    app_module.user_errors(command)()  # the next command (in the same process) warns again
    assert said == ["joint 6 barely moves the TCP", "another", "another"]


def test_a_command_that_reports_stages_shows_them_without_a_count():
    clock, stream = Clock(), io.StringIO()
    writer = plain.PlainProgress("design", None, stream, clock)
    for stage in ("drawing candidates", "choosing 30 of 100000"):
        clock.now += 6.0
        writer.advance(steps=0, stage=stage)
    assert stream.getvalue().splitlines() == ["design: stage drawing candidates (6 s)",
                                              "design: stage choosing 30 of 100000 (12 s)"]


def test_every_option_a_message_names_is_a_real_option():
    import typer

    from robocal.interfaces.cli import app

    command = typer.main.get_command(app)
    options = {"--help", "--version"} | {option for sub in command.commands.values() for param in sub.params
                                         for option in param.opts + param.secondary_opts}
    named = {}
    for path in (ROOT / "robocal").rglob("*.py"):
        text = "\n".join(line for line in path.read_text().splitlines() if not line.lstrip().startswith("#"))
        for found in re.finditer(r"--[a-z][a-z0-9-]*[a-z0-9]", text):
            named.setdefault(found.group(), str(path.relative_to(ROOT)))
    assert {option: where for option, where in named.items() if option not in options} == {}


def test_a_stream_captured_in_process_gets_no_progress_lines(monkeypatch):
    stream = io.StringIO()  # a test runner's capture: no file descriptor
    monkeypatch.setattr(sys, "stderr", stream)
    with plain.plain_progress("fitting", 3) as advance:
        advance()
    assert not plain._is_file(stream) and plain._is_file(Pipe()) and stream.getvalue() == ""


def test_the_command_lines_progress_in_a_real_pipe_is_plain_lines():
    script = ("import time\n"
              "import robocal.interfaces.progress as p\n"
              "p.FIRST_LINE_SECONDS = p.INTERVAL_SECONDS = 0.0\n"
              "from robocal.interfaces.cli.rendering import progress\n"
              "with progress('comparing the methods, fit', 3) as advance:\n"
              "    for k in range(3):\n"
              "        advance(last=f'\\x1b[1mfold {k}\\x1b[0m')\n")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT, timeout=120,
                            env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert result.returncode == 0, result.stderr
    assert result.stderr.splitlines() == [f"comparing the methods, fit: {k} of 3  last fold {k - 1} (0 s)"
                                          for k in (1, 2, 3)], result.stderr
