"""The one bounded reader (robocal.io.reading) behind every file format: devices, directories,
oversized files, endless lines, UTF-16 and other byte-order marks, binary files and JSON nested
beyond the parser's depth each give one line naming the file, for every reader."""
import json
import os
import shutil
from pathlib import Path

import pytest

from refusals import assert_refused, copy_inputs, run_ok
from robocal.errors import FileFormatError
from robocal.io import reading
from robocal.io.fixtures import read_fixture
from robocal.io.programs.core import read_text as read_program
from robocal.io.robot_file import read_robot
from robocal.io.tables import read_measurements, read_targets
from robocal.io.urdf import read_urdf
from robocal.simulation.true_robot import read_truth

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
FIXTURE = 'name = "plate"\n[sockets]\nA = [0.0, 0.0, 0.0]\nB = [150.0, 0.0, 0.0]\nC = [0.0, 120.0, 0.0]\n'
MEASUREMENTS = "q1,q2,q3,q4,q5,q6,x,y,z\n" + "\n".join(
    f"{k},{-90 + k},{45 - k},0,{k * 2},{-k},{100 + k},{200 - k},{300 + k}" for k in range(10)) + "\n"

# Every reader of a user's file, as (what it reads, how it is called).
READERS = [
    ("measurements", read_measurements),
    ("targets", read_targets),
    ("fixture", read_fixture),
    ("robot file", read_robot),
    ("urdf", read_urdf),
    ("truth file", read_truth),
    ("robot program", read_program),
]


@pytest.mark.parametrize("name, reader", READERS, ids=[r[0] for r in READERS])
def test_every_reader_refuses_a_device_before_reading_it(name, reader):
    with pytest.raises(FileFormatError, match="/dev/zero is not a regular file"):
        reader("/dev/zero")


@pytest.mark.parametrize("name, reader", READERS, ids=[r[0] for r in READERS])
def test_every_reader_refuses_a_directory_in_one_line(name, reader, tmp_path):
    with pytest.raises(FileFormatError, match="is a directory"):
        reader(tmp_path)


@pytest.mark.parametrize("name, reader", READERS, ids=[r[0] for r in READERS])
def test_every_reader_says_a_missing_file_does_not_exist(name, reader, tmp_path):
    with pytest.raises(FileFormatError, match="absent.* does not exist"):
        reader(tmp_path / "absent.txt")


@pytest.mark.parametrize("name, reader", READERS, ids=[r[0] for r in READERS])
def test_every_reader_refuses_a_file_larger_than_its_kind_reads(name, reader, tmp_path, monkeypatch):
    path = tmp_path / "big"
    path.write_text("x" * 4096)
    monkeypatch.setattr(reading, "LIMITS", {kind: 1024 for kind in reading.LIMITS})
    with pytest.raises(FileFormatError, match="more than any .* robocal reads"):
        reader(path)


@pytest.mark.parametrize("name, reader", [r for r in READERS if r[0] != "truth file"],
                         ids=[r[0] for r in READERS if r[0] != "truth file"])
def test_every_line_based_reader_refuses_an_endless_line(name, reader, tmp_path, monkeypatch):
    path = tmp_path / "long"
    path.write_text("q1,x\n" + "1" * 5000 + "\n")
    monkeypatch.setattr(reading, "MAX_LINE", 1000)
    with pytest.raises(FileFormatError, match="line 2 is over"):
        reader(path)


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-be", "utf-32", "utf-8-sig"])
def test_a_fixture_saved_with_a_byte_order_mark_reads_as_the_utf8_one(encoding, tmp_path):
    plain, marked = tmp_path / "plain.toml", tmp_path / "marked.toml"
    plain.write_text(FIXTURE, encoding="utf-8")
    text = FIXTURE.encode("utf-16-be") if encoding == "utf-16-be" else FIXTURE.encode(encoding)
    marked.write_bytes(b"\xfe\xff" + text if encoding == "utf-16-be" else text)
    got, want = read_fixture(marked).sockets, read_fixture(plain).sockets
    assert list(got) == list(want) and all((got[k] == want[k]).all() for k in want)


def test_a_measurement_file_saved_as_utf16_reads_as_the_utf8_one(tmp_path):
    plain, marked = tmp_path / "plain.csv", tmp_path / "marked.csv"
    plain.write_text(MEASUREMENTS, encoding="utf-8")
    marked.write_bytes(MEASUREMENTS.encode("utf-16"))
    assert (read_measurements(marked).positions == read_measurements(plain).positions).all()


def test_binary_bytes_without_a_mark_are_refused_as_binary(tmp_path):
    path = tmp_path / "workbook.csv"
    path.write_bytes(b"q1,x\n\x00\x01\x02")
    with pytest.raises(FileFormatError, match="not a text CSV file"):
        read_measurements(path)


