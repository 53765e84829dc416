"""robocal filter on an ABB RAPID module: every robtarget is what compensate gives in its
tooldata and wobjdata, every other byte stays, a nominal model changes nothing, run-time
motions and filtered modules are refused."""
import re

import numpy as np
import pytest
from filter_support import (
    PROGRAMS,
    assert_filter_refused,
    assert_only_targets_changed,
    assert_same_poses,
    filter_and_compensate,
    true_and_nominal_models,
    without_comment,
)
from scipy.spatial.transform import Rotation

from robocal.errors import InputError
from robocal.interfaces.filter import filter_job
from robocal.io.library import load_robot
from robocal.io.programs import postures
from robocal.io.programs.core import Number
from robocal.io.programs.rapid import not_unit

MODULE = PROGRAMS / "rapid" / "PickPlace.mod"


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    return true_and_nominal_models("irb120", tmp_path_factory)


def _frame(xyz, quaternion):
    w, x, y, z = quaternion
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_quat([x, y, z, w]).as_matrix()
    pose[:3, 3] = xyz
    return pose


# The module's tGripper and wobjTable, as the test reads them.
GRIPPER = _frame([0, 0, 115.5], [1, 0, 0, 0])
TABLE = _frame([300, -150, 50], [0.9659258, 0, 0, 0.258819])


def frames(target):
    if target.name in ("pHome", "inline"):  # tool0, wobj0: the flange in the robot's base
        return np.eye(4), np.eye(4)
    return TABLE, GRIPPER


def test_every_robtarget_is_what_compensate_gives(models, tmp_path):
    (tmp_path / "out").mkdir()
    before, after, expected, q, result = filter_and_compensate(models["true"], MODULE, tmp_path / "out", tmp_path,
                                                               frames=frames)
    assert result.targets == len(before) == 11
    assert_same_poses(after, expected)
    moved = np.linalg.norm(np.array([a.pose[:3, 3] - b.pose[:3, 3] for a, b in zip(after, before)]), axis=1)
    assert 0.2 < moved.mean() < 3.0
    # Each robtarget is reached with its confdata: quadrants of axes 1, 4, 6 and cfx.
    irb = load_robot("irb120")
    conf = postures.abb(irb, irb.joints_from_file(q))
    named = np.array([t.posture for t in before])
    assert np.array_equal(conf[:, 3], named[:, 3])
    # A quadrant may differ only for a joint on its border (pHome's axis 4 at 0 deg).
    border = np.abs(q[:, [0, 3, 5]] - 90 * np.round(q[:, [0, 3, 5]] / 90)) < 0.5
    assert np.all((conf[:, :3] == named[:, :3]) | border)
    # The quaternions stay unit and on the file's side.
    for a, b in zip(after, before):
        new, old = (np.array([n.value for n in t.numbers[3:]]) for t in (a, b))
        assert abs(np.linalg.norm(new) - 1) < 1e-6 and new @ old > 0


def test_only_the_targets_numbers_change(models, tmp_path):
    filter_job(models["true"], [MODULE], tmp_path, allow_unfiltered=True)
    assert_only_targets_changed(MODULE, tmp_path / MODULE.name, "!")
    text = (tmp_path / MODULE.name).read_bytes().decode("latin-1")
    assert text.startswith("MODULE PickPlace\r\n! robocal filter: ")


def test_a_nominal_model_reproduces_the_module(models, tmp_path):
    filter_job(models["nominal"], [MODULE], tmp_path, allow_unfiltered=True)
    data, count = without_comment((tmp_path / MODULE.name).read_bytes(), "!")
    assert count == 1 and data == MODULE.read_bytes()


def test_run_time_motions_are_refused_then_listed(models, tmp_path):
    with pytest.raises(InputError) as refusal:
        filter_job(models["true"], [MODULE], tmp_path)
    message = str(refusal.value)
    for line, what in ((41, "Offs(pPick"), (48, "RelTool(pPlace"), (53, "pTemp := CRobT"), (54, "MoveL pTemp")):
        assert f"PickPlace.mod line {line}: " in message and what in message
    assert not list(tmp_path.iterdir())
    result = filter_job(models["true"], [MODULE], tmp_path, allow_unfiltered=True)
    assert len(result.unfiltered) == 4


