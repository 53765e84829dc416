"""Every method given every other built-in robot's data: each pair must be refused in one
line, with a non-zero exit, no traceback and no file written (issue 23's "every method
refuses every pair").

For each ordered pair (data robot, model robot) of the seven built-in robots, the data robot
is simulated (``--errors typical``, 160 joint-uniform poses, 320 for the
network, which keeps half to validate and needs some 150 to train; for ball-in-socket data, three
placements of the plate fixture with 8 configurations a socket) and ``robocal calibrate``
is run in-process on the model robot with each method: kinematic, kriging, hybrid, ann,
auto (position data) and constraint (socket data).  Pairs of robots with different joint
counts are included (the reader refuses those by their columns).  The same robot's own data
are the control: they must calibrate.  Every run accepts the extrapolation, so that a
refusal is the data check's.  Prints one line per method: refused pairs, clean
refusals, and the distinct first words of the reasons.

    python bench/wrong_robot.py                 # some 20 minutes on one core (auto: 12)
    python bench/wrong_robot.py --methods ann   # the methods named
"""
import argparse
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from typer.testing import CliRunner  # noqa: E402

from robocal.interfaces.cli import app  # noqa: E402
from robocal.io.library import builtin_names  # noqa: E402

PLATE = str(Path(__file__).resolve().parents[1] / "examples" / "plate-fixture.toml")
POSITION_METHODS = ("kinematic", "kriging", "hybrid", "ann", "auto")
EXTRA = {"ann": ["--generations", "5"]}
runner = CliRunner()


def _invoke(args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return runner.invoke(app, [str(a) for a in args])


def _simulate(root):
    files = {}
    for name in builtin_names():
        files[name, "positions"] = root / f"{name}.csv"
        files[name, "sockets"] = root / f"{name}_sockets.csv"
        files[name, "network"] = root / f"{name}_network.csv"
        for args in (["simulate", name, "--n", "160", "--seed", "1", "--out", files[name, "positions"]],
                     ["simulate", name, "--n", "320", "--seed", "1", "--out", files[name, "network"]],
                     ["simulate", name, "--sampling", "sockets", "--fixture", PLATE, "--placements", "3",
                      "--per-socket", "8", "--seed", "1", "--out", files[name, "sockets"]]):
            result = _invoke(args)
            if result.exit_code != 0:
                sys.exit(f"simulate {name} failed: {result.output.strip()}")
    return files


def _outcome(result, out):
    """'ok', 'clean' (one error line, no traceback, nothing written) or 'garbled: ...'."""
    lines = [line for line in result.output.splitlines() if line.strip()]
    if result.exit_code == 0:
        return "ok"
    errors = [line for line in lines if line.lower().lstrip("│ ").startswith("error")]
    crashed = result.exception is not None and not isinstance(result.exception, SystemExit)
    if crashed or "Traceback" in result.output or len(errors) != 1 or len(lines) > 2:
        return f"garbled: {result.output.strip()[:200]!r} {result.exception!r}"
    if out.exists() or any(out.parent.glob("*.tmp")):
        return "stray file"
    return "clean"


def _reason(line, root):
    """The error line's kind: its first words, the file and the numbers left out."""
    words = line.replace(str(root) + "/", "").split()[1:]
    words = ["N" if any(c.isdigit() for c in word) and not word[0].isalpha() else word for word in words]
    return " ".join(word for word in words if not word.endswith(".csv"))[:60]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default=",".join(POSITION_METHODS + ("constraint",)))
    methods = parser.parse_args().methods.split(",")
    names = builtin_names()
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        files = _simulate(root)
        out = root / "out" / "model.json"
        out.parent.mkdir()
        for method in methods:
            start, counts, reasons, problems, control = time.perf_counter(), {}, set(), [], []
            kind = {"constraint": "sockets", "ann": "network"}.get(method, "positions")
            for data in names:
                for model in names:
                    # Accepting the extrapolation: a refusal is then the data check's, not that of
                    # the error predicted where the robot will work (60 poses over the whole
                    # joint space are too few for Kriging there, on the robot's own data too).
                    args = ["calibrate", model, files[data, kind], "--method", method, "--out", out,
                            "--accept-extrapolation", *EXTRA.get(method, [])]
                    if method == "constraint":
                        args += ["--fixture", PLATE]
                    result = _invoke(args)
                    outcome = _outcome(result, out)
                    if data == model:
                        control.append(outcome == "ok")
                        if outcome != "ok":
                            problems.append(f"{data}'s own data refused: {result.output.strip()[:160]}")
                        out.unlink(missing_ok=True)
                        continue
                    counts[outcome] = counts.get(outcome, 0) + 1
                    if outcome == "clean":
                        line = next(x for x in result.output.splitlines() if x.lower().lstrip("│ ").startswith("error"))
                        reasons.add(_reason(line, root))
                    else:
                        problems.append(f"{data} as {model}: {outcome}")
                        out.unlink(missing_ok=True)
            pairs = sum(counts.values())
            print(f"{method:<10} {counts.get('clean', 0)}/{pairs} pairs refused cleanly; own data calibrated "
                  f"{sum(control)}/{len(control)}; {time.perf_counter() - start:.0f} s")
            for problem in problems:
                print(f"    PROBLEM: {problem}")
            for reason in sorted(reasons):
                print(f"    {reason}")


if __name__ == "__main__":
    main()
