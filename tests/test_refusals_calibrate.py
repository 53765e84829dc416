"""What `robocal calibrate` refuses: every row of the table exits non-zero with one error line (plus at
most the usage hint), no traceback, no file left behind and no input rewritten
(:func:`refusals.assert_refused`), each in a fresh copy of the prepared inputs
(``conftest.refusal_inputs``).  Add a row with every refusal added to robocal.  The
legitimate variants of its inputs (ACCEPTED) run."""
import json
from pathlib import Path

import pytest

from refusals import EXAMPLES, PLATE, assert_accepted, assert_refused, copy_inputs, run_ok, runner
from robocal.interfaces.cli import app

REFUSED = [
    ("calibrate ur5 meas.csv --out m.json --tip tool0", "URDF"),
    ("calibrate ur5 comment.csv --out m.json", "comment"),
    # files
    ("calibrate ur5 missing.csv --out m.json", "does not exist"),
    ("calibrate ur5 empty.csv --out m.json", ""),
    ("calibrate ur5 header_only.csv --out m.json", ""),
    ("calibrate ur5 joints_only.csv --out m.json", "x, y, z"),
    ("calibrate ur5 nan.csv --out m.json", ""),
    ("calibrate ur5 text.csv --out m.json", ""),
    ("calibrate ur5 seven.csv --out m.json", ""),
    ("calibrate ur5 binary.csv --out m.json", ""),
    ("calibrate ur5 few.csv --out m.json", ""),
    ("calibrate ur5 same.csv --out m.json", "distinct"),
    ("calibrate ur5 beyond.csv --out m.json", "row 7"),
    ("calibrate ur5 metres.csv --out m.json", "metres"),
    ("calibrate nosuchrobot meas.csv --out m.json", ""),
    ("calibrate no_joints.toml meas.csv --out m.json", ""),
    ("calibrate ur5 meas.csv --out missing_dir/m.json", ""),
    ("calibrate ur5 meas.csv --out a_directory", ""),
    # options
    ("calibrate ur5 meas.csv --out m.json --method nope", "nope"),
    ("calibrate ur5 meas.csv --out m.json --method kriging --payload 2", "--payload"),
    ("calibrate ur5 meas.csv --out m.json --trend linear", "--trend"),
    ("calibrate ur5 meas.csv --out m.json --method kriging --loss huber", "--loss"),
    ("calibrate ur5 meas.csv --out m.json --method kriging --pairs all", "--pairs"),
    ("calibrate ur5 meas.csv --out m.json --parameters everything", ""),
    ("calibrate ur5 meas.csv --out m.json --loss cauchy", ""),
    ("calibrate ur5 meas.csv --out m.json --register maybe", ""),
    ("calibrate ur5 meas.csv --out m.json --payload 2", "--payload"),
    ("calibrate ur5 meas.csv --out m.json --parameters full+compliance --payload -1", "payload"),
    ("calibrate ur5 meas.csv --out m.json --parameters full+compliance --payload 5000", "give the payload in kg"),
    ("calibrate ur5 meas.csv --out m.json --method kriging --nugget abc", ""),
    ("calibrate ur5 meas.csv --out m.json --method kriging --trend cubic", ""),
    ("calibrate ur5 meas.csv --out m.json --method ann --hidden 8", ""),
    ("calibrate ur5 meas.csv --out m.json --method ann --refine adam", ""),
    ("calibrate ur5 meas.csv --out m.json --method ann --trainer sgd", ""),
    ("calibrate ur5 meas.csv --out m.json --method ann --parameters full+gains", "--base-model"),
    ("calibrate ur5 meas.csv --out m.json --method ann --base-model other", ""),
    ("calibrate ur5 meas.csv --out m.json --fixture {examples}/plate-fixture.toml", "ball-in-socket"),
    ("calibrate ur5 meas.csv --out m.json --method constraint", ""),
    ("calibrate ur5 meas.csv --out m.json --method kriging --nugget inf", "--nugget"),
    ("calibrate ur5 meas.csv --out m.json --method kriging --nugget nan", "--nugget"),
    ("calibrate ur5 meas.csv --out m.json --method ann --hidden 0,4", "--hidden"),
    ("calibrate ur5 meas.csv --out m.json --method ann --hidden 4,-4", "--hidden"),
    ("calibrate ur5 meas.csv --out m.json --method ann --generations abc", "--generations"),
    ("calibrate ur5 meas.csv --out m.json --method ann --hidden 100000,100000", "<= 256"),
    ("calibrate ur5 meas.csv --out m.json --method ann --trainer lbfgs", "at least 145 poses"),
    ("calibrate ur5 meas.csv --out m.json --method kinematic --hidden 4,4", "--hidden does not apply"),
    ("calibrate ur5 meas.csv --out m.json --method kinematic --generations 5", "--generations does not apply"),
    ("calibrate ur5 meas.csv --out m.json --method kinematic --seed 3", "--seed does not apply"),
    ("calibrate ur5 meas.csv --out m.json --method hybrid --hidden 4,4", "--hidden does not apply"),
    ("calibrate ur5 meas.csv --out m.json --parameters full+compliance --payload nan", "--payload"),
    ("calibrate ur5 meas.csv --out m.json --parameters full+compliance --payload inf", "--payload"),
    ("calibrate ur5 meas.csv --out m.json --method constraint --fixture {plate}", "ball-in-socket"),
    # ball-in-socket data
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint", "--fixture"),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture missing.toml", ""),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture one_socket.toml", ""),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture not_toml.toml", ""),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture misspelt.toml", "[sockets]"),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture {examples}/plate-fixture.toml "
     "--parameters offsets", ""),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture {examples}/plate-fixture.toml "
     "--pairs some", ""),
    ("calibrate kr150-2 sockets.csv --out m.json", "x, y, z"),
    # an output that is an input, or a second output in a missing folder: refused before anything is written
    ("calibrate ur5 meas.csv --out meas.csv", "name it meas.json"),  # refused by its name first
    # measurement CSV
    ("calibrate ur5 dup_header.csv --out m.json", "'q1' appears twice"),
    ("calibrate ur5 upper.csv --out m.json", "did you mean 'q1'"),
    ("calibrate ur5 misspelt.csv --out m.json", "did you mean 'q3'"),
    ("calibrate ur5 px.csv --out m.json", "did you mean 'x'"),
    ("calibrate ur5 inf.csv --out m.json", "not a finite number"),
    ("calibrate ur5 nan_joint.csv --out m.json", "column 'q1'"),
    ("calibrate ur5 empty_cell.csv --out m.json", "the cell is empty"),
    ("calibrate ur5 short_row.csv --out m.json", "5 cells but the header has 12"),
    ("calibrate ur5 long_row.csv --out m.json", "14 cells"),
    ("calibrate ur5 truncated.csv --out m.json", "row 3"),
    ("calibrate ur5 semicolon.csv --out m.json", "not comma-separated"),
    ("calibrate ur5 decimal_comma.csv --out m.json", "not comma-separated"),
    ("calibrate ur5 radians.csv --out m.json", "mm and degrees"),
    ("calibrate ur5 neg_sigma.csv --out m.json", "must be > 0"),
    ("calibrate ur5 zero_sigma.csv --out m.json", "must be > 0"),
    ("calibrate ur5 nan_sigma.csv --out m.json", "column 'sx'"),
    ("calibrate ur5 no_q1.csv --out m.json", "no q1"),
    ("calibrate ur5 no_header.csv --out m.json", "add a header line"),
    ("calibrate ur5 header_twice.csv --out m.json", "row 32"),
    ("calibrate iiwa14 meas.csv --out m.json", "7 joints"),
    ("calibrate ur5 meas.csv --out .", "directory"),
    ("calibrate ur5 meas.csv", "--out"),
    ("calibrate ur5", "measurements"),
    # robot TOML and URDF
    ("calibrate ur5.urdf meas.csv --out m.json --tip nosuchlink", "no link 'nosuchlink'"),
    ("calibrate ur5.urdf meas.csv --out m.json --root nosuchlink", "no link 'nosuchlink'"),
    ("calibrate ur5.urdf meas.csv --out m.json --root link_3 --tip link_2", "no path"),
    ("calibrate r_metres.toml meas.csv --out m.json", "metres"),
    ("calibrate r_radians.toml meas.csv --out m.json", "mm and degrees"),
    ("calibrate r_text.toml meas.csv --out m.json", "must be a number"),
    ("calibrate r_nan.toml meas.csv --out m.json", "must be finite"),
    ("calibrate r_inf.toml meas.csv --out m.json", "must be finite"),
    ("calibrate r_misspelt.toml meas.csv --out m.json", "did you mean 'alpha'"),
    ("calibrate r_conv.toml meas.csv --out m.json", "'sdh'"),
    ("calibrate r_minmax.toml meas.csv --out m.json", "above max"),
    ("calibrate r_missing_a.toml meas.csv --out m.json", "missing a"),
    ("calibrate r_trunc.toml meas.csv --out m.json", "not valid TOML"),
    ("calibrate r_binary.toml meas.csv --out m.json", "not a text file"),
    ("calibrate r_dupkey.toml meas.csv --out m.json", "not valid TOML"),
    ("calibrate r_negmass.toml meas.csv --out m.json --parameters full+compliance", "masses"),
    ("calibrate u_trunc.urdf meas.csv --out m.json", "not well-formed XML"),
    ("calibrate u_notxml.urdf meas.csv --out m.json", "not well-formed XML"),
    ("calibrate u_text.urdf meas.csv --out m.json", "not three numbers"),
    ("calibrate u_nojoints.urdf meas.csv --out m.json", "no movable joint"),
    ("calibrate u_loop.urdf meas.csv --out m.json", "form a loop through the links"),
    ("calibrate ur5 huge.csv --out m.json", "row 2, column 'x': 1e300 is beyond"),
    ("calibrate kr150-2 sock_one.csv --out m.json --method constraint --fixture {plate}", "distances between sockets"),
    # fixture TOML and ball-in-socket data
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture fx_text.toml", "socket B"),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture fx_two.toml", "socket B"),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture fx_nan.toml", "socket B"),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture fx_same.toml", "both at"),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture fx_empty.toml", "[sockets]"),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture fx_no_a.toml", "socket id(s) A"),
    ("calibrate kr150-2 sock_unknown.csv --out m.json --method constraint --fixture {plate}", "socket id(s) Z"),
    ("calibrate kr150-2 sock_empty_id.csv --out m.json --method constraint --fixture {plate}", "socket id"),
    ("calibrate kr150-2 sockets.csv --out m.json --method constraint --fixture {plate} --loss huber", "--loss"),
    ("calibrate kr150-2 sockets.csv --out m.json --method kriging --fixture {plate}", "x, y, z"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_calibrate_refuses_in_one_line(refusal_inputs, tmp_path, monkeypatch, command, says):
    before = copy_inputs(refusal_inputs, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)


ACCEPTED = [
    "calibrate ur5 spaces.csv --out m.json",
    "calibrate ur5 extra_col.csv --out m.json",
    "calibrate ur5 blank_lines.csv --out m.json",
    "calibrate ur5 bom.csv --out m.json",
    "calibrate ur5 crlf.csv --out m.json",
    "calibrate ur5 quoted.csv --out m.json",
]


@pytest.mark.parametrize("command", ACCEPTED)
def test_legitimate_calibrate_variant_is_accepted(refusal_inputs, tmp_path, monkeypatch, command):
    copy_inputs(refusal_inputs, tmp_path, monkeypatch)
    assert_accepted(command.format(examples=EXAMPLES).split())


def test_beyond_limits_accepts_the_rows_it_names(refusal_inputs, tmp_path):
    result = runner.invoke(app, ["calibrate", "ur5", str(refusal_inputs / "beyond.csv"), "--out",
                                 str(tmp_path / "m.json"), "--beyond-limits"])
    assert result.exit_code == 0, result.output


def test_the_table_is_large_enough():
    assert len(REFUSED) >= 60


def test_the_same_fit_from_a_reformatted_file(refusal_inputs, tmp_path, monkeypatch):
    """spaces after commas, quotes, CRLF, a BOM and blank lines change nothing in the fit."""
    copy_inputs(refusal_inputs, tmp_path, monkeypatch)
    models = {}
    for name in ("meas", "spaces", "quoted", "crlf", "bom", "blank_lines"):
        run_ok("calibrate", "ur5", f"{name}.csv", "--out", f"{name}.json")
        models[name] = json.loads(Path(f"{name}.json").read_text())["kinematics"]
    assert all(model == models["meas"] for model in models.values())
