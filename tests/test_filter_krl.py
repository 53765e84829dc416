"""robocal filter on a KUKA KRL program (a .src with its .dat): every target is what
compensate gives, every other byte stays, a nominal model changes nothing, run-time motions
and filtered programs are refused."""
import os
import re
import shutil
from pathlib import Path

import numpy as np

import pytest
from filter_support import (
    PROGRAMS,
    assert_filter_refused,
    assert_only_targets_changed,
    assert_same_poses,
    filter_and_compensate,
    model_of,
    true_and_nominal_models,
    true_robot,
    without_comment,
)
from typer.testing import CliRunner

from robocal.errors import InputError
from robocal.interfaces.cli import app
from robocal.interfaces.filter import filter_job
from robocal.io.library import load_robot
from robocal.io.programs import postures
from robocal.spatial.rotations import rpy_to_matrix

KRL = PROGRAMS / "krl"
SRC = KRL / "pallet_cell.src"
CONFIG = KRL / "$config.dat"


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    return true_and_nominal_models("kr150-2", tmp_path_factory)


def test_every_target_is_what_compensate_gives(models, tmp_path):
    (tmp_path / "out").mkdir()
    before, after, expected, q, result = filter_and_compensate(models["true"], SRC, tmp_path / "out", tmp_path)
    assert result.targets == len(before) == 14
    assert_same_poses(after, expected)
    moved = np.linalg.norm(np.array([a.pose[:3, 3] - b.pose[:3, 3] for a, b in zip(after, before)]), axis=1)
    assert 0.3 < moved.mean() < 3.0  # the simulated robot misses by about 1 mm
    # A PTP point is reached in the posture it names: S and T of the compensated joints.
    kr = load_robot("kr150-2")
    status, turn = postures.kuka(kr, kr.joints_from_file(q))
    named = [(k, t.posture) for k, t in enumerate(before) if t.posture is not None and not t.follows]
    assert len(named) >= 5
    for k, (s, t) in named:
        assert (status[k], turn[k]) == (s, t), before[k].name


def test_only_the_targets_numbers_change(models, tmp_path):
    filter_job(models["true"], [SRC], tmp_path, allow_unfiltered=True)
    for name in ("pallet_cell.src", "pallet_cell.dat"):
        assert_only_targets_changed(KRL / name, tmp_path / name, ";")
    # the summary: one row per target and per run-time motion
    rows = (tmp_path / "filter-summary.csv").read_text().splitlines()
    assert rows[0] == "file,line,name,status,moved_mm,turned_deg,in_domain,bound_mm,robocal_file"
    assert len(rows) == 1 + 14 + 3
    assert "pallet_cell.dat,14,XP1,filtered," in rows[4]


def test_a_nominal_model_reproduces_the_program(models, tmp_path):
    filter_job(models["nominal"], [SRC], tmp_path, allow_unfiltered=True)
    for name in ("pallet_cell.src", "pallet_cell.dat"):
        data, count = without_comment((tmp_path / name).read_bytes(), ";")
        assert count == 1 and data == (KRL / name).read_bytes()


def _frame(x, y, z, a, b, c):
    pose = np.eye(4)
    pose[:3, :3] = rpy_to_matrix(np.radians([c, b, a]))
    pose[:3, 3] = x, y, z
    return pose


def test_tool_and_base_from_the_config(models, tmp_path):
    # TOOL_DATA[1] and BASE_DATA[2] of the $config.dat, as the test reads them.
    tool1, base2 = _frame(0, 0, 45.5, 0, 0, 0), _frame(35, -20, -15, 1.5, 0, 0)

    def frames(target):  # every target comes after FDAT FP1 (TOOL_NO 1, BASE_NO 2) made them active
        return base2, tool1

    (tmp_path / "out").mkdir()
    _, after, expected, _, _ = filter_and_compensate(models["true"], SRC, tmp_path / "out", tmp_path,
                                                          frames=frames, config=CONFIG)
    assert_same_poses(after, expected)
    # The nominal model still changes nothing, through both frames and back.
    (tmp_path / "nominal").mkdir()
    filter_job(models["nominal"], [SRC], tmp_path / "nominal", config=CONFIG, allow_unfiltered=True)
    for name in ("pallet_cell.src", "pallet_cell.dat"):
        assert without_comment((tmp_path / "nominal" / name).read_bytes(), ";")[0] == (KRL / name).read_bytes()


