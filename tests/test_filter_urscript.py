"""robocal filter on a URScript program: every pose a motion takes is what compensate
gives, in metres and radians; offsets, joint lists and every other byte stay; a nominal
model changes nothing; run-time poses and filtered scripts are refused."""
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

from robocal.errors import InputError, RobocalError
from robocal.interfaces.filter import filter_job

SCRIPT = PROGRAMS / "urscript" / "feeder_to_tray.script"


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    return true_and_nominal_models("ur5", tmp_path_factory)


def test_every_pose_is_what_compensate_gives(models, tmp_path):
    (tmp_path / "out").mkdir()
    before, after, expected, q, result = filter_and_compensate(models["true"], SCRIPT, tmp_path / "out", tmp_path)
    assert result.targets == len(before) == 7
    assert [t.name for t in before[:3]] == ["above_feeder", "at_feeder", "drop"]
    assert_same_poses(after, expected)
    # The controller takes the solution nearest where it stands: the branch of the joint
    # targets before (shoulder, elbow and wrist as in home_q), every point after the other.
    assert np.all(np.abs(np.diff(q, axis=0)) < 90)


def test_only_the_targets_numbers_change(models, tmp_path):
    filter_job(models["true"], [SCRIPT], tmp_path, allow_unfiltered=True)
    assert_only_targets_changed(SCRIPT, tmp_path / SCRIPT.name, "#")
    text = (tmp_path / SCRIPT.name).read_text()
    assert "approach = p[0, 0, -0.05, 0, 0, 0]" in text  # an offset, not a target
    assert "pose_add(drop, p[0, 0, 0.08, 0, 0, 0])" in text
    assert "movej([0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0]" in text


def test_a_nominal_model_reproduces_the_script(models, tmp_path):
    filter_job(models["nominal"], [SCRIPT], tmp_path, allow_unfiltered=True)
    data, count = without_comment((tmp_path / SCRIPT.name).read_bytes(), "#")
    assert count == 1 and data == SCRIPT.read_bytes()


def test_run_time_poses_are_refused_then_listed(models, tmp_path):
    with pytest.raises(InputError) as refusal:
        filter_job(models["true"], [SCRIPT], tmp_path)
    for line in (17, 23, 24):
        assert f"feeder_to_tray.script line {line}: " in str(refusal.value)
    assert not list(tmp_path.iterdir())
    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    result = filter_job(models["true"], [SCRIPT], tmp_path / "a", allow_unfiltered=True)
    assert sorted(int(item.split(" line ")[1].split(":")[0]) for item in result.unfiltered) == [17, 23, 24]
    assert (tmp_path / "a" / "filter-summary.csv").read_text().count("unfiltered (run time)") == 3
    with pytest.raises(InputError, match="written by robocal filter already"):
        filter_job(models["true"], [tmp_path / "a" / SCRIPT.name], tmp_path / "b", allow_unfiltered=True)


def test_a_pose_in_degrees_is_refused_not_read_as_radians(models, tmp_path):
    program = tmp_path / "degrees.script"
    program.write_text("def prog():\n  movel(p[0.4, 0.1, 0.3, 180, 0, 0], a=1.2, v=0.25)\nend\n")
    (tmp_path / "out").mkdir()
    with pytest.raises(InputError, match="degrees.script, line 2: .* more than a full turn: URScript poses take rad"):
        filter_job(models["true"], [program], tmp_path / "out")
    assert not list((tmp_path / "out").iterdir())


@pytest.mark.parametrize("content, says", [(b"\x00\x01\x02\xff\xfe", "is not a text program"),
                                           (b"", "no motion found"),
                                           (b"# only a comment\n", "no motion found")])
def test_a_binary_or_motionless_file_is_refused(models, tmp_path, content, says):
    program = tmp_path / "p.script"
    program.write_bytes(content)
    (tmp_path / "out").mkdir()
    with pytest.raises(RobocalError, match=says):
        filter_job(models["true"], [program], tmp_path / "out")
    assert not list((tmp_path / "out").iterdir())


HOME = "movej([0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0], a=1.4, v=1.05)"
ABOVE, AT = "p[-0.29802, -0.29810, 0.35729, 2.0194, 2.4066, 0.0]", "p[-0.31453, -0.30763, 0.29608, 2.0194, 2.4066, 0]"


def _script(*lines):
    return {"p.script": "def p():\n" + "".join(f"  {line}\n" for line in lines) + "end\n"}


# The controller reaches a pose from where the robot stands: with no joint position before it,
# the first motion's arm branch is unknown.  Positions in mm lie a thousand times too far.
REFUSED = [
    ("movel-first", _script(f"movel({ABOVE}, a=0.5, v=0.1)", f"movel({AT})"),
     "p.script line 2 (inline): no joint position comes before this motion, so the controller reaches it in the arm "
     "branch of wherever the robot stands when the program starts, which robocal cannot know; put a movej([...])"),
    ("named-pose-by-movej-first", _script(f"above = {ABOVE}", "movej(above)", HOME, f"movel({AT})"),
     "p.script line 2 (above): no joint position comes before this motion"),
    ("positions-in-mm", _script(HOME, "movel(p[-298.02, -298.10, 357.29, 2.0194, 2.4066, 0.0])",
                                "movel(p[-314.53, -307.63, 296.08, 2.0194, 2.4066, 0])"),
     "530310 to 552572 mm from its base: URScript positions are in metres, these look like mm (divide them by 1000); "
     "nothing was written"),
    # hostile pass 5: a pose read from the robot when the program runs
    ("pose-read-at-run-time", _script(HOME, "p9 = get_actual_tcp_pose()", f"movel({ABOVE})", "movel(p9)"),
     "2 motion(s) are computed at run time and cannot be filtered (p.script line 3: p9 = get_actual_tcp_pose()"),
]


@pytest.mark.parametrize("files, says", [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED])
def test_scripts_that_cannot_be_filtered_are_refused(models, tmp_path, monkeypatch, files, says):
    assert_filter_refused(models["true"], files, ["p.script"], says, tmp_path, monkeypatch)


def test_a_joint_position_first_fixes_the_branch(models, tmp_path):
    (tmp_path / "fo").mkdir()
    (tmp_path / "p.script").write_text(_script(HOME, f"movel({ABOVE}, a=0.5, v=0.1)")["p.script"])
    assert filter_job(models["true"], [tmp_path / "p.script"], tmp_path / "fo").targets == 1
