"""Acceptance and timing of ``robocal fleet`` (issue 17): 20 simulated robots, one with a
damaged measurement file, on a local Dask cluster of 1 and of 2 workers.

The fleet: the seven built-in robots, each with errors of its own (``--errors typical``, a
seed per robot), measured on ``N_TRAIN`` poses to calibrate and ``N_TEST`` other poses of the
same true robot to evaluate; the methods mixed (kinematic with several parameter sets and a
robust loss, kriging, hybrid, auto, ann, and constraint on ball-in-socket data of
examples/plate-fixture.toml).  Robot 13's training file has a text in a joint cell: it must
fail alone.  Acceptance, for every run: 19 model files, 19 reports, one failure in
DIR/summary.csv; and the model files of the two runs are the same (their time and checksum
aside).

Each run is ``robocal fleet FLEET.toml --out DIR --jobs N`` as a user types it (a process of
its own: the cluster's start and stop are in the time).  The machine may be shared: the load
average before and after each run, and the CPU time of the run's processes, are printed
beside its wall time.

    python bench/fleet.py                 # 1 and 2 workers, in a temporary folder
    python bench/fleet.py --work /tmp/f   # keep the data and the outputs there
    python bench/fleet.py --workers 1,2,4
    python bench/fleet.py --compare       # robocal compare on the 1,000 UR5 poses instead

``--compare`` times ``robocal compare ur5.toml ur5.csv --json`` (the real UR5, 1,000 poses,
5 folds, every method) with no cluster, and with ``--jobs N`` for each worker count, each a
process of its own; the printed figures of every run must be the same (fit times aside).
"""
import argparse
import csv
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from robocal.interfaces.fleet import fitted_content
from robocal.interfaces.jobs import simulate_job

N_TRAIN, N_TEST = 120, 40
FIXTURE = Path(__file__).resolve().parents[1] / "examples" / "plate-fixture.toml"
DAMAGED = 13  # this robot's training file gets a text in a joint cell
# (robot, method, options) of the 20 robots, in the fleet file's order.
PLAN = [
    ("ur5", "kinematic", {}),
    ("ur10", "kinematic", {"parameters": "full+gains"}),
    ("kr150-2", "kriging", {}),
    ("irb120", "hybrid", {"seed": 1}),
    ("panda", "kinematic", {"loss": "huber"}),
    ("iiwa14", "kinematic", {"parameters": "offsets"}),
    ("fanuc-r2000ic-165f", "auto", {}),
    ("ur5", "hybrid", {"inputs": "sincos"}),
    ("ur10", "kriging", {"correlation": "matern52"}),
    ("kr150-2", "constraint", {}),
    ("irb120", "kinematic", {"parameters": "full+compliance"}),
    ("panda", "ann", {"hidden": [8, 8], "generations": 60}),
    ("iiwa14", "hybrid", {}),
    ("ur5", "kinematic", {}),
    ("ur10", "auto", {}),
    ("kr150-2", "kinematic", {"parameters": "full+gains"}),
    ("irb120", "constraint", {"pairs": "spanning"}),
    ("fanuc-r2000ic-165f", "kriging", {}),
    ("panda", "hybrid", {"seed": 2}),
    ("iiwa14", "kinematic", {}),
]