def test_a_broken_utf16_file_is_refused_in_one_line(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_bytes(b"\xff\xfen\x00a\x00\x00\xd8")  # a lone surrogate
    with pytest.raises(FileFormatError, match="save the fixture file again as UTF-8"):
        read_fixture(path)


def test_json_nested_beyond_the_parser_is_refused_in_one_line(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(FileFormatError, match="nests its lists or objects"):
        read_truth(path)


def test_line_lengths_are_checked_across_slice_boundaries(monkeypatch):
    monkeypatch.setattr(reading, "_SLICE", 7)
    monkeypatch.setattr(reading, "MAX_LINE", 10)
    reading.check_line_lengths(b"0123456789\n0123456789\n0123456789", "f", "table")
    with pytest.raises(FileFormatError, match="line 3 is over"):
        reading.check_line_lengths(b"0123456789\n0123456789\n01234567890", "f", "table")


@pytest.fixture(scope="module")
def model_folder(tmp_path_factory, ur5_files):
    root = tmp_path_factory.mktemp("reading")
    run_ok("simulate", "ur5", "--n", "40", "--out", root / "meas.csv")
    shutil.copy(ur5_files / "model.json", root / "model.json")
    (root / "FO").mkdir()
    (root / "long.csv").write_text("x,y,z,rx,ry,rz\n" + "1" * (1 << 20) + ",2,3,180,0,0\n")
    (root / "deep.json").write_text("[" * 200_000 + "]" * 200_000)
    (root / "fixture16.toml").write_bytes(FIXTURE.encode("utf-16"))
    (root / "meas16.csv").write_bytes((root / "meas.csv").read_text().encode("utf-16"))
    return root


def _sparse(path, size):
    with open(path, "wb") as stream:
        stream.truncate(size)


# Files no reader may read to the end, made in each row's folder (a copy would read them):
# links to devices, a named pipe nobody writes, a sparse file of 3 GiB.
SPECIAL = {
    "zero.json": lambda path: path.symlink_to("/dev/zero"),
    "zero.toml": lambda path: path.symlink_to("/dev/zero"),
    "zero.csv": lambda path: path.symlink_to("/dev/zero"),
    "zero.urdf": lambda path: path.symlink_to("/dev/zero"),
    "random.csv": lambda path: path.symlink_to("/dev/urandom"),
    "fifo.script": os.mkfifo,
    "big.csv": lambda path: _sparse(path, 3 << 30),
}
COMMAND_LINE = [
    ("calibrate ur5 /dev/zero --out m.json", "/dev/zero is not a regular file"),
    ("calibrate /dev/zero meas.csv --out m.json", "must end in .toml or .urdf"),
    ("design ur5 --n 12 --existing /dev/zero --out p.csv", "/dev/zero is not a regular file"),
    ("simulate ur5 --errors deep.json --out s.csv", "nests its lists or objects"),
    ("calibrate ur5 . --out m.json", "is a directory"),
    # hostile pass 5: every other kind of file, by its reader, a device, a pipe or huge
    ("serve zero.json --port 0", "zero.json is not a regular file (a device or a pipe): save the model file"),
    ("show zero.toml", "zero.toml is not a regular file (a device or a pipe): save the robot file"),
    ("filter model.json fifo.script --out FO",
     "fifo.script is not a regular file (a device or a pipe): save the program"),
    ("design ur5 --candidates zero.csv --n 5 --out p.csv", "zero.csv is not a regular file"),
    ("export zero.json --out r.toml", "zero.json is not a regular file"),
    ("compare ur5 random.csv", "random.csv is not a regular file"),
    ("export model.json --format urdf --urdf zero.urdf --out o.urdf",
     "zero.urdf is not a regular file (a device or a pipe): save the URDF"),
    ("calibrate ur5 /dev/null --out m.json", "/dev/null is not a regular file"),
    ("compare ur5 big.csv", "big.csv is 3,072 MiB, more than any CSV file robocal reads (2,048 MiB)"),
    ("compensate model.json long.csv --out c.csv", "long.csv, line 2 is over 1 MiB long"),
    ("report model.json meas.csv --validation deep.json --out r.html",
     "deep.json nests its lists or objects thousands of levels deep"),
    ("calibrate deep.json meas.csv --method frames --out m2.json",
     "deep.json: not a robocal model file (its JSON nests thousands"),
]


@pytest.mark.parametrize("args, says", COMMAND_LINE, ids=[row[0] for row in COMMAND_LINE])
def test_the_command_line_refuses_what_the_reader_refuses(args, says, model_folder, tmp_path, monkeypatch):
    before = copy_inputs(model_folder, tmp_path, monkeypatch)
    for name, make in SPECIAL.items():
        make(tmp_path / name)
        before[name] = (tmp_path / name).stat().st_mtime_ns
    assert_refused(args.split(), says, tmp_path, before)


def test_a_utf16_measurement_file_calibrates_like_the_utf8_one(model_folder, tmp_path, monkeypatch):
    copy_inputs(model_folder, tmp_path, monkeypatch)
    plain = json.loads(run_ok("calibrate", "ur5", "meas.csv", "--out", "a.json", "--json").output)
    marked = json.loads(run_ok("calibrate", "ur5", "meas16.csv", "--out", "b.json", "--json").output)
    assert marked["residual_after_training"] == plain["residual_after_training"]
    assert marked["calibration"] == plain["calibration"]
