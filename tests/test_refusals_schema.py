"""No traceback from any file: a document of the wrong shape (a value of the wrong type, a
missing key, a table nested where a number belongs) is one line naming the file and the
place, for robot files, fixture files, fleet files and truth files alike; each reader asks
robocal.io.schema for the values it uses.  The good files of each kind still read."""
import json

import pytest

from refusals import EXAMPLES, PLATE, assert_refused, run_ok
from robocal.interfaces.fleet import read_fleet
from robocal.io import schema
from robocal.io.fixtures import read_fixture

ROBOT = (EXAMPLES.parent / "robocal" / "io" / "robots" / "ur5.toml").read_text()
FILES = {
    "r_convention_list.toml": ROBOT.replace('convention = "dh"', "convention = []"),
    "r_joints_numbers.toml": 'name = "x"\nconvention = "dh"\njoints = [1, 2]\n',
    "r_joints_nested.toml": 'name = "x"\nconvention = "dh"\njoints = [[1]]\n',
    "r_tool_number.toml": "tool = 3\n" + ROBOT,
    "r_type_table.toml": ROBOT.replace("[[joints]]\n", "[[joints]]\ntype = { a = 1 }\n", 1),
    "r_a_text.toml": ROBOT.replace("a = 0.0", 'a = "zero"', 1),
    "r_a_nested.toml": ROBOT.replace("a = 0.0", "a = { b = 1 }", 1),
    # Nested beyond the parser's recursion: one line too, for every TOML reader (robot, fixture, fleet).
    "r_deep.toml": ROBOT + "deep = " + "[" * 50000 + "]" * 50000 + "\n",
    "f_deep.toml": "name = \"p\"\ndeep = " + "[" * 50000 + "]" * 50000 + "\n",
    "fleet_deep.toml": "deep = " + "[" * 50000 + "]" * 50000 + "\n",
    "f_sockets_number.toml": "name = \"p\"\nsockets = 3\n",
    "f_name_table.toml": "name = { a = 1 }\n[sockets]\nA = [0, 0, 0]\nB = [100, 0, 0]\n",
    "f_socket_table.toml": "[sockets]\nA = { x = 1 }\nB = [100, 0, 0]\n",
    "fleet_robot_number.toml": "robot = 3\n",
    "fleet_options_number.toml": '[[robot]]\nname = "r1"\nrobot = "ur5"\ntrain = "t.csv"\noptions = 5\n',
    "fleet_options_nested.toml": '[[robot]]\nname = "r1"\nrobot = "ur5"\ntrain = "t.csv"\n'
                                 '[robot.options.seed]\nvalue = 3\n',
    "fleet_name_list.toml": '[[robot]]\nname = ["r1"]\nrobot = "ur5"\ntrain = "t.csv"\n',
    "existing_two_joints.csv": "q1,q2\n1,2\n",
    "existing_text.csv": "q1,q2,q3,q4,q5,q6\n0,-90,[90],0,90,0\n",
    "points_no_z.txt": "name;x;y\nP1;1;2\n",
    "joints.csv": "q1,q2,q3,q4,q5,q6,name\n0,-90,90,0,90,0,P1\n",
    # hostile pass 5
    "placements_nan.csv": "x,y,z,rx,ry,rz\n1500,-300,300,0,0,0\nnan,300,300,0,0,0\n1700,0,300,0,0,45\n",
    "candidates_word.csv": "q1,q2,q3,q4,q5,q6\n" + "".join(f"{10 * k},-90,{'ninety' if k == 4 else 90},0,90,0\n"
                                                         for k in range(8)),
    "joint_log_no_q.csv": "name,a,b,c\nP1,1,2,3\n",
    "points.txt": "// units: mm\nP1 400 100 400\n",
    "existing_empty.csv": "",
    "points_utf16be.txt": "name x y z\nP1 400 100 400\n".encode("utf-16-be"),
}
REFUSED = [
    ("show r_convention_list.toml", "convention must be one of 'dh', 'mdh', 'poe', got []"),
    ("show r_joints_numbers.toml", "joints must be [[joints]] tables"),
    ("show r_joints_nested.toml", "joints must be [[joints]] tables"),
    ("show r_tool_number.toml", "[tool] must be a table with xyz and rpy, got 3"),
    ("show r_type_table.toml", "joint 1 type must be one of 'revolute', 'prismatic'"),
    ("show r_a_text.toml", "joint 1 a must be a number, got 'zero'"),
    ("show r_a_nested.toml", "joint 1 a must be a number, got {'b': 1}"),
    ("show r_deep.toml", "nests its arrays or tables thousands of levels deep"),
    ("design r_deep.toml --n 10 --pool 200 --out p.csv", "nests its arrays or tables thousands of levels deep"),
    ("simulate kr150-2 --sampling sockets --fixture f_deep.toml --out s.csv", "nests its arrays or tables"),
    ("fleet fleet_deep.toml --out out", "nests its arrays or tables thousands of levels deep"),
    ("simulate kr150-2 --sampling sockets --fixture f_sockets_number.toml --out s.csv", "no [sockets] table"),
    ("simulate kr150-2 --sampling sockets --fixture f_name_table.toml --out s.csv", "name must be a non-empty text"),
    ("simulate kr150-2 --sampling sockets --fixture f_socket_table.toml --out s.csv", "socket A"),
    ("fleet fleet_robot_number.toml --out out", "'robot' must be [[robot]] tables"),
    ("fleet fleet_options_number.toml --out out", "options must be a table of calibrate's options"),
    ("fleet fleet_options_nested.toml --out out", "options.seed must be a text, a number or a list of numbers"),
    ("fleet fleet_name_list.toml --out out", "name must be a non-empty text in quotes, got ['r1']"),
    ("design ur5 --n 10 --pool 200 --existing existing_two_joints.csv --out p.csv", "lacks columns q3, q4, q5, q6"),
    ("design ur5 --n 10 --pool 200 --existing existing_text.csv --out p.csv", "'[90]'"),
    ("import --points points_no_z.txt --joints joints.csv --out m.csv", "names no z column"),
    ("simulate ur5 --errors truth_robot_number.json --out s.csv", "robot must be a non-empty text"),
    ("simulate ur5 --errors truth_seed_huge.json --out s.csv", "truth_seed_huge.json"),
    ("simulate ur5 --errors truth_deviation_list.json --out s.csv", "truth_deviation_list.json"),
    # hostile pass 5
    (f"design kr150-2 --fixture {PLATE} --placements placements_nan.csv --n 18 --out p.csv",
     "placements_nan.csv row 3, column x: 'nan' is not a finite number"),
    ("design ur5 --candidates candidates_word.csv --n 5 --out p.csv", "row 6, column 'q3': 'ninety' is not a number"),
    ("import --points points.txt --joints joint_log_no_q.csv --out m.csv", "a joint log needs the columns q1..qN"),
    ("design ur5 --existing existing_empty.csv --n 5 --pool 300 --out p.csv", "existing_empty.csv is empty"),
    ("import --points points_utf16be.txt --joints joints.csv --out m.csv", "points_utf16be.txt is not a text CSV file"),
]


