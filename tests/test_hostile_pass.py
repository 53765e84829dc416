"""A hostile new user's pass over robocal: inputs that test_bad_inputs, test_bad_data,
test_cli_conventions and test_small_lies do not try.  Every refused command line exits
non-zero with one error line (plus at most the usage hint), no traceback and no file left
behind; every refused Python call raises a RobocalError subclass that says what is wrong;
the legitimate variants of the file formats are accepted."""
import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal.errors import FileFormatError, InputError, RobocalError
from refusals import assert_refused, copy_inputs
from robocal.interfaces.cli import app

runner = CliRunner()
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PLATE = EXAMPLES / "plate-fixture.toml"


def _ok(*args):
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output


def _replace_cells(rows, change):
    """Rows of a CSV with ``change(index, cell)`` applied to every cell."""
    return [",".join(change(k, v) for k, v in enumerate(row.split(","))) for row in rows]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("hostile")
    _ok("simulate", "ur5", "--n", "60", "--seed", "1", "--out", root / "meas.csv")
    _ok("calibrate", "ur5", root / "meas.csv", "--out", root / "model.json")
    _ok("export", root / "model.json", "--format", "urdf", "--out", root / "ur5.urdf")
    _ok("dataset", "ur5-tsinghua", "--out", root / "tsinghua")
    _ok("simulate", "kr150-2", "--sampling", "sockets", "--fixture", PLATE, "--placements", "3",
        "--per-socket", "6", "--out", root / "sockets.csv")
    _ok("calibrate", "kr150-2", root / "sockets.csv", "--method", "constraint", "--fixture", PLATE,
        "--out", root / "cmodel.json")

    lines = (root / "meas.csv").read_text().splitlines()
    head, rows = lines[0], lines[1:]
    first = rows[0].split(",")

    def csv(header, body):
        return header + "\n" + "\n".join(body) + "\n"

    targets = (EXAMPLES / "ur5-targets.csv").read_text().splitlines()
    robot = (root / "tsinghua.toml").read_text()
    urdf = (root / "ur5.urdf").read_text()
    sockets = (root / "sockets.csv").read_text().splitlines()
    model = json.loads((root / "model.json").read_text())
    text = {
        # measurement CSVs
        "dup_header.csv": csv(head.replace("q2", "q1"), rows),
        "upper.csv": csv(head.upper(), rows),
        "misspelt.csv": csv(head.replace("q3", "q_3"), rows),
        "px.csv": csv(head.replace(",x,y,z", ",px,py,pz"), rows),
        "inf.csv": csv(head, [",".join(first[:7] + ["inf"] + first[8:])] + rows[1:]),
        "nan_joint.csv": csv(head, [",".join(["nan"] + first[1:])] + rows[1:]),
        "empty_cell.csv": csv(head, [",".join([""] + first[1:])] + rows[1:]),
        "short_row.csv": csv(head, [",".join(first[:5])] + rows[1:]),
        "long_row.csv": csv(head, [rows[0] + ",1,2"] + rows[1:]),
        "truncated.csv": (root / "meas.csv").read_text()[:len(head) + len(rows[0]) + 41],
        "semicolon.csv": csv(head.replace(",", ";"), [r.replace(",", ";") for r in rows]),
        "decimal_comma.csv": csv(head.replace(",", ";"), [r.replace(",", ";").replace(".", ",") for r in rows]),
        "radians.csv": csv(head, _replace_cells(rows, lambda k, v: repr(math.radians(float(v))) if k < 6 else v)),
        "neg_sigma.csv": csv(head, _replace_cells(rows, lambda k, v: "-0.02" if k >= 9 else v)),
        "zero_sigma.csv": csv(head, _replace_cells(rows, lambda k, v: "0" if k >= 9 else v)),
        "nan_sigma.csv": csv(head, [",".join(first[:9] + ["nan"] + first[10:])] + rows[1:]),
        "no_q1.csv": csv(head.split(",", 1)[1], [r.split(",", 1)[1] for r in rows]),
        "no_header.csv": "\n".join(rows) + "\n",
        "header_twice.csv": csv(head, rows[:30] + [head] + rows[30:]),
        # legitimate variants
        "spaces.csv": csv(", ".join(head.split(",")), rows),
        "extra_col.csv": csv(head + ",comment", [r + ",hello" for r in rows]),
        "blank_lines.csv": head + "\n\n" + "\n\n".join(rows) + "\n\n",
        "bom.csv": "\ufeff" + csv(head, rows),
        "crlf.csv": head + "\r\n" + "\r\n".join(rows) + "\r\n",
        "quoted.csv": csv(head, ['"' + r.replace(",", '","') + '"' for r in rows]),
        # ball-in-socket data
        "sock_unknown.csv": csv(sockets[0], [sockets[1].replace(",A", ",Z")] + sockets[2:]),
        "sock_empty_id.csv": csv(sockets[0], [sockets[1].rsplit(",", 1)[0] + ","] + sockets[2:]),
        # one socket in each placement: no distance between sockets
        "sock_one.csv": csv(sockets[0], [r for r in sockets[1:] if r.endswith(",A")]),
        # absurd magnitudes
        "huge.csv": csv(head, [",".join(first[:6] + ["1e300"] + first[7:])] + rows[1:]),
        "t_huge.csv": csv(targets[0], [",".join(targets[1].split(",")[:4] + ["-5e9"] + targets[1].split(",")[5:])] + targets[2:]),
        # targets
        "t_nan.csv": csv(targets[0], ["nan" + targets[1][targets[1].index(","):]] + targets[2:]),
        "t_text.csv": csv(targets[0], ["abc" + targets[1][targets[1].index(","):]] + targets[2:]),
        "t_inf.csv": csv(targets[0], ["inf" + targets[1][targets[1].index(","):]] + targets[2:]),
        "t_empty.csv": "",
        "t_header.csv": targets[0] + "\n",
        "t_norot.csv": csv("x,y,z", [",".join(t.split(",")[:3]) for t in targets[1:]]),
        "t_dup.csv": csv(targets[0].replace("y", "x", 1), targets[1:]),
        "t_metres.csv": csv(targets[0], _replace_cells(targets[1:], lambda k, v: str(float(v) / 1000) if k < 3 else v)),
        "t_fewq.csv": csv(targets[0].rsplit(",", 1)[0], [t.rsplit(",", 1)[0] for t in targets[1:]]),
        # robot TOML
        "r_metres.toml": re.sub(r"(\n(?:a|d) = )(-?[0-9.]+)", lambda m: m.group(1) + repr(float(m.group(2)) / 1000),
                                robot),
        "r_radians.toml": re.sub(r"(\nalpha = )(-?[0-9.]+)",
                                 lambda m: m.group(1) + repr(math.radians(float(m.group(2)))), robot),
        "r_text.toml": robot.replace("a = -425.0", 'a = "abc"', 1),
        "r_nan.toml": robot.replace("a = -425.0", "a = nan", 1),
        "r_inf.toml": robot.replace("d = 89.159", "d = inf", 1),
        "r_misspelt.toml": robot.replace("alpha = 0.0", "alfa = 0.0", 1),
        "r_conv.toml": robot.replace('convention = "dh"', 'convention = "sdh"'),
        "r_minmax.toml": robot.replace("min = -360.0", "min = 360.0", 1).replace("max = 360.0", "max = -360.0", 1),
        "r_missing_a.toml": robot.replace("a = -425.0\n", "", 1),
        "r_trunc.toml": robot[:300],
        "r_dupkey.toml": robot.replace("a = -425.0", "a = -425.0\na = 1.0", 1),
        "r_negmass.toml": robot.replace("mass = 3.7", "mass = -3.7", 1),
        # URDF
        "u_trunc.urdf": urdf[:len(urdf) // 2],
        "u_notxml.urdf": "hello world",
        "u_text.urdf": re.sub(r'xyz="[^"]*"', 'xyz="a b c"', urdf, count=2),
        "u_nojoints.urdf": '<robot name="x"><link name="a"/></robot>',
        "u_loop.urdf": re.sub(r'(<joint name="joint_1".*?<parent link=")[^"]*(")', r"\g<1>link_6\g<2>", urdf, count=1,
                              flags=re.S),
        # fixture TOML
        "fx_text.toml": 'name = "x"\n[sockets]\nA = [0, 0, 0]\nB = ["a", 0, 0]\n',
        "fx_two.toml": 'name = "x"\n[sockets]\nA = [0, 0, 0]\nB = [100, 0]\n',
        "fx_nan.toml": 'name = "x"\n[sockets]\nA = [0, 0, 0]\nB = [nan, 0, 0]\n',
        "fx_same.toml": 'name = "x"\n[sockets]\nA = [0, 0, 0]\nB = [0, 0, 0]\nC = [0, 120, 0]\n',
        "fx_empty.toml": "",
        "fx_no_a.toml": 'name = "x"\n[sockets]\nB = [150, 0, 0]\nC = [0, 120, 0]\nD = [0, 0, 50]\n',
        # model JSON
        "m_list.json": "[1, 2, 3]",
        "m_empty.json": "",
        "m_reformat.json": json.dumps(model, indent=8),
        "val_bad.json": '{"schema": "robocal.validation"}',
        "val_no_pool.json": json.dumps({"method": "kinematic", "file": "meas.csv", "poses": 60, "folds": 5,
                                        "cross_validation": {}}),
        "val_kriging.json": json.dumps({"method": "kriging", "file": "meas.csv", "poses": 60, "folds": 5,
                                        "cross_validation": {"pooled": {"mean_mm": 0.1}},
                                        "nominal_cross_validation": {"pooled": {"mean_mm": 2.0}}}),
    }
    for key, change in {"m_version.json": ("schema_version", 99), "m_schema.json": ("schema", "other"),
                        "m_method.json": ("method", "magic"), "m_created.json": ("created", "yesterday")}.items():
        edited = dict(model)
        edited[change[0]] = change[1]
        text[key] = json.dumps(edited)
    for name, content in text.items():
        (root / name).write_text(content)
    (root / "r_binary.toml").write_bytes(b"\x00\x01\xff\xfe" * 50)
    (root / "t_binary.csv").write_bytes(bytes(range(256)) * 4)
    (root / "m_binary.json").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(100))
    return root


