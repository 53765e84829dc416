"""No stray output on failure: the files and folders a command writes are one unit
(robocal.io.atomic.outputs_together, around every verb and the fleet): a command that fails
or is interrupted half-way leaves none of the ones it created and puts back the ones it
replaced; one that succeeds keeps them all."""
import contextlib

import pytest

from refusals import EXAMPLES, assert_refused, run_ok
from robocal.errors import InputError
from robocal.interfaces import fleet as fleet_module
from robocal.io import atomic
from robocal.io.atomic import make_directory, outputs_together, write_text_atomic


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_a_dataset_whose_last_file_cannot_be_written_leaves_none(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "d_test.csv").mkdir()  # the last of four files cannot be written
    before = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    assert_refused(["dataset", "ur5-tsinghua", "--split", "0.5", "--out", "d"], "d_test.csv", tmp_path, before)
    assert _files(tmp_path) == ["d_test.csv"]
    run_ok("dataset", "ur5-tsinghua", "--split", "0.5", "--out", "e")  # the same command that can write keeps all
    assert {"e.toml", "e_train.csv", "e_test.csv"} <= set(_files(tmp_path))


def test_a_fleet_whose_scheduler_cannot_be_reached_leaves_no_folder(tmp_path, monkeypatch):
    @contextlib.contextmanager
    def unreachable(address):
        raise InputError(f"cannot reach the Dask scheduler at {address}")
        yield

    monkeypatch.setattr("robocal.parallel._remote_client", unreachable)
    monkeypatch.chdir(tmp_path)
    assert_refused(["fleet", str(EXAMPLES / "fleet" / "fleet.toml"), "--out", "results/fleet", "--scheduler",
                    "tcp://127.0.0.1:9"], "cannot reach the Dask scheduler", tmp_path, {})
    assert not (tmp_path / "results").exists()


CALLS = []


def interrupted_after_one(task):
    """A fleet's task that writes its robot's model, then Ctrl-C at the second robot."""
    CALLS.append(task["name"])
    if len(CALLS) % 2 == 0:
        raise KeyboardInterrupt
    write_text_atomic(fleet_module.Path(task["folder"]) / fleet_module.MODEL_FILE, "this run")
    return fleet_module.failed_row(task)


def test_a_fleet_interrupted_after_a_robot_leaves_nothing_and_an_earlier_run_as_it_was(tmp_path, monkeypatch):
    out = tmp_path / "out"
    robot_folder = make_directory(out / "cell1-ur5")
    (robot_folder / "model.json").write_text("earlier run")
    CALLS.clear()
    monkeypatch.setattr(fleet_module, "run_robot", interrupted_after_one)
    with pytest.raises(KeyboardInterrupt):
        fleet_module.fleet_job(EXAMPLES / "fleet" / "fleet.toml", out)
    assert _files(out) == ["cell1-ur5", "cell1-ur5/model.json"]
    assert (robot_folder / "model.json").read_text() == "earlier run"
    with pytest.raises(KeyboardInterrupt):
        fleet_module.fleet_job(EXAMPLES / "fleet" / "fleet.toml", tmp_path / "new" / "out")
    assert not (tmp_path / "new").exists()


def test_outputs_together_undoes_created_and_replaced_files_and_keeps_them_on_success(tmp_path):
    kept = tmp_path / "kept.txt"
    kept.write_text("before")
    with pytest.raises(OSError), outputs_together():
        write_text_atomic(kept, "during")
        write_text_atomic(tmp_path / "new.txt", "new")
        write_text_atomic(tmp_path / "new.txt", "newer")
        make_directory(tmp_path / "a" / "b")
        (tmp_path / "a" / "b" / "x").write_text("x")
        assert kept.read_text() == "during"  # the command may read back what it wrote
        raise OSError("disk full")
    assert _files(tmp_path) == ["kept.txt"] and kept.read_text() == "before"
    with outputs_together():
        write_text_atomic(kept, "after")
        write_text_atomic(tmp_path / "new.txt", "new")
    assert _files(tmp_path) == ["kept.txt", "new.txt"] and kept.read_text() == "after"
    assert not list(tmp_path.glob(".*"))  # no backup left behind
    write_text_atomic(kept, "outside a block")  # no unit: as before
    assert atomic._OUTPUTS.get() is None and kept.read_text() == "outside a block"
