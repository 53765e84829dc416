# ruff: noqa: E501  (one input per table row)
"""Hostile inputs: too few poses and clustered poses, for every method. Each is refused in one
line saying how many poses (or configurations per socket) the method needs, and nothing is
written."""
import numpy as np
import pytest

from hostile import refuse


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
    ("sockets-three-rows", ["calibrate", "kr150-2", "f.csv", "--method", "constraint", "--fixture", "plate.toml", "--out", "o.json"], first(3, "sockets.csv"), "record more configurations per socket"),
    ("tight-cluster-one-position", CAL, tight_cluster, "the positions do not follow the robot"),
]


@pytest.mark.parametrize("args, content, says", [r[1:] for r in REFUSED], ids=[r[0] for r in REFUSED])
def test_too_few_or_clustered_poses_are_refused(tmp_path, args, content, says):
    refuse(tmp_path, args, {"f.csv": content}, says)