REFUSED = [
    # calibrate: measurement CSV
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
    # calibrate: options
    ("calibrate ur5 meas.csv --out m.json --method kriging --nugget inf", "--nugget"),
    ("calibrate ur5 meas.csv --out m.json --method kriging --nugget nan", "--nugget"),
    ("calibrate ur5 meas.csv --out m.json --method ann --hidden 0,4", "--hidden"),
    ("calibrate ur5 meas.csv --out m.json --method ann --hidden 4,-4", "--hidden"),
    ("calibrate ur5 meas.csv --out m.json --method ann --generations abc", "--generations"),
    ("calibrate ur5 meas.csv --out m.json --method ann --hidden 100000,100000", "smaller hidden layers"),
    ("calibrate ur5 meas.csv --out m.json --method ann --trainer lbfgs", "at least 145 poses"),
    ("calibrate ur5 meas.csv --out m.json --method kinematic --hidden 4,4", "--hidden does not apply"),
    ("calibrate ur5 meas.csv --out m.json --method kinematic --generations 5", "--generations does not apply"),
    ("calibrate ur5 meas.csv --out m.json --method kinematic --seed 3", "--seed does not apply"),
    ("calibrate ur5 meas.csv --out m.json --method hybrid --hidden 4,4", "--hidden does not apply"),
    ("calibrate ur5 meas.csv --out m.json --parameters full+compliance --payload nan", "--payload"),
    ("calibrate ur5 meas.csv --out m.json --parameters full+compliance --payload inf", "--payload"),
    ("calibrate ur5 meas.csv --out m.json --method constraint --fixture {plate}", "ball-in-socket"),
    # calibrate: robot TOML and URDF
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
    # calibrate: fixture TOML and ball-in-socket data
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
    # evaluate
    ("evaluate model.json dup_header.csv", "appears twice"),
    ("evaluate model.json no_q1.csv", "no q1"),
    ("evaluate m_list.json meas.csv", "not a robocal model file"),
    ("evaluate m_empty.json meas.csv", "not a robocal model file"),
    ("evaluate m_binary.json meas.csv", "not a robocal model file"),
    ("evaluate m_version.json meas.csv", "upgrade robocal"),
    ("evaluate m_schema.json meas.csv", "not a robocal model file"),
    ("evaluate m_method.json meas.csv", "checksum"),
    ("evaluate m_created.json meas.csv", "checksum"),
    ("evaluate meas.csv model.json", "not a robocal model file"),
    ("evaluate tsinghua.toml meas.csv", "not a robocal model file"),
    ("evaluate model.json meas.csv --fixture missing.toml", "does not exist"),
    ("evaluate model.json meas.csv --out x.json", "--out"),
    ("evaluate model.json missing.csv --json", "does not exist"),
    ("evaluate cmodel.json sockets.csv --fixture fx_same.toml", "both at"),
    ("evaluate cmodel.json sockets.csv --fixture fx_no_a.toml", "socket id(s) A"),
    ("evaluate cmodel.json meas.csv", "limits"),
    # compensate
    ("compensate model.json t_nan.csv --out c.csv", "not a finite number"),
    ("compensate model.json t_huge.csv --out c.csv", "column 'ry': -5e9 is beyond"),
    ("compensate model.json t_text.csv --out c.csv", "'abc' is not a number"),
    ("compensate model.json t_inf.csv --out c.csv", "not a finite number"),
    ("compensate model.json t_empty.csv --out c.csv", "is empty"),
    ("compensate model.json t_header.csv --out c.csv", "no data rows"),
    ("compensate model.json t_norot.csv --out c.csv", "rx, ry, rz"),
    ("compensate model.json t_dup.csv --out c.csv", "appears twice"),
    ("compensate model.json t_metres.csv --out c.csv", "none of the 8 targets"),
    ("compensate model.json t_fewq.csv --out c.csv", "6 joints"),
    ("compensate model.json t_binary.csv --out c.csv", "not a text CSV"),
    ("compensate model.json meas.csv --out c.csv", "rx, ry, rz"),
    ("compensate model.json {examples}/kr150-targets.csv --out c.csv", "none of the 5 targets"),
    ("compensate model.json {examples}/ur5-targets.csv --out nodir/c.csv", "nodir"),
    ("compensate model.json {examples}/ur5-targets.csv", "--out"),
    # report
    ("report model.json meas.csv --out nodir/r.html", "nodir"),
    ("report model.json meas.csv --out r.html --pdf r.html", ".pdf"),
    ("report model.json meas.csv --out meas.csv", ".html"),
    ("report m_version.json meas.csv --out r.html", "upgrade robocal"),
    ("report model.json no_q1.csv --out r.html", "no q1"),
    ("report model.json meas.csv --out r.html --validation val_bad.json", "cross_validation"),
    ("report model.json meas.csv --out r.html --validation meas.csv", "robocal validate --json"),
    ("report model.json meas.csv --out r.html --validation val_kriging.json", "the model is 'kinematic'"),
    ("report model.json meas.csv --out r.html --validation val_no_pool.json", "cross_validation.pooled.mean_mm"),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --per-socket 100000 --out s.csv", "10,000"),
    # export
    ("export model.json --out nodir/x.toml", "nodir"),
    ("export m_version.json --out x.toml", "upgrade robocal"),
    ("export model.json", "--out"),
    # validate
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
    # simulate
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
    ("simulate ur5 --sampling lhs --box -0.6,-0.3,-0.2,0.2,0,0.3 --out s.csv", "cannot be reached"),
    ("simulate ur5 --sampling grid --out s.csv", "--box"),
    ("simulate ur5 --errors missing.json --out s.csv", "does not exist"),
    ("simulate ur5 --errors model.json --out s.csv", "not a robocal truth file"),
    ("simulate ur5 --errors meas.csv --out s.csv", "--errors"),
    ("simulate ur5 --out nodir/s.csv", "nodir"),
    ("simulate iiwa14 --errors liu2022 --out s.csv", "kr150-2"),
    ("simulate u_text.urdf --out s.csv", "not three numbers"),
    ("simulate r_metres.toml --n 10 --out s.csv", "looks like metres"),
    ("simulate r_metres.toml --sampling sockets --fixture {plate} --out s.csv", "looks like metres"),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --placements 0 --out s.csv", "--placements"),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --placements -1 --out s.csv", "--placements"),
    ("simulate kr150-2 --sampling sockets --fixture fx_text.toml --out s.csv", "socket B"),
    ("simulate kr150-2 --sampling sockets --fixture {plate} --joint-noise -1 --out s.csv", "--joint-noise"),
    # dataset
    ("dataset ur5-tsinghua --out d --split 0", "--split"),
    ("dataset ur5-tsinghua --out d --split 1", "--split"),
    ("dataset ur5-tsinghua --out d --split nan", "--split"),
    ("dataset ur5-tsinghua --out d --split abc", "--split"),
    ("dataset ur5-tsinghua --out d --split 0.5 --seed -1", "--seed"),
    ("dataset ur5-tsinghua --out nodir/d", "nodir"),
    ("dataset ur5-tsinghua", "--out"),
    ("dataset", "dataset"),
    # show, robots, methods, demo
    ("show ur5.urdf --tip nosuchlink", "no link 'nosuchlink'"),
    ("show r_text.toml", "must be a number"),
    ("show r_binary.toml", "not a text file"),
    ("show u_notxml.urdf", "not well-formed XML"),
    ("show meas.csv", ".toml or .urdf"),
    ("show model.json", ".toml or .urdf"),
    ("show", "robot"),
    ("robots extra", "extra"),
    ("robots --json", "--json"),
    ("methods kinematic", "kinematic"),
    ("methods --json", "--json"),
    ("demo extra", "extra"),
    ("demo --seed 3", "--seed"),
]


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_hostile_command_is_refused_in_one_line(files, tmp_path, monkeypatch, command, says):
    before = copy_inputs(files, tmp_path, monkeypatch)
    assert_refused(command.format(examples=EXAMPLES, plate=PLATE).split(), says, tmp_path, before)