def test_run_time_motions_are_refused_then_listed(models, tmp_path):
    with pytest.raises(InputError) as refusal:
        filter_job(models["true"], [SRC], tmp_path)
    message = str(refusal.value)
    for line in (46, 47, 67):
        assert f"pallet_cell.src line {line}" in message
    assert "\n" not in message and not list(tmp_path.iterdir())
    result = CliRunner().invoke(app, ["filter", str(models["true"]), str(SRC), "--out", str(tmp_path)])
    assert result.exit_code == 2 and "Traceback" not in result.output and not list(tmp_path.iterdir())
    result = CliRunner().invoke(app, ["filter", str(models["true"]), str(SRC), "--out", str(tmp_path),
                                      "--allow-unfiltered"])
    assert result.exit_code == 0, result.output
    assert "line 46: LIN_REL" in result.output and "line 67: XP6.Z assigned in code" in result.output
    summary = (tmp_path / "filter-summary.csv").read_text()
    assert summary.count("unfiltered (run time)") == 3


def test_a_filtered_program_is_refused(models, tmp_path):
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir(), second.mkdir()
    filter_job(models["true"], [SRC], first, allow_unfiltered=True)
    with pytest.raises(InputError, match="written by robocal filter already"):
        filter_job(models["true"], [first / "pallet_cell.src"], second, allow_unfiltered=True)
    assert not list(second.iterdir())


def test_unreachable_targets_are_refused(models, tmp_path):
    program = tmp_path / "far.src"
    shutil.copy(SRC, program)
    shutil.copy(SRC.with_suffix(".dat"), tmp_path / "far.dat")  # its data list, beside it
    text = program.read_bytes().replace(b"PTP {X 1580.745", b"PTP {X 4580.745")
    program.write_bytes(text)
    (tmp_path / "out").mkdir()
    with pytest.raises(InputError, match=r"far.src line 57 \(inline\).*nothing was written"):
        filter_job(models["true"], [program], tmp_path / "out", allow_unfiltered=True)
    assert not list((tmp_path / "out").iterdir())
    assert Path(program).exists()


def test_targets_outside_the_domain_are_refused_unless_accepted(tmp_path):
    # Trained with A1 between 0 and 90 deg: XP6, XP7, XP8 (A1 -20, -35, -50) lie outside.
    model = model_of(true_robot("kr150-2"), tmp_path, first_joint=(0.0, 90.0))
    (tmp_path / "out").mkdir()
    with pytest.raises(InputError, match=r"outside the model's domain of validity.*XP6.*--accept-extrapolation"):
        filter_job(model, [SRC], tmp_path / "out", allow_unfiltered=True)
    assert not list((tmp_path / "out").iterdir())
    result = filter_job(model, [SRC], tmp_path / "out", allow_unfiltered=True, accept_extrapolation=True)
    assert result.outside_domain >= 3
    summary = (tmp_path / "out" / "filter-summary.csv").read_text().splitlines()[1:]
    rows = {r.split(",")[2]: r.split(",")[6] for r in summary}
    assert rows["XP8"] == "0" and rows["XP3"] == "1"


