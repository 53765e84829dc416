"""What the verbs that only print (`robocal show`, `robots`, `methods`, `demo`) refuse: every row
of the table exits non-zero with one error line (plus at
most the usage hint), no traceback, no file left behind and no input rewritten
(:func:`refusals.assert_refused`), each in a fresh copy of the prepared inputs
(``conftest.refusal_inputs``).  Add a row with every refusal added to robocal."""
import pytest

from refusals import EXAMPLES, PLATE, assert_refused, copy_inputs

REFUSED = [
    ("show nosuchrobot", ""),
    ("show empty_robot.toml", "empty"),
    ("show no_convention.toml", "convention"),
    ("show ur5 --tip tool0", "URDF"),
    ("show no_joints.toml", ""),
    ("show ur5.urdf --tip nosuchlink", "no link 'nosuchlink'"),
    ("show r_text.toml", "must be a number"),
    ("show r_binary.toml", "not a text file"),
    ("show u_notxml.urdf", "not well-formed XML"),
    ("show meas.csv", "meas.csv is a measurement file"),
    ("show model.json", "is a robocal model file, written by 'robocal calibrate', not a robot file"),
    ("show", "robot"),
    ("robots extra", "extra"),
    ("robots --json", "--json"),
    ("methods kinematic", "kinematic"),
    ("methods --json", "--json"),
    ("demo extra", "extra"),
    ("demo --seed 3", "--seed"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_printing_verb_refuses_in_one_line(refusal_inputs, tmp_path, monkeypatch, command, says):
    before = copy_inputs(refusal_inputs, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)