def make_fleet(folder):
    """The measurement files and FLEET.toml of the 20 robots in ``folder``."""
    data = folder / "data"
    data.mkdir(parents=True, exist_ok=True)
    tables = []
    for k, (robot, method, options) in enumerate(PLAN, start=1):
        name = f"r{k:02d}-{robot}"
        train, test, truth = data / f"{name}_train.csv", data / f"{name}_test.csv", data / f"{name}_truth.json"
        if method == "constraint":
            sockets = {"sampling": "sockets", "fixture": str(FIXTURE), "placements": 6, "per_socket": 8}
            simulate_job(robot, train, seed=k, truth=truth, **sockets)
            simulate_job(robot, test, seed=100 + k, errors=str(truth), **{**sockets, "placements": 3})
        else:
            simulate_job(robot, train, n=N_TRAIN, seed=k, truth=truth)
            simulate_job(robot, test, n=N_TEST, seed=100 + k, errors=str(truth))
        if k == DAMAGED:
            lines = train.read_text().splitlines()
            cells = lines[7].split(",")
            lines[7] = ",".join(["ninety"] + cells[1:])
            train.write_text("\n".join(lines) + "\n")
        table = [f'name = "{name}"', f'robot = "{robot}"', f'train = "data/{train.name}"',
                 f'test = "data/{test.name}"', f'method = "{method}"']
        if method == "constraint":
            table.append(f"fixture = {json.dumps(str(FIXTURE))}")
        if options:
            table.append("options = { " + ", ".join(f"{key} = {json.dumps(value)}" for key, value in options.items())
                         + " }")
        tables.append("[[robot]]\n" + "\n".join(table) + "\n")
    fleet = folder / "fleet.toml"
    fleet.write_text("# 20 simulated robots for bench/fleet.py; paths relative to this file.\n\n" + "\n".join(tables))
    return fleet


def load():
    return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


def spin(steps):
    """Pure-Python arithmetic: CPU and nothing else."""
    total = 0
    for k in range(steps):
        total += k * k
    return total


def ceiling(workers, steps=30_000_000):
    """How many times the work of one process ``workers`` processes got done in the same wall
    time just now: what the machine (shared, perhaps) offers a run of that many workers."""
    from multiprocessing import get_context

    with get_context("spawn").Pool(workers) as pool:
        pool.map(spin, [1] * workers)  # the processes started
        start = time.perf_counter()
        pool.map(spin, [steps])
        one = time.perf_counter() - start
        start = time.perf_counter()
        pool.map(spin, [steps] * workers, chunksize=1)
        many = time.perf_counter() - start
    return workers * one / many


def run(fleet, out, workers):
    """``robocal fleet`` with a local cluster of ``workers``: (wall s, CPU s of its processes)."""
    print(f"  {workers} worker(s): before, {load()}", flush=True)
    wall, cpu, done = timed([sys.executable, "-m", "robocal.interfaces.cli", "fleet", str(fleet), "--out", str(out),
                             "--jobs", str(workers), "--json"])
    if done.returncode != 1:  # 1: some robot failed, as one must here
        sys.exit(f"robocal fleet exited with {done.returncode}:\n{done.stderr}")
    tasks = [row["seconds"] for row in json.loads(done.stdout)["robots"] if row["seconds"] is not None]
    # How much of the run the workers spent in the robots' tasks (the rest: starting and stopping
    # the cluster, and idle workers at the end); and how much CPU the run's processes got.
    print(f"  {workers} worker(s): {wall:.1f} s wall, {cpu:.1f} s CPU ({cpu / wall:.2f} cores on average); the robots' "
          f"tasks {sum(tasks):.1f} s in all, the longest {max(tasks):.1f} s, the workers busy "
          f"{100 * sum(tasks) / (wall * workers):.0f} % of the wall time; after, {load()}", flush=True)
    return wall, cpu


def timed(command):
    """(wall s, CPU s of the process and its children, completed process) of ``command``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done


def figures(printed):
    """compare's JSON without its fit times: what must not depend on where the fits ran."""
    result = json.loads(printed)
    for model in result["models"]:
        model.pop("seconds")
        for split in model["scores"].values():
            split.pop("fit_seconds")
    return result


