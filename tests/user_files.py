"""The files a user has after the README's first steps, made once per run (simulated,
calibrated, compensated, evaluated, designed, reported, exported, as a new user would make
them with the CLI), and one way to run a command on a copy of them and judge the outcome: a
clean refusal (non-zero exit, one line, no traceback, nothing written) or a correct answer.
Shared by the tables of inputs a user could give: broken files, wrong units, the wrong kind of
file, too few poses, unreachable plans, unwritable outputs, unbounded work, pipes.

The inputs of these tables were written from the README and each verb's --help, without
reading robocal's source; each row is an input a user could plausibly give."""
import atexit
import csv
import functools
import io
import math
import os
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

from typer.testing import CliRunner

import once_per_run
from robocal.interfaces.cli import app

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
runner = CliRunner()


def _ok(*args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result


@functools.cache
def base_files():
    """A folder of the files a user has after the README's first steps (read-only for the
    tables: each row runs in a copy), made once per run (:mod:`once_per_run`)."""
    return once_per_run.made_once("user-files", _make_base_files, _new_folder)


def _new_folder():
    root = Path(tempfile.mkdtemp(prefix="robocal-user-files-"))
    atexit.register(shutil.rmtree, root, True)
    return root


def _make_base_files(root):
    old = os.getcwd()
    os.chdir(root)
    try:
        shutil.copy(EXAMPLES / "plate-fixture.toml", "plate.toml")
        shutil.copy(EXAMPLES / "ur5-targets.csv", "targets.csv")
        _ok("simulate", "ur5", "--n", "60", "--errors", "typical", "--seed", "1",
            "--out", "ur5.csv", "--truth", "ur5_truth.json")
        _ok("simulate", "kr150-2", "--n", "60", "--errors", "typical", "--seed", "2", "--out", "kr.csv")
        _ok("calibrate", "ur5", "ur5.csv", "--out", "ur5_model.json")
        _ok("calibrate", "kr150-2", "kr.csv", "--out", "kr_model.json")
        _ok("compensate", "ur5_model.json", "targets.csv", "--out", "cmds.csv")
        _ok("evaluate", "ur5_model.json", "ur5.csv", "--per-pose", "perpose.csv")
        _ok("design", "ur5", "--n", "12", "--pool", "300", "--out", "plan.csv")
        _ok("simulate", "kr150-2", "--sampling", "sockets", "--fixture", "plate.toml",
            "--placements", "4", "--per-socket", "6", "--out", "sockets.csv")
        _ok("calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "plate.toml",
            "--out", "sock_model.json")
        _ok("report", "ur5_model.json", "ur5.csv", "--out", "report.html")
        _ok("export", "ur5_model.json", "--out", "ur5_cal.toml")
        _ok("export", "ur5_model.json", "--out", "ur5_cal.urdf")
        _ok("iso9283", "plan", "ur5", "--out", "iso.csv")
    finally:
        os.chdir(old)
    for path in root.iterdir():
        path.chmod(0o444)


def nominal_fk(base, form="{!r}", noise_mm=0.0):
    """ur5.csv's joints with the nominal UR5's own TCP positions (plus Gaussian ``noise_mm``)
    as x, y, z, each number written with ``form``: what a targets generator writes."""
    import numpy as np

    from robocal.io.library import load_robot

    chain = load_robot("ur5")
    lines = (base / "ur5.csv").read_text().splitlines()
    joints = np.array([[float(v) for v in line.split(",")[:6]] for line in lines[1:]])
    positions = chain.fk_positions(chain.joints_from_file(joints))
    positions = positions + np.random.default_rng(0).normal(0.0, noise_mm, positions.shape)
    rows = [",".join(form.format(float(v)) for v in [*q, *p]) for q, p in zip(joints, positions)]
    return "q1,q2,q3,q4,q5,q6,x,y,z\n" + "\n".join(rows) + "\n"


def campaign(factor_cmd=1.0, factor_measured=1.0, angles=None, angles_cmd=1.0, rpy=None):
    """An ISO 9283 campaign from the base plan (iso.csv): each visit measured 0.1 mm beside its
    command (seeded), the commanded and measured positions times the factors; ``angles``: the
    measured rx, ry, rz too, 0.05 deg beside the command (within +-180), times ``angles``, and
    the commanded ones times ``angles_cmd``; ``rpy``: the commanded angles (deg) instead of
    the plan's."""
    def make(base):
        rows = list(csv.reader(io.StringIO((base / "iso.csv").read_text())))
        header = rows[0]
        k = [header.index(c) for c in ("x_cmd", "y_cmd", "z_cmd")]
        a = [header.index(c) for c in ("rx_cmd", "ry_cmd", "rz_cmd")]
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(header + ["x", "y", "z"] + (["rx", "ry", "rz"] if angles is not None else []))
        for n, row in enumerate(rows[1:]):
            if rpy is not None:
                for i, value in zip(a, rpy):
                    row[i] = repr(float(value))
            wobble = [0.1 * math.sin(n * 7 + j) for j in range(3)]
            measured = [repr((float(row[i]) + w) * factor_measured) for i, w in zip(k, wobble)]
            if angles is not None:
                measured += [repr(((float(row[i]) + 0.05 * math.cos(n * 5 + j) + 180) % 360 - 180) * angles)
                             for j, i in enumerate(a)]
            writer.writerow([repr(float(v) * factor_cmd) if i in k else repr(float(v) * angles_cmd) if i in a else v
                             for i, v in enumerate(row)] + measured)
        return out.getvalue()
    return make


def text(name):
    return (base_files() / name).read_text()


def prepare(folder, files=None):
    """Copy the base files into ``folder`` and write ``files`` (name -> str, bytes, or a
    callable of the base folder giving either; a name with a folder makes the folder)."""
    folder = Path(folder)
    for path in base_files().iterdir():
        shutil.copy(path, folder / path.name)
        (folder / path.name).chmod(0o644)
    for name, content in (files or {}).items():
        if callable(content):
            content = content(base_files())
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            (folder / name).write_bytes(content)
        else:
            with open(folder / name, "w", newline="") as stream:
                stream.write(content)
    return folder


class Outcome:
    def __init__(self, result, lines, new):
        self.result, self.lines, self.new = result, lines, new
        self.code = result.exit_code
        self.output = result.output


def invoke(folder, args):
    """Run ``robocal ARGS`` in ``folder``; the outcome with every line a user would read
    (robocal's warnings included) and the files it left."""
    folder = Path(folder)
    before = {p.name for p in folder.iterdir()}
    old = os.getcwd()
    os.chdir(folder)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = runner.invoke(app, [str(a) for a in args])
    finally:
        os.chdir(old)
    lines = [line for line in result.output.splitlines() if line.strip()]
    lines += [f"warning: {w.message}" for w in caught if "robocal" in str(w.filename)]
    new = sorted({p.name for p in folder.iterdir()} - before)
    return Outcome(result, lines, new)


def assert_clean_refusal(outcome, says):
    out = outcome.output
    assert outcome.code not in (0, None), out
    assert "Traceback" not in out, out
    exc = outcome.result.exception
    assert exc is None or isinstance(exc, SystemExit), repr(exc)
    assert len(outcome.lines) == 1, outcome.lines
    assert outcome.lines[0].startswith("error:"), outcome.lines
    assert says in outcome.lines[0], outcome.lines[0]
    assert outcome.new == [], outcome.new


def refuse(folder, args, files, says):
    prepare(folder, files)
    outcome = invoke(folder, args)
    assert_clean_refusal(outcome, says)
    return outcome


def run_process(folder, args, timeout=30, env=None, stdin=subprocess.DEVNULL, stderr_into_stdout=False):
    """``python -m robocal ARGS`` in ``folder`` as a user runs it, output in a pipe
    (``stderr_into_stdout``: one pipe for both, in the order they were written, as a log
    of ``robocal ... 2>&1`` has them)."""
    environment = dict(os.environ, PYTHONPATH=str(REPO), COLUMNS="80", **(env or {}))
    streams = {"stdout": subprocess.PIPE, "stderr": subprocess.STDOUT} if stderr_into_stdout else \
        {"capture_output": True}
    return subprocess.run([sys.executable, "-m", "robocal", *map(str, args)], cwd=folder,
                          env=environment, text=True, timeout=timeout, stdin=stdin, **streams)
