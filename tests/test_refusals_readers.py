"""What robocal's readers refuse or warn about: measurement and target CSVs, robot TOML and
URDF files, fixtures; each refusal is one FileFormatError or InputError that says what is wrong
(and where: row, column, key or link)."""
import warnings

import numpy as np
import pytest

from refusals import EXAMPLES, PLATE
from robocal.errors import FileFormatError, InputError


# ---------------------------------------------------------------- load_robot and read_observations
@pytest.mark.parametrize("name, says", [
    ("r_text.toml", "must be a number"),
    ("r_binary.toml", "not a text file"),
    ("u_notxml.urdf", "not well-formed XML"),
])
def test_load_robot_refuses_a_broken_file(refusal_inputs, name, says):
    from robocal.io.library import load_robot

    with pytest.raises(InputError, match=says):
        load_robot(str(refusal_inputs / name))


def test_load_robot_refuses_an_unknown_urdf_tip(refusal_inputs):
    from robocal.io.library import load_robot

    with pytest.raises(InputError, match="no link 'nope'"):
        load_robot(str(refusal_inputs / "ur5.urdf"), tip="nope")


@pytest.mark.parametrize("name, robot, fixture, error, says", [
    ("none.csv", "ur5", None, FileFormatError, "does not exist"),
    (".", "ur5", None, FileFormatError, "is a directory"),
    ("meas.csv", "iiwa14", None, FileFormatError, "7 joints"),
    ("meas.csv", "ur5", PLATE, InputError, "ball-in-socket data only"),
    ("dup_header.csv", "ur5", None, FileFormatError, "appears twice"),
    ("radians.csv", "ur5", None, InputError, "the joint values look like radians"),
])
def test_read_observations_refuses_what_it_cannot_use(refusal_inputs, name, robot, fixture, error, says):
    from robocal.io.library import builtin
    from robocal.io.observations import read_observations

    if error is None:
        with pytest.warns(Warning, match="radians"):
            assert read_observations(refusal_inputs / name, builtin(robot)).n_poses == 60
        return
    with pytest.raises(error, match=says):
        read_observations(refusal_inputs / name, builtin(robot), fixture)


def test_socket_data_read_without_a_fixture_is_refused_at_the_fit(refusal_inputs):
    from robocal.io.library import builtin
    from robocal.io.observations import read_observations
    from robocal.methods import make_method

    chain = builtin("kr150-2")
    data = read_observations(refusal_inputs / "sockets.csv", chain)
    with pytest.raises(InputError, match="needs the fixture"):
        make_method("constraint").fit(chain, data)


# ---------------------------------------------------------------- absurd magnitudes in a CSV
@pytest.mark.parametrize("column, value", [("x", "1e300"), ("q2", "-5e7"), ("rz", "1e9")])
def test_absurd_magnitudes_are_refused_at_read_time_with_row_and_column(tmp_path, column, value):
    from robocal.io.tables import read_measurements

    header = ["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z", "rx", "ry", "rz"]
    rows = [[str(10.0 * i + k) for k in range(6)] + ["100", "200", str(300 + i), "180", "0", "0"] for i in range(6)]
    rows[3][header.index(column)] = value
    path = tmp_path / "m.csv"
    path.write_text("\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n")
    with pytest.raises(FileFormatError, match=rf"row 5, column '{column}': {value} is beyond"):
        read_measurements(path)


def test_absurd_target_values_are_refused(tmp_path):
    from robocal.io.tables import read_targets

    path = tmp_path / "t.csv"
    path.write_text("x,y,z,rx,ry,rz\n400,0,300,180,0,0\n400,1e300,300,180,0,0\n")
    with pytest.raises(FileFormatError, match="row 3, column 'y'"):
        read_targets(path)


# ---------------------------------------------------------------- robot files and URDF
def _robot_doc(**joint):
    return {"name": "r", "convention": "dh",
            "joints": [{"a": 0.0, "alpha": 90.0, "d": 300.0, "theta": 0.0, **joint},
                       {"a": 400.0, "alpha": 0.0, "d": 0.0, "theta": 0.0}]}


