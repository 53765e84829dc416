# ruff: noqa: E501  (one input per table row)
"""Outputs that cannot be written, or commands that fail after choosing them.
Each is refused in one line before any work, and leaves no file or folder behind (nor a
partial program in a filter's output folder)."""
import os
import re
import stat
from pathlib import Path

import pytest

from user_files import invoke, prepare, refuse

# A program filter takes: a joint position first fixes the arm branch of the motion after it.
KRL = Path(__file__).resolve().parent / "data" / "programs" / "krl" / "pallet_cell.src"
POINTS = "P1 500 100 300\nP2 400 -100 350\n"
JOINT_LOG = "name,q1,q2,q3,q4,q5,q6\nP1,0,-90,90,0,90,0\nP2,10,-80,80,0,90,0\n"
URSCRIPT = "def prog():\n  movej([0,-1.57,1.57,-1.57,-1.57,0])\n  movel(p[0.4,0.1,0.3,3.14,0,0])\nend\n"
REFUSED = [
    ("calibrate-into-missing-folder", ["calibrate", "ur5", "ur5.csv", "--out", "nodir/o.json"], None, "directory nodir does not exist"),
    ("calibrate-out-is-a-folder", ["calibrate", "ur5", "ur5.csv", "--out", "o.json"], {"o.json/keep": "x"}, "o.json is a directory"),
    ("calibrate-out-ends-in-slash", ["calibrate", "ur5", "ur5.csv", "--out", "newdir/"], None, "newdir/ names a folder, not a file"),
    ("calibrate-out-ends-in-slash-dot", ["calibrate", "ur5", "ur5.csv", "--out", "newdir/."], None, "newdir/. names a folder, not a file"),
    ("compensate-out-ends-in-slash", ["compensate", "ur5_model.json", "targets.csv", "--out", "c/"], None, "c/ names a folder, not a file"),
    ("simulate-truth-ends-in-slash", ["simulate", "ur5", "--n", "10", "--out", "s.csv", "--truth", "t/"], None, "t/ names a folder, not a file"),
    ("iso-plan-out-ends-in-slash", ["iso9283", "plan", "ur5", "--out", "plans/"], None, "plans/ names a folder, not a file"),
    ("calibrate-out-name-too-long", ["calibrate", "ur5", "ur5.csv", "--out", "x" * 300 + ".json"], None, "File name too long"),
    ("calibrate-out-over-its-robot-file", ["calibrate", "ur5_cal.toml", "ur5.csv", "--out", "ur5_cal.toml"], None, "name it ur5_cal.json"),
    ("calibrate-out-named-csv", ["calibrate", "ur5", "ur5.csv", "--out", "o.csv"], None, "name it o.json"),
    ("calibrate-out-over-its-input", ["calibrate", "ur5", "ur5.csv", "--out", "ur5.csv"], None, "name it ur5.json"),
    ("simulate-truth-into-missing-folder", ["simulate", "ur5", "--n", "10", "--out", "s.csv", "--truth", "nodir/t.json"], None, "directory nodir does not exist"),
    ("simulate-truth-over-its-out", ["simulate", "ur5", "--n", "10", "--out", "s.csv", "--truth", "s.csv"], None, "name it s.json"),
    ("simulate-out-over-its-fixture", ["simulate", "kr150-2", "--sampling", "sockets", "--fixture", "plate.toml", "--placements", "2", "--per-socket", "3", "--out", "plate.toml"], None, "--out writes CSV, but 'plate.toml'"),
    ("simulate-truth-named-csv", ["simulate", "ur5", "--n", "10", "--out", "s.csv", "--truth", "t.csv"], None, "name it t.json"),
    ("report-pdf-into-missing-folder", ["report", "ur5_model.json", "ur5.csv", "--out", "r.html", "--pdf", "nodir/r.pdf"], None, "directory nodir does not exist"),
    ("report-pdf-over-its-html", ["report", "ur5_model.json", "ur5.csv", "--out", "r.html", "--pdf", "r.html"], None, "name it r.pdf"),
    ("report-pdf-named-txt", ["report", "ur5_model.json", "ur5.csv", "--out", "r.html", "--pdf", "r.txt"], None, "--pdf needs a .pdf file name"),
    ("evaluate-per-pose-into-missing-folder", ["evaluate", "ur5_model.json", "ur5.csv", "--per-pose", "nodir/p.csv"], None, "directory nodir does not exist"),
    ("evaluate-per-pose-over-its-model", ["evaluate", "ur5_model.json", "ur5.csv", "--per-pose", "ur5_model.json"], None, "names a JSON file: name it ur5_model.csv"),
    ("evaluate-per-pose-of-bad-measurements", ["evaluate", "ur5_model.json", "cmds.csv", "--per-pose", "p.csv"], None, "not a measurement file"),
    ("compensate-into-missing-folder", ["compensate", "ur5_model.json", "targets.csv", "--out", "nodir/o.csv"], None, "directory nodir does not exist"),
    ("compensate-nothing-reachable", ["compensate", "ur5_model.json", "tf.csv", "--out", "o.csv"], {"tf.csv": "x,y,z,rx,ry,rz\n5000,0,0,180,0,0\n"}, "nothing was written"),
    ("export-into-missing-folder", ["export", "ur5_model.json", "--out", "nodir/e.toml"], None, "directory nodir does not exist"),
    ("export-format-against-name", ["export", "ur5_model.json", "--format", "urdf", "--out", "e.toml"], None, "name it e.urdf or drop --format"),
    ("export-ur-yaml-of-a-kuka", ["export", "kr_model.json", "--format", "ur-yaml", "--out", "e.yaml"], None, "is not a UR arm"),
    ("design-into-missing-folder", ["design", "ur5", "--n", "12", "--pool", "200", "--out", "nodir/p.csv"], None, "directory nodir does not exist"),
    ("design-out-over-existing", ["design", "ur5", "--n", "12", "--pool", "200", "--existing", "ur5.csv", "--out", "ur5.csv"], None, "is also an input of this command"),
    ("design-out-over-candidates", ["design", "ur5", "--n", "12", "--candidates", "plan.csv", "--out", "plan.csv"], None, "plan.csv is also an input of this command"),
    ("iso-plan-with-report", ["iso9283", "plan", "ur5", "--out", "i.csv", "--report", "nodir/r.html"], None, "not a plan"),
    ("iso-plan-without-out", ["iso9283", "plan", "ur5"], None, "iso9283 plan needs the robot and --out"),
    ("dataset-into-missing-folder", ["dataset", "ur5-tsinghua", "--out", "nodir/u"], None, "directory nodir does not exist"),
    ("dataset-out-under-a-file", ["dataset", "ur5-tsinghua", "--out", "afile/u"], {"afile": "x"}, "afile is a file, not a directory"),
    ("dataset-one-output-is-a-folder", ["dataset", "ur5-tsinghua", "--out", "ts", "--split", "0.5"], {"ts_test.csv/x": ""}, "ts_test.csv is a directory"),
    ("dataset-split-above-one", ["dataset", "ur5-tsinghua", "--out", "u", "--split", "1.5"], None, "--split must be a number between 0 and 1"),
    ("dataset-split-zero", ["dataset", "ur5-tsinghua", "--out", "u", "--split", "0"], None, "--split must be a number between 0 and 1"),
    ("dataset-unknown", ["dataset", "ur6-nowhere", "--out", "u"], None, "'ur6-nowhere' is not available"),
    ("filter-out-is-a-file", ["filter", "ur5_model.json", "p.script", "--out", "afile"], {"afile": "x", "p.script": URSCRIPT}, "--out afile is not a directory"),
    ("filter-out-missing", ["filter", "ur5_model.json", "p.script", "--out", "FO"], {"p.script": URSCRIPT}, "--out FO is not a directory"),
    ("filter-folder-as-program", ["filter", "ur5_model.json", "prog", "--out", "FO"], {"prog/x": "", "FO/x": ""}, "prog is a directory: give the path of the program file"),
    ("filter-krl-read-as-rapid", ["filter", "kr_model.json", "p.src", "--out", "FO", "--language", "rapid"], {"p.src": KRL.read_text(), "p.dat": KRL.with_suffix(".dat").read_text(), "FO/x": ""}, "no motion found in p.src: is it a ABB RAPID program?"),
    ("filter-over-its-program", ["filter", "ur5_model.json", "p.script", "--out", "."], {"p.script": URSCRIPT}, "is also an input of this command"),
    ("import-into-missing-folder", ["import", "--points", "pts.txt", "--joints", "j.csv", "--out", "nodir/i.csv"], {"pts.txt": "P1 1 2 3\n", "j.csv": "name,q1,q2,q3,q4,q5,q6\nP1,0,0,0,0,0,0\n"}, "directory nodir does not exist"),
    ("import-out-over-its-joint-log", ["import", "--points", "pts.txt", "--joints", "j.csv", "--out", "j.csv"], {"pts.txt": "P1 500 100 300\nP2 400 -100 350\n", "j.csv": "name,q1,q2,q3,q4,q5,q6\nP1,0,-90,90,0,90,0\nP2,10,-80,80,0,90,0\n"}, "j.csv is also an input of this command"),
    ("validate-size-zero", ["validate", "ur5", "ur5.csv", "--folds", "3", "--sizes", "0,10"], None, "--sizes must be comma-separated whole numbers >= 1"),
    # hostile pass 5: outputs where no file can be made (sysfs, procfs), and outputs that are an input
    ("export-into-sysfs", ["export", "ur5_model.json", "--out", "/sys/r.toml"], None, "cannot write /sys/r.toml: no permission to create files in /sys"),
    ("compensate-into-sysfs", ["compensate", "ur5_model.json", "targets.csv", "--out", "/sys/c.csv"], None, "cannot write /sys/c.csv: no permission"),
    ("design-into-procfs", ["design", "ur5", "--n", "12", "--pool", "300", "--out", "/proc/p.csv"], None, "cannot write /proc/p.csv: No such file or directory"),
    ("iso-plan-into-sysfs", ["iso9283", "plan", "ur5", "--cycles", "2", "--out", "/sys/plan.csv"], None, "cannot write /sys/plan.csv: no permission"),
    ("import-into-sysfs", ["import", "--points", "pts.txt", "--joints", "j.csv", "--out", "/sys/m.csv"], {"pts.txt": POINTS, "j.csv": JOINT_LOG}, "cannot write /sys/m.csv: no permission"),
    ("dataset-into-sysfs", ["dataset", "mukca-panda-1", "--out", "/sys/p1"], None, "cannot write /sys/p1.toml: no permission"),
    ("simulate-into-sysfs", ["simulate", "ur5", "--n", "10", "--out", "/sys/s.csv"], None, "cannot write /sys/s.csv: no permission"),
    ("evaluate-per-pose-into-sysfs", ["evaluate", "ur5_model.json", "ur5.csv", "--per-pose", "/sys/pp.csv"], None, "cannot write /sys/pp.csv: no permission"),
    ("filter-into-sysfs", ["filter", "ur5_model.json", "p.script", "--out", "/sys"], {"p.script": URSCRIPT}, "cannot write /sys/p.script: no permission"),
    ("simulate-out-and-truth-one-json", ["simulate", "ur5", "--n", "10", "--out", "s.json", "--truth", "s.json"], None, "--out writes CSV, but 's.json' names a JSON file: name it s.csv"),
    ("import-out-over-its-points", ["import", "--points", "pts.txt", "--joints", "j.csv", "--out", "pts.txt"], {"pts.txt": POINTS, "j.csv": JOINT_LOG}, "pts.txt is also an input of this command"),
    ("design-out-over-its-targets", ["design", "ur5", "--targets", "t.csv", "--n", "8", "--pool", "400", "--out", "t.csv"], {"t.csv": "x,y,z,rx,ry,rz\n-400,-150,300,180,0,0\n-350,100,350,180,0,90\n"}, "t.csv is also an input of this command"),
    ("iso-plan-out-over-its-robot-file", ["iso9283", "plan", "ur5_cal.toml", "--out", "ur5_cal.toml"], None, "ur5_cal.toml is also an input of this command"),
    ("export-urdf-out-over-its-urdf", ["export", "ur5_model.json", "--format", "urdf", "--urdf", "ur5_cal.urdf", "--out", "ur5_cal.urdf"], None, "ur5_cal.urdf is also an input of this command"),
    ("export-out-is-a-folder", ["export", "ur5_model.json", "--out", "d"], {"d/x": ""}, "d is a directory: give a file name"),
    ("fleet-out-is-a-file", ["fleet", "fl.toml", "--out", "afile", "--jobs", "1"], {"fl.toml": '[[robot]]\nname = "r1"\nrobot = "ur5"\ntrain = "ur5.csv"\n', "afile": "x"}, "--out afile is a file: give a folder"),
]


