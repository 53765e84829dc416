"""What `robocal evaluate` refuses: every row of the table exits non-zero with one error line (plus at
most the usage hint), no traceback, no file left behind and no input rewritten
(:func:`refusals.assert_refused`), each in a fresh copy of the prepared inputs
(``conftest.refusal_inputs``).  Add a row with every refusal added to robocal.  The
legitimate variants of its inputs (ACCEPTED) run."""
import pytest

from refusals import EXAMPLES, PLATE, assert_accepted, assert_refused, copy_inputs

REFUSED = [
    ("evaluate model.json metres.csv", "metres"),
    ("evaluate missing.json meas.csv", ""),
    ("evaluate junk.json meas.csv", ""),
    ("evaluate edited.json meas.csv", "checksum"),
    ("evaluate truncated.json meas.csv", ""),
    ("evaluate model.json missing.csv", ""),
    ("evaluate model.json sockets.csv", ""),
    ("evaluate model.json meas.csv --fixture {examples}/plate-fixture.toml", ""),
    ("evaluate model.json dup_header.csv", "appears twice"),
    ("evaluate model.json no_q1.csv", "no q1"),
    ("evaluate m_list.json meas.csv", "not a robocal model file"),
    ("evaluate m_empty.json meas.csv", "not a robocal model file"),
    ("evaluate m_binary.json meas.csv", "not a robocal model file"),
    ("evaluate m_version.json meas.csv", "upgrade robocal"),
    ("evaluate m_schema.json meas.csv", "not a robocal model file"),
    ("evaluate m_method.json meas.csv", "checksum"),
    ("evaluate m_created.json meas.csv", "checksum"),
    ("evaluate meas.csv model.json", "meas.csv is a measurement file"),
    ("evaluate tsinghua.toml meas.csv", "is a robot file, written by 'robocal export', not a model file"),
    ("evaluate model.json meas.csv --fixture missing.toml", "does not exist"),
    ("evaluate model.json meas.csv --out x.json", "--out"),
    ("evaluate model.json missing.csv --json", "does not exist"),
    ("evaluate cmodel.json sockets.csv --fixture fx_same.toml", "both at"),
    ("evaluate cmodel.json sockets.csv --fixture fx_no_a.toml", "socket id(s) A"),
    ("evaluate cmodel.json meas.csv", "limits"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_evaluate_refuses_in_one_line(refusal_inputs, tmp_path, monkeypatch, command, says):
    before = copy_inputs(refusal_inputs, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)


ACCEPTED = [
    "evaluate m_reformat.json meas.csv",
    "evaluate model.json meas.csv --beyond-limits",
]


@pytest.mark.parametrize("command", ACCEPTED)
def test_legitimate_evaluate_variant_is_accepted(refusal_inputs, tmp_path, monkeypatch, command):
    copy_inputs(refusal_inputs, tmp_path, monkeypatch)
    assert_accepted(command.format(examples=EXAMPLES).split())