ACCEPTED = [
    "calibrate ur5 spaces.csv --out m.json",
    "calibrate ur5 extra_col.csv --out m.json",
    "calibrate ur5 blank_lines.csv --out m.json",
    "calibrate ur5 bom.csv --out m.json",
    "calibrate ur5 crlf.csv --out m.json",
    "calibrate ur5 quoted.csv --out m.json",
    "evaluate m_reformat.json meas.csv",
    "evaluate model.json meas.csv --beyond-limits",
    "export model.json --convention poe --format urdf --out x.urdf",
    "export cmodel.json --out x.toml",
    "compensate cmodel.json {examples}/kr150-targets.csv --out c.csv",
    "simulate ur5 --sampling grid --n 2 --box -600,-300,-200,200,0,300 --out s.csv",
    "simulate ur5 --n 10 --orientation --orientation --out s.csv",
]


@pytest.mark.parametrize("command", ACCEPTED)
def test_legitimate_variant_is_accepted(files, tmp_path, monkeypatch, command):
    copy_inputs(files, tmp_path, monkeypatch)
    result = runner.invoke(app, command.format(examples=EXAMPLES).split())
    assert result.exit_code == 0, result.output
    assert not any(line.startswith("error:") for line in result.output.splitlines()), result.output


def test_the_same_fit_from_a_reformatted_file(files, tmp_path, monkeypatch):
    """spaces after commas, quotes, CRLF, a BOM and blank lines change nothing in the fit."""
    copy_inputs(files, tmp_path, monkeypatch)
    models = {}
    for name in ("meas", "spaces", "quoted", "crlf", "bom", "blank_lines"):
        _ok("calibrate", "ur5", f"{name}.csv", "--out", f"{name}.json")
        models[name] = json.loads(Path(f"{name}.json").read_text())["kinematics"]
    assert all(model == models["meas"] for model in models.values())