@pytest.mark.parametrize("args, files, says", [r[1:] for r in REFUSED], ids=[r[0] for r in REFUSED])
def test_failed_command_leaves_nothing(tmp_path, args, files, says):
    prepare(tmp_path, {k: v for k, v in (files or {}).items() if "/" not in k})
    for name in files or {}:
        if "/" in name:
            (tmp_path / name).parent.mkdir()
    refuse(tmp_path, args, None, says)


PROGRAMS = [
    ("unreachable-target", {"p.script": "def prog():\n  movel(p[5.4,0.1,0.3,3.14,0,0])\n  movel(p[0.4,0.1,0.3,3.14,0,0])\nend\n"}, ["p.script"], "cannot be reached by the calibrated robot"),
    ("computed-at-run-time", {"p.script": "def prog():\n  a = p[0.4,0.1,0.3,3.14,0,0]\n  movel(pose_trans(a, p[0,0,0.1,0,0,0]))\nend\n"}, ["p.script"], "computed at run time"),
    ("urscript-in-mm", {"p.script": "def prog():\n  movel(p[400,100,300,180,0,0])\nend\n"}, ["p.script"], "more than a full turn: URScript poses take radians"),
    ("krl-without-dat", {"p.src": "DEF p()\nPTP XP1\nEND\n"}, ["p.src"], "its data list is missing: no p.dat"),
    ("two-programs-one-name", {"a/p.script": URSCRIPT, "b/p.script": URSCRIPT}, ["a/p.script", "b/p.script"], "two programs are named p.script: they would be written to the same file"),
    ("krl-position-without-c", {"p.src": KRL.read_text(), "p.dat": re.sub(r",C -?[0-9.]+", "", KRL.with_suffix(".dat").read_text(), count=1)}, ["p.src"], "PTP XP1: a partial position"),
    ("second-program-unreachable", {"a.script": URSCRIPT.replace("prog", "a"), "b.script": "def b():\n  movel(p[9.4,0.1,0.3,3.14,0,0])\nend\n"}, ["a.script", "b.script"], "b.script line 2"),
]


