"""UR10 series D (ipa, ISO cubes) shipped as `robocal dataset ipa-ur10-d`: its ISO 9283
campaign (robocal.io.ipa_iso) is the tracker's measurements moved rigidly into the robot's
base frame, and `robocal iso9283` gives the standard's figures of its repeated poses."""
import csv
import json

import numpy as np
import pytest

from refusals import run_ok
from robocal.io.datasets import ipa_ur10
from robocal.io.ipa_iso import series_d_campaign


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """The packaged series D exported (series D is shipped from its source, not among the
    originals $ROBOCAL_SHARED_DATA may name)."""
    root = tmp_path_factory.mktemp("series_d")
    with pytest.MonkeyPatch.context() as patch:
        patch.delenv("ROBOCAL_SHARED_DATA", raising=False)
        report = json.loads(run_ok("dataset", "ipa-ur10-d", "--out", root / "d", "--json").stdout)
        yield root, report


def _pairwise(points):
    return np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)


def test_the_campaign_is_the_tracker_data_moved_rigidly_into_the_base_frame(exported, monkeypatch):
    monkeypatch.delenv("ROBOCAL_SHARED_DATA", raising=False)
    root, report = exported
    assert report["poses"] == 632 and report["iso_campaign"].endswith("d_iso.csv")
    rows = list(csv.DictReader(open(root / "d_iso.csv", newline="")))
    attained = np.array([[float(r[a]) for a in "xyz"] for r in rows])
    series_d = ipa_ur10("D").measurements  # file units (deg), as the campaign file is written
    tracker = series_d.positions
    np.testing.assert_allclose(_pairwise(attained), _pairwise(tracker), rtol=0, atol=1e-8)
    joints = np.array([[float(r[f"q{k}"]) for k in range(1, 7)] for r in rows])
    np.testing.assert_allclose(joints, series_d.joints, rtol=0, atol=1e-9)
    # An uncalibrated UR10 about a fitted frame: about a millimetre, not a misregistration.
    assert 0.3 < report["registration_rms_mm"] < 1.5


def _iso_figures(exported, monkeypatch):
    """(robocal's ``iso9283 --json`` figures of the exported campaign, its commanded and its
    attained positions (N, 3) mm as the campaign file holds them)."""
    monkeypatch.delenv("ROBOCAL_SHARED_DATA", raising=False)
    root, _ = exported
    figures = json.loads(run_ok("iso9283", root / "d_iso.csv", "--json").stdout)
    campaign = series_d_campaign()["columns"]
    commanded = np.column_stack([campaign[c] for c in ("x_cmd", "y_cmd", "z_cmd")])
    attained = np.column_stack([campaign[c] for c in "xyz"])
    return figures, commanded, attained


def test_iso9283_figures_of_series_d_equal_the_formulas(exported, monkeypatch):
    figures, commanded, attained = _iso_figures(exported, monkeypatch)
    first = figures["poses"][0]
    # P1 is the first row's command: its visits are the rows commanded within 2 mm of it.
    visits = np.linalg.norm(commanded - commanded[0], axis=1) <= 2.0
    assert first["n"] == visits.sum() >= 4
    barycentre = attained[visits].mean(axis=0)
    lengths = np.linalg.norm(attained[visits] - barycentre, axis=1)
    ap = np.linalg.norm(barycentre - commanded[visits].mean(axis=0))
    rp = lengths.mean() + 3 * lengths.std(ddof=1)
    np.testing.assert_allclose([first["AP_mm"], first["RP_mm"]], [ap, rp], rtol=0, atol=1e-9)
    assert len(figures["poses"]) + len(figures["visited_once"]) > 500  # the cubes' other poses
    assert all(p["n"] >= 2 for p in figures["poses"])


def test_every_repeated_pose_of_series_d_equals_the_formulas(exported, monkeypatch):
    # Every pose, not only P1: visits grouped here independently (a row joins the first group
    # whose first command lies within 2 mm of its own), poses visited once left out.
    figures, commanded, attained = _iso_figures(exported, monkeypatch)
    firsts, groups = [], []
    for row, command in enumerate(commanded):
        near = [k for k, first in enumerate(firsts) if np.linalg.norm(command - first) <= 2.0]
        if near:
            groups[near[0]].append(row)
        else:
            firsts.append(command)
            groups.append([row])
    expected = []
    for rows in (g for g in groups if len(g) >= 2):
        barycentre = attained[rows].mean(axis=0)
        lengths = np.linalg.norm(attained[rows] - barycentre, axis=1)
        expected.append((len(rows), np.linalg.norm(barycentre - commanded[rows].mean(axis=0)),
                         lengths.mean() + 3 * lengths.std(ddof=1)))
    got = [(p["n"], p["AP_mm"], p["RP_mm"]) for p in figures["poses"]]
    assert len(got) == len(expected) == 50
    np.testing.assert_allclose(np.array(sorted(got)), np.array(sorted(expected)), rtol=0, atol=1e-9)
