"""Units on every number a user types or a file carries (robocal.io.units): a length typed in
metres, an angle in radians, is refused in one line naming the likely unit, by the one test
for its kind (:func:`~robocal.io.units.check_robot_lengths` judged by the robot's reach,
:func:`~robocal.io.units.looks_like_radians`); the same numbers in mm and degrees, the
README's examples and the shipped examples, pass."""
import numpy as np
import pytest

from refusals import EXAMPLES, PLATE, assert_refused, run_ok
from robocal.errors import InputError
from robocal.io import units
from robocal.io.fixtures import Fixture, read_fixture
from robocal.io.library import builtin
from robocal.io.tables import read_targets

DESIGN = "design ur5 --n 10 --pool 200 --out p.csv"
SOCKETS = "design kr150-2 --fixture {plate} --n 24 --per-socket 2 --out p.csv"
REFUSED = [
    (f"{DESIGN} --box 0.3,0.6,-0.2,0.2,0.1,0.5", "--box: largest 0.6, .* look like metres"),
    (f"{DESIGN} --box 300,600,-200,200,100,500 --rpy 3.14,0,0", "angles of --rpy look like radians"),
    (f"{DESIGN} --box 300,600,-200,200,100,500 --rpy 0,1.5708,0", "angles of --rpy look like radians"),
    (f"{DESIGN} --box 300,600,-200,200,100,500 --hint 0,-1.57,1.57,0,1.57,0",
     "joint values of --hint look like radians"),
    (f"{DESIGN} --box 300,600,-200,200,100,500 --hint 0,-90,90", "--hint gives 3 joint values"),
    (f"{DESIGN} --tool 0,0,0.1", "--tool: distance from the origin 0.1, .* look like metres"),
    (f"{DESIGN} --tracker 2,0,0.5", "--tracker: distance from the origin 2.06, .* look like metres"),
    (f"{DESIGN} --walls -1,1,-1,1", "--walls: largest 1, .* look like metres"),
    (f"{SOCKETS} --region 1,2,-0.5,0.5,0,0.4", "--region: largest 2, .* look like metres"),
    (f"{SOCKETS} --region 1000,2000,-500,500,0,400 --tool 0,0,0.2", "--tool: distance from the origin 0.2"),
    (f"{SOCKETS} --placements where_m.csv", "the x, y, z of where_m.csv: largest 1.8, .* look like metres"),
    (f"{SOCKETS} --placements where_rad.csv", "the rx, ry, rz of where_rad.csv look like radians"),
]
PLACEMENTS = {"where_m.csv": "x,y,z,rx,ry,rz\n1.5,0,0,0,0,0\n1.8,0.3,0,0,0,90\n",
              "where_rad.csv": "x,y,z,rx,ry,rz\n1500,0,0,0,0,0\n1800,300,0,0,0,1.5708\n",
              "where.csv": "x,y,z,rx,ry,rz\n1500,0,0,0,0,0\n1800,300,0,0,0,90\n"}


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_a_number_typed_in_other_units_is_refused_in_one_line(tmp_path, monkeypatch, command, says):
    monkeypatch.chdir(tmp_path)
    for name, text in PLACEMENTS.items():
        (tmp_path / name).write_text(text)
    import re

    args = command.format(plate=PLATE).split()
    from refusals import runner
    from robocal.interfaces.cli import app

    result = runner.invoke(app, args)
    errors = [line for line in result.output.splitlines() if line.lower().startswith("error")]
    assert result.exit_code != 0 and len(errors) == 1 and re.search(says, errors[0]), result.output
    assert_refused(args, errors[0][len("error: "):][:30], tmp_path, {p.name: p.stat().st_mtime_ns
                                                                     for p in tmp_path.iterdir()})


@pytest.mark.parametrize("extra", ["--box 300,600,-200,200,100,500 --rpy 180,0,0",
                                   "--box 300,600,-200,200,100,500 --rpy 180,0,0 --hint 0,-90,90,-90,-90,0",
                                   "--tool 0,0,100 --tracker 2000,0,500", "--walls -1000,1000,-1000,1000",
                                   "--tool 0,0,0"])
