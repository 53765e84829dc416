# ruff: noqa: E501  (one input per table row)
"""What a user sees in a pipe or an 80-column log. Help text that fits 80
columns without a word broken or an option name cut, command output without control
characters (carriage returns, escape sequences) or repeated lines, and a refusal that is one
line on stderr with nothing on stdout."""
import collections
import csv
import math
import re

import pytest
from typer.testing import CliRunner

from user_files import campaign, invoke, prepare, refuse, run_process
from robocal.interfaces.cli import app

VERBS = ["simulate", "calibrate", "evaluate", "compensate", "filter", "serve", "report", "export", "compare", "validate",
         "dataset", "design", "import", "iso9283", "demo", "fleet", "robots", "show", "methods", None]
BOX = re.compile(r"[│╭╮╰╯─┃┏┓┗┛━┌┐└┘├┤┬┴┼╇┡┩┳┻╋]")


def _help(verb, columns):
    args = [verb, "--help"] if verb else ["--help"]
    result = CliRunner().invoke(app, args, env={"COLUMNS": str(columns)})
    assert result.exit_code == 0
    return result.output


# An 80-column log, and a 60-column terminal: where the type column cannot hold its longest
# choice (full+compliance+gains), the type goes under the option's name ("--network /
# --no-network" joins an option's names there), so that no choice, name or word is broken.
@pytest.mark.parametrize("columns", [80, 60])
@pytest.mark.parametrize("verb", VERBS, ids=[v or "robocal" for v in VERBS])
def test_help_fits_the_terminal_without_a_broken_word(verb, columns):
    narrow, wide = _help(verb, columns), _help(verb, 1000)
    assert all(len(line) <= columns for line in narrow.splitlines())
    assert not [c for c in narrow if ord(c) < 32 and c != "\n"]
    words = lambda t: set(BOX.sub(" ", t).split())  # noqa: E731
    assert words(narrow) - {"/"} <= words(wide), sorted(words(narrow) - words(wide))
    # A <placeholder> the help's markdown took for a tag leaves an empty path segment behind.
    assert not re.search(r"[^:\s]//", narrow), [line for line in narrow.splitlines() if re.search(r"[^:\s]//", line)]


def _plain(lines):
    """The messages (warnings, notes), not the rows of a table; a note wrapped at the
    console's width (its later lines indented deeper) is one message."""
    messages, indents = [], []
    for line in lines:
        if not line.strip() or BOX.match(line.strip()[0]):
            continue
        indent = len(line) - len(line.lstrip(" "))
        if messages and indent >= indents[-1] + 2:
            messages[-1] += " " + line.strip()
        else:
            messages.append(line)
            indents.append(indent)
    return messages


RUNS = [
    ("simulate", ["simulate", "ur5", "--n", "30", "--seed", "4", "--out", "s.csv"]),
    ("calibrate", ["calibrate", "ur5", "ur5.csv", "--out", "o.json"]),
    ("calibrate-ann", ["calibrate", "ur5", "ur5.csv", "--method", "ann", "--generations", "5", "--hidden", "4,4", "--accept-extrapolation", "--out", "a.json"]),
    ("evaluate", ["evaluate", "ur5_model.json", "ur5.csv"]),
    ("compensate", ["compensate", "ur5_model.json", "targets.csv", "--out", "c.csv"]),
    ("design", ["design", "ur5", "--n", "12", "--pool", "200", "--out", "p.csv"]),
    ("validate", ["validate", "ur5", "ur5.csv", "--folds", "3"]),
    ("iso-plan", ["iso9283", "plan", "ur5", "--out", "i.csv"]),
    ("export", ["export", "ur5_model.json", "--out", "e.urdf"]),
    # Titles longer than the console (the console prints text unwrapped, titles too): wrapped.
    ("design-fixture", ["design", "kr150-2", "--fixture", "plate.toml", "--region", "1200,2000,-500,500,200,800", "--n", "72", "--out", "p.csv"]),
    ("design-long-name", ["design", "ur5", "--n", "12", "--pool", "200", "--out", "the-poses-to-measure-on-the-second-day-of-the-campaign.csv"]),
    # hostile pass 5: what an 80-column log of the printing verbs, a URDF export and unreachable targets holds
    ("show-kr150", ["show", "kr150-2"]),
    ("show-iiwa14", ["show", "iiwa14"]),
    ("show-ur10", ["show", "ur10"]),
    ("robots", ["robots"]),
    ("methods", ["methods"]),
    ("export-kr150-urdf", ["export", "kr_model.json", "--format", "urdf", "--out", "r.urdf"]),
]


