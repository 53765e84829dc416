"""What `robocal validate` refuses: every row of the table exits non-zero with one error line (plus at
most the usage hint), no traceback, no file left behind and no input rewritten
(:func:`refusals.assert_refused`), each in a fresh copy of the prepared inputs
(``conftest.refusal_inputs``).  Add a row with every refusal added to robocal."""
import pytest

from refusals import EXAMPLES, PLATE, assert_refused, copy_inputs

REFUSED = [
    ("validate ur5 beyond.csv", "--beyond-limits"),
    ("validate ur5 meas.csv --folds 1", ""),
    ("validate ur5 meas.csv --folds 1000", ""),
    ("validate ur5 meas.csv --sizes 10,abc", ""),
    ("validate ur5 meas.csv --sizes 5000", ""),
    ("validate ur5 meas.csv --method kriging --loss huber", "--loss"),
    ("validate kr150-2 sockets.csv --method constraint --fixture {examples}/plate-fixture.toml --sizes 10", "--sizes"),
    ("validate kr150-2 one_placement.csv --method constraint --fixture {examples}/plate-fixture.toml", "placement"),
    ("validate ur5 meas.csv --folds 0", "--folds"),
    ("validate ur5 meas.csv --folds -3", "--folds"),
    ("validate ur5 meas.csv --folds 2.5", "--folds"),
    ("validate ur5 meas.csv --sizes 0,10", "--sizes"),
    ("validate ur5 meas.csv --sizes -5,10", "--sizes"),
    ("validate ur5 meas.csv --sizes ,", "--sizes"),
    ("validate ur5 meas.csv --method kriging --parameters full", "--parameters does not apply"),
    ("validate ur5 meas.csv --method constraint", "fixture and socket"),
    ("validate ur5 meas.csv --payload 2", "--payload"),
    ("validate ur5 meas.csv --fixture {plate}", "ball-in-socket"),
    ("validate ur5 meas.csv --pairs spanning", "--pairs does not apply"),
    ("validate ur5 radians.csv", "mm and degrees"),
    ("validate ur5 missing.csv", "does not exist"),
    ("validate nosuchrobot meas.csv", "no built-in robot"),
    ("validate ur5 meas.csv --out x.json", "--out"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_validate_refuses_in_one_line(refusal_inputs, tmp_path, monkeypatch, command, says):
    before = copy_inputs(refusal_inputs, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)
