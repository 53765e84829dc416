"""The one check every refusal table of command lines applies: the command is refused with a
non-zero exit and one error line (plus at most the usage hint), no traceback, no file left
behind (no ``.tmp`` either) and no input rewritten; and its counterpart, :func:`run_ok`, for
the command lines that must succeed; and the prepared inputs every refusal table breaks
(:func:`write_refusal_inputs`, built once per session by ``conftest.refusal_inputs``)."""
import json
import math
import re
import shutil
import warnings
from pathlib import Path

from typer.testing import CliRunner

from robocal.interfaces.cli import app

runner = CliRunner()
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PLATE = EXAMPLES / "plate-fixture.toml"


def run_ok(*args):
    """Run ``robocal ARGS`` (each turned into text); assert it exits with 0; the result."""
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result


def copy_files(source, folder):
    """Copy the files of ``source`` into ``folder`` (created if need be); ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for path in source.iterdir():
        shutil.copy(path, folder / path.name)
    return folder


def copy_inputs(files, folder, monkeypatch):
    """Copy the prepared inputs into a fresh ``folder`` and work there; returns their
    modification times, to tell a rewritten input from an untouched one."""
    for path in files.iterdir():
        (shutil.copytree if path.is_dir() else shutil.copy)(path, folder / path.name)
    monkeypatch.chdir(folder)
    return {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}


def assert_refused(args, says, folder, before):
    """Run ``args`` in ``folder`` (prepared by :func:`copy_inputs`) and check the refusal;
    ``says`` must stand in the error line."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # warnings are the CLI's business, not the tables'
        result = runner.invoke(app, args)
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code != 0, result.output
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    errors = [line for line in lines if line.lower().lstrip("│ ").startswith("error")]
    assert len(errors) == 1 and len(lines) <= 2, result.output
    assert says in errors[0], result.output
    after = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    assert set(after) == set(before), f"left behind: {set(after) - set(before)}"
    assert after == before, "an input file was rewritten"


def assert_accepted(args):
    """Run ``args`` in the current folder; it must succeed without an error line."""
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert not any(line.startswith("error:") for line in result.output.splitlines()), result.output


def refused_with_usage_error(args, *unwanted):
    """Run ``robocal ARGS``: it must exit with 2 and one line, no traceback, and leave none of
    the ``unwanted`` paths; the output."""
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1, result.output
    for path in unwanted:
        assert not Path(path).exists(), path
    return result.output


def _replace_cells(rows, change):
    """Rows of a CSV with ``change(index, cell)`` applied to every cell."""
    return [",".join(change(k, v) for k, v in enumerate(row.split(","))) for row in rows]


def write_refusal_inputs(root):
    """Write into ``root`` (which already holds meas.csv and model.json of a UR5, sockets.csv
    and cmodel.json of a KR 150-2 on the plate fixture) good files to break and broken
    variants of every format robocal reads, and the legitimate variants it must accept."""
    run_ok("export", root / "model.json", "--format", "urdf", "--out", root / "ur5.urdf")
    run_ok("dataset", "ur5-tsinghua", "--out", root / "tsinghua")
    run_ok("simulate", "kr150-2", "--sampling", "sockets", "--fixture", PLATE, "--placements", "1", "--per-socket",
           "6", "--out", root / "one_placement.csv")
    _write_variants_of_every_format(root)
    _write_broken_files(root)


def _write_variants_of_every_format(root):

    lines = (root / "meas.csv").read_text().splitlines()
    head, rows = lines[0], lines[1:]
    first = rows[0].split(",")

    def csv(header, body):
        return header + "\n" + "\n".join(body) + "\n"

    # The example without its robocal_file column: a targets file as a user writes it.
    targets = [line.rsplit(",", 1)[0] for line in (EXAMPLES / "ur5-targets.csv").read_text().splitlines()]
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
        "t_huge.csv": csv(targets[0], [",".join(targets[1].split(",")[:4] + ["-5e9"] + targets[1].split(",")[5:])]
                          + targets[2:]),
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


def _write_broken_files(root):
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
