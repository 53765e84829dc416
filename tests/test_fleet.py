"""robocal fleet and robocal.parallel: the fleet file checked whole before any work, a robot
with bad data failing alone, outputs only inside DIR, the same model file serially and on
Dask (a local cluster, and a real scheduler and worker started as separate processes), and
every other command without Dask."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal import parallel
from robocal.errors import InputError
from robocal.interfaces.cli import app
from robocal.interfaces.fleet import SUMMARY_COLUMNS, fitted_content, fleet_job, read_fleet
from robocal.interfaces.jobs import evaluate_job, simulate_job
from robocal.io.file_kinds import KIND_COLUMN

runner = CliRunner()
try:
    import dask.distributed  # noqa: F401
    HAVE_DASK = True
except ImportError:
    HAVE_DASK = False
needs_dask = pytest.mark.skipif(not HAVE_DASK, reason="dask[distributed] is not installed (pip install '.[test]')")

ROBOCAL = [sys.executable, "-m", "robocal.interfaces.cli"]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """Small simulated measurement files: a UR5 (train and test of one true robot), an IRB 120
    (train only) and a damaged file."""
    folder = tmp_path_factory.mktemp("fleet-data")
    simulate_job("ur5", folder / "ur5_train.csv", n=40, seed=1, truth=folder / "ur5_truth.json")
    simulate_job("ur5", folder / "ur5_test.csv", n=15, seed=2, errors=str(folder / "ur5_truth.json"))
    simulate_job("irb120", folder / "irb_train.csv", n=30, seed=3)
    good = (folder / "irb_train.csv").read_text().splitlines()
    cells = good[5].split(",")
    damaged = good[:5] + [",".join(["twelve degrees"] + cells[1:])] + good[6:]  # row 5: a text in q1
    (folder / "damaged.csv").write_text("\n".join(damaged) + "\n")
    return folder


def write_fleet(path, robots):
    """A fleet file of ``robots`` (dicts; options as a dict)."""
    lines = []
    for robot in robots:
        lines.append("[[robot]]")
        for key, value in robot.items():
            if isinstance(value, dict):
                value = "{ " + ", ".join(f"{k} = {json.dumps(v)}" for k, v in value.items()) + " }"
            else:
                value = json.dumps(value)
            lines.append(f"{key} = {value}")
        lines.append("")
    path.write_text("\n".join(lines))
    return path


def small_fleet(data, folder, *, damaged=True):
    """Three robots, paths relative to the fleet file (which sits in ``folder``)."""
    rel = os.path.relpath(data, folder)
    robots = [{"name": "cell1-ur5", "robot": "ur5", "train": f"{rel}/ur5_train.csv", "test": f"{rel}/ur5_test.csv"},
              {"name": "cell2-irb", "robot": "irb120", "train": f"{rel}/irb_train.csv",
               "options": {"parameters": "full", "loss": "huber"}}]
    if damaged:
        robots.append({"name": "cell3-bad", "robot": "irb120", "train": f"{rel}/damaged.csv"})
    return write_fleet(folder / "fleet.toml", robots)


def summary(out):
    import csv

    with open(out / "summary.csv", newline="") as stream:
        return list(csv.DictReader(stream))


# --------------------------------------------------------------------------- the fleet file
GOOD = {"name": "r1", "robot": "ur5", "train": "t.csv"}
REFUSED = [
    ([{**GOOD, "name": "../../x"}], "name '../../x' is not a plain file name"),
    ([{**GOOD, "name": "/tmp/x"}], "is not a plain file name"),
    ([{**GOOD, "name": ".hidden"}], "is not a plain file name"),
    ([{**GOOD, "name": "a b"}], "is not a plain file name"),
    ([{**GOOD, "name": "Summary.CSV"}], "is not a plain file name"),
    ([{**GOOD, "colour": "red"}], "unknown key 'colour'"),
    ([{"name": "r1", "robot": "ur5"}], "no train"),
    ([{"robot": "ur5", "train": "t.csv"}], "no name"),
    ([GOOD, {**GOOD, "name": "R1"}], "robots 1 and 2 are both named 'r1' / 'R1'"),
    ([{**GOOD, "robot": "ur55"}], "robot 'ur55' is neither a built-in robot"),
    ([{**GOOD, "options": {"folds": 3}}], "calibrate has no option --folds"),
    ([{**GOOD, "options": {"json": True}}], "calibrate has no option --json"),
    ([{**GOOD, "options": {"parameters": "fulll"}}], "options.parameters must be one of"),
    ([{**GOOD, "options": {"seed": 1.5}}], "options.seed must be a whole number"),
    ([{**GOOD, "options": {"shared_theta": "yes"}}], "options.shared_theta is on or off"),
    ([{**GOOD, "method": "krigin"}], "method must be one of"),
    ([{**GOOD, "method": "kriging", "options": {"payload": 3}}], "--payload does not apply to the kriging method"),
    ([{**GOOD, "method": "auto", "options": {"seed": 2}}], "leave seed out of options"),
    ([{**GOOD, "options": {"parameters": "frames"}}], "a fleet calibrates from robot files"),
    ([{**GOOD, "test": 3}], "test must be a non-empty text"),
]


@pytest.mark.parametrize("robots, message", REFUSED, ids=[m for _, m in REFUSED])
def test_a_mistake_in_the_fleet_file_is_one_line_and_nothing_runs(tmp_path, robots, message):
    fleet = write_fleet(tmp_path / "fleet.toml", robots)
    with pytest.raises(InputError, match="^" + str(fleet).replace("\\", "\\\\")) as caught:
        fleet_job(fleet, tmp_path / "out")
    assert message in str(caught.value) and "\n" not in str(caught.value)
    assert not (tmp_path / "out").exists()  # refused before anything was created


@pytest.mark.parametrize("text, message", [
    ("[robot]\nname = 'r1'\n", "must be [[robot]] tables"),
    ("robots = 3\n", "unknown key 'robots' at the top"),
    ("", "lists no robots"),
    ("[[robot]\n", "is not valid TOML"),
])
def test_a_fleet_file_of_the_wrong_shape_is_refused(tmp_path, text, message):
    (tmp_path / "fleet.toml").write_text(text)
    result = runner.invoke(app, ["fleet", str(tmp_path / "fleet.toml"), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and message in result.output and "Traceback" not in result.output


def test_paths_are_relative_to_the_fleet_file_and_options_reach_the_method(tmp_path, data, monkeypatch):
    fleet = small_fleet(data, tmp_path, damaged=False)
    robots = read_fleet(fleet)
    assert robots[0].train == str(data / "ur5_train.csv") and robots[0].test == str(data / "ur5_test.csv")
    assert robots[1].settings == {"parameters": "full", "loss": "huber"}
    monkeypatch.chdir(data)  # the fleet file given from another folder: its paths still resolve from its own
    result = fleet_job(os.path.relpath(fleet, data), tmp_path / "out")
    assert result.failed == 0
    model = json.loads((tmp_path / "out" / "cell2-irb" / "model.json").read_text())
    assert model["training"]["file"] == str(data / "irb_train.csv")
    assert model["options"]["loss"] == "huber"


def test_outputs_stay_inside_the_output_folder(tmp_path, data):
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "cell1-ur5").symlink_to(outside, target_is_directory=True)
    with pytest.raises(InputError, match="is a symbolic link or a file"):
        fleet_job(small_fleet(data, tmp_path), tmp_path / "out")
    assert list(outside.iterdir()) == []
    fleet = write_fleet(tmp_path / "f2.toml", [{**GOOD, "train": "new/r1/model.json"}])
    with pytest.raises(InputError, match="is a file the fleet writes"):
        fleet_job(fleet, tmp_path / "new")
    assert not (tmp_path / "new").exists()


# --------------------------------------------------------------------------- running a fleet
@pytest.fixture(scope="module")
def serial_run(data, tmp_path_factory):
    """The small fleet run serially (no Dask) through the Python API."""
    folder = tmp_path_factory.mktemp("serial")
    seen = []
    result = fleet_job(small_fleet(data, folder), folder / "out", on_robot=lambda row, k, n: seen.append((k, n)))
    return folder / "out", result, seen


def test_a_robot_with_a_damaged_file_fails_alone(serial_run, data):
    out, result, seen = serial_run
    assert seen == [(1, 3), (2, 3), (3, 3)]
    assert (result.ok, result.failed) == (2, 1)
    rows = {row["name"]: row for row in summary(out)}
    assert list(summary(out)[0]) == [*SUMMARY_COLUMNS, KIND_COLUMN]
    assert rows["cell3-bad"]["status"] == "failed" and "twelve degrees" in rows["cell3-bad"]["message"]
    assert rows["cell3-bad"]["mean_mm"] == "" and not (out / "cell3-bad").exists()
    for name in ("cell1-ur5", "cell2-irb"):
        assert rows[name]["status"] == "ok"
        assert (out / name / "model.json").is_file() and (out / name / "report.html").is_file()
    ur5 = rows["cell1-ur5"]
    assert (ur5["n_train"], ur5["n_test"]) == ("40", "15")
    # What 'robocal evaluate' says of the model on the test file, well below the registered nominal's error.
    evaluated = evaluate_job(out / "cell1-ur5" / "model.json", data / "ur5_test.csv").scores
    assert float(ur5["mean_mm"]) == round(evaluated["mean_mm"], 4)
    assert float(ur5["max_mm"]) == round(evaluated["max_mm"], 4)
    assert evaluated["mean_mm"] < 0.5 * evaluated["nominal"]["mean_mm"]
    assert rows["cell2-irb"]["n_test"] == "" and "no test file" in rows["cell2-irb"]["message"]
    page = (out / "summary.html").read_text()
    assert 'href="cell1-ur5/report.html"' in page and "cell3-bad/report.html" not in page
    assert not list(out.rglob("*.partial")) and not list(out.rglob("*.tmp"))


def test_a_failed_robot_keeps_the_files_of_an_earlier_run(tmp_path, data):
    robot = {"name": "r1", "robot": "irb120", "train": str(data / "irb_train.csv")}
    fleet = write_fleet(tmp_path / "fleet.toml", [robot])
    fleet_job(fleet, tmp_path / "out")
    before = (tmp_path / "out" / "r1" / "model.json").read_text()
    summary_before = (tmp_path / "out" / "summary.csv").read_text()
    write_fleet(fleet, [{**robot, "test": str(data / "damaged.csv")}])
    # Its only robot failing, the fleet writes nothing, and says why in one line.
    with pytest.raises(InputError, match="every robot of the fleet failed, nothing written .*keeps the files of an "
                                         "earlier run"):
        fleet_job(fleet, tmp_path / "out")
    assert (tmp_path / "out" / "r1" / "model.json").read_text() == before
    assert (tmp_path / "out" / "summary.csv").read_text() == summary_before


@pytest.mark.slow
@needs_dask
def test_the_command_line_on_a_local_cluster_exits_1_when_a_robot_fails(tmp_path, data):
    fleet = small_fleet(data, tmp_path)
    env, scratch = _own_temporary_folder(tmp_path)
    done = subprocess.run(ROBOCAL + ["fleet", str(fleet), "--out", str(tmp_path / "out"), "--jobs", "2"],
                          capture_output=True, text=True, timeout=300, env=env)
    assert list(scratch.iterdir()) == []  # the cluster's scratch space went with it
    assert done.returncode == 1, done.stderr
    assert "1 of 3 robots failed" in done.stderr and "Traceback" not in done.stderr
    assert "local cluster of 2 workers" in done.stdout
    assert [row["status"] for row in summary(tmp_path / "out")] == ["ok", "ok", "failed"]
    assert len(list((tmp_path / "out").glob("*/model.json"))) == 2


@pytest.mark.slow
@needs_dask
def test_a_real_scheduler_and_worker_run_the_fleet_and_validate_as_they_run_here(tmp_path, data, serial_run):
    """``dask scheduler`` and ``dask worker`` started as processes of their own on localhost."""
    scheduler_file = tmp_path / "scheduler.json"
    dask_cli = [sys.executable, "-m", "dask"]
    local = ["--host", "127.0.0.1", "--no-dashboard", "--dashboard-address", "127.0.0.1:0"]
    processes = []
    try:
        scheduler = ["scheduler", "--port", "0", "--scheduler-file", str(scheduler_file)]
        processes.append(subprocess.Popen(dask_cli + scheduler + local, stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL))
        address = _wait_for_address(scheduler_file, processes[0])
        processes.append(subprocess.Popen(dask_cli + ["worker", address, "--nworkers", "1", "--nthreads", "1"] + local,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        small_fleet(data, tmp_path)
        # Relative paths, from a folder the worker does not run in: they reach it made absolute.
        done = subprocess.run(ROBOCAL + ["fleet", "fleet.toml", "--out", "out", "--scheduler", address, "--json"],
                              capture_output=True, text=True, timeout=300, cwd=tmp_path)
        # The folds of a cross-validation on the same workers: the figures of a run without them.
        validate = ROBOCAL + ["validate", "ur5", str(data / "ur5_train.csv"), "--method", "hybrid", "--folds", "3",
                              "--json"]
        remote = subprocess.run(validate + ["--scheduler", address], capture_output=True, text=True, timeout=300)
    finally:
        for process in reversed(processes):
            process.terminate()
        for process in processes:
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
    assert done.returncode == 1, done.stderr
    result = json.loads(done.stdout)
    assert result["ran_on"] == f"the Dask cluster at {address}" and result["workers"] == 1
    assert [row["status"] for row in result["robots"]] == ["ok", "ok", "failed"]
    # The same cross-validation without a scheduler, in this process (one BLAS thread, as the
    # command line sets for itself: conftest): what it prints is what the scheduler's run prints.
    here = runner.invoke(app, validate[len(ROBOCAL):])
    assert remote.returncode == 0 == here.exit_code, remote.stderr + here.output
    assert json.loads(remote.stdout) == json.loads(here.stdout)
    serial_out = serial_run[0]
    for name in ("cell1-ur5", "cell2-irb"):
        dask_model, serial_model = tmp_path / "out" / name / "model.json", serial_out / name / "model.json"
        assert fitted_content(dask_model) == fitted_content(serial_model)


def _wait_for_address(scheduler_file, process, seconds=60):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if process.poll() is not None:
            pytest.fail(f"dask scheduler exited with status {process.returncode}")
        try:
            return json.loads(scheduler_file.read_text())["address"]
        except (OSError, ValueError, KeyError):
            time.sleep(0.2)
    pytest.fail("dask scheduler did not write its address")


def _own_temporary_folder(tmp_path):
    """An environment whose temporary folder (TMPDIR) is an empty one of the test's: where
    Dask's scratch space went (dask-scratch-space: lock files, a folder per worker)."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    return dict(os.environ, TMPDIR=str(folder)), folder


