"""Which poses a model has seen, by content (robocal.io.fingerprint): a copy, a re-ordering or
a re-export with six decimals of the training rows is recognised; new measurements of the
same configurations, which differ by a tracker's noise, are not."""
import numpy as np
import pytest

from robocal.errors import FileFormatError
from robocal.io.fingerprint import fingerprint, seen

RNG = np.random.default_rng(3)
JOINTS = RNG.uniform(-180, 180, (5000, 6))
POSITIONS = RNG.uniform(-1500, 1500, (5000, 3))


@pytest.fixture(scope="module")
def entry():
    return fingerprint(JOINTS[:2500], POSITIONS[:2500])


def test_training_rows_are_seen_in_any_order_and_new_ones_are_not(entry):
    order = RNG.permutation(5000)
    found = seen(entry, JOINTS[order], POSITIONS[order])
    assert found[order < 2500].all() and not found[order >= 2500].any()


def test_a_re_export_with_six_decimals_is_still_the_training_data(entry):
    assert seen(entry, np.round(JOINTS[:2500], 6), np.round(POSITIONS[:2500], 6)).mean() > 0.999


def test_remeasured_poses_differ_by_the_trackers_noise_and_are_new(entry):
    again = POSITIONS[:2500] + RNG.normal(0, 0.01, (2500, 3))
    assert seen(entry, JOINTS[:2500], again).mean() < 0.01


def test_ball_in_socket_rows_are_told_apart_by_their_socket():
    labels = np.array(["A/1", "A/2"] * 10)
    entry = fingerprint(JOINTS[:20], labels=labels)
    assert seen(entry, JOINTS[:20], labels=labels).all()
    assert not seen(entry, JOINTS[:20], labels=labels[::-1]).any()


@pytest.mark.parametrize("broken", [{"resolution": 1.0, "grids": ["", ""]}, {"resolution": 1e-3, "grids": ["@@", ""]},
                                    {"resolution": 1e-3, "grids": ["AAA=", ""]}, "not a dict"])
def test_an_edited_fingerprint_is_refused_in_one_line(broken):
    with pytest.raises(FileFormatError, match="training fingerprint"):
        seen(broken, JOINTS[:3], POSITIONS[:3])
