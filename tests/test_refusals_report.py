"""What `robocal report` refuses: every row of the table exits non-zero with one error line (plus at
most the usage hint), no traceback, no file left behind and no input rewritten
(:func:`refusals.assert_refused`), each in a fresh copy of the prepared inputs
(``conftest.refusal_inputs``).  Add a row with every refusal added to robocal."""
import pytest

from refusals import EXAMPLES, PLATE, assert_refused, copy_inputs

REFUSED = [
    ("report model.json meas.csv --out r.txt", ".html"),
    ("report model.json meas.csv --out r.html --pdf p.png", ".pdf"),
    ("report model.json meas.csv --out r.html --validation cv_junk.json", "validate"),
    ("report model.json meas.csv --out r.html --validation junk.json", ""),
    ("report model.json meas.csv --out r.html --validation missing.json", "does not exist"),
    ("report model.json meas.csv --out nodir/r.html", "nodir"),
    ("report model.json meas.csv --out r.html --pdf r.html", ".pdf"),
    ("report model.json meas.csv --out meas.csv", ".html"),
    ("report m_version.json meas.csv --out r.html", "upgrade robocal"),
    ("report model.json no_q1.csv --out r.html", "no q1"),
    ("report model.json meas.csv --out r.html --validation val_bad.json", "cross_validation"),
    ("report model.json meas.csv --out r.html --validation meas.csv", "meas.csv is a measurement file"),
    ("report model.json meas.csv --out r.html --validation val_kriging.json", "the model is 'kinematic'"),
    ("report model.json meas.csv --out r.html --validation val_no_pool.json", "cross_validation.pooled.mean_mm"),
    # an output that is an input, or a second output in a missing folder: refused before anything is written
    ("report model.json meas.csv --out r.html --pdf missing_dir/p.pdf", "does not exist"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_report_refuses_in_one_line(refusal_inputs, tmp_path, monkeypatch, command, says):
    before = copy_inputs(refusal_inputs, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)
