# ruff: noqa: E501  (one input per table row)
"""Unbounded work. Endless inputs (/dev/zero, a FIFO nobody writes, stdin),
lines of megabytes, and option values that would take hours or terabytes are refused in one
line at once, before any work, and nothing is written."""
import os

import pytest

from user_files import EXAMPLES, prepare, refuse, run_process

HUGE = [
    ("simulate-n", ["simulate", "ur5", "--n", "1000000000", "--out", "s.csv"], "--n must be a whole number >= 1 and <= 1,000,000"),
    ("simulate-n-ten-million", ["simulate", "ur5", "--n", "10000000", "--out", "s.csv"], "<= 1,000,000"),
    ("simulate-placements", ["simulate", "kr150-2", "--sampling", "sockets", "--fixture", "plate.toml", "--placements", "100000000", "--out", "s.csv"], "--placements must be a whole number >= 1 and <= 1,000"),
    ("simulate-per-socket", ["simulate", "kr150-2", "--sampling", "sockets", "--fixture", "plate.toml", "--per-socket", "100000000", "--out", "s.csv"], "--per-socket must be a whole number >= 2 and <= 10,000"),
    ("simulate-sockets-placements-times-per-socket", ["simulate", "kr150-2", "--sampling", "sockets", "--fixture", "plate.toml", "--placements", "1000", "--per-socket", "10000", "--out", "s.csv"], "is 30,000,000 configurations, more than the 10,000"),
    ("simulate-grid-n", ["simulate", "ur5", "--sampling", "grid", "--box", "200,500,-300,300,100,500", "--n", "1000000000000", "--out", "s.csv"], "--n must be a whole number >= 1 and <= 1,000,000"),
    ("design-n", ["design", "ur5", "--n", "1000000000", "--out", "p.csv"], "--n must be a whole number >= 1 and <= 100,000"),
    ("design-pool", ["design", "ur5", "--n", "12", "--pool", "1000000000000", "--out", "p.csv"], "--pool must be a whole number >= 10 and <= 200,000"),
    ("design-pool-ten-million", ["design", "ur5", "--n", "12", "--pool", "10000000", "--out", "p.csv"], "<= 200,000"),
    ("design-per-socket", ["design", "kr150-2", "--n", "72", "--fixture", "plate.toml", "--region", "1000,1500,-300,300,0,200", "--per-socket", "100000000", "--out", "p.csv"], "--per-socket must be"),
    ("ann-generations", ["calibrate", "ur5", "ur5.csv", "--method", "ann", "--generations", "1000000000", "--out", "o.json"], "--generations must be a whole number >= 0 and <= 10,000"),
    ("ann-hidden", ["calibrate", "ur5", "ur5.csv", "--method", "ann", "--hidden", "100000,100000", "--out", "o.json"], "--hidden must be at least 2 comma-separated whole numbers"),
    ("ann-five-thousand-layers", ["calibrate", "ur5", "ur5.csv", "--method", "ann", "--hidden", ",".join(["8"] * 5000), "--out", "o.json"], "at most 8 of them"),
    ("auto-folds", ["calibrate", "ur5", "ur5.csv", "--method", "auto", "--folds", "1000000", "--out", "o.json"], "--folds must be a whole number >= 2 and <= 1,000"),
    ("validate-folds", ["validate", "ur5", "ur5.csv", "--folds", "1000000"], "use --folds <= 60"),
    ("validate-sizes", ["validate", "ur5", "ur5.csv", "--sizes", "10,1000000000"], "use sizes <= 42"),
    ("compare-folds", ["compare", "ur5", "ur5.csv", "--folds", "100000000"], "--folds must be a whole number >= 2 and <= 1,000"),
    ("iso-cycles", ["iso9283", "plan", "ur5", "--cycles", "1000000000", "--out", "i.csv"], "--cycles must be a whole number >= 2 and <= 1,000"),
    ("jobs", ["calibrate", "ur5", "ur5.csv", "--jobs", "100000", "--out", "o.json"], "--jobs must be a whole number >= 1 and <= 1,024"),
    ("validate-jobs-zero", ["validate", "ur5", "ur5.csv", "--jobs", "0"], "--jobs must be a whole number >= 1, got '0'"),
    ("seed", ["calibrate", "ur5", "ur5.csv", "--method", "kriging", "--seed", "999999999999999999999999", "--out", "o.json"], "--seed must be a whole number >= 0"),
    ("calibrate-dash-as-stdin", ["calibrate", "ur5", "-", "--out", "o.json"], "- does not exist"),
    ("calibrate-proc-file", ["calibrate", "ur5", "/proc/self/status", "--out", "o.json"], "/proc/self/status is not comma-separated"),
    ("calibrate-dev-zero-robot", ["calibrate", "/dev/zero", "ur5.csv", "--out", "o.json"], "a robot file must end in .toml or .urdf"),
    # hostile pass 5
    ("validate-jobs", ["validate", "ur5", "ur5.csv", "--jobs", "100000"], "--jobs must be a whole number >= 1 and <= 1,024"),
    ("fleet-jobs", ["fleet", str(EXAMPLES / "fleet" / "fleet.toml"), "--out", "res", "--jobs", "50000"], "--jobs must be a whole number >= 1 and <= 1,024"),
    ("import-max-dt", ["import", "--points", "pts.txt", "--joints", "j.csv", "--out", "m.csv", "--by", "time", "--max-dt", "1e300"], "--max-dt must be a number >= 0 and <= 3,600"),
    ("iso-edge-a-trillion-mm", ["iso9283", "plan", "kr150-2", "--edge", "1e12", "--out", "i.csv"], "no ISO 9283 cube of edge 1e+12 mm is reachable by 'KUKA KR 150-2'"),
    ("genetic-generations", ["calibrate", "ur5", "ur5.csv", "--method", "ann", "--trainer", "ga", "--generations", "2000000000", "--out", "o.json"], "--generations must be a whole number >= 0 and <= 10,000"),
]