def test_the_same_numbers_in_mm_and_degrees_are_designed(tmp_path, monkeypatch, extra):
    monkeypatch.chdir(tmp_path)
    run_ok(*DESIGN.split(), *extra.split())
    assert (tmp_path / "p.csv").exists()


@pytest.mark.parametrize("orientation, radians", [
    ("180,0,0", False), ("-180,0,0", False), ("0,0,0", False), ("0,90,0", False), ("179.9,0.1,-90", False),
    ("0,0,3", False), ("3.14159,0,1.57", True), ("0,0.785398,0", True), ("2.5,0.3,-1.2", True)])
def test_one_test_of_typed_angles_tells_radians(orientation, radians):
    values = [float(v) for v in orientation.split(",")]
    assert units.looks_like_radians(values) is radians
    assert units.looks_like_radians(np.radians([180.0, 0.0, 0.0]))  # the example's rx, converted


def test_placements_in_mm_and_degrees_are_read(tmp_path):
    from robocal.io.poses import read_placements

    (tmp_path / "where.csv").write_text(PLACEMENTS["where.csv"])
    poses, names = read_placements(tmp_path / "where.csv")
    assert names == ["P1", "P2"] and poses[1][:3, 3].tolist() == [1800.0, 300.0, 0.0]


def test_the_shipped_targets_and_fixture_pass_and_in_radians_or_metres_are_refused(tmp_path):
    for example in ("ur5-targets.csv", "kr150-targets.csv"):
        read_targets(EXAMPLES / example)
    fixture = read_fixture(PLATE)
    with pytest.raises(InputError, match="socket spacing: largest .* look like metres"):
        Fixture("metres", {k: v / 1000 for k, v in fixture.sockets.items()})
    lines = (EXAMPLES / "kr150-targets.csv").read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    converted = [r[:3] + [repr(float(np.radians(float(v)))) for v in r[3:6]] + r[6:] for r in rows]
    path = tmp_path / "t.csv"
    path.write_text("\n".join([lines[0]] + [",".join(r) for r in converted]) + "\n")
    with pytest.raises(InputError, match="rx, ry, rz of .* look like radians"):
        read_targets(path)


def test_lengths_are_judged_by_the_robots_reach():
    kr150, ur5 = builtin("kr150-2"), builtin("ur5")
    assert units.reach_mm(kr150) > 2.5 * units.reach_mm(ur5) / 1.5
    units.check_robot_lengths(ur5, [0.0, 0.0, 25.0], "--tool", position=True)  # a short probe in mm
    with pytest.raises(InputError, match="look like metres"):
        units.check_robot_lengths(kr150, [0.0, 0.0, 0.3], "--tool", position=True)
    with pytest.raises(InputError, match="they are not mm"):
        units.check_lengths(1e-6, 1.0, "--box", "a box")


# --------------------------------------------------------------------------- issue 26, pass 5
# Every number of the same kind meets the same test: a request's rx, ry, rz as a targets file's;
# a program's joint values as a measurement file's q columns (joint limits, in the program's
# unit); a robot file's angles as typed angles; a joint log's as a file of configurations; a
# standard deviation or a tilt typed in metres or radians by its setting's plausible interval.
UR5 = builtin("ur5")
HOME_DEG = [0.0, -90.0, 90.0, -90.0, -90.0, 0.0]
MOVEL = "  movel(p[-0.29802, -0.29810, 0.35729, 2.0194, 2.4066, 0.0], a=1.2, v=0.25)\n"
KRL_DAT = ("&ACCESS RVP\nDEFDAT cell\n  DECL E6AXIS HOME={{{}}}\n  DECL E6POS XP1={{X 400.0,Y 100.0,Z 300.0,A 0.0,"
           "B 90.0,C 0.0,S 2,T 10}}\nENDDAT\n")
KRL_SRC = "&ACCESS RVP\nDEF cell( )\n  PTP HOME\n  LIN XP1\nEND\n"