# ------------------------------------------------------------------------- Python API
def _api_rows():
    from robocal.estimation.calibration import KinematicCalibration
    from robocal.estimation.constraint.estimator import ConstraintCalibration
    from robocal.estimation.kriging import Kriging
    from robocal.estimation.network.model import NetworkErrorModel
    from robocal.io.fixtures import read_fixture
    from robocal.io.library import builtin, load_robot
    from robocal.io.observations import Observations
    from robocal.methods import make_method

    chain = builtin("ur5")
    q = chain.random_configurations(60, rng=1)
    p = chain.fk_positions(q)
    q_nan, p_nan, p_inf = q.copy(), p.copy(), p.copy()
    q_nan[3, 2], p_nan[4, 1], p_inf[4, 1] = np.nan, np.nan, np.inf
    rng = np.random.default_rng(0)
    X, Y = rng.normal(size=(40, 6)), rng.normal(size=(40, 3))
    X_nan = X.copy()
    X_nan[0, 5] = np.nan
    Y_inf = Y.copy()
    Y_inf[1, 2] = np.inf
    plate = read_fixture(PLATE)
    ids = ["A", "B", "C"] * 20

    def fit(name, joints, positions, **settings):
        return lambda: make_method(name, **settings).fit(chain, Observations.of(joints, positions))

    def kin(**settings):
        return lambda: KinematicCalibration(**settings).fit(chain, q, p)

    return [
        ("method positions (N, 2)", fit("kinematic", q, p[:, :2]), "positions must have shape"),
        ("method positions too short", fit("kinematic", q, p[:50]), "positions must have shape"),
        ("kinematic NaN joint", fit("kinematic", q_nan, p), "NaN or infinite"),
        ("kinematic NaN position", fit("kinematic", q, p_nan), "NaN or infinite"),
        ("kinematic inf position", fit("kinematic", q, p_inf), "NaN or infinite"),
        ("kriging NaN position", fit("kriging", q, p_nan), "NaN or infinite"),
        ("ann NaN joint", fit("ann", q_nan, p, generations=2), "NaN or infinite"),
        ("kinematic 5 poses", fit("kinematic", q[:5], p[:5]), "at least 12 different poses"),
        ("kriging 2 poses", fit("kriging", q[:2], p[:2]), "at least 5 different poses"),
        ("ann 3 poses", fit("ann", q[:3], p[:3], generations=2), "at least 5 different poses"),
        ("kinematic 7 joint columns", fit("kinematic", np.c_[q, q[:, :1]], p), r"\(60, 7\)"),
        ("kinematic 5 joint columns", fit("kinematic", q[:, :5], p), r"\(60, 5\)"),
        ("kinematic one 1-D pose", fit("kinematic", q[0], p[:1]), "1 distinct poses"),
        ("make_method setting of another method", lambda: make_method("kinematic", nugget=1), "does not apply"),
        ("make_method unknown name", lambda: make_method("magic"), "'magic' is not available"),
        ("make_method None", lambda: make_method(None), "None is not available"),
        ("kinematic parameters=everything", fit("kinematic", q, p, parameters="everything"), "everything"),
        ("kinematic loss=cauchy", fit("kinematic", q, p, loss="cauchy"), "cauchy"),
        ("kriging trend=cubic", fit("kriging", q, p, trend="cubic"), "cubic"),
        ("kriging nugget=-1", fit("kriging", q, p, nugget=-1), "nugget"),
        ("ann hidden=(0, 4)", fit("ann", q, p, hidden=(0, 4), generations=2), "hidden"),
        ("constraint on position data", fit("constraint", q, p), "fixture and socket"),
        ("kriging on constraint data",
         lambda: make_method("kriging").fit(chain, Observations.of(q, placement=["P1"] * 60, socket=["A"] * 60,
                                                                    fixture=plate)), "x, y, z"),
        ("Observations.of joints only", lambda: Observations.of(q), "measured positions or ball-in-socket"),
        ("Observations.of rotations (N, 3)", lambda: Observations.of(q, p, rotations=np.zeros((60, 3))),
         "rotations must have shape"),
        ("negative sigmas", lambda: make_method("kinematic").fit(chain, Observations.of(q, p, sigmas=-np.ones((60, 3)))),
         "must be > 0"),
        ("Kriging regression=cubic", lambda: Kriging(regression="cubic").fit(X, Y), "regression"),
        ("Kriging correlation=exp", lambda: Kriging(correlation="exp").fit(X, Y), "correlation"),
        ("Kriging nugget=-1", lambda: Kriging(nugget=-1).fit(X, Y), "nugget"),
        ("Kriging nugget=nan", lambda: Kriging(nugget=float("nan")).fit(X, Y), "nugget"),
        ("Kriging theta_bounds reversed", lambda: Kriging(theta_bounds=(1e2, 1e-6)).fit(X, Y), "theta_bounds"),
        ("Kriging theta0 negative", lambda: Kriging(theta0=-1.0).fit(X, Y), "theta0"),
        ("Kriging theta0 wrong length", lambda: Kriging(theta0=[1.0, 2.0]).fit(X, Y), "theta0"),
        ("Kriging n_starts=0 without theta0", lambda: Kriging(n_starts=0).fit(X, Y), "theta0"),
        ("Kriging X and Y lengths", lambda: Kriging().fit(X, Y[:30]), "40 rows but Y has 30"),
        ("Kriging NaN in X", lambda: Kriging().fit(X_nan, Y), "NaN or infinite"),
        ("Kriging inf in Y", lambda: Kriging().fit(X, Y_inf), "NaN or infinite"),
        ("Kriging one sample", lambda: Kriging().fit(X[:1], Y[:1]), "at least 2 points"),
        ("Kriging 3-D X", lambda: Kriging().fit(X.reshape(40, 2, 3), Y), "2-D"),
        ("Kriging predict unfitted", lambda: Kriging().predict(X), "not fitted"),
        ("Kriging predict wrong width", lambda: Kriging().fit(X, Y).predict(X[:, :4]), "4 columns"),
        ("Kriging predict NaN", lambda: Kriging().fit(X, Y).predict(np.full((2, 6), np.nan)), "NaN or infinite"),
        ("Network hidden=()", lambda: NetworkErrorModel(hidden=()).fit(X, Y), "hidden"),
        ("Network hidden=(0, 3)", lambda: NetworkErrorModel(hidden=(0, 3), generations=2).fit(X, Y), "hidden"),
        ("Network trainer=sgd", lambda: NetworkErrorModel(trainer="sgd").fit(X, Y), "trainer"),
        ("Network refine=adam", lambda: NetworkErrorModel(refine="adam").fit(X, Y), "refine"),
        ("Network generations=-1", lambda: NetworkErrorModel(generations=-1).fit(X, Y), "generations"),
        ("Network populations=0", lambda: NetworkErrorModel(populations=0, generations=2).fit(X, Y), "populations"),
        ("Network bits=0", lambda: NetworkErrorModel(bits=0, generations=2).fit(X, Y), "bits"),
        ("Network X and Y lengths", lambda: NetworkErrorModel(generations=2).fit(X, Y[:10]), "40 rows but Y has 10"),
        ("Network NaN X", lambda: NetworkErrorModel(generations=2).fit(np.full((40, 6), np.nan), Y), "NaN"),
        ("Network predict unfitted", lambda: NetworkErrorModel().predict(X), "not fitted"),
        ("Network too few poses", lambda: NetworkErrorModel(trainer="lbfgs").fit(X, Y), "smaller hidden layers"),
        ("Network inputs=cartesian", lambda: NetworkErrorModel(inputs="cartesian", generations=2).fit(X, Y), "inputs"),
        ("KinematicCalibration parameters", kin(parameters="bogus"), "bogus"),
        ("KinematicCalibration loss", kin(loss="cauchy"), "cauchy"),
        ("KinematicCalibration position_sigma=0", kin(position_sigma=0), "position_sigma"),
        ("KinematicCalibration position_sigma=-1", kin(position_sigma=-1), "position_sigma"),
        ("KinematicCalibration payload=-1", kin(parameters="full+compliance", payload=-1), "payload"),
        ("KinematicCalibration lengths", lambda: KinematicCalibration().fit(chain, q, p[:40]), r"\(40, 3\)"),
        ("KinematicCalibration positions (N, 2)", lambda: KinematicCalibration().fit(chain, q, p[:, :2]), r"\(60, 2\)"),
        ("KinematicCalibration 5 joints", lambda: KinematicCalibration().fit(chain, q[:, :5], p), r"\(60, 5\)"),
        ("KinematicCalibration NaN", lambda: KinematicCalibration().fit(chain, q, p_nan), "NaN or infinite"),
        ("KinematicCalibration predict unfitted", lambda: KinematicCalibration().predict(q), "not fitted"),
        ("ConstraintCalibration pairs", lambda: ConstraintCalibration(pairs="some").fit(chain, q, ["P1"] * 60, ids,
                                                                                        plate), "pairs"),
        ("ConstraintCalibration id lengths", lambda: ConstraintCalibration().fit(chain, q, ["P1"] * 10, ids, plate),
         "one entry per configuration"),
        ("ConstraintCalibration unknown socket",
         lambda: ConstraintCalibration().fit(chain, q, ["P1"] * 60, ["Z"] * 60, plate), "socket id"),
        ("ConstraintCalibration NaN joints", lambda: ConstraintCalibration().fit(chain, q_nan, ["P1"] * 60, ids, plate),
         "NaN or infinite"),
        ("ConstraintCalibration payload=-1",
         lambda: ConstraintCalibration(compliance=True, payload=-1).fit(chain, q, ["P1"] * 60, ids, plate), "payload"),
        ("Chain.fk 5 columns", lambda: chain.fk(np.zeros((3, 5))), "6 joints"),
        ("Chain.fk 3-D", lambda: chain.fk(np.zeros((2, 3, 6))), "6 joints"),
        ("Chain.fk scalar", lambda: chain.fk(1.0), "6 joints"),
        ("Chain.fk_positions 7 values", lambda: chain.fk_positions(np.zeros(7)), "6 joints"),
        ("joints_from_file text", lambda: chain.joints_from_file([["a"] * 6]), "must be numbers"),
        ("joints_from_file None", lambda: chain.joints_from_file(None), "one number"),
        ("load_robot unknown", lambda: load_robot("nosuch"), "no built-in robot"),
        ("load_robot None", lambda: load_robot(None), "no built-in robot"),
        ("load_robot csv", lambda: load_robot(str(EXAMPLES / "ur5-targets.csv")), ".toml or .urdf"),
        ("load_robot directory", lambda: load_robot(str(EXAMPLES)), ".toml or .urdf"),
        ("load_robot missing toml", lambda: load_robot(str(EXAMPLES / "none.toml")), "does not exist"),
    ]


