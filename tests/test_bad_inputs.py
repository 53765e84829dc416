"""A hostile user's inputs, through the command line: every row must be refused with a non-zero
exit, one line that says what is wrong (plus at most the usage hint), no traceback, and no
output file left behind.  Add a row with every refusal added to robocal."""
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from refusals import assert_refused, copy_inputs
from robocal.interfaces.cli import app

runner = CliRunner()
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Good files to break: a UR5 measurement file and its model, ball-in-socket data, and
    broken variants of each format."""
    root = tmp_path_factory.mktemp("bad")

    def run(*args):
        result = runner.invoke(app, [str(a) for a in args])
        assert result.exit_code == 0, result.output

    run("simulate", "ur5", "--n", "80", "--out", root / "meas.csv")
    run("calibrate", "ur5", root / "meas.csv", "--out", root / "model.json")
    run("simulate", "kr150-2", "--sampling", "sockets", "--fixture", EXAMPLES / "plate-fixture.toml",
        "--placements", "3", "--per-socket", "6", "--out", root / "sockets.csv")
    run("simulate", "kr150-2", "--sampling", "sockets", "--fixture", EXAMPLES / "plate-fixture.toml",
        "--placements", "1", "--per-socket", "6", "--out", root / "one_placement.csv")
    lines = (root / "meas.csv").read_text().splitlines()
    header, rows = lines[0], lines[1:]
    write = {
        "empty.csv": "",
        "header_only.csv": header + "\n",
        "joints_only.csv": "q1,q2,q3,q4,q5,q6\n" + "\n".join(",".join(r.split(",")[:6]) for r in rows) + "\n",
        "nan.csv": "\n".join([header, rows[0].replace(rows[0].split(",")[6], "nan", 1)] + rows[1:]) + "\n",
        "text.csv": "\n".join([header, "abc" + rows[0][rows[0].index(","):]] + rows[1:]) + "\n",
        "seven.csv": header.replace("q6,", "q6,q7,") + "\n" + "\n".join(
            ",".join(r.split(",")[:6] + ["0"] + r.split(",")[6:]) for r in rows) + "\n",
        "few.csv": "\n".join([header] + rows[:3]) + "\n",
        "same.csv": "\n".join([header] + [rows[0]] * 40) + "\n",
        "no_targets_cols.csv": "x,y,z\n1,2,3\n",
        "far.csv": "x,y,z,rx,ry,rz\n5000,0,0,180,0,0\n0,7000,0,180,0,0\n",
        "one_socket.toml": 'name = "one"\n[sockets]\nA = [0, 0, 0]\n',
        "not_toml.toml": "this is [not toml\n",
        "misspelt.toml": 'name = "x"\n[socket]\nA = [0, 0, 0]\nB = [1, 0, 0]\n',
        "no_joints.toml": 'name = "nothing"\nconvention = "dh"\n',
        "empty_robot.toml": "",
        "no_convention.toml": 'name = "x"\n[[joints]]\na = 1.0\n',
        "comment.csv": "# measured 2024\n" + header + "\n" + "\n".join(rows) + "\n",
        "junk.json": "{not json",
        "cv_junk.json": json.dumps({"hello": 1}),
    }
    for name, text in write.items():
        (root / name).write_text(text)
    (root / "binary.csv").write_bytes(b"\xff\xfe\x00\x01garbage")
    cells = [r.split(",") for r in rows]
    beyond = [c.copy() for c in cells]
    # The same pose one turn further: beyond the +-360 deg limits, but what the robot measured.
    q1 = float(beyond[5][0])
    beyond[5][0] = repr(q1 + 360.0 if q1 >= 0 else q1 - 360.0)
    (root / "beyond.csv").write_text("\n".join([header] + [",".join(c) for c in beyond]) + "\n")
    xyz = [header.split(",").index(k) for k in "xyz"]
    metres = [[str(float(v) / 1000) if k in xyz else v for k, v in enumerate(c)] for c in cells]
    (root / "metres.csv").write_text("\n".join([header] + [",".join(c) for c in metres]) + "\n")
    model = json.loads((root / "model.json").read_text())
    model["kinematics"]["joints"][1]["a"] += 0.5
    (root / "edited.json").write_text(json.dumps(model))
    (root / "truncated.json").write_text((root / "model.json").read_text()[:500])
    (root / "a_directory").mkdir()
    return root


ROWS = [
    # calibrate: files
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
    ("validate ur5 beyond.csv", "--beyond-limits"),
    ("evaluate model.json metres.csv", "metres"),
    ("calibrate nosuchrobot meas.csv --out m.json", ""),
    ("calibrate no_joints.toml meas.csv --out m.json", ""),
    ("calibrate ur5 meas.csv --out missing_dir/m.json", ""),
    ("calibrate ur5 meas.csv --out a_directory", ""),
    # calibrate: options
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
    ("calibrate ur5 meas.csv --out m.json --method kriging --nugget abc", ""),
    ("calibrate ur5 meas.csv --out m.json --method kriging --trend cubic", ""),
    ("calibrate ur5 meas.csv --out m.json --method ann --hidden 8", ""),
    ("calibrate ur5 meas.csv --out m.json --method ann --refine adam", ""),
    ("calibrate ur5 meas.csv --out m.json --method ann --trainer sgd", ""),
    ("calibrate ur5 meas.csv --out m.json --method ann --parameters full+gains", "--base-model"),
    ("calibrate ur5 meas.csv --out m.json --method ann --base-model other", ""),
    ("calibrate ur5 meas.csv --out m.json --fixture {examples}/plate-fixture.toml", "ball-in-socket"),
    ("calibrate ur5 meas.csv --out m.json --method constraint", ""),
    # calibrate: ball-in-socket data
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
    # evaluate
    ("evaluate missing.json meas.csv", ""),
    ("evaluate junk.json meas.csv", ""),
    ("evaluate edited.json meas.csv", "checksum"),
    ("evaluate truncated.json meas.csv", ""),
    ("evaluate model.json missing.csv", ""),
    ("evaluate model.json sockets.csv", ""),
    ("evaluate model.json meas.csv --fixture {examples}/plate-fixture.toml", ""),
    # compensate
    ("compensate model.json missing.csv --out c.csv", ""),
    ("compensate model.json no_targets_cols.csv --out c.csv", "rx"),
    ("compensate model.json far.csv --out c.csv", "none of the 2 targets"),
    ("compensate junk.json {examples}/ur5-targets.csv --out c.csv", ""),
    # report
    ("report model.json meas.csv --out r.txt", ".html"),
    ("report model.json meas.csv --out r.html --pdf p.png", ".pdf"),
    ("report model.json meas.csv --out r.html --validation cv_junk.json", "validate"),
    ("report model.json meas.csv --out r.html --validation junk.json", ""),
    # export
    ("export model.json --format step --out x.toml", ""),
    ("export model.json --convention abc --out x.toml", ""),
    ("export missing.json --out x.toml", ""),
    # validate
    ("validate ur5 meas.csv --folds 1", ""),
    ("validate ur5 meas.csv --folds 1000", ""),
    ("validate ur5 meas.csv --sizes 10,abc", ""),
    ("validate ur5 meas.csv --sizes 5000", ""),
    ("validate ur5 meas.csv --method kriging --loss huber", "--loss"),
    ("validate kr150-2 sockets.csv --method constraint --fixture {examples}/plate-fixture.toml --sizes 10", "--sizes"),
    ("validate kr150-2 one_placement.csv --method constraint --fixture {examples}/plate-fixture.toml", "placement"),
    # simulate
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
    ("simulate ur5 --sampling grid --joint-noise 0.1 --box 0,1,0,1,0,1 --out s.csv", "--joint-noise does not apply"),
    ("simulate kr150-2 --sampling sockets --fixture {examples}/plate-fixture.toml --box 1,2,3,4,5,6 --out s.csv",
     "--box does not apply"),
    ("simulate kr150-2 --sampling sockets --fixture {examples}/plate-fixture.toml --per-socket 1 --out s.csv", ""),
    # an output that is an input, or a second output in a missing folder: refused before anything is written
    ("calibrate ur5 meas.csv --out meas.csv", "name it meas.json"),  # refused by its name first
    ("compensate model.json meas.csv --out meas.csv", "also an input"),
    ("export model.json --out model.json", "name it model.toml"),  # refused by its name first
    ("simulate ur5 --n 10 --out s --truth s", "two outputs"),
    ("simulate ur5 --n 10 --out s.csv --truth missing_dir/t.json", "does not exist"),
    ("report model.json meas.csv --out r.html --pdf missing_dir/p.pdf", "does not exist"),
    # dataset, show
    ("dataset nope --out d", ""),
    ("dataset ur5-tsinghua --out d --split 1.5", "--split"),
    ("show nosuchrobot", ""),
    ("show empty_robot.toml", "empty"),
    ("show no_convention.toml", "convention"),
    ("show ur5 --tip tool0", "URDF"),
    ("calibrate ur5 meas.csv --out m.json --tip tool0", "URDF"),
    ("calibrate ur5 comment.csv --out m.json", "comment"),
    ("report model.json meas.csv --out r.html --validation missing.json", "does not exist"),
    ("show no_joints.toml", ""),
]


@pytest.mark.parametrize("command, says", ROWS, ids=[row[0] for row in ROWS])
def test_bad_input_is_refused_with_one_line_and_leaves_nothing(files, tmp_path, monkeypatch, command, says):
    before = copy_inputs(files, tmp_path, monkeypatch)  # a fresh folder per row: nothing written is missed
    assert_refused(command.format(examples=EXAMPLES).split(), says, tmp_path, before)


def test_beyond_limits_accepts_the_rows_it_names(files, tmp_path):
    result = runner.invoke(app, ["calibrate", "ur5", str(files / "beyond.csv"), "--out", str(tmp_path / "m.json"),
                                 "--beyond-limits"])
    assert result.exit_code == 0, result.output


def test_the_table_is_large_enough():
    assert len(ROWS) >= 60