@pytest.mark.parametrize("files, programs, says", [r[1:] for r in PROGRAMS], ids=[r[0] for r in PROGRAMS])
def test_refused_filter_writes_no_program(tmp_path, files, programs, says):
    prepare(tmp_path, files)
    (tmp_path / "FO").mkdir()
    model = "kr_model.json" if programs[0].endswith(".src") else "ur5_model.json"
    outcome = invoke(tmp_path, ["filter", model, *programs, "--out", "FO"])
    assert outcome.code == 2 and len(outcome.lines) == 1 and says in outcome.lines[0], outcome.lines
    assert os.listdir(tmp_path / "FO") == []


# A fleet whose every robot fails at run time writes nothing (no summary, no folder).
FLEET_ALL_FAIL = [
    ('train = "nope.csv"', "does not exist"),
    ('train = "."', ""),
    ('train = "/dev/zero"', ""),
]


@pytest.mark.parametrize("entry, says", FLEET_ALL_FAIL)
def test_a_fleet_whose_every_robot_fails_leaves_no_output(entry, says, tmp_path):
    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    fleet = tmp_path / "fleet.toml"
    fleet.write_text(f'[[robot]]\nname = "a"\nrobot = "ur5"\n{entry}\n')
    out = tmp_path / "FO"
    result = CliRunner().invoke(app, ["fleet", str(fleet), "--out", str(out)])
    assert result.exit_code != 0 and "Traceback" not in result.output
    assert says in result.output
    assert not out.exists()


