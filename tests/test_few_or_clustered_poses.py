# ruff: noqa: E501  (one input per table row)
"""Too few poses and clustered poses, for every method. Each is refused in one
line saying how many poses (or configurations per socket) the method needs, and nothing is
written."""
import numpy as np
import pytest

from user_files import refuse


def first(n, name="ur5.csv"):
    return lambda base: "\n".join((base / name).read_text().splitlines()[: n + 1]) + "\n"


def tight_cluster(base):
    """40 configurations within 0.5 deg of one pose, all with that pose's measured position."""
    header, first_row = (base / "ur5.csv").read_text().splitlines()[:2]
    cells = first_row.split(",")
    rng = np.random.default_rng(0)
    rows = [",".join(f"{float(v) + rng.normal(0, 0.5):.6f}" for v in cells[:6]) + "," + ",".join(cells[6:])
            for _ in range(40)]
    return header + "\n" + "\n".join(rows) + "\n"


def cluster(degrees, positions_move=False, n=40):
    """``n`` configurations within +-``degrees`` of the first measured pose (seeded); the
    positions that pose's, within 0.02 mm, or (``positions_move``) the nominal robot's TCP
    at each configuration: clustered poses whatever their positions say."""
    def make(base):
        from robocal.io.library import load_robot

        header, first_row = (base / "ur5.csv").read_text().splitlines()[:2]
        names = header.split(",")
        cells = first_row.split(",")
        rng = np.random.default_rng(1)
        chain = load_robot("ur5")
        rows = []
        for _ in range(n):
            q = [float(v) + rng.uniform(-degrees, degrees) for v in cells[:6]]
            xyz = chain.fk_positions(np.radians([q]))[0] + rng.normal(0, 0.05, 3) if positions_move else \
                [float(cells[names.index(a)]) + rng.uniform(-0.02, 0.02) for a in "xyz"]
            row = dict(zip(names, cells), **{f"q{k + 1}": f"{v:.6f}" for k, v in enumerate(q)},
                       **{a: f"{v:.6f}" for a, v in zip("xyz", xyz)})
            rows.append(",".join(row[c] for c in names))
        return header + "\n" + "\n".join(rows) + "\n"
    return make


def repeated(n, times):
    """The first ``n`` measured poses, the list written ``times`` times over."""
    def make(base):
        lines = (base / "ur5.csv").read_text().splitlines()
        return "\n".join(lines[:1] + lines[1:n + 1] * times) + "\n"
    return make


def one_joint_turns(joint, n):
    """``n`` poses where only ``joint`` turns (-150..150 deg) from the first measured pose,
    at the nominal robot's TCP plus 0.02 mm noise (seeded)."""
    def make(base):
        from robocal.io.library import load_robot

        header, first_row = (base / "ur5.csv").read_text().splitlines()[:2]
        cells = first_row.split(",")
        chain = load_robot("ur5")
        rng = np.random.default_rng(3)
        rows = []
        for i in range(n):
            q = [float(v) for v in cells[:6]]
            q[joint - 1] = -150 + 300 * i / (n - 1)
            xyz = chain.fk_positions(np.radians([q]))[0] + rng.normal(0, 0.02, 3)
            rows.append(",".join([f"{v:.6f}" for v in [*q, *xyz]] + cells[9:]))
        return header + "\n" + "\n".join(rows) + "\n"
    return make