@pytest.mark.parametrize("args, says", [row[1:] for row in HUGE], ids=[row[0] for row in HUGE])
def test_unbounded_option_is_refused_at_once(tmp_path, args, says):
    refuse(tmp_path, args, None, says)


LONG = [
    ("a-line-of-ten-megabytes", lambda b: "q1,q2,q3,q4,q5,q6,x,y,z\n" + "1," * 5_000_000 + "1\n", "line 2 is over 1 MiB long"),
    ("a-header-of-twenty-megabytes", lambda b: "q" * 20_000_000 + "\n1\n", "line 1 is over 1 MiB long"),
    ("a-number-of-a-hundred-thousand-digits", lambda b: "q1,q2,q3,q4,q5,q6,x,y,z\n" + ("1" * 100000 + ",0,0,0,0,0,1,2,3\n") * 10, "row 2, column 'q1'"),
]


@pytest.mark.parametrize("content, says", [row[1:] for row in LONG], ids=[row[0] for row in LONG])
def test_endless_lines_are_refused(tmp_path, content, says):
    refuse(tmp_path, ["calibrate", "ur5", "l.csv", "--out", "o.json"], {"l.csv": content}, says)


def _fifo(folder, name):
    os.mkfifo(folder / name)


ENDLESS = [
    ("calibrate-dev-zero", ["calibrate", "ur5", "/dev/zero", "--out", "o.json"], None, "/dev/zero is not a regular file"),
    ("compensate-dev-urandom", ["compensate", "ur5_model.json", "/dev/urandom", "--out", "o.csv"], None, "/dev/urandom is not a regular file"),
    ("evaluate-fifo-model", ["evaluate", "f.json", "ur5.csv"], "f.json", "f.json is not a regular file"),
    ("calibrate-fifo-measurements", ["calibrate", "ur5", "f.csv", "--out", "o.json"], "f.csv", "f.csv is not a regular file"),
    ("calibrate-fifo-fixture", ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "f.toml", "--out", "o.json"], "f.toml", "f.toml is not a regular file"),
    # the JSON and TOML readers of other files: each names the device, none says "does not exist"
    ("report-dev-urandom-validation", ["report", "ur5_model.json", "ur5.csv", "--validation", "/dev/urandom", "--out", "r.html"], None, "/dev/urandom is not a regular file"),
    ("report-fifo-validation", ["report", "ur5_model.json", "ur5.csv", "--validation", "v.json", "--out", "r.html"], "v.json", "v.json is not a regular file"),
    ("report-folder-validation", ["report", "ur5_model.json", "ur5.csv", "--validation", ".", "--out", "r.html"], None, ". is a directory"),
    ("simulate-fifo-truth", ["simulate", "ur5", "--errors", "t.json", "--n", "5", "--out", "s.csv"], "t.json", "t.json is not a regular file"),
    ("fleet-dev-zero", ["fleet", "/dev/zero", "--out", "res"], None, "/dev/zero is not a regular file"),
    ("import-dev-zero-points", ["import", "--points", "/dev/zero", "--joints", "ur5.csv", "--out", "m.csv"], None, "/dev/zero is not a regular file"),
]


@pytest.mark.parametrize("args, fifo, says", [row[1:] for row in ENDLESS], ids=[row[0] for row in ENDLESS])
def test_endless_input_is_refused_without_reading_it(tmp_path, args, fifo, says):
    prepare(tmp_path)
    if fifo:
        _fifo(tmp_path, fifo)
    _refused_in_one_line(tmp_path, args, says)


def _refused_in_one_line(folder, args, says):
    """``robocal ARGS`` in ``folder``: status 2, one line saying ``says``, no file made."""
    before = set(os.listdir(folder))
    done = run_process(folder, args, timeout=60)
    lines = [line for line in (done.stdout + done.stderr).splitlines() if line.strip()]
    assert done.returncode == 2 and len(lines) == 1 and says in lines[0], lines
    assert set(os.listdir(folder)) == before