def test_the_unknown_key_message_lists_each_key_once():
    from robocal.io.robot_file import chain_from_dict

    with pytest.raises(FileFormatError, match="known keys") as caught:
        chain_from_dict(_robot_doc(zzz=1.0))
    listed = str(caught.value).split("known keys: ")[1].split(", ")
    assert len(listed) == len(set(listed)) and "beta" in listed


def test_a_poe_joint_with_beta_is_refused_not_ignored():
    from robocal.io.robot_file import chain_from_dict

    doc = {"name": "p", "convention": "poe",
           "joints": [{"axis": [0, 0, 1], "point": [0, 0, 0], "theta": 0.0, "beta": 1.0}]}
    with pytest.raises(FileFormatError, match="joint 1 has beta"):
        chain_from_dict(doc)


_JOINT = ('<joint name="{}" type="revolute"><parent link="{}"/><child link="{}"/><axis xyz="0 0 1"/>'
          '<origin xyz="0 0 0.1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')


def _urdf(tmp_path, links, joints):
    path = tmp_path / "r.urdf"
    path.write_text('<robot name="r">' + "".join(f'<link name="{name}"/>' for name in links)
                    + "".join(_JOINT.format(*joint) for joint in joints) + "</robot>")
    return path


@pytest.mark.parametrize("links, joints, says", [
    ("ab", [("j1", "a", "b"), ("j2", "b", "a")], "'j1', 'j2' form a loop through the links 'a', 'b'"),
    # a loop beside a proper tree: the tree alone would have been read without a word
    ("rabc", [("j0", "r", "a"), ("j1", "b", "c"), ("j2", "c", "b")], "form a loop through the links 'b', 'c'"),
    ("ab", [("j1", "a", "b"), ("j2", "b", "b")], "joint 'j2' has link 'b' as both its parent and its child"),
    ("rab", [("j0", "r", "a"), ("j1", "r", "b"), ("j2", "a", "b")], "link 'b' is the child of two joints"),
])
def test_a_urdf_that_is_not_a_tree_names_the_links(tmp_path, links, joints, says):
    from robocal.io.urdf import read_urdf

    with pytest.raises(FileFormatError, match=says):
        read_urdf(_urdf(tmp_path, links, joints))


# ---------------------------------------------------------------- target orientations in radians
def _targets(tmp_path, orientation):
    path = tmp_path / "t.csv"
    path.write_text("x,y,z,rx,ry,rz\n" + "".join(f"{400 + 10 * k},0,300,{orientation}\n" for k in range(3)))
    return path


@pytest.mark.parametrize("orientation", ["3.14159,0,1.57", "-3.1416,0,0", "1.5708,0,0", "2.5,0.3,-1.2",
                                         "0,0.785398,0"])
def test_target_orientations_in_radians_are_refused(tmp_path, orientation):
    from robocal.io.tables import read_targets

    with pytest.raises(InputError, match="rx, ry, rz of .* look like radians"):
        read_targets(_targets(tmp_path, orientation))


@pytest.mark.parametrize("orientation", ["180,0,0", "-180,0,0", "0,0,0", "0.5,-0.8,0.2", "0,0,3", "2,-1,0",
                                         "179.9,0.1,-90", "0,90,0", "0,0,0.5"])
def test_degree_targets_raise_no_false_alarm(tmp_path, orientation):
    from robocal.io.tables import read_targets

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_targets(_targets(tmp_path, orientation))
        for example in ("ur5-targets.csv", "kr150-targets.csv"):
            read_targets(EXAMPLES / example)


def test_the_example_targets_converted_to_radians_are_refused(tmp_path):
    from robocal.io.tables import read_targets

    # Without the example's robocal_file column: the numbers only.
    lines = [line.rsplit(",", 1)[0] for line in (EXAMPLES / "ur5-targets.csv").read_text().splitlines()]
    rows = [[float(v) for v in line.split(",")] for line in lines[1:]]
    converted = [r[:3] + list(np.radians(r[3:6])) + r[6:] for r in rows]
    path = tmp_path / "t.csv"
    path.write_text("\n".join([lines[0]] + [",".join(str(float(v)) for v in r) for r in converted]) + "\n")
    with pytest.raises(InputError, match="look like radians"):
        read_targets(path)