CAL = ["calibrate", "ur5", "f.csv", "--out", "o.json"]
REFUSED = [
    ("one-pose", CAL, first(1), "1 distinct poses give 3 equations for 35 parameters"),
    ("two-poses", CAL, first(2), "2 distinct poses give 6 equations"),
    ("three-poses", CAL, first(3), "measure at least 12 different poses"),
    ("five-poses", CAL, first(5), "5 distinct poses give 15 equations"),
    ("eight-poses", CAL, first(8), "8 distinct poses give 24 equations"),
    ("kriging-three-poses", ["calibrate", "ur5", "f.csv", "--method", "kriging", "--out", "o.json"], first(3), "needs at least 5 different poses"),
    ("hybrid-five-poses", ["calibrate", "ur5", "f.csv", "--method", "hybrid", "--out", "o.json"], first(5), "measure at least 12 different poses"),
    ("network-five-poses", ["calibrate", "ur5", "f.csv", "--method", "ann", "--generations", "5", "--out", "o.json"], first(5), "measure at least 145 poses"),
    ("validate-five-poses", ["validate", "ur5", "f.csv", "--folds", "5"], first(5), "give 12 equations for 35 parameters"),
    ("frames-two-poses", ["calibrate", "ur5_model.json", "f.csv", "--method", "frames", "--out", "o.json"], first(2), "re-registering 9 parameters needs at least 6 poses"),
    ("sockets-three-rows", ["calibrate", "kr150-2", "f.csv", "--method", "constraint", "--fixture", "plate.toml", "--out", "o.json"], first(3, "sockets.csv"), "no placement has the ball in two different sockets"),
    ("frames-one-pose-six-times", ["calibrate", "ur5_model.json", "f.csv", "--method", "frames", "--out", "o.json"], lambda base: "\n".join((base / "ur5.csv").read_text().splitlines()[:1] + (base / "ur5.csv").read_text().splitlines()[1:2] * 6) + "\n", "holds 1 distinct pose(s): re-registering 9 parameters needs at least 6 poses"),
    ("validate-fifty-folds-of-twenty", ["validate", "ur5", "f.csv", "--folds", "50"], first(20), "--folds 50 folds need at least 50 poses, got 20"),
    ("tight-cluster-one-position", CAL, tight_cluster, "the positions do not follow the robot"),
    ("cluster-half-degree", CAL, cluster(0.5), "its 40 poses are clustered (no joint moves more than"),
    ("cluster-half-degree-kriging", ["calibrate", "ur5", "f.csv", "--method", "kriging", "--out", "o.json"], cluster(0.5), "poses are clustered"),
    ("cluster-half-degree-hybrid", ["calibrate", "ur5", "f.csv", "--method", "hybrid", "--out", "o.json"], cluster(0.5), "poses are clustered"),
    ("cluster-one-degree-positions-move", CAL, cluster(1.0, positions_move=True), "measure poses spread over the workspace, the TCP at least"),
    ("cluster-one-degree-kriging", ["calibrate", "ur5", "f.csv", "--method", "kriging", "--out", "o.json"], cluster(1.0, positions_move=True), "poses are clustered"),
    ("cluster-one-degree-frames", ["calibrate", "ur5_model.json", "f.csv", "--method", "frames", "--out", "o.json"], cluster(1.0, positions_move=True), "poses are clustered"),
    ("cluster-validate", ["validate", "ur5", "f.csv", "--folds", "3"], cluster(1.0, positions_move=True), "poses are clustered"),
    # hostile pass 5
    ("kriging-four-poses-three-times", ["calibrate", "ur5", "f.csv", "--method", "kriging", "--out", "o.json"], repeated(4, 3), "f.csv holds 4 distinct pose(s) in 12 rows: the kriging method"),
    ("validate-six-poses-in-three-folds", ["validate", "ur5", "f.csv", "--folds", "3"], first(6), "4 distinct poses give 12 equations for 35 parameters"),
    ("network-thirty-clustered-poses", ["calibrate", "ur5", "f.csv", "--method", "ann", "--generations", "30", "--out", "o.json"], cluster(2.0, positions_move=True, n=30), "30 poses give 90 equations for the 435 weights"),
    ("only-the-wrist-turns", CAL, one_joint_turns(6, 30), "the measured points are (nearly) collinear"),
]


@pytest.mark.parametrize("args, content, says", [r[1:] for r in REFUSED], ids=[r[0] for r in REFUSED])
def test_too_few_or_clustered_poses_are_refused(tmp_path, args, content, says):
    refuse(tmp_path, args, {"f.csv": content}, says)


# Clusters are refused to fits only: a model is scored on them, and poses spread more (+-5 deg
# about one posture: fitted, its predicted error says how far it holds; +-30 deg; the first 12
# of the base file) calibrate.
def test_a_model_is_still_scored_on_clustered_poses(tmp_path):
    from user_files import invoke, prepare

    prepare(tmp_path, {"f.csv": cluster(0.5, positions_move=True)})
    outcome = invoke(tmp_path, ["evaluate", "ur5_model.json", "f.csv"])
    assert outcome.code == 0, outcome.output


