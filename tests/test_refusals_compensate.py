"""What `robocal compensate` refuses: every row of the table exits non-zero with one error line (plus at
most the usage hint), no traceback, no file left behind and no input rewritten
(:func:`refusals.assert_refused`), each in a fresh copy of the prepared inputs
(``conftest.refusal_inputs``).  Add a row with every refusal added to robocal.  The
legitimate variants of its inputs (ACCEPTED) run."""
import pytest

from refusals import EXAMPLES, PLATE, assert_accepted, assert_refused, copy_inputs, refused_with_usage_error

REFUSED = [
    ("compensate model.json missing.csv --out c.csv", ""),
    ("compensate model.json no_targets_cols.csv --out c.csv", "rx"),
    ("compensate model.json far.csv --out c.csv", "none of the 2 targets"),
    ("compensate junk.json {examples}/ur5-targets.csv --out c.csv", ""),
    ("compensate model.json t_nan.csv --out c.csv", "not a finite number"),
    ("compensate model.json t_huge.csv --out c.csv", "column 'ry': -5e9 is beyond"),
    ("compensate model.json t_text.csv --out c.csv", "'abc' is not a number"),
    ("compensate model.json t_inf.csv --out c.csv", "not a finite number"),
    ("compensate model.json t_empty.csv --out c.csv", "is empty"),
    ("compensate model.json t_header.csv --out c.csv", "no data rows"),
    ("compensate model.json t_norot.csv --out c.csv", "rx, ry, rz"),
    ("compensate model.json t_dup.csv --out c.csv", "appears twice"),
    ("compensate model.json t_metres.csv --out c.csv", "they look like metres"),
    ("compensate model.json t_fewq.csv --out c.csv", "6 joints"),
    ("compensate model.json t_binary.csv --out c.csv", "not a text CSV"),
    ("compensate model.json meas.csv --out c.csv", "rx, ry, rz"),
    ("compensate model.json {examples}/kr150-targets.csv --out c.csv", "none of the 5 targets"),
    ("compensate model.json {examples}/ur5-targets.csv --out nodir/c.csv", "nodir"),
    ("compensate model.json {examples}/ur5-targets.csv", "--out"),
    # an output that is an input, or a second output in a missing folder: refused before anything is written
    ("compensate model.json meas.csv --out meas.csv", "also an input"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_compensate_refuses_in_one_line(refusal_inputs, tmp_path, monkeypatch, command, says):
    before = copy_inputs(refusal_inputs, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)


ACCEPTED = [
    "compensate cmodel.json {examples}/kr150-targets.csv --out c.csv",
]


@pytest.mark.parametrize("command", ACCEPTED)
def test_legitimate_compensate_variant_is_accepted(refusal_inputs, tmp_path, monkeypatch, command):
    copy_inputs(refusal_inputs, tmp_path, monkeypatch)
    assert_accepted(command.format(examples=EXAMPLES).split())


def test_compensate_fails_when_no_target_is_reachable(ur5_files, tmp_path):
    model, out = ur5_files / "model.json", tmp_path / "c.csv"
    far = tmp_path / "far.csv"
    far.write_text("x,y,z,rx,ry,rz\n5000,0,0,180,0,0\n0,7000,0,180,0,0\n")
    assert "none of the 2 targets" in refused_with_usage_error(["compensate", model, far, "--out", out], out)