API = _api_rows()


@pytest.mark.parametrize("call, says", [row[1:] for row in API], ids=[row[0] for row in API])
def test_hostile_python_call_raises_a_robocal_error(call, says):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(RobocalError, match=says) as caught:
            call()
    assert isinstance(caught.value, InputError)


@pytest.mark.parametrize("name, says", [
    ("r_text.toml", "must be a number"),
    ("r_binary.toml", "not a text file"),
    ("u_notxml.urdf", "not well-formed XML"),
])
def test_load_robot_refuses_a_broken_file(files, name, says):
    from robocal.io.library import load_robot

    with pytest.raises(InputError, match=says):
        load_robot(str(files / name))


def test_load_robot_refuses_an_unknown_urdf_tip(files):
    from robocal.io.library import load_robot

    with pytest.raises(InputError, match="no link 'nope'"):
        load_robot(str(files / "ur5.urdf"), tip="nope")


@pytest.mark.parametrize("name, robot, fixture, error, says", [
    ("none.csv", "ur5", None, FileFormatError, "does not exist"),
    (".", "ur5", None, FileFormatError, "is a directory"),
    ("meas.csv", "iiwa14", None, FileFormatError, "7 joints"),
    ("meas.csv", "ur5", PLATE, InputError, "ball-in-socket data only"),
    ("dup_header.csv", "ur5", None, FileFormatError, "appears twice"),
    ("radians.csv", "ur5", None, InputError, "the joint values look like radians"),
])
def test_read_observations_refuses_what_it_cannot_use(files, name, robot, fixture, error, says):
    from robocal.io.library import builtin
    from robocal.io.observations import read_observations

    if error is None:
        with pytest.warns(Warning, match="radians"):
            assert read_observations(files / name, builtin(robot)).n_poses == 60
        return
    with pytest.raises(error, match=says):
        read_observations(files / name, builtin(robot), fixture)


def test_socket_data_read_without_a_fixture_is_refused_at_the_fit(files):
    from robocal.io.library import builtin
    from robocal.io.observations import read_observations
    from robocal.methods import make_method

    chain = builtin("kr150-2")
    data = read_observations(files / "sockets.csv", chain)
    with pytest.raises(InputError, match="needs the fixture"):
        make_method("constraint").fit(chain, data)