@pytest.mark.parametrize("args", [r[1] for r in RUNS], ids=[r[0] for r in RUNS])
def test_output_in_a_pipe_has_no_control_characters_or_repeated_lines(tmp_path, args):
    prepare(tmp_path)
    outcome = invoke(tmp_path, args)
    assert outcome.code == 0, outcome.output
    assert not [c for c in outcome.output if ord(c) < 32 and c != "\n"]
    repeated = [line for line, n in collections.Counter(_plain(outcome.lines)).items() if n > 1]
    assert repeated == []
    # An 80-column log: the result's notes wrap and its tables fit (a pipe's console is 80
    # columns wide); stderr's one-line notes, warnings and errors stay one line each.
    said = ("note:", "warning:", "error:")
    assert [line for line in outcome.lines if len(line) > 80 and not line.startswith(said)] == []


def test_refusal_in_a_pipe_is_one_line_on_stderr(tmp_path):
    prepare(tmp_path)
    done = run_process(tmp_path, ["calibrate", "ur5", "cmds.csv", "--out", "o.json"])
    assert done.returncode == 2 and done.stdout == ""
    assert len(done.stderr.splitlines()) == 1 and done.stderr.startswith("error: cmds.csv")


def test_a_kriging_calibration_does_not_repeat_its_folds_warnings(tmp_path):
    # The held-out folds (the error to expect, the 95 % bound) predict poses outside each
    # fold's own training box: those are not the user's targets, and were printed 9 times.
    # The data made in this process (the same file); the calibration is the process watched.
    assert invoke(tmp_path, ["simulate", "ur5", "--n", "60", "--seed", "1", "--out", "u.csv"]).code == 0
    done = run_process(tmp_path, ["calibrate", "ur5", "u.csv", "--method", "kriging", "--accept-extrapolation",
                                  "--out", "k.json"], timeout=120)
    assert done.returncode == 0, done.stderr
    assert "training box" not in done.stderr


def test_radian_joints_of_position_data_are_refused_in_one_line_not_warned_first(tmp_path):
    # The robot judges the units of position data (robocal.io.units): the reader's own guess
    # from the joint values alone said the same thing a line before the refusal.
    assert invoke(tmp_path, ["simulate", "ur5", "--n", "40", "--seed", "1", "--out", "u.csv"]).code == 0
    with open(tmp_path / "u.csv", newline="") as stream:
        rows = list(csv.reader(stream))
    header = rows[0]
    with open(tmp_path / "rad.csv", "w", newline="") as stream:
        csv.writer(stream).writerows([header] + [[repr(math.radians(float(v))) if c.startswith("q") else v
                                                  for c, v in zip(header, row)] for row in rows[1:]])
    done = run_process(tmp_path, ["calibrate", "ur5", "rad.csv", "--out", "r.json"])
    assert done.returncode != 0 and "look like radians" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert not (tmp_path / "r.json").exists()


