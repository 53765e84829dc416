"""Which poses a model has seen, by content (robocal.io.fingerprint): a pose is its joint
configuration.  A copy, a re-ordering, a re-export rounded to 0.1°, a revolute joint written
one turn off, or the same configurations with other x, y, z are the training poses; poses as
far apart on one joint as the closest distinct poses of the shipped datasets are new."""
import numpy as np
import pytest

from robocal.errors import FileFormatError
from robocal.io.fingerprint import LEGACY_RESOLUTION, _encode, _legacy_digests, fingerprint, seen

RNG = np.random.default_rng(3)
JOINTS = RNG.uniform(-180, 180, (5000, 6))  # deg
POSITIONS = RNG.uniform(-1500, 1500, (5000, 3))  # mm
REVOLUTE = np.ones(6, dtype=bool)


@pytest.fixture(scope="module")
def entry():
    return fingerprint(JOINTS[:2500], REVOLUTE)


def test_training_rows_are_seen_in_any_order_and_new_ones_are_not(entry):
    order = RNG.permutation(5000)
    found = seen(entry, JOINTS[order], revolute=REVOLUTE)
    assert found[order < 2500].all() and not found[order >= 2500].any()


@pytest.mark.parametrize("decimals", [6, 3, 1])
def test_a_re_export_rounded_to_a_tenth_of_a_degree_is_still_the_training_data(entry, decimals):
    assert seen(entry, np.round(JOINTS[:2500], decimals), revolute=REVOLUTE).all()


def test_a_revolute_joint_one_turn_off_is_the_same_pose(entry):
    turned = JOINTS[:2500].copy()
    turned[:, 5] -= 360.0
    turned[:, 0] += 360.0
    assert seen(entry, turned, revolute=REVOLUTE).all()
    # A prismatic joint (mm) 360 away is somewhere else.
    assert not seen(fingerprint(JOINTS[:2500], np.zeros(6, bool)), turned, revolute=np.zeros(6, bool)).any()


# 0.084°: the closest distinct poses of the shipped datasets (ipa-ur10-d, 0.8 mm apart).
@pytest.mark.parametrize("step", [0.084, 0.4, 1.0, 5.0])
def test_a_pose_that_far_away_on_one_joint_is_new(entry, step):
    moved = JOINTS[:2500].copy()
    moved[:, 2] += step
    assert not seen(entry, moved, revolute=REVOLUTE).any()


def test_positions_do_not_decide_the_pose(entry):
    again = POSITIONS[:2500] + RNG.normal(0, 0.01, (2500, 3))
    assert seen(entry, JOINTS[:2500], again, revolute=REVOLUTE).all()


def test_a_fingerprint_written_before_joints_alone_decided_reads_as_it_was_written():
    legacy = {"resolution": LEGACY_RESOLUTION,
              "grids": [_encode(_legacy_digests(JOINTS[:100], POSITIONS[:100], None, grid)) for grid in (0, 1)]}
    assert seen(legacy, JOINTS[:200], POSITIONS[:200]).tolist() == [True] * 100 + [False] * 100
    assert not seen(legacy, JOINTS[:100], POSITIONS[:100] + 0.01).any()


GOOD = {"resolution": 1e-3, "tolerance": 0.06, "n_joints": 6}


@pytest.mark.parametrize("broken", [{**GOOD, "joints": "@@"}, {**GOOD, "joints": "AAAA"},
                                    {**GOOD, "n_joints": 5, "joints": ""}, {**GOOD, "tolerance": 1.0, "joints": ""},
                                    {"resolution": 1e-3, "grids": [""]}, {"resolution": 1.0, "grids": ["", ""]},
                                    "not a dict"])
def test_an_edited_fingerprint_is_refused_in_one_line(broken):
    with pytest.raises(FileFormatError, match="training fingerprint"):
        seen(broken, JOINTS[:3], POSITIONS[:3])