def _robot(chain=UR5, change=None):
    """``chain``'s robot TOML, with ``change(key, value)`` applied to every line 'key = value'."""
    from robocal.io.robot_file import robot_to_toml

    def edit(line):
        key, _, value = line.partition(" = ")
        try:
            return f"{key} = {float(change(key, float(value)))!r}"
        except ValueError:
            return line

    return "\n".join(edit(line) if change and " = " in line else line
                     for line in robot_to_toml(chain).splitlines()) + "\n"


def _joint_log(joints, header=None):
    names = header or [f"q{k}" for k in range(1, joints.shape[1] + 1)]
    return "\n".join([",".join(["point"] + names)] + [",".join([f"P{i}"] + [repr(float(v)) for v in row])
                                                      for i, row in enumerate(joints)]) + "\n"


def _pass5_inputs():
    q = UR5.random_configurations(20, rng=3)
    positions = UR5.fk_positions(q)
    degrees = UR5.joints_to_file(q)
    axes = ",".join(f"A{k} {v}" for k, v in enumerate(np.radians(HOME_DEG), start=1))
    return {
        "deg.script": f"def prog():\n  movej([139.6318, 101.8499, -267.3761, -81.0, 100.0, 8.0], a=1.4, v=1.05)\n"
                      f"{MOVEL}end\n",
        "rad.script": f"def prog():\n  movej([{', '.join(map(str, np.radians(HOME_DEG)))}], a=1.4, v=1.05)\n"
                      f"{MOVEL}end\n",
        "cell.src": KRL_SRC, "cell.dat": KRL_DAT.format(axes),
        "alpha_rad.toml": _robot(change=lambda key, v: np.radians(v) if key == "alpha" else v),
        "kr_alpha_rad.toml": _robot(builtin("kr150-2"), lambda key, v: np.radians(v) if key == "alpha" else v),
        "limits_rad.toml": _robot(change=lambda key, v: np.radians(v) if key in ("min", "max") else v),
        "ur5.toml": _robot(),
        "pts.txt": "\n".join(f"P{i} " + " ".join(repr(float(c)) for c in p) for i, p in enumerate(positions)) + "\n",
        "j_rad.csv": _joint_log(q),
        "j_deg.csv": _joint_log(degrees),
        "j_tagged.csv": _joint_log(q, [f"q{k}[rad]" for k in range(1, 7)]),
        "fo/.keep": "",
    }


PASS5_REFUSED = [
    # 1. serve: in test_a_request_in_radians_is_answered_with_an_error_line
    # 2. a program's joint values: URScript takes radians, KRL degrees
    ("filter {model} deg.script --out fo",
     r"deg.script, line 2: q1 = 139.632 rad lies beyond joint 1's limits .* look like degrees; URScript takes radians"),
    ("filter {model} cell.src --out fo", r"cell.src, line 3: the joint values look like radians .* KRL takes degrees"),
    # 3. standard deviations typed in metres or radians
    ("calibrate ur5 {meas} --position-sigma 0.00002 --out m.json",
     r"--position-sigma must be at least 0.001 mm .* is it in metres\? \(2e-05 m is 0.02 mm\)"),
    ("calibrate ur5 {meas} --orientation-sigma 0.00003 --out m.json", "--orientation-sigma .* is it in radians"),
    ("design ur5 --n 10 --pool 200 --noise 0.00002 --out p.csv", "--noise must be at least 0.001 mm"),
    ("simulate ur5 --noise 0.0005 --out s.csv", r"--noise must be 0 or at least 0.001 mm .* is it in metres"),
    ("design ur5 --n 10 --pool 200 --joint-noise 0.00003 --out p.csv", "--joint-noise .* is it in radians"),
    # 4. a robot file's angles in radians
    ("show alpha_rad.toml", r"alpha_rad.toml: the alpha of the \[\[joints\]\] look like radians .* mm and degrees"),
    ("simulate kr_alpha_rad.toml --n 10 --out s.csv", "the alpha of the .* look like radians"),
    ("show limits_rad.toml", "the min and max of the revolute .* look like radians"),
    # 5. a joint log in radians, untagged
    ("import --points pts.txt --joints j_rad.csv --out m.csv", "j_rad.csv lie within ±6.3: they look like radians"),
    # 6. a tilt typed in radians
    (f"{SOCKETS} --max-tilt 0.5236",
     r"--max-tilt must be 0 or at least 2 deg, .* is it in radians\? \(0.5236 rad is 30"),
]
PASS5_ACCEPTED = [
    "filter {model} rad.script --out fo",
    "show ur5.toml",
    "import --points pts.txt --joints j_deg.csv --out m.csv",
    "import --points pts.txt --joints j_tagged.csv --out m.csv",
    "design ur5 --n 10 --pool 200 --noise 0.001 --joint-noise 0.002 --out p.csv",
    "simulate ur5 --n 10 --noise 0 --out s.csv",
]


