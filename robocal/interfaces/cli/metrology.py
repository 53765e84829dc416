"""Commands of the metrology workflow around a calibration: import (tracker points joined to
the robot's joint log) and iso9283 (the standard's acceptance test: plan and figures)."""
import typer

from ...errors import InputError
from ...settings import Choice, Number, Numbers, Setting
from .app import verb
from .options import JSON, ROOT, TIP, declared, out_option
from .rendering import print_imported, print_iso9283, print_json, print_result, say

ISO_ACTIONS = ("plan",)

# import's options.
IMPORT = (
    Setting("points", ..., "--points", "The tracker's point export: a name and x, y, z per line; any of ; tab , or "
            "spaces between fields, decimal commas, // or # comments; the unit from its header, a comment or "
            "--units."),
    Setting("joints", ..., "--joints", "The robot's joint log (CSV): q1..qN (deg, or tagged such as q1[rad]) and "
            "the point's name, or a time column."),
    Setting("units", None, "--units", "The points' length unit when the file does not state it: mm, m, cm, in or "
            "um (default mm; a contradiction is refused).", Choice(("mm", "m", "cm", "in", "um"))),
    Setting("by", None, "--by", "Join by point name (default when the log has a name column) or by time (the "
            "nearest timestamp within --max-dt).", Choice(("name", "time"))),
    Setting("max_dt", 0.5, "--max-dt", "By time: the largest gap between a joint row and its point, in seconds.",
            Number(at_least=0, at_most=3600)),
)
# iso9283's options (plan, and a measured campaign's figures).
ISO9283 = (
    Setting("out_file", None, "--out", "With plan: the campaign CSV to write."),
    Setting("centre", None, "--centre", "With plan: the cube's centre x,y,z (mm, robot base frame; default where "
            "the robot works most).", Numbers(count=3)),
    Setting("edge", None, "--edge", "With plan: the cube's edge in mm (default the largest one reachable).",
            Number(at_least=1)),
    Setting("rpy", None, "--rpy", "With plan: the TCP orientation rx,ry,rz in deg (default 180,0,0).",
            Numbers(count=3)),
    Setting("cycles", 30, "--cycles", "With plan: cycles (the standard: 30).",
            Number(whole=True, at_least=2, at_most=1000)),
    Setting("match_mm", 2.0, "--match-mm", "Without a pose column: visits whose commands lie within this (mm) are "
            "of one pose.", Number(at_least=1e-6, at_most=1000)),
    Setting("model", None, "--model", "With a campaign: a model file; the figures the compensated robot is "
            "predicted to reach, beside the measured ones (needs the joint command q1..qN in the campaign)."),
    Setting("report", None, "--report", "With a campaign: write the ISO page (test conditions, instrument, before "
            "and after) to this .html file."),
    Setting("instrument", None, "--instrument", "With --report: the instrument that measured the campaign (e.g. "
            "'Leica AT960, SMR 1.5 in')."),
    Setting("conditions", None, "--conditions", "With --report: the test conditions (load, speed, temperature, "
            "warm-up)."),
)


@verb(name="import")
@declared(IMPORT)
def import_points(*, points: str, joints: str, out_file: str = out_option("Measurement CSV to write.", ".csv"),
                  units: str, by: str, max_dt: float, as_json: bool = JSON):
    """Join a tracker's named points to the robot's joint log into a measurement file.

    A joint row with no point, or a point with no joint row, is reported and left out, never
    guessed; points measured more than once are averaged and their spread reported.

    Example: robocal import --points tracker.txt --joints joints.csv --out meas.csv
    """
    from ...io.point_join import import_points as run

    result = run(points, joints, out_file, units=units, by=by, max_dt=max_dt)
    print_imported(result, out_file, as_json)


@verb()
@declared(ISO9283)
def iso9283(target: str = typer.Argument(..., help="A campaign CSV to compute the figures of (pose, cycle, "
                                                    "x_cmd..z_cmd, x..z, optionally rx_cmd..rz_cmd and rx..rz), "
                                                    "or 'plan'."),
            robot: str = typer.Argument(None, help="With plan: the robot (built-in name, .toml or .urdf)."), *,
            out_file: str, centre: str, edge: float, rpy: str, cycles: int, match_mm: float, model: str, report: str,
            instrument: str, conditions: str, tip: str = TIP, root: str = ROOT, as_json: bool = JSON):
    """ISO 9283 pose accuracy and repeatability (AP, RP), distance accuracy (AD, RD).

    Plan: robocal iso9283 plan ur10 --out campaign.csv  (P1..P5 on a cube, 30 cycles)

    Figures: robocal iso9283 measured.csv --json [--model model.json] [--report iso.html]
    """
    from ...acceptance.job import plan_job
    from ..metrology_jobs import iso9283_job

    if target == "plan":
        given = [name for name, value in (("--model", model), ("--report", report), ("--instrument", instrument),
                                          ("--conditions", conditions)) if value is not None]
        if given:
            raise InputError(f"{', '.join(given)} {'concern' if len(given) > 1 else 'concerns'} a measured campaign, "
                             "not a plan: robocal iso9283 "
                             "CAMPAIGN.csv --model MODEL.json --report iso.html")
        if robot is None or out_file is None:
            raise InputError("iso9283 plan needs the robot and --out: robocal iso9283 plan ROBOT --out campaign.csv")
        result = plan_job(robot, out_file, centre=centre, edge=edge, rpy=rpy, cycles=cycles, root=root, tip=tip)
        print_result(result, as_json, f"ISO 9283 campaign -> {out_file}")
        return
    given = [name for name, value in (("ROBOT", robot), ("--out", out_file), ("--centre", centre), ("--edge", edge),
                                      ("--rpy", rpy)) if value is not None]
    if given:
        raise InputError(f"{', '.join(given)} plan a campaign: give 'plan' first (robocal iso9283 plan ROBOT --out "
                         "FILE), or leave them out to compute a measured campaign's figures")
    if report is None and (instrument is not None or conditions is not None):
        raise InputError("--instrument and --conditions are written on the ISO page: give --report iso.html too")
    result = iso9283_job(target, match_mm=match_mm, model=model, report=report, instrument=instrument,
                         conditions=conditions)
    if as_json:
        print_json(result.to_dict())
        return
    print_iso9283(result.figures)
    once = list(result.figures.visited_once)
    if once:
        say("note", "cyan", f"{len(once)} commanded pose{'s' if len(once) > 1 else ''} visited once (no repeatability) "
                            f"left out: {', '.join(once[:10])}{' ...' if len(once) > 10 else ''}")
    compensated = result.compensated
    if compensated is not None:
        say("note", "cyan", f"compensated by {model}: {compensated.note}")
        print_iso9283(compensated.figures, f"compensated, predicted by {model}")
        from ..report_iso import largest

        measured, predicted = result.figures, compensated.figures
        say("note", "cyan", f"largest AP {largest(measured, 'AP'):.4f} mm measured -> "
                            f"{largest(predicted, 'AP'):.4f} mm compensated (predicted); largest RP "
                            f"{largest(measured, 'RP'):.4f} -> {largest(predicted, 'RP'):.4f} mm")
    if report is not None:
        say("note", "cyan", f"ISO page -> {report}")