def test_a_reader_that_stops_early_does_not_cost_the_model(tmp_path):
    """``robocal calibrate ... | head -1``: the pipe closes after one line; the command goes on,
    writes its model, and says nothing of the closed pipe."""
    import os
    import subprocess
    import sys

    from user_files import REPO

    prepare(tmp_path)
    environment = dict(os.environ, PYTHONPATH=str(REPO), COLUMNS="80")
    process = subprocess.Popen([sys.executable, "-m", "robocal", "calibrate", "ur5", "ur5.csv", "--out", "m.json"],
                               cwd=tmp_path, env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    process.stdout.readline()
    process.stdout.close()  # as head does after its line
    stderr = process.stderr.read().decode()
    assert process.wait(timeout=120) == 0, stderr
    assert "Traceback" not in stderr and "pipe" not in stderr.lower(), stderr
    assert (tmp_path / "m.json").stat().st_size > 0


@pytest.mark.parametrize("env", [{"PYTHONIOENCODING": "ascii"}, {"LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0"}],
                         ids=["ascii-stream", "c-locale"])
@pytest.mark.parametrize("args", [["show", "kr150-2"], ["calibrate", "ur5", "ur5.csv", "--out", "m.json"]],
                         ids=["show", "calibrate"])
def test_a_stream_without_utf8_gets_the_output_not_a_traceback(tmp_path, env, args):
    prepare(tmp_path)
    result = run_process(tmp_path, args, timeout=120, env=env)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr
    assert result.stdout.strip()


def _rows(name, change):
    """The base file ``name`` with its data rows replaced by ``change(rows)``."""
    def make(base):
        header, *rows = (base / name).read_text().splitlines()
        return "\n".join([header, *change(rows)]) + "\n"
    return make


# Data a reader warns about (identical rows) and a verb then refuses: the refusal is the one
# line, the reader's warning is not printed before it (robocal.interfaces.cli.app.held_warnings).
SAME_ROW = _rows("ur5.csv", lambda rows: [rows[0]] * 40)
WARNED_THEN_REFUSED = [
    ("calibrate", ["calibrate", "ur5", "s.csv", "--out", "o.json"], "1 distinct poses"),
    ("calibrate-kriging", ["calibrate", "ur5", "s.csv", "--method", "kriging", "--out", "o.json"], "1 distinct pose(s)"),
    ("calibrate-auto", ["calibrate", "ur5", "s.csv", "--method", "auto", "--out", "o.json"], "measure poses spread over the workspace"),
    ("compare", ["compare", "ur5", "s.csv"], "measure poses spread over the workspace"),
    ("validate", ["validate", "ur5", "s.csv", "--folds", "3"], "1 distinct poses"),
    ("reregister", ["calibrate", "ur5_model.json", "s.csv", "--method", "frames", "--out", "o.json"], "1 distinct pose(s)"),
    ("tagged-radians-beyond-limits", ["calibrate", "ur5", "r.csv", "--out", "o.json"], "lies beyond joint"),
]


@pytest.mark.parametrize("args, says", [r[1:] for r in WARNED_THEN_REFUSED], ids=[r[0] for r in WARNED_THEN_REFUSED])
def test_data_warned_about_and_then_refused_give_the_refusal_alone(tmp_path, args, says):
    # r.csv: identical rows too, and joint values tagged radians that are degrees (refused
    # by the joint limits after the reader has read, and warned of, the repeats).
    tagged = _rows("ur5.csv", lambda rows: rows + rows[:3])
    files = {"s.csv": SAME_ROW,
             "r.csv": lambda base: tagged(base).replace("q1,q2,q3,q4,q5,q6", ",".join(f"q{k}[rad]" for k in range(1, 7)), 1)}
    refuse(tmp_path, args, files, says)


def _repeated(make, count):
    """The file ``make`` gives with its first ``count`` data rows written again at its end."""
    def repeated(base):
        header, *rows = make(base).splitlines()
        return "\n".join([header, *rows, *rows[:count]]) + "\n"
    return repeated


# Rows exported twice, to every written decimal: every reader of measured rows warns once (the
# one implementation, robocal.io.tables.warn_about_identical_rows), and the data are used.
REPEATED_MEASUREMENTS = _repeated(lambda base: (base / "ur5.csv").read_text(), 3)
REPEATED_CAMPAIGN = _repeated(campaign(), 5)
WARNED_AND_ACCEPTED = [
    ("calibrate", ["calibrate", "ur5", "d.csv", "--out", "o.json"], REPEATED_MEASUREMENTS, "rows 2 and 62"),
    ("evaluate", ["evaluate", "ur5_model.json", "d.csv"], REPEATED_MEASUREMENTS, "rows 2 and 62"),
    ("evaluate-json", ["evaluate", "ur5_model.json", "d.csv", "--json"], REPEATED_MEASUREMENTS, "rows 2 and 62"),
    ("report", ["report", "ur5_model.json", "d.csv", "--out", "r.html"], REPEATED_MEASUREMENTS, "rows 2 and 62"),
    ("iso9283", ["iso9283", "d.csv"], REPEATED_CAMPAIGN, "5 groups of rows are identical (rows 2 and 152;"),
    ("iso9283-json", ["iso9283", "d.csv", "--json"], REPEATED_CAMPAIGN, "5 groups of rows are identical (rows 2 and 152;"),
]


@pytest.mark.parametrize("args, content, says", [r[1:] for r in WARNED_AND_ACCEPTED],
                         ids=[r[0] for r in WARNED_AND_ACCEPTED])
def test_data_warned_about_and_accepted_still_show_the_warning_once(tmp_path, args, content, says):
    prepare(tmp_path, {"d.csv": content})
    outcome = invoke(tmp_path, args)
    assert outcome.code == 0, outcome.output
    warned = [line for line in outcome.lines if "are identical" in line]
    assert len(warned) == 1 and says in warned[0], outcome.lines


def test_a_held_warning_is_printed_before_the_result_in_a_pipe(tmp_path):
    prepare(tmp_path, {"d.csv": _rows("ur5.csv", lambda rows: rows + rows[:3])})
    done = run_process(tmp_path, ["evaluate", "ur5_model.json", "d.csv"], env={"PYTHONUNBUFFERED": "1"},
                       stderr_into_stdout=True)
    assert done.returncode == 0, done.stdout
    lines = done.stdout.splitlines()
    warned = [k for k, line in enumerate(lines) if "are identical" in line]
    assert len(warned) == 1 and warned[0] < min(k for k, line in enumerate(lines) if BOX.search(line)), lines


def _option_names():
    """(command, every name of its options: --accept-extrapolation, --no-network, ...)."""
    import typer

    group = typer.main.get_command(app)
    for name in sorted(group.commands):
        params = group.commands[name].params
        yield name, sorted({opt for p in params for opt in (*p.opts, *p.secondary_opts) if opt.startswith("-")})


OPTION_NAMES = list(_option_names())


@pytest.mark.parametrize("verb, names", OPTION_NAMES, ids=[row[0] for row in OPTION_NAMES])
def test_help_in_80_columns_shows_every_option_name_whole(verb, names):
    shown = set(BOX.sub(" ", _help(verb, 80)).replace(",", " ").split())
    cut = [name for name in names if name not in shown]
    assert cut == [], cut
    assert "…" not in _help(verb, 80)


# Tables wider than the line: every number printed whole (rich cut them to "-424…"), the
# table within the line: without its borders, or in parts that each repeat the row's label.
TABLES = [
    ("show-exported-robot", ["show", "ur5_cal.toml"]),  # export's calibrated UR5: 4 decimals everywhere
    ("show-dataset-b-robot", ["show", "b.toml"]),
    ("show-builtin-panda", ["show", "panda"]),
    ("calibrate-parameters", ["calibrate", "ur5", "ur5.csv", "--out", "o.json"]),
    ("design-standard-errors", ["design", "ur5", "--n", "12", "--pool", "200", "--out", "p.csv"]),
    ("evaluate", ["evaluate", "ur5_model.json", "ur5.csv"]),
    # a word wider than the line (a file name of 90 characters): folded, never cut to "…"
    ("compensate-long-file-name", ["compensate", "ur5_model.json", "targets.csv", "--out", "commands-for-cell-4-" + "x" * 66 + ".csv"]),
]
NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def _printed(tmp_path, args, columns, monkeypatch):
    from robocal.interfaces.cli import rendering

    monkeypatch.setattr(rendering.out, "_width", columns)  # the console's width, read at import
    outcome = invoke(tmp_path, args)
    assert outcome.code == 0, outcome.output
    return [line for line in outcome.result.stdout.splitlines() if line.strip()]


@pytest.mark.parametrize("columns", [80, 60])
@pytest.mark.parametrize("args", [r[1] for r in TABLES], ids=[r[0] for r in TABLES])
def test_a_table_wider_than_the_line_prints_every_number_whole(tmp_path, monkeypatch, args, columns):
    prepare(tmp_path)
    if "b.toml" in args:
        assert invoke(tmp_path, ["dataset", "ipa-ur10-b", "--out", "b"]).code == 0
    wide = _printed(tmp_path, args, 1000, monkeypatch)
    narrow = _printed(tmp_path, args, columns, monkeypatch)
    assert not [line for line in narrow if "…" in line], narrow
    # (a note keeps a file name whole on a line of its own, however long)
    assert [line for line in narrow if len(line.rstrip()) > columns and " " in line.strip()] == [], narrow
    numbers = lambda lines: collections.Counter(NUMBER.findall("\n".join(lines)))  # noqa: E731
    missing = numbers(wide) - numbers(narrow)  # a table in parts repeats its labels: more, never fewer
    assert not missing, (sorted(missing), narrow)


# A summary's vectors print every component: the messages' "said once" joining dropped a
# repeated 0.0, so rpy (180, 0, 0) printed as "180.0, 0.0".
VECTORS = [
    ("iso-plan-default-rpy", ["iso9283", "plan", "ur10", "--cycles", "2", "--out", "i.csv"], "rpy deg", "180.0, 0.0, 0.0"),
    ("iso-plan-rpy-one-zero", ["iso9283", "plan", "ur10", "--cycles", "2", "--rpy", "180,0,30", "--out", "i.csv"], "rpy deg", "180.0, 0.0, 30.0"),
]


@pytest.mark.parametrize("args, row, says", [r[1:] for r in VECTORS], ids=[r[0] for r in VECTORS])
def test_a_vector_in_a_summary_prints_every_component(tmp_path, args, row, says):
    outcome = invoke(tmp_path, args)
    assert outcome.code == 0, outcome.output
    printed = [line for line in outcome.lines if row in line]
    assert len(printed) == 1 and says in printed[0], outcome.lines


def test_messages_saying_the_same_are_still_joined_but_numbers_are_not():
    from robocal.interfaces.cli.rendering import cell

    assert cell(["output 1: s", "output 2: s"]) == "outputs 1, 2: s"
    assert cell([0.0, 0.0, 0.0]) == "0.0, 0.0, 0.0"
    assert cell([400, 0, 0]) == "400, 0, 0"