def test_unreadable_inputs_are_one_line(models, tmp_path):
    runner = CliRunner()
    text = tmp_path / "p.txt"
    text.write_text("PTP {X 1}\n")
    fifo = tmp_path / "pipe.src"
    os.mkfifo(fifo)
    for args, says in (([text], "cannot tell the robot language"), ([tmp_path / "missing.src"], "does not exist"),
                       (["/dev/zero"], "is not a regular file"), ([fifo], "is not a regular file"),
                       ([tmp_path], "is a directory"), ([text, "--language", "fanuc"], "unknown --language")):
        result = runner.invoke(app, ["filter", str(models["true"]), *map(str, args), "--out", str(tmp_path)])
        lines = [line for line in result.output.splitlines() if line.strip()]
        assert result.exit_code == 2 and len(lines) == 1 and says in lines[0], result.output


def _text(path):
    return path.read_bytes().decode("latin-1")


def _in_metres(text):
    """The data list with every X, Y, Z of its Cartesian targets divided by 1000."""
    return re.sub(r"\{X (-?[\d.]+),Y (-?[\d.]+),Z (-?[\d.]+)",
                  lambda m: "{" + ",".join(f"{k} {float(v) / 1000:.6f}" for k, v in zip("XYZ", m.groups())), text)


FIRST_POINT = "{X 1580.745,Y -173.97,Z 1562.688,A 13.217,B -28.817,C 161.742}"
HOME = "{A1 0,A2 -90,A3 90,A4 0,A5 45,A6 0}"


def _cell(dat=None):
    """pallet_cell.src with its .dat (``dat(text)`` changes it; without ``dat``, none)."""
    files = {"pallet_cell.src": _text(SRC)}
    if dat is not None:
        files["pallet_cell.dat"] = dat(_text(KRL / "pallet_cell.dat"))
    return files


# Programs robocal cannot filter truthfully, refused in one line naming why.
REFUSED = [
    ("src-without-its-dat", lambda: _cell(), ["pallet_cell.src"],
     "its data list is missing: no pallet_cell.dat (in any case) in "),
    ("dat-in-metres", lambda: _cell(_in_metres), ["pallet_cell.src", "--allow-unfiltered"],
     "pallet_cell.dat (in the robot's base): largest 1.95, where a length about robot 'KUKA KR 150-2' (reach"),
    ("first-ptp-without-s-and-t", lambda: {**_cell(str), "p.src": f"DEF p( )\nPTP {FIRST_POINT}\nLIN XP1\nEND\n"},
     ["p.src", "pallet_cell.dat"], "p.src line 2 (inline): no joint position comes before this motion"),
    ("first-lin-without-s-and-t", lambda: {"p.src": f"DEF p( )\nLIN {FIRST_POINT}\nPTP {HOME}\nEND\n"}, ["p.src"],
     "start the program with a PTP to joint values (an E6AXIS"),
    # hostile pass 5
    ("ptp-rel", lambda: {"p.src": f"DEF p( )\nPTP {HOME}\nPTP_REL {{A1 10}}\nEND\n"}, ["p.src"],
     "1 motion(s) are computed at run time and cannot be filtered (p.src line 3: PTP_REL"),
    ("dat-saved-as-utf-16", lambda: _cell(lambda t: t.encode("utf-16-le").decode("latin-1")), ["pallet_cell.src"],
     "pallet_cell.dat is not a text program (it holds NUL bytes"),
]


@pytest.mark.parametrize("files, programs, says", [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED])
def test_programs_that_cannot_be_filtered_are_refused(models, tmp_path, monkeypatch, files, programs, says):
    assert_filter_refused(models["true"], files(), programs, says, tmp_path, monkeypatch)


def test_a_data_list_named_in_another_case_is_found(models, tmp_path):
    # Files copied from the controller's disk: CELL.DAT beside cell.src.
    shutil.copy(SRC, tmp_path / "cell.src")
    shutil.copy(KRL / "pallet_cell.dat", tmp_path / "CELL.DAT")
    (tmp_path / "fo").mkdir()
    result = filter_job(models["true"], [tmp_path / "cell.src"], tmp_path / "fo", allow_unfiltered=True)
    assert result.targets == 14
    assert_only_targets_changed(tmp_path / "CELL.DAT", tmp_path / "fo" / "CELL.DAT", ";")
