"""Every shipped real dataset through every method, from the command line (issue 23's "no
real dataset shipped in the package is refused").

Each dataset is written by ``robocal dataset`` with a random split, and ``robocal calibrate``
runs on the training part with each method, as a user would, without
``--accept-extrapolation``: UR5 Tsinghua and ipa UR10 series B split in halves, ipa UR10
series A a tenth to train (its 11,905 poses would take the network and the comparison
minutes), the three MUKCa Pandas' placements split in halves.  ``robocal evaluate`` then scores
the model on the rest.  One line per run: the exit status, the error predicted over the
joint range beside the registered nominal robot's, the held-out mean beside the nominal
robot's as ``evaluate`` reports it (for ball-in-socket data, the socket consistency), and
the seconds; a refusal prints its line.

    python bench/shipped_data.py            # about 4 minutes
"""
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from typer.testing import CliRunner  # noqa: E402

from robocal.interfaces.cli import app  # noqa: E402

POSITION_DATA = (("ur5-tsinghua", "0.5"), ("ipa-ur10-b", "0.5"), ("ipa-ur10-a", "0.1"))
SOCKET_DATA = ("mukca-panda-1", "mukca-panda-2", "mukca-panda-3")
POSITION_METHODS = ("kinematic", "kriging", "hybrid", "ann", "auto")
SOCKET_METHODS = ("constraint", "auto")
EXTRA = {"ann": ["--generations", "20"]}
runner = CliRunner()


def _invoke(args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return runner.invoke(app, [str(a) for a in args])


def _figure(document, *keys):
    for key in keys:
        document = document.get(key) if isinstance(document, dict) else None
    return float("nan") if document is None else float(document)


def _run(root, name, method, fixture=None):
    """One calibration of ``name``'s training part and its evaluation on the rest."""
    extra = ["--fixture", fixture] if fixture else []
    model = root / f"{name}-{method}.json"
    start = time.perf_counter()
    done = _invoke(["calibrate", root / f"{name}.toml", root / f"{name}_train.csv", "--method", method,
                    "--out", model, "--json", *extra, *EXTRA.get(method, [])])
    seconds = time.perf_counter() - start
    poses = sum(1 for _ in open(root / f"{name}_train.csv")) - 1
    if done.exit_code != 0:
        said = next((line for line in done.output.splitlines() if line.strip()), "")
        print(f"{name:<15}{method:<12}{poses:>6}  exit {done.exit_code}: {said[:150]}", flush=True)
        return False
    predicted = json.loads(done.stdout).get("predicted_error") or {}
    scored = json.loads(_invoke(["evaluate", model, root / f"{name}_test.csv", "--json", *extra]).stdout)
    nominal = scored.get("nominal") if isinstance(scored.get("nominal"), dict) else {}
    print(f"{name:<15}{method:<12}{poses:>6}  exit 0{_figure(predicted, 'mean_mm'):>10.3f}"
          f"{_figure(predicted, 'nominal_mean_mm'):>9.3f}{_figure(scored, 'mean_mm'):>10.3f}"
          f"{_figure(nominal, 'mean_mm'):>9.3f}{seconds:>8.1f}", flush=True)
    return True


def main():
    print(f"{'dataset':<15}{'method':<12}{'poses':>6}  {'':<6}{'predicted':>10}{'nominal':>9}{'held out':>10}"
          f"{'nominal':>9}{'s':>8}")
    accepted = runs = 0
    with tempfile.TemporaryDirectory(prefix="robocal-shipped-") as folder:
        root = Path(folder)
        for name, share in POSITION_DATA:
            if _invoke(["dataset", name, "--out", root / name, "--split", share, "--seed", "0"]).exit_code != 0:
                sys.exit(f"robocal dataset {name} failed")
            for method in POSITION_METHODS:
                runs += 1
                accepted += _run(root, name, method)
        for name in SOCKET_DATA:
            if _invoke(["dataset", name, "--out", root / name, "--split", "0.5", "--seed", "0"]).exit_code != 0:
                sys.exit(f"robocal dataset {name} failed")
            for method in SOCKET_METHODS:
                runs += 1
                accepted += _run(root, name, method, fixture=root / f"{name}_fixture.toml")
    print(f"\n{accepted} of {runs} calibrations accepted (predicted and nominal: mean mm over the joint range; "
          "held out: the other part's mean, ball-in-socket data their socket consistency)")


if __name__ == "__main__":
    main()