def _pass5_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name, text in _pass5_inputs().items():
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    (tmp_path / "fo" / ".keep").unlink()


def _pass5_args(command, ur5_files):
    return command.format(model=ur5_files / "model.json", meas=ur5_files / "meas.csv", plate=PLATE).split()


@pytest.mark.parametrize("command, says", PASS5_REFUSED, ids=[row[0] for row in PASS5_REFUSED])
def test_pass5_a_number_in_other_units_is_refused_in_one_line(tmp_path, monkeypatch, ur5_files, command, says):
    import re

    from refusals import runner
    from robocal.interfaces.cli import app

    _pass5_folder(tmp_path, monkeypatch)
    args = _pass5_args(command, ur5_files)
    result = runner.invoke(app, args)
    errors = [line for line in result.output.splitlines() if line.lower().startswith("error")]
    assert result.exit_code != 0 and len(errors) == 1 and re.search(says, errors[0]), result.output
    assert_refused(args, errors[0][len("error: "):][:30], tmp_path, {p.name: p.stat().st_mtime_ns
                                                                     for p in tmp_path.iterdir()})
    assert not list((tmp_path / "fo").iterdir())


@pytest.mark.parametrize("command", PASS5_ACCEPTED)
def test_pass5_the_same_numbers_in_mm_and_degrees_pass(tmp_path, monkeypatch, ur5_files, command):
    _pass5_folder(tmp_path, monkeypatch)
    run_ok(*_pass5_args(command, ur5_files))


REQUEST = {"x": -506.815, "y": -242.645, "z": -38.323, "rx": 78.439, "ry": -9.785, "rz": -81.802,
           "q": [16, -47, 117, -81, 100, 8]}


def test_a_request_in_radians_is_answered_with_an_error_line(ur5_files):
    import json

    from robocal.interfaces.serve import Answerer

    in_radians = {**REQUEST, **{k: float(np.radians(REQUEST[k])) for k in ("rx", "ry", "rz")}}
    answerer = Answerer(ur5_files / "model.json")
    answer, ok = answerer.answer(json.dumps(in_radians).encode())
    assert not ok and "the rx, ry, rz of the request look like radians" in json.loads(answer)["error"], answer
    answer, ok = answerer.answer(json.dumps(REQUEST).encode())
    assert ok and len(json.loads(answer)["q"]) == 6, answer
    csv = Answerer(ur5_files / "model.json", "csv")
    row = [in_radians[k] for k in ("x", "y", "z", "rx", "ry", "rz")]
    answer, ok = csv.answer(",".join(map(str, row)).encode())
    assert not ok and "look like radians" in json.loads(answer)["error"], answer


@pytest.mark.parametrize("option, text", [
    ("--position-sigma", "0.001"), ("--position-sigma", "0.02"), ("--orientation-sigma", "0.01"),
    ("--noise", "0.001"), ("--noise", "0.02"), ("--noise", "20"), ("--joint-noise", "0"), ("--joint-noise", "0.002"),
    ("--max-tilt", "0"), ("--max-tilt", "2"), ("--max-tilt", "30")])
def test_plausible_standard_deviations_and_tilts_are_taken(option, text):
    from robocal.interfaces.cli.plan import DESIGN, SIMULATE
    from robocal.methods.kinematic import ORIENTATION_SIGMA, POSITION_SIGMA

    settings = [s for s in (POSITION_SIGMA, ORIENTATION_SIGMA, *SIMULATE, *DESIGN) if s.option == option]
    assert settings
    for setting in settings:
        assert setting.parse(text) == float(text) == setting.check(float(text))
