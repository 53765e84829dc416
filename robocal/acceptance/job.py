"""``robocal iso9283``: plan an ISO 9283 campaign, and compute its pose characteristics."""
from __future__ import annotations

import numpy as np

from ..io.atomic import check_outputs
from ..io.iso_campaign import read_iso_campaign, write_plan
from ..io.library import load_robot
from ..io.units import check_robot_lengths, check_typed_units
from .iso9283 import CYCLES, DEFAULT_MATCH_MM, characteristics, plan_campaign


def plan_job(robot, out, *, centre=None, edge=None, rpy=None, cycles=CYCLES, root=None, tip=None):
    """Plan the standard's campaign for ``robot`` and write it to ``out``: one row per
    visit (pose, cycle, the commanded x_cmd..rz_cmd and the joint command q1..qN), P1..P5
    in every cycle.  Returns the JSON-ready summary."""
    check_outputs([out], [robot])
    chain = load_robot(robot, root=root, tip=tip)
    # Typed numbers meet the one units check every verb's options meet (robocal.io.units).
    check_typed_units(chain, rpy=rpy)
    if centre is not None:
        check_robot_lengths(chain, centre, "--centre", position=True)
    if edge is not None:
        check_robot_lengths(chain, [edge], "--edge")
    plan = plan_campaign(chain, centre=centre, edge_mm=edge, rpy_deg=(180.0, 0.0, 0.0) if rpy is None else rpy,
                         cycles=cycles)
    write_plan(out, plan, chain)
    return {"robot": chain.name, "out": str(out), "cube_centre_mm": [round(float(v), 3) for v in plan.centre],
            "cube_edge_mm": round(plan.edge_mm, 3), "rpy_deg": [float(v) for v in plan.rpy_deg],
            "poses": {name: [round(float(v), 3) for v in p] for name, p in zip(plan.names, plan.positions)},
            "cycles": cycles, "visits": cycles * len(plan.names)}


def check_match_mm(match_mm):
    """InputError unless ``match_mm`` is a distance > 0 mm."""
    if not np.isfinite(match_mm) or match_mm <= 0:
        from ..errors import InputError

        raise InputError(f"--match-mm must be a distance > 0 mm, got {match_mm}")


def characteristics_job(measurements, *, match_mm=DEFAULT_MATCH_MM):
    """The ISO 9283 figures of the campaign file ``measurements`` (JSON-ready)."""
    check_match_mm(match_mm)
    return characteristics(read_iso_campaign(measurements), match_mm=match_mm).to_dict()
