"""robocal's own outputs given back to it (robocal.io.file_kinds): every reader recognises a
robocal file of a kind it does not take and refuses it, naming the kind, whether the file
says its kind in its robocal_file column or only by the columns robocal writes."""
import csv
from pathlib import Path

import pytest

from refusals import assert_refused, copy_inputs, run_ok
from robocal.errors import FileFormatError
from robocal.io.file_kinds import KIND_COLUMN, check, identify, recognise
from robocal.io.tables import read_measurements, read_targets


def _rows(path):
    with open(path, newline="") as stream:
        return list(csv.reader(stream))


def _write(path, rows):
    with open(path, "w", newline="") as stream:
        csv.writer(stream).writerows(rows)


def _without_kind_column(source, target):
    rows = _rows(source)
    keep = [i for i, name in enumerate(rows[0]) if name != KIND_COLUMN]
    _write(target, [[row[i] for i in keep] for row in rows])


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """A model and each kind of CSV robocal writes from it, with copies whose kind column
    was deleted (files written before it existed)."""
    root = tmp_path_factory.mktemp("own")
    run_ok("simulate", "ur5", "--n", "40", "--seed", "3", "--out", root / "meas.csv")
    run_ok("calibrate", "ur5", root / "meas.csv", "--out", root / "model.json")
    rows = _rows(root / "meas.csv")
    xyz = [rows[0].index(c) for c in "xyz"]
    _write(root / "targets.csv", [["x", "y", "z", "rx", "ry", "rz"]]
           + [[row[i] for i in xyz] + ["180", "0", "0"] for row in rows[1:]])
    run_ok("compensate", root / "model.json", root / "targets.csv", "--out", root / "commands.csv")
    run_ok("design", "ur5", "--n", "12", "--pool", "400", "--out", root / "poses.csv")
    for kind in ("commands", "poses"):
        _without_kind_column(root / f"{kind}.csv", root / f"{kind}_unmarked.csv")
    # cut to what a targets file holds, and the frame column robocal writes in its own words
    rows = _rows(root / "commands.csv")
    keep = [rows[0].index(name) for name in ("x", "y", "z", "rx", "ry", "rz", "q1", "q2", "q3", "q4", "q5", "q6",
                                             "frame")]
    _write(root / "commands_frame_only.csv", [[row[i] for i in keep] for row in rows])
    return root


@pytest.mark.parametrize("name", ["commands", "poses"])
def test_each_output_says_its_kind_on_every_row(outputs, name):
    rows = _rows(outputs / f"{name}.csv")
    assert rows[0][-1] == KIND_COLUMN and {row[-1] for row in rows[1:]} == {name}


@pytest.mark.parametrize("suffix", ["", "_unmarked"])
@pytest.mark.parametrize("name, reader, says", [
    ("commands", read_targets, "written by 'robocal compensate', not a targets file"),
    ("commands", read_measurements, "written by 'robocal compensate', not a measurement file"),
    ("poses", read_targets, "written by 'robocal design', not a targets file"),
    ("poses", read_measurements, "planned poses, written by 'robocal design': measure them"),
])
def test_every_reader_refuses_robocal_output_it_does_not_take(outputs, name, reader, says, suffix):
    with pytest.raises(FileFormatError, match=says):
        reader(outputs / f"{name}{suffix}.csv")


def test_files_of_several_kinds_pasted_together_are_refused(outputs, tmp_path):
    rows = _rows(outputs / "commands.csv")
    rows[2][-1] = "poses"
    _write(tmp_path / "pasted.csv", rows)
    with pytest.raises(FileFormatError, match="says commands, poses: robocal writes one of"):
        read_targets(tmp_path / "pasted.csv")


def test_a_kind_robocal_never_writes_is_refused(tmp_path):
    with pytest.raises(FileFormatError, match="says invented"):
        recognise(["x", KIND_COLUMN], lambda name: ["invented", "invented"])


@pytest.mark.parametrize("reader, says", [(read_targets, "not a targets file"),
                                          (read_measurements, "not a measurement file")])
def test_commands_cut_to_a_targets_columns_are_known_by_their_frame_text(outputs, reader, says):
    with pytest.raises(FileFormatError, match=f"written by 'robocal compensate', {says}"):
        reader(outputs / "commands_frame_only.csv")


def test_a_user_frame_column_of_other_words_is_no_kind(outputs, tmp_path):
    rows = _rows(outputs / "commands_frame_only.csv")
    reached = [row[:-1] + ["tracker frame"] for row in rows[1:] if all(row)]
    _write(tmp_path / "targets.csv", [rows[0]] + reached)
    assert read_targets(tmp_path / "targets.csv").positions.shape == (len(reached), 3)


def test_a_user_file_with_none_of_robocals_columns_is_none_of_robocals_kinds():
    # a user's measurements are told by their columns, and read as measurements or targets
    assert recognise(["q1", "q2", "x", "y", "z", "frame"]) == "measurements"
    for reader in ("measurements", "targets", "configurations", "joint-log"):
        assert check("meas.csv", reader, header=["q1", "q2", "x", "y", "z", "frame"]) == "measurements"
    assert recognise(["x", "y", "z", "rx", "ry", "rz", "in_domain"]) is None


@pytest.mark.parametrize("args, says", [
    ("compensate model.json commands.csv --out again.csv", "not a targets file"),
    ("compensate model.json commands_unmarked.csv --out again.csv", "not a targets file"),
    ("calibrate ur5 commands.csv --out m.json", "not a measurement file"),
    ("evaluate model.json commands.csv", "not a measurement file"),
    ("compensate model.json poses.csv --out again.csv", "not a targets file"),
    ("design ur5 --n 12 --existing commands.csv --out p.csv", "written by 'robocal compensate'"),
])
def test_the_command_line_refuses_robocal_output_given_back(args, says, outputs, tmp_path, monkeypatch):
    before = copy_inputs(outputs, tmp_path, monkeypatch)
    assert_refused(args.split(), says, tmp_path, before)


def test_a_design_with_the_measured_positions_added_is_a_measurement_file(outputs, tmp_path):
    rows = _rows(outputs / "poses.csv")
    measured = _rows(outputs / "meas.csv")[1:13]
    xyz = [_rows(outputs / "meas.csv")[0].index(c) for c in "xyz"]
    _write(tmp_path / "measured.csv", [rows[0] + ["x", "y", "z"]]
           + [row + [m[i] for i in xyz] for row, m in zip(rows[1:], measured)])
    assert read_measurements(tmp_path / "measured.csv").positions.shape == (12, 3)
    assert Path(tmp_path / "measured.csv").exists()


def test_a_file_of_long_lines_is_known_from_its_first_lines_wherever_they_are_cut():
    """identify() reads a text's first 256 KiB only; the line it would cut is left out, so a
    kind cell cut in two is never taken for a kind robocal does not write."""
    line = "1.0," + "2" * 3000 + ",commands\n"
    header = "x,note," + KIND_COLUMN + "\n"
    cuts = 0
    for blank in range(len(line)):  # blank lines move where the cut falls
        prefix = header + "\n" * blank
        if (4 * 65536 - len(prefix)) % len(line) > len(line) - len("commands\n"):  # inside the kind cell
            cuts += 1
            assert identify(prefix + line * 200) == "commands"
    assert cuts == len("commands")