def _device(path, minor):
    """A character device like /dev/null (minor 3) or /dev/full (minor 7) at ``path``, or a
    skip where this user may not make one."""
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
    except (PermissionError, AttributeError, OSError):
        pytest.skip("making a character device needs root")


# An output that is a device is written through, never renamed over: as root a rename would
# turn the device into a regular file (/dev/null, /dev/full gone for every other program).
@pytest.mark.parametrize("verb", [["calibrate", "ur5", "ur5.csv", "--out"],
                                  ["compensate", "ur5_model.json", "targets.csv", "--out"]])
def test_an_output_that_is_a_device_stays_a_device(tmp_path, verb):
    prepare(tmp_path)
    _device(tmp_path / "null", 3)
    _device(tmp_path / "full", 7)
    assert invoke(tmp_path, [*verb, "null"]).code == 0
    outcome = invoke(tmp_path, [*verb, "full"])
    assert outcome.code == 2 and len(outcome.lines) == 1 and "No space left on device" in outcome.lines[0], outcome.lines
    for name in ("null", "full"):
        assert stat.S_ISCHR((tmp_path / name).stat().st_mode), f"{name} was replaced by a regular file"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def _fifo(folder):
    os.mkfifo(folder / "pipe")
    return "pipe"


def _socket(folder):
    import socket

    server = socket.socket(socket.AF_UNIX)
    server.bind(str(folder / "sock"))
    return "sock"


