"""Issue 14, the items a second hostile pass left: each answer here was silently wrong or its
message garbled before the fix.  Command-line refusals are rows of test_bad_inputs and
test_hostile_pass; these are the Python API and the checks that need more than one line."""
import warnings
from pathlib import Path

import numpy as np
import pytest

from robocal.errors import FileFormatError, InputError, RobocalWarning
from robocal.io.library import builtin
from robocal.io.observations import Observations

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
UR5 = builtin("ur5")


# ---------------------------------------------------------------- joints that are not numbers
@pytest.mark.parametrize("call", [
    lambda: Observations.of([["a"] * 6], np.zeros((1, 3))),
    lambda: UR5.fk([["a"] * 6]),
    lambda: UR5.fk_positions([["a"] * 6]),
    lambda: UR5.fk_jacobian([["a"] * 6]),
], ids=["Observations.of", "fk", "fk_positions", "fk_jacobian"])
def test_text_joints_are_one_clear_input_error(call):
    with pytest.raises(InputError, match="must be numbers"):
        call()


def test_text_positions_are_one_clear_input_error():
    with pytest.raises(InputError, match="positions must be numbers"):
        Observations.of(np.zeros((1, 6)), [["x", 1, 2]])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("fk", ["fk", "fk_positions"])
def test_fk_refuses_a_missing_or_infinite_joint_value(fk, bad):
    q = UR5.random_configurations(4, rng=0)
    q[2, 3] = bad
    with pytest.raises(InputError, match="configuration 2"):
        getattr(UR5, fk)(q)


def test_a_row_of_nan_is_still_no_configuration():
    """The IK answers NaN rows for unreachable targets, and its solver steps through them:
    such a row gives a NaN pose, the other rows their poses."""
    q = UR5.random_configurations(3, rng=0)
    q[1] = np.nan
    poses = UR5.fk(q)
    assert np.isnan(poses[1, :3]).all() and np.isfinite(poses[[0, 2]]).all()


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