def test_stdin_of_zeros_is_refused(tmp_path):
    prepare(tmp_path)
    with open("/dev/zero", "rb") as zeros:
        done = run_process(tmp_path, ["calibrate", "ur5", "/dev/stdin", "--out", "o.json"], stdin=zeros)
    lines = [line for line in (done.stdout + done.stderr).splitlines() if line.strip()]
    assert done.returncode == 2 and lines == [lines[0]] and "is not a regular file" in lines[0]
    assert not (tmp_path / "o.json").exists()


@pytest.mark.parametrize("loaded", ["_multiarray_umath", "_flapack"])
def test_ctrl_c_while_the_command_line_starts_ends_in_one_line(loaded, tmp_path):
    # SIGINT while the command line imports NumPy, then SciPy's LAPACK, before its own handling is in
    # place (a second or more on a busy machine): one line and status 130, no
    # KeyboardInterrupt traceback, no file.  Sent when that library's extension is mapped, not
    # after a fixed delay: under load 50 ms fell in the interpreter's own start-up (its site
    # imports), which no program can answer ("Fatal Python error", status 1).
    import signal
    import subprocess
    import sys
    import time

    from user_files import REPO

    environment = dict(os.environ, PYTHONPATH=str(REPO))
    process = subprocess.Popen([sys.executable, "-m", "robocal", "simulate", "kr150-2", "--n", "50000", "--out",
                                "big.csv"], cwd=tmp_path, env=environment, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    try:
        while time.monotonic() < deadline and process.poll() is None:
            with open(f"/proc/{process.pid}/maps") as maps:
                if loaded in maps.read():
                    break
            time.sleep(0.002)
    except OSError:  # the process ended between the poll and the read
        pass
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and "Traceback" not in err, err
    assert err.strip().splitlines()[-1].endswith("interrupted")
    assert not (tmp_path / "big.csv").exists()


# Files over their kind's size limit, refused from their size alone before a byte is read
# (sparse files: no test writes megabytes).  A tracker's point export has its own, smaller
# limit: its lines are split in Python.
OVERSIZE = [
    ("import-points-of-a-hundred-megabytes", ["import", "--points", "pts.txt", "--joints", "j.csv", "--out", "m.csv"], "pts.txt", 100 << 20, "pts.txt is 100 MiB, more than any point file robocal reads (32 MiB)"),
    ("import-joint-log-of-three-gigabytes", ["import", "--points", "p.txt", "--joints", "big.csv", "--out", "m.csv"], "big.csv", 3 << 30, "big.csv is 3,072 MiB, more than any"),
    ("report-validation-of-twenty-megabytes", ["report", "ur5_model.json", "ur5.csv", "--validation", "v.json", "--out", "r.html"], "v.json", 20 << 20, "v.json is 20 MiB, more than any validation file robocal reads (16 MiB)"),
]


@pytest.mark.parametrize("args, name, size, says", [row[1:] for row in OVERSIZE], ids=[row[0] for row in OVERSIZE])
def test_a_file_over_its_size_limit_is_refused_unread(tmp_path, args, name, size, says):
    prepare(tmp_path)
    (tmp_path / "p.txt").write_text("// units: mm\nQ0 400 100 400\n")
    (tmp_path / "j.csv").write_text("name,q1,q2,q3,q4,q5,q6\nQ0,0,-80,90,-100,-90,0\n")
    with open(tmp_path / name, "w") as stream:
        stream.write("name,q1,q2,q3,q4,q5,q6\n")
        stream.truncate(size)  # sparse: nothing is written
    _refused_in_one_line(tmp_path, args, says)


def test_joining_many_points_takes_linear_time(tmp_path):
    # 200,000 points, 10 of them logged: the join looked up each name's first line with a
    # scan of all the names (quadratic: 3 million points ran for minutes); now whole arrays.
    import time

    import numpy as np

    from robocal.io.point_join import join
    from robocal.io.tracker_points import TrackerPoints

    n = 200_000
    names = np.array([f"Q{k}" for k in range(n)] + ["Q5"])  # Q5 measured twice, 2 mm apart
    positions = np.tile([400.0, 100.0, 400.0], (n + 1, 1))
    positions[-1, 0] += 2.0
    points = TrackerPoints(path="p.txt", names=names, positions=positions, uncertainty=None, temperature=None,
                           time=None, unit="mm", lines=np.arange(2, n + 3))
    (tmp_path / "j.csv").write_text("name,q1,q2,q3,q4,q5,q6\n"
                                    + "".join(f"Q{k},{k},-80,90,-100,-90,0\n" for k in range(10)))
    start = time.process_time()  # the join's work (quadratic: 12 s), not the machine's load
    data, report = join(points, tmp_path / "j.csv")
    assert time.process_time() - start < 5.0
    assert report.matched == 10 and len(report.points_without_joints) == n - 10
    assert report.duplicates == (("Q5", 2, 1.0),)
    assert data.positions[5].tolist() == [401.0, 100.0, 400.0]
    assert report.points_without_joints[0] == (12, "Q10")  # the first line of each unused name