@pytest.fixture(scope="module")
def truth(tmp_path_factory):
    folder = tmp_path_factory.mktemp("truth")
    run_ok("simulate", "ur5", "--n", "20", "--out", folder / "s.csv", "--truth", folder / "truth.json")
    return json.loads((folder / "truth.json").read_text())


def _write(folder, truth):
    for name, text in FILES.items():
        (folder / name).write_bytes(text if isinstance(text, bytes) else text.encode())
    broken = {"robot_number": {"robot": 5}, "seed_huge": {"seed": float("inf")},
              "deviation_list": {"deviations": {"a2": [1, 2]}}}
    for name, change in broken.items():
        (folder / f"truth_{name}.json").write_text(json.dumps({**truth, **change}))


@pytest.mark.parametrize("command, says", REFUSED, ids=[row[0] for row in REFUSED])
def test_a_document_of_the_wrong_shape_is_one_line(tmp_path, monkeypatch, truth, command, says):
    _write(tmp_path, truth)
    monkeypatch.chdir(tmp_path)
    before = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    assert_refused(command.split(), says, tmp_path, before)


def test_the_good_files_of_each_kind_still_read(tmp_path, monkeypatch, truth):
    (tmp_path / "ur5.toml").write_text(ROBOT)
    (tmp_path / "truth.json").write_text(json.dumps(truth))
    monkeypatch.chdir(tmp_path)
    assert "UR5" in run_ok("show", "ur5.toml").output
    run_ok("simulate", "ur5", "--errors", "truth.json", "--n", "10", "--out", "s.csv")
    assert len(read_fixture(PLATE).ids) >= 2
    assert len(read_fleet(EXAMPLES / "fleet" / "fleet.toml")) == 3