def test_a_filtered_module_is_refused(models, tmp_path):
    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    filter_job(models["true"], [MODULE], tmp_path / "a", allow_unfiltered=True)
    with pytest.raises(InputError, match="written by robocal filter already"):
        filter_job(models["true"], [tmp_path / "a" / MODULE.name], tmp_path / "b", allow_unfiltered=True)
    assert not list((tmp_path / "b").iterdir())


def _module(old, new):
    """PickPlace.mod with ``old`` (which it holds once) replaced by ``new``."""
    text = MODULE.read_bytes().decode("latin-1")
    assert text.count(old) == 1
    return {"PickPlace.mod": text.replace(old, new)}


def _robtargets_in_metres():
    """A module moving tool0 in the base frame through four of PickPlace's robtargets, their
    x, y, z written in metres."""
    lines = [line.strip() for line in MODULE.read_bytes().decode("latin-1").splitlines()
             if line.strip().startswith(("CONST robtarget", "PERS robtarget"))][:4]
    names = [re.match(r"\w+ robtarget (\w+):=", line).group(1) for line in lines]
    metres = [re.sub(r":=\[\[([-\d.]+),([-\d.]+),([-\d.]+)\]",
                     lambda m: ":=[[" + ",".join(f"{float(v) / 1000:.3f}" for v in m.groups()) + "]", line)
              for line in lines]
    return {"PickPlace.mod": "MODULE Pick\n" + "".join(f"    {line}\n" for line in metres) + "    PROC main()\n"
            + "".join(f"        MoveJ {name},v100,fine,tool0;\n" for name in names) + "    ENDPROC\nENDMODULE\n"}


# An ABB controller refuses an orientation that is not normalised: robocal refuses it too,
# rather than writing a unit quaternion in its place.
REFUSED = [
    ("robtarget-quaternion-doubled", lambda: _module("[-0.011718,0.931016,-0.360296,0.057085]",
                                                     "[-0.023436,1.862032,-0.720592,0.11417]"),
     "PickPlace.mod line 10: the quaternion of robtarget pApproach [-0.023436, 1.862032, -0.720592, 0.11417] has "
     "norm 2"),
    ("robtarget-quaternion-off-by-1e-4", lambda: _module("0.931016", "0.931116"),
     "PickPlace.mod line 10: the quaternion of robtarget pApproach"),
    ("tooldata-quaternion", lambda: _module("[[0,0,115.5],[1,0,0,0]]", "[[0,0,115.5],[2,0,0,0]]"),
     "PickPlace.mod line 6: the quaternion of tooldata tGripper [2, 0, 0, 0] has norm 2"),
    ("wobjdata-quaternion", lambda: _module("[0.9659258,0,0,0.258819]", "[0.9659258,0,0,0.358819]"),
     "the quaternion of wobjdata wobjTable (uframe)"),
    # hostile pass 5: a module whose robtargets were written in metres
    ("robtargets-in-metres", _robtargets_in_metres,
     "the target positions of PickPlace.mod (in the robot's base): largest 0.594, where a length about robot "
     "'ABB IRB 120'"),
]


@pytest.mark.parametrize("files, says", [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED])
def test_a_quaternion_that_is_not_unit_is_refused(models, tmp_path, monkeypatch, files, says):
    assert_filter_refused(models["true"], files(), ["PickPlace.mod", "--allow-unfiltered"], says, tmp_path, monkeypatch)


@pytest.mark.parametrize("written, unit", [
    ("1, 0, 0, 0", True),
    ("0.7071, 0.7071, 0, 0", True),              # 4 decimals: 0.70705..0.70715 each reach norm 1
    ("0.7072, 0.7072, 0, 0", False),             # at least 1.00006
    ("0.70711, 0.70711, 0, 0", True),
    ("0.70712, 0.70712, 0, 0", False),           # at least 1.000013
    ("0.5, 0.5, 0.5, 0.5", True),
    ("0.866025, 0, 0, 0.5", True),
    ("0.866, 0, 0, 0.5", True),                  # 0.866025 to 3 decimals (0 and 0.5: to 3 as well)
    ("0.865, 0, 0, 0.5", False),                 # at most 0.9998
    ("0.70710678, 0.7071, 0, 0", False),         # the finest component sets the precision: 0.999995
    ("1, 1, 0, 0", False),                       # whole numbers are exact
    ("2, 0, 0, 0", False),
    ("0, 0, 0, 0", False),
])
def test_a_quaternion_is_unit_at_the_decimals_written(written, unit):
    numbers = [Number(0, text.strip()) for text in written.split(",")]
    assert (len(not_unit([numbers])) == 0) == unit