@pytest.mark.parametrize("content, extra", [
    # the prediction of a +-5 deg cluster refuses it as an extrapolation unless accepted
    (cluster(5.0, positions_move=True), ["--accept-extrapolation"]),
    (cluster(30.0, positions_move=True), []),
    (first(12), []),
], ids=["five-degrees-accepted-extrapolation", "thirty-degrees", "first-12"])
def test_poses_spread_like_a_campaign_calibrate(tmp_path, content, extra):
    from user_files import invoke, prepare

    prepare(tmp_path, {"f.csv": content})
    outcome = invoke(tmp_path, CAL + extra)
    assert outcome.code == 0, outcome.output
    assert (tmp_path / "o.json").stat().st_size > 0


def one_placement(base):
    """The base ball-in-socket file's rows of its first fixture placement only."""
    lines = (base / "sockets.csv").read_text().splitlines()
    column = lines[0].split(",").index("fixture")
    first_placement = lines[1].split(",")[column]
    return "\n".join([lines[0]] + [r for r in lines[1:] if r.split(",")[column] == first_placement]) + "\n"


def test_sockets_of_one_placement_fit_and_say_the_placement_is_one(tmp_path):
    """One fixture placement pins part of the model (the rest is held by its prior): a fit,
    not a traceback (the identifiability of fewer constraint rows than parameters), with a
    warning that the error elsewhere is not measured."""
    from user_files import invoke, prepare

    prepare(tmp_path, {"f.csv": one_placement})
    outcome = invoke(tmp_path, ["calibrate", "kr150-2", "f.csv", "--method", "constraint", "--fixture", "plate.toml",
                                "--out", "o.json"])
    assert outcome.code == 0, outcome.output
    assert "Traceback" not in outcome.output
    assert any("one fixture placement" in line and "measure at two or more placements" in line
               for line in outcome.lines), outcome.lines
    assert (tmp_path / "o.json").stat().st_size > 0


def test_sockets_of_several_placements_do_not_warn_of_one(tmp_path):
    from user_files import invoke, prepare

    prepare(tmp_path)
    outcome = invoke(tmp_path, ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture",
                                "plate.toml", "--out", "o.json"])
    assert outcome.code == 0, outcome.output
    assert not any("one fixture placement" in line for line in outcome.lines), outcome.lines


def test_kriging_on_poses_along_a_line_says_what_to_measure_once(tmp_path):
    # 40 poses along x (y and z within 0.5 mm): the correlation length across the line cannot
    # be found, for two outputs alike.  The diagnostic says what to measure, once for both,
    # and names no setting the command line does not have (it said "lower theta_bounds").
    import re

    from user_files import invoke, prepare

    prepare(tmp_path)
    assert invoke(tmp_path, ["simulate", "ur5", "--sampling", "lhs", "--box", "200,600,-100,-99.5,300,300.5",
                             "--n", "40", "--seed", "21", "--out", "f.csv"]).code == 0
    # Beyond the line the model adds its extrapolated trend, predicted worse than the registered
    # nominal robot over the working range: the kinematic calibration answers there instead.
    answered = invoke(tmp_path, ["calibrate", "ur5", "f.csv", "--method", "kriging", "--out", "o.json"])
    said = "\n".join(answered.lines)
    assert answered.code == 0 and "the kinematic full calibration answers there" in said, said
    outcome = invoke(tmp_path, ["calibrate", "ur5", "f.csv", "--method", "kriging", "--out", "o.json",
                                "--accept-extrapolation"])
    assert outcome.code == 0, outcome.output
    text = " ".join(re.sub(r"[│┃┌┐└┘├┤─]", " ", outcome.output).split())
    assert text.count("hit its lower bound") == 1 and "outputs 1, 2: theta hit its lower bound" in text, text
    assert "measure points spread wider" in text and not re.search(r"\b[a-z]+_[a-z_]+\b", text), text
