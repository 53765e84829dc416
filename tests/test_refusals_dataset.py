"""What `robocal dataset` refuses: every row of the table exits non-zero with one error line (plus at
most the usage hint), no traceback, no file left behind and no input rewritten
(:func:`refusals.assert_refused`), each in a fresh copy of the prepared inputs
(``conftest.refusal_inputs``).  Add a row with every refusal added to robocal."""
import pytest

from refusals import EXAMPLES, PLATE, assert_refused, copy_inputs, refused_with_usage_error

REFUSED = [
    ("dataset nope --out d", ""),
    ("dataset ur5-tsinghua --out d --split 1.5", "--split"),
    ("dataset ur5-tsinghua --out d --split 0", "--split"),
    ("dataset ur5-tsinghua --out d --split 1", "--split"),
    ("dataset ur5-tsinghua --out d --split nan", "--split"),
    ("dataset ur5-tsinghua --out d --split abc", "--split"),
    ("dataset ur5-tsinghua --out d --split 0.5 --seed -1", "--seed"),
    ("dataset ur5-tsinghua --out nodir/d", "nodir"),
    ("dataset ur5-tsinghua --out ./", "is a folder: give a prefix"),
    ("dataset ur5-tsinghua --out .", "is a folder: give a prefix"),
    ("dataset ur5-tsinghua", "--out"),
    ("dataset", "dataset"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_dataset_refuses_in_one_line(refusal_inputs, tmp_path, monkeypatch, command, says):
    before = copy_inputs(refusal_inputs, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)


def test_a_refused_dataset_split_writes_nothing(tmp_path):
    prefix = tmp_path / "ur5"
    message = refused_with_usage_error(["dataset", "ur5-tsinghua", "--out", prefix, "--split", "1.5"], f"{prefix}.toml",
                       f"{prefix}_train.csv")
    assert "--split" in message
    assert list(tmp_path.iterdir()) == []
