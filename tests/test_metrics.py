"""Error statistics (robocal.estimation.metrics): the figures and the JSON keys every verb
prints and saves."""
import dataclasses
import json

import numpy as np
import pytest

from robocal.estimation.metrics import ErrorStats, error_stats

KEYS = ["n", "mean_mm", "rms_mm", "max_mm", "p95_mm", "x_mean_mm", "x_max_mm", "y_mean_mm", "y_max_mm",
        "z_mean_mm", "z_max_mm"]


def test_error_stats_gives_the_figures_of_the_errors_under_the_json_keys_in_their_order():
    errors = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, -1.0], [1.0, -2.0, 2.0]])
    stats = error_stats(errors)
    assert list(stats.to_dict()) == KEYS
    assert stats.n == 3
    assert stats.mean_mm == pytest.approx((5.0 + 1.0 + 3.0) / 3)
    assert stats.rms_mm == pytest.approx(np.sqrt((25.0 + 1.0 + 9.0) / 3))
    assert stats.max_mm == 5.0 and stats.p95_mm == pytest.approx(np.percentile([5.0, 1.0, 3.0], 95))
    assert (stats.x_mean_mm, stats.x_max_mm) == (pytest.approx(4.0 / 3), 3.0)
    assert (stats.y_mean_mm, stats.y_max_mm) == (pytest.approx(2.0), 4.0)
    assert (stats.z_mean_mm, stats.z_max_mm) == (pytest.approx(1.0), 2.0)
    # JSON-ready: plain floats and ints, which round-trip.
    assert ErrorStats.from_dict(json.loads(json.dumps(stats.to_dict()))) == stats


def test_no_errors_give_only_their_count():
    stats = error_stats(np.zeros((0, 3)))
    assert stats == ErrorStats(n=0) and stats.to_dict() == {"n": 0} and stats.rms_mm is None


def test_error_stats_are_frozen_and_from_dict_leaves_other_figures_out():
    stats = error_stats(np.ones((4, 3)))
    with pytest.raises(dataclasses.FrozenInstanceError):
        stats.rms_mm = 0.0
    document = {**stats.to_dict(), "rot_mean_deg": 0.1, "nominal": {"n": 4}}
    assert ErrorStats.from_dict(document) == stats