def _link_to_fifo(folder):
    os.symlink(_fifo(folder), folder / "link")
    return "link"


def _link_to_folder(folder):
    (folder / "sub").mkdir()
    os.symlink("sub", folder / "link")
    return "link"


# An output that is no regular file is refused in one line before any work, never waited on:
# a named pipe nobody reads (opening it to write would wait for ever), a socket, a folder
# behind a symbolic link.  Run as a process with a deadline: a hang fails the row.
KINDS = [
    ("fifo-without-reader", _fifo, "pipe is a named pipe (FIFO) that no program reads"),
    ("symlink-to-fifo", _link_to_fifo, "link is a named pipe (FIFO) that no program reads"),
    ("socket", _socket, "sock is a socket, not a file"),
    ("symlink-to-folder", _link_to_folder, "link is a directory"),
]


@pytest.mark.parametrize("make, says", [k[1:] for k in KINDS], ids=[k[0] for k in KINDS])
@pytest.mark.parametrize("verb", [["compensate", "ur5_model.json", "targets.csv", "--out"],
                                  ["design", "ur5", "--n", "12", "--pool", "200", "--out"]], ids=["compensate", "design"])
def test_an_output_that_is_no_regular_file_is_refused_without_waiting(tmp_path, verb, make, says):
    from user_files import run_process

    prepare(tmp_path)
    name = make(tmp_path)
    before = sorted(os.listdir(tmp_path))
    process = run_process(tmp_path, [*verb, name], timeout=60)
    lines = process.stderr.strip().splitlines()
    assert process.returncode == 2 and len(lines) == 1 and says in lines[0], process.stderr
    assert process.stdout == "" and sorted(os.listdir(tmp_path)) == before


def test_a_named_pipe_with_a_reader_receives_the_whole_output(tmp_path):
    import threading

    from user_files import run_process

    prepare(tmp_path)
    os.mkfifo(tmp_path / "pipe")
    received = []
    reader = threading.Thread(target=lambda: received.append((tmp_path / "pipe").read_text()), daemon=True)
    reader.start()
    process = run_process(tmp_path, ["compensate", "ur5_model.json", "targets.csv", "--out", "pipe"], timeout=60)
    reader.join(10)
    assert process.returncode == 0, process.stderr
    assert received and received[0].splitlines()[0].startswith("q1,") and len(received[0].splitlines()) == 9
    assert stat.S_ISFIFO((tmp_path / "pipe").stat().st_mode)


def test_a_write_the_system_stops_names_the_output_and_leaves_nothing(tmp_path):
    # A file-size limit (ulimit -f) stops the write with EFBIG, as a full disk does with
    # ENOSPC: the system's error names no file, the refusal names the output.
    import subprocess
    import sys

    from user_files import REPO

    script = ("import resource, sys; resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000)); "
              "sys.argv = ['robocal'] + sys.argv[1:]; from robocal.entry import main; main()")
    process = subprocess.run([sys.executable, "-c", script, "simulate", "ur5", "--n", "2000", "--out", "big.csv"],
                             cwd=tmp_path, capture_output=True, text=True, timeout=120,
                             env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and "big.csv" in lines[0] and "left as it was" in lines[0], process.stderr
    assert list(tmp_path.iterdir()) == []
