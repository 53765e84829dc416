"""What `robocal export` refuses: every row of the table exits non-zero with one error line (plus at
most the usage hint), no traceback, no file left behind and no input rewritten
(:func:`refusals.assert_refused`), each in a fresh copy of the prepared inputs
(``conftest.refusal_inputs``).  Add a row with every refusal added to robocal.  The
legitimate variants of its inputs (ACCEPTED) run."""
import pytest

from refusals import EXAMPLES, PLATE, assert_accepted, assert_refused, copy_inputs

REFUSED = [
    ("export model.json --format step --out x.toml", ""),
    ("export model.json --convention abc --out x.toml", ""),
    ("export missing.json --out x.toml", ""),
    ("export model.json --out nodir/x.toml", "nodir"),
    ("export m_version.json --out x.toml", "upgrade robocal"),
    ("export model.json", "--out"),
    # an output that is an input, or a second output in a missing folder: refused before anything is written
    ("export model.json --out model.json", "name it model.toml"),  # refused by its name first
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_export_refuses_in_one_line(refusal_inputs, tmp_path, monkeypatch, command, says):
    before = copy_inputs(refusal_inputs, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)


ACCEPTED = [
    "export model.json --convention poe --format urdf --out x.urdf",
    "export cmodel.json --out x.toml",
]


@pytest.mark.parametrize("command", ACCEPTED)
def test_legitimate_export_variant_is_accepted(refusal_inputs, tmp_path, monkeypatch, command):
    copy_inputs(refusal_inputs, tmp_path, monkeypatch)
    assert_accepted(command.format(examples=EXAMPLES).split())