@pytest.mark.parametrize("call, says", [
    (lambda: schema.numbers([1, "2", 3], "w", count=3), "w must be a list of 3 numbers, got [1, '2', 3]"),
    (lambda: schema.number(float("nan"), "w"), "w must be finite"),
    (lambda: schema.keys({"colour": 1}, "w", ("color",)), "did you mean 'color'"),
    (lambda: schema.keys({}, "w", ("a",), required=("a",)), "w lacks a"),
    (lambda: schema.text("x" * 500, "w", ("a",)), "..."),
])
def test_the_schema_helper_names_the_place_and_what_it_must_be(call, says):
    from robocal.errors import FileFormatError

    with pytest.raises(FileFormatError) as caught:
        call()
    assert says in str(caught.value) and len(str(caught.value)) < 200


# --------------------------------------------------------------------------- every value, every wrong type
WRONG = [None, [], {}, "x", -1, 1e300, True, [[1]], {"a": {"b": 1}}, [1, 2], "", ["x", "y", "z"]]


def _places(document, prefix=()):
    """Every path to a value of ``document`` (the first three entries of a list)."""
    yield prefix
    if isinstance(document, dict):
        for key, value in document.items():
            yield from _places(value, prefix + (key,))
    elif isinstance(document, list):
        for k, value in enumerate(document[:3]):
            yield from _places(value, prefix + (k,))


def _variants(document):
    """``document`` with one value replaced by a value of a wrong type, or removed."""
    import copy

    for place in list(_places(document))[1:]:
        for value in WRONG + ["remove"]:
            changed = copy.deepcopy(document)
            inner = changed
            for step in place[:-1]:
                inner = inner[step]
            if value == "remove":
                del inner[place[-1]]
            else:
                inner[place[-1]] = value
            yield place, value, changed


def _only_user_errors(read, document):
    import warnings

    from robocal.errors import RobocalError

    crashes = {}
    for place, value, changed in _variants(document):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a huge number overflows on the way to its refusal
                read(changed)
        except RobocalError:
            pass
        except Exception as exc:  # noqa: BLE001 - what the test looks for
            crashes.setdefault(type(exc).__name__, (place, value, str(exc)[:80]))
    return crashes


def test_a_robot_document_with_any_value_of_a_wrong_type_is_a_user_error():
    import tomllib

    from robocal.io.robot_file import chain_from_dict

    for name in ("ur5", "panda", "fanuc-r2000ic-165f"):
        document = tomllib.loads((EXAMPLES.parent / "robocal" / "io" / "robots" / f"{name}.toml").read_text())
        document["tolerances"] = {"length_mm": 0.1}
        document["tool"] = {"xyz": [0, 0, 100], "rpy": [0, 0, 0]}
        assert _only_user_errors(lambda d, where=name: chain_from_dict(d, where), document) == {}, name


def test_a_fleet_robot_or_truth_with_any_value_of_a_wrong_type_is_a_user_error(tmp_path, truth):
    from robocal.interfaces.fleet import _robot
    from robocal.simulation.true_robot import TrueRobot

    table = {"name": "r1", "robot": "ur5", "train": "t.csv", "test": "t.csv", "method": "ann", "fixture": "f.toml",
             "options": {"hidden": [16, 16], "seed": 3, "generations": 100}}
    assert _only_user_errors(lambda d: _robot(d, 1, tmp_path / "fleet.toml", tmp_path), table) == {}
    assert _only_user_errors(lambda d: TrueRobot.from_dict(d, "truth.json"), truth) == {}
