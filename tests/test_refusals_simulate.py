"""What `robocal simulate` refuses: every row of the table exits non-zero with one error line (plus at
most the usage hint), no traceback, no file left behind and no input rewritten
(:func:`refusals.assert_refused`), each in a fresh copy of the prepared inputs
(``conftest.refusal_inputs``).  Add a row with every refusal added to robocal.  The
legitimate variants of its inputs (ACCEPTED) run."""
import pytest

from refusals import EXAMPLES, PLATE, assert_accepted, assert_refused, copy_inputs, refused_with_usage_error

REFUSED = [
    ("simulate ur5 --n 0 --out s.csv", "--n"),
    ("simulate ur5 --sampling lhs --out s.csv", "--box"),
    ("simulate ur5 --sampling nope --out s.csv", ""),
    ("simulate ur5 --noise -1 --out s.csv", "--noise"),
    ("simulate ur5 --sampling lhs --box 1,2,3 --out s.csv", "--box"),
    ("simulate ur5 --errors liu2022 --out s.csv", ""),
    ("simulate kr150-2 --sampling sockets --out s.csv", "--fixture"),
    ("simulate ur5 --rpy 1,2,3 --out s.csv", "--rpy does not apply"),
    ("simulate ur5 --placements 3 --out s.csv", "--placements does not apply"),
    ("simulate ur5 --fixture {examples}/plate-fixture.toml --out s.csv", "--fixture does not apply"),
    ("simulate ur5 --sampling grid --joint-noise 0.1 --box 0,100,0,100,0,100 --out s.csv",
     "--joint-noise does not apply"),
    ("simulate kr150-2 --sampling sockets --fixture {examples}/plate-fixture.toml --box 1,2,3,4,5,6 --out s.csv",
     "--box does not apply"),
    ("simulate kr150-2 --sampling sockets --fixture {examples}/plate-fixture.toml --per-socket 1 --out s.csv", ""),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --per-socket 100000 --out s.csv", "10,000"),
    ("simulate ur5 --n -5 --out s.csv", "--n"),
    ("simulate ur5 --n abc --out s.csv", "--n"),
    ("simulate ur5 --n 1.5 --out s.csv", "--n"),
    ("simulate ur5 --seed -1 --out s.csv", "--seed"),
    ("simulate ur5 --seed 1e3 --out s.csv", "--seed"),
    ("simulate ur5 --noise inf --out s.csv", "--noise"),
    ("simulate ur5 --sampling lhs --box -600,-300,-200,200,0,300 --rpy 1,2 --out s.csv", "--rpy"),
    ("simulate ur5 --sampling lhs --box -600,-300,-200,200,0,300 --hint 1,2,3 --out s.csv", "3 joint values"),
    ("simulate ur5 --sampling lhs --box 300,-600,-200,200,0,300 --out s.csv", "must not exceed"),
    ("simulate ur5 --sampling lhs --box a,b,c,d,e,f --out s.csv", "--box"),
    ("simulate ur5 --sampling lhs --box 5000,6000,5000,6000,5000,6000 --out s.csv", "cannot be reached"),
    ("simulate ur5 --sampling lhs --box -0.6,-0.3,-0.2,0.2,0,0.3 --out s.csv", "--box: largest 0.6"),
    ("simulate ur5 --sampling lhs --box -600,-300,-200,200,0,300 --rpy 3.1416,0,0 --out s.csv", "look like radians"),
    ("simulate ur5 --sampling grid --out s.csv", "--box"),
    ("simulate ur5 --errors missing.json --out s.csv", "does not exist"),
    ("simulate ur5 --errors model.json --out s.csv", "written by 'robocal calibrate', not a truth file"),
    ("simulate ur5 --errors meas.csv --out s.csv", "meas.csv is a measurement file"),
    ("simulate ur5 --out nodir/s.csv", "nodir"),
    ("simulate iiwa14 --errors liu2022 --out s.csv", "kr150-2"),
    ("simulate u_text.urdf --out s.csv", "not three numbers"),
    ("simulate r_metres.toml --n 10 --out s.csv", "looks like metres"),
    ("simulate r_metres.toml --sampling sockets --fixture {plate} --out s.csv", "looks like metres"),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --placements 0 --out s.csv", "--placements"),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --placements -1 --out s.csv", "--placements"),
    ("simulate kr150-2 --sampling sockets --fixture fx_text.toml --out s.csv", "socket B"),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --joint-noise -1 --out s.csv", "--joint-noise"),
    # an output that is an input, or a second output in a missing folder: refused before anything is written
    ("simulate ur5 --n 10 --out s --truth s", "two outputs"),
    ("simulate ur5 --n 10 --out s.csv --truth missing_dir/t.json", "does not exist"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_simulate_refuses_in_one_line(refusal_inputs, tmp_path, monkeypatch, command, says):
    before = copy_inputs(refusal_inputs, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)


ACCEPTED = [
    # (the command, the data rows of s.csv it writes)
    ("simulate ur5 --sampling grid --n 2 --box -600,-300,-200,200,0,300 --out s.csv", None),
    ("simulate ur5 --n 10 --orientation --orientation --out s.csv", 10),
    # hostile pass 5
    ("simulate fanuc-r2000ic-165f --n 20 --orientation --out s.csv", 20),
    ("simulate panda --sampling sockets --fixture {examples}/plate-fixture.toml --placements 2 --per-socket 4 "
     "--out s.csv", 24),
]


@pytest.mark.parametrize("command, rows", ACCEPTED, ids=[row[0] for row in ACCEPTED])
def test_legitimate_simulate_variant_is_accepted(refusal_inputs, tmp_path, monkeypatch, command, rows):
    copy_inputs(refusal_inputs, tmp_path, monkeypatch)
    assert_accepted(command.format(examples=EXAMPLES).split())
    assert rows is None or len((tmp_path / "s.csv").read_text().splitlines()) == rows + 1


def test_simulate_refuses_zero_poses(tmp_path):
    out = tmp_path / "m.csv"
    assert "--n" in refused_with_usage_error(["simulate", "ur5", "--n", "0", "--out", out], out)
