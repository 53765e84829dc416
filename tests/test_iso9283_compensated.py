"""`robocal iso9283 CAMPAIGN --model M.json`: the compensated robot's figures, predicted as
each visit's measured position less the model's systematic error at its joint command, against
an independent computation of the standard's formulas; RP unchanged where commands repeat; the
ISO page written beside them; refusals in one line."""
import csv
import json

import numpy as np
import pytest

from refusals import assert_refused, copy_inputs, run_ok
from robocal.interfaces.jobs import load_fitted
from robocal.simulation import read_truth

NOISE_MM = 0.02


def _by_hand(attained, commanded):
    """AP and RP (mm) of one pose's visits, the standard's formulas in plain NumPy."""
    barycentre = attained.mean(axis=0)
    ap = np.sqrt(((barycentre - commanded.mean(axis=0)) ** 2).sum())
    lengths = np.sqrt(((attained - barycentre) ** 2).sum(axis=1))
    return ap, lengths.mean() + 3 * np.sqrt(((lengths - lengths.mean()) ** 2).sum() / (len(lengths) - 1))


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """A UR5 with typical errors (its truth kept), a kinematic model calibrated on 80 of its
    poses, and an ISO campaign (10 cycles) it ran with the nominal commands, measured in the
    base frame the model registered, with noise."""
    root = tmp_path_factory.mktemp("iso_model")
    run_ok("simulate", "ur5", "--n", "80", "--seed", "5", "--out", root / "meas.csv", "--truth", root / "truth.json")
    run_ok("calibrate", "ur5", root / "meas.csv", "--out", root / "model.json")
    run_ok("iso9283", "plan", "ur5", "--out", root / "plan.csv", "--cycles", "10")
    truth = read_truth(root / "truth.json")
    model, _ = load_fitted(root / "model.json")
    base = model.reference.base
    rows = list(csv.DictReader(open(root / "plan.csv", newline="")))
    joints = np.radians([[float(r[f"q{k}"]) for k in range(1, 7)] for r in rows])
    in_measurement_frame = truth.positions(joints)
    # The instrument registered to the robot base the model found: p_base = R^T (p - t).
    attained = (in_measurement_frame - base[:3, 3]) @ base[:3, :3]
    attained += np.random.default_rng(3).normal(0, NOISE_MM, attained.shape)
    with open(root / "measured.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(list(rows[0]) + ["x", "y", "z"])
        for row, point in zip(rows, attained):
            writer.writerow(list(row.values()) + [repr(float(v)) for v in point])
    return root, rows, joints, attained


def test_compensated_figures_equal_an_independent_computation_to_1e9(campaign):
    root, rows, joints, attained = campaign
    printed = json.loads(run_ok("iso9283", root / "measured.csv", "--model", root / "model.json", "--json").stdout)
    compensated = printed["compensated"]
    assert compensated["predicted"] is True and "predicted, not measured" in compensated["note"]
    model, fitted = load_fitted(root / "model.json")
    rotation, shift = model.reference.base[:3, :3], model.reference.base[:3, 3]
    systematic = (fitted.predict(joints) - shift) @ rotation - model.nominal.fk_positions(joints)
    commanded = np.array([[float(r[c]) for c in ("x_cmd", "y_cmd", "z_cmd")] for r in rows])
    names = np.array([r["pose"] for r in rows])
    for measured, predicted in zip(printed["poses"], compensated["poses"]):
        rows_of = names == measured["pose"]
        ap, rp = _by_hand(attained[rows_of], commanded[rows_of])
        ap_after, rp_after = _by_hand(attained[rows_of] - systematic[rows_of], commanded[rows_of])
        np.testing.assert_allclose([measured["AP_mm"], measured["RP_mm"]], [ap, rp], rtol=0, atol=1e-9)
        np.testing.assert_allclose([predicted["AP_mm"], predicted["RP_mm"]], [ap_after, rp_after], rtol=0, atol=1e-9)
        # The plan repeats its commands bit for bit: one prediction per pose, RP unchanged.
        assert abs(predicted["RP_mm"] - measured["RP_mm"]) < 1e-9
    before = max(p["AP_mm"] for p in printed["poses"])
    after = max(p["AP_mm"] for p in compensated["poses"])
    assert before > 1.0 and after < 0.1 * before  # the typical errors and the tool offset, mostly removed
    # The distance's direction moves with the correction, so RD changes, but by far less than AD.
    assert abs(compensated["distance"]["AD_mm"]) < abs(printed["distance"]["AD_mm"])
    assert compensated["distance"]["RD_mm"] == pytest.approx(printed["distance"]["RD_mm"], rel=1e-3)


def test_the_iso_page_shows_conditions_instrument_and_both_sets_of_figures(campaign, tmp_path):
    root, *_ = campaign
    page = tmp_path / "iso.html"
    printed = json.loads(run_ok("iso9283", root / "measured.csv", "--model", root / "model.json", "--report", page,
                                "--instrument", "Leica AT960 & SMR", "--conditions", "100 % load, 20 degC",
                                "--json").stdout)
    text = page.read_text()
    assert printed["report"] == str(page)
    assert "Leica AT960 &amp; SMR" in text and "100 % load, 20 degC" in text
    assert "cycles (visits per pose)</td><td class=\"num\">10 (the standard asks for 30)" in text
    first = printed["poses"][0]
    assert f"{first['AP_mm']:.4f}" in text and f"{printed['compensated']['poses'][0]['AP_mm']:.4f}" in text
    assert "Before: measured" in text and "predicted" in text
    assert "poses visited once (no repeatability: left out)</td><td class=\"num\">0<" in text


def test_the_iso_page_without_a_model_says_how_to_get_the_after_figures(campaign, tmp_path):
    root, *_ = campaign
    run_ok("iso9283", root / "measured.csv", "--report", tmp_path / "iso.html")
    text = (tmp_path / "iso.html").read_text()
    assert "give --model MODEL.json" in text and "not stated (give --instrument" in text


def test_the_iso_page_names_the_instrument_column_when_no_option_is_given(campaign, tmp_path):
    root, *_ = campaign
    rows = list(csv.DictReader(open(root / "measured.csv", newline="")))
    with open(tmp_path / "with_instrument.csv", "w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]) + ["instrument"])
        writer.writeheader()
        writer.writerows({**row, "instrument": "AT960 #1"} for row in rows)
    run_ok("iso9283", tmp_path / "with_instrument.csv", "--report", tmp_path / "iso.html")
    assert "AT960 #1 (the campaign&#x27;s instrument column)" in (tmp_path / "iso.html").read_text()


@pytest.fixture(scope="module")
def refusal_folder(campaign, tmp_path_factory):
    """The campaign, its model, and the campaign without its joint command."""
    root, *_ = campaign
    folder = tmp_path_factory.mktemp("iso_refusals")
    for name in ("measured.csv", "model.json", "plan.csv"):
        (folder / name).write_bytes((root / name).read_bytes())
    rows = list(csv.DictReader(open(root / "measured.csv", newline="")))
    with open(folder / "nojoints.csv", "w", newline="") as stream:
        kept = [k for k in rows[0] if not k.startswith("q")]
        writer = csv.DictWriter(stream, fieldnames=kept, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    with open(folder / "fivejoints.csv", "w", newline="") as stream:
        kept = [k for k in rows[0] if k != "q6"]
        writer = csv.DictWriter(stream, fieldnames=kept, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    with open(folder / "radians.csv", "w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows({k: repr(float(np.radians(float(v)))) if k.startswith("q") else v for k, v in row.items()}
                         for row in rows)
    # Another robot's campaign: the real UR10 series D's ISO cubes (d_iso.csv) for the UR5 model.
    run_ok("dataset", "ipa-ur10-d", "--out", folder / "d")
    return folder


@pytest.mark.parametrize("args, says", [
    ("iso9283 nojoints.csv --model model.json", "has no joint command q1..q6"),
    ("iso9283 fivejoints.csv --model model.json", "has joint columns q1..q5, but the model's robot"),
    ("iso9283 radians.csv --model model.json", "radians.csv: the joint values look like radians"),
    ("iso9283 d_iso.csv --model model.json", "so these data are not this robot's"),
    ("iso9283 d_iso.csv --model model.json --report iso.html", "so these data are not this robot's"),
    ("iso9283 measured.csv --model measured.csv", "written by 'robocal iso9283 plan', not a model file"),
    ("iso9283 measured.csv --report iso.pdf", "give --report a .html file name"),
    ("iso9283 measured.csv --report nofolder/iso.html", "nofolder"),
    ("iso9283 measured.csv --instrument tracker", "give --report iso.html too"),
    ("iso9283 plan ur5 --out p.csv --model model.json", "concerns a measured campaign, not a plan"),
])
def test_iso9283_model_and_report_refuse_in_one_line(args, says, refusal_folder, tmp_path, monkeypatch):
    before = copy_inputs(refusal_folder, tmp_path, monkeypatch)
    assert_refused(args.split(), says, tmp_path, before)


def test_the_model_report_carries_the_iso_page_of_a_campaign(campaign, tmp_path):
    root, *_ = campaign
    printed = json.loads(run_ok("iso9283", root / "measured.csv", "--model", root / "model.json", "--json").stdout)
    run_ok("report", root / "model.json", root / "meas.csv", "--out", tmp_path / "r.html", "--iso",
           root / "measured.csv")
    text = (tmp_path / "r.html").read_text()
    assert "ISO 9283 pose characteristics</h2>" in text and "Test conditions and instrument" in text
    assert all(f"{p['AP_mm']:.4f}" in text for p in printed["compensated"]["poses"])


def test_a_real_campaign_commanded_with_another_tool_is_refused_not_figured(refusal_folder, tmp_path, monkeypatch):
    # The real UR10 series D: its ISO cubes pass, with a model calibrated on its own tracker
    # data, the checks (units, the one data check) that refuse them for a UR5 model (above).
    # But their commanded positions lie 92 mm from where the robot file's nominal robot puts
    # the joint commands (another tool or frame): figured anyway, the compensated AP came out
    # 19 mm where 1.14 mm was measured.
    run_ok("calibrate", refusal_folder / "d.toml", refusal_folder / "d.csv", "--out", refusal_folder / "d_model.json")
    try:
        before = copy_inputs(refusal_folder, tmp_path, monkeypatch)
        assert_refused(["iso9283", "d_iso.csv", "--model", "d_model.json"], "the campaign's tool or frame is not the "
                       "model's", tmp_path, before)
    finally:
        (refusal_folder / "d_model.json").unlink()