# Stopping a fleet on a local cluster: when its two workers work, or while the cluster starts
# (its first worker process just spawned).  It answers in one line, and leaves no worker
# process and nothing in the temporary folder (Dask's scratch space went there, and stayed).
STOPS = [("ctrl-c-at-work", signal.SIGINT, 2), ("sigterm-at-work", signal.SIGTERM, 2),
         ("sigterm-while-the-cluster-starts", signal.SIGTERM, 1)]


@pytest.mark.slow
@needs_dask
@pytest.mark.parametrize("signum, workers_seen", [s[1:] for s in STOPS], ids=[s[0] for s in STOPS])
def test_a_stopped_fleet_closes_its_local_cluster_and_leaves_no_scratch(tmp_path, data, signum, workers_seen):
    import psutil

    fleet = write_fleet(tmp_path / "fleet.toml", [
        {"name": f"r{k}", "robot": "irb120", "train": str(data / "irb_train.csv"), "method": "auto"} for k in range(4)])
    env, scratch = _own_temporary_folder(tmp_path)
    process = subprocess.Popen(ROBOCAL + ["fleet", str(fleet), "--out", str(tmp_path / "out"), "--jobs", "2"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        parent = psutil.Process(process.pid)
        deadline = time.monotonic() + 60
        workers = []
        while len(workers) < workers_seen and time.monotonic() < deadline and process.poll() is None:
            workers = [c for c in parent.children(recursive=True) if "spawn" in " ".join(c.cmdline())]
            time.sleep(0.05)
        assert len(workers) >= workers_seen, "the local cluster's workers did not start"
        workers = parent.children(recursive=True)
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 128 + signum, stderr
    assert "Traceback" not in stderr and stderr.strip().splitlines()[-1] == "interrupted", stderr
    gone, alive = psutil.wait_procs(workers, timeout=20)
    assert not alive, f"worker processes left running: {alive}"
    assert list(scratch.iterdir()) == [] and not (tmp_path / "out").exists()


@needs_dask
@pytest.mark.slow
def _ctrl_c_to_the_group_once(tmp_path, data, ready):
    """Run a fleet of four ``auto`` fits on one worker in a process group of its own, send
    the group SIGINT as a terminal's Ctrl-C does once ``ready(workers)`` (psutil processes of
    the cluster's workers) holds, and return (exit code, stderr)."""
    import psutil

    fleet = write_fleet(tmp_path / "fleet.toml", [
        {"name": f"r{k}", "robot": "irb120", "train": str(data / "irb_train.csv"), "method": "auto"} for k in range(4)])
    process = subprocess.Popen(ROBOCAL + ["fleet", str(fleet), "--out", str(tmp_path / "out"), "--jobs", "1"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        parent, deadline, sent = psutil.Process(process.pid), time.monotonic() + 60, False
        while not sent and time.monotonic() < deadline and process.poll() is None:
            workers = [c for c in parent.children(recursive=True) if "spawn_main" in " ".join(c.cmdline())]
            if workers and ready(workers):
                os.killpg(process.pid, signal.SIGINT)
                sent = True
            time.sleep(0.01)
        assert sent, "the workers were never ready for the signal"
        _, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    return process.returncode, stderr


def test_ctrl_c_to_the_whole_process_group_ends_in_one_line(tmp_path, data):
    # A terminal's Ctrl-C reaches every process of its group, the local cluster's workers too:
    # once started they ignore it, so only the command line answers, once, and leaves no
    # output folder.
    def ignoring_ctrl_c(worker):
        try:
            ignored = next(line for line in open(f"/proc/{worker.pid}/status") if line.startswith("SigIgn"))
        except (OSError, StopIteration):
            return False
        return bool(int(ignored.split()[1], 16) & (1 << (signal.SIGINT - 1)))

    code, stderr = _ctrl_c_to_the_group_once(tmp_path, data, lambda workers: all(map(ignoring_ctrl_c, workers)))
    assert "Traceback" not in stderr and "Error" not in stderr, stderr
    assert code in (0, 128 + signal.SIGINT), stderr  # 0: the fleet was done before the signal
    if code:
        assert not (tmp_path / "out").exists()


def test_ctrl_c_to_the_whole_process_group_while_a_worker_imports_ends_in_one_line(tmp_path, data):
    # The instant a worker process exists it is still importing Dask, long before its preload
    # ignores Ctrl-C, and the group's Ctrl-C stops it with a KeyboardInterrupt: its traceback
    # went to the terminal.  Workers are started with their stderr in the cluster's scratch
    # folder, and the command line's own answer is the one line.
    code, stderr = _ctrl_c_to_the_group_once(tmp_path, data, lambda workers: True)
    assert "Traceback" not in stderr and "Error" not in stderr, stderr
    assert code == 128 + signal.SIGINT and stderr.strip() == "interrupted", stderr
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------- without Dask
BLOCK_DASK = """
import sys
class _NoDask:
    def find_spec(self, name, path=None, target=None):
        if name.split('.')[0] in ('dask', 'distributed'):
            raise ImportError('No module named ' + repr(name))
sys.meta_path.insert(0, _NoDask())
sys.argv = ['robocal'] + sys.argv[1:]
from robocal.interfaces.cli import main
main()
"""


@pytest.mark.slow
def test_without_dask_fleet_says_how_to_install_it_and_the_rest_works(tmp_path, data):
    fleet = small_fleet(data, tmp_path)
    done = subprocess.run([sys.executable, "-c", BLOCK_DASK, "fleet", str(fleet), "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "pip install 'robocal[fleet]'" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "out").exists()
    done = subprocess.run([sys.executable, "-c", BLOCK_DASK, "demo", "--json"], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["reachable"] == 100


def test_importing_robocal_and_its_command_line_imports_no_dask():
    code = ("import sys, robocal, robocal.interfaces.cli, robocal.interfaces.fleet, robocal.parallel; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "[]", done.stderr


# --------------------------------------------------------------------------- the executor
def square_plus(item):
    return {"value": item["x"] ** 2 + item.get("plus", 0), "array": np.arange(item["x"])}


def refuse_three(x):
    if x == 3:
        raise ValueError("three")
    return x


def test_map_jobs_runs_serially_in_order_without_dask():
    done = []
    results = parallel.map_jobs(square_plus, [{"x": 3}, {"x": 1, "plus": 1}, {"x": 2}],
                                on_done=lambda k, r: done.append(k))
    assert [r["value"] for r in results] == [9, 2, 4] and done == [0, 1, 2]
    assert parallel.current() is parallel.SERIAL
    with pytest.raises(ValueError, match="three"):
        parallel.map_jobs(refuse_three, [1, 3, 5])
    assert parallel.map_jobs(refuse_three, [1, 3, 5], on_error=lambda k, exc: -k) == [1, -1, 5]


def test_only_module_level_functions_and_plain_data_cross_to_workers():
    from robocal.io.library import builtin

    with pytest.raises(TypeError, match="module-level functions only"):
        parallel.map_jobs(lambda item: item, [1])
    with pytest.raises(TypeError, match="module-level functions only"):
        parallel.map_jobs(parallel.Executor().map, [1])
    with pytest.raises(TypeError, match=r"item 1\['robot'\] is a Chain"):
        parallel.map_jobs(refuse_three, [{"robot": "ur5"}, {"robot": builtin("ur5")}])
    with pytest.raises(TypeError, match="array of object"):
        parallel.check_plain({"x": np.array([None, 1])})
    with pytest.raises(InputError, match="not both"):
        parallel.map_jobs(refuse_three, [1], jobs=2, scheduler="tcp://127.0.0.1:1")
    with pytest.raises(InputError, match="--jobs must be a whole number"):
        parallel.map_jobs(refuse_three, [1], jobs=0)


@pytest.mark.slow
@needs_dask
def test_an_active_executor_runs_map_jobs_on_its_cluster():
    with parallel.executor(jobs=1) as chosen:
        assert parallel.current() is chosen and chosen.workers == 1
        # The scheduler and every worker listen on the loopback address only.
        addresses = [chosen.client.scheduler.address, *chosen.client.scheduler_info()["workers"]]
        assert len(addresses) == 2 and all(a.startswith("tcp://127.0.0.1:") for a in addresses), addresses
        results = parallel.map_jobs(square_plus, [{"x": k} for k in range(4)])
        assert [r["value"] for r in results] == [0, 1, 4, 9]
        assert [list(r["array"]) for r in results][3] == [0, 1, 2]
    assert parallel.current() is parallel.SERIAL


def test_the_example_fleet_file_is_valid_and_its_files_exist():
    example = Path(__file__).resolve().parents[1] / "examples" / "fleet" / "fleet.toml"
    robots = read_fleet(example)
    assert [robot.name for robot in robots] == ["cell1-ur5", "cell2-irb120", "cell3-kr150"]
    for robot in robots:
        assert all(Path(p).is_file() for p in (robot.train, robot.test, robot.fixture) if p is not None)