def compare_runs(folder, counts):
    """robocal compare on the real UR5 with no cluster and with each worker count."""
    exported = subprocess.run([sys.executable, "-m", "robocal.interfaces.cli", "dataset", "ur5-tsinghua", "--out",
                               str(folder / "ur5"), "--json"], capture_output=True, text=True)
    if exported.returncode:
        sys.exit(exported.stderr)
    command = [sys.executable, "-m", "robocal.interfaces.cli", "compare", str(folder / "ur5.toml"),
               str(folder / "ur5.csv"), "--json"]
    print(f"robocal compare, real UR5, 1,000 poses, 5 folds, every method; {os.cpu_count()} CPUs; {load()}")
    walls, results = {}, {}
    for workers in [None] + counts:
        wall, cpu, done = timed(command + ([] if workers is None else ["--jobs", str(workers)]))
        if done.returncode:
            sys.exit(f"robocal compare exited with {done.returncode}:\n{done.stderr}")
        walls[workers], results[workers] = wall, figures(done.stdout)
        print(f"  {'no cluster' if workers is None else f'--jobs {workers}'}: {wall:.1f} s wall, {cpu:.1f} s CPU; "
              f"after, {load()}", flush=True)
    print(f"  the same figures in every run: {all(r == results[None] for r in results.values())}")
    for workers in counts[1:]:
        print(f"  speed-up --jobs {counts[0]} -> {workers}: {walls[counts[0]] / walls[workers]:.2f}x; no cluster -> "
              f"--jobs {workers}: {walls[None] / walls[workers]:.2f}x; {workers} processes of pure arithmetic got "
              f"{ceiling(workers) / ceiling(counts[0]):.2f}x the work of {counts[0]} done just after ({load()})")


def check(out):
    """The acceptance of one run's outputs; returns its summary rows."""
    with open(out / "summary.csv", newline="") as stream:
        rows = list(csv.DictReader(stream))
    models, reports = list(out.glob("*/model.json")), list(out.glob("*/report.html"))
    failed = [row for row in rows if row["status"] != "ok"]
    verdict = "ok" if (len(rows), len(models), len(reports), len(failed)) == (20, 19, 19, 1) else "NOT MET"
    print(f"  {out.name}: {len(models)} models, {len(reports)} reports, {len(failed)} failed of {len(rows)} "
          f"[{verdict}]")
    for row in failed:
        print(f"    {row['name']}: {row['message']}")
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, help="folder for the data and outputs (default: a temporary one)")
    parser.add_argument("--workers", default="1,2", help="worker counts to time, e.g. 1,2")
    parser.add_argument("--compare", action="store_true", help="time robocal compare on the real UR5 instead")
    args = parser.parse_args()
    counts = [int(n) for n in args.workers.split(",")]
    with tempfile.TemporaryDirectory() as temporary:
        folder = args.work or Path(temporary)
        folder.mkdir(parents=True, exist_ok=True)
        if args.compare:
            compare_runs(folder, counts)
            return
        print(f"robocal fleet, {len(PLAN)} simulated robots ({N_TRAIN} training / {N_TEST} test poses; "
              f"ball-in-socket robots 48 / 24), one damaged file; {os.cpu_count()} CPUs; {load()}")
        start = time.perf_counter()
        fleet = make_fleet(folder)
        print(f"  data simulated in {time.perf_counter() - start:.1f} s: {fleet}")
        times, rows = {}, {}
        for workers in counts:
            out = folder / f"out-{workers}"
            times[workers] = run(fleet, out, workers)
            rows[workers] = check(out)
        first = counts[0]
        for workers in counts[1:]:
            same = all(fitted_content(model) == fitted_content(folder / f"out-{workers}" / model.relative_to(
                folder / f"out-{first}")) for model in (folder / f"out-{first}").glob("*/model.json"))
            print(f"  model files of {first} and {workers} worker(s) the same: {same}")
            print(f"  speed-up {first} -> {workers} workers: {times[first][0] / times[workers][0]:.2f}x wall "
                  f"({times[first][0]:.1f} s / {times[workers][0]:.1f} s); {workers} processes of pure arithmetic "
                  f"got {ceiling(workers) / ceiling(first):.2f}x the work of {first} done just after: the most this "
                  f"machine offered ({load()})")
        print("  per robot (first run): " + ", ".join(f"{row['name']} {row['method']} {row['mean_mm'] or '-'} mm"
                                                     for row in rows[first]))


if __name__ == "__main__":
    main()
