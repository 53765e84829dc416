"""Commands of the metrology workflow around a calibration: import (tracker points joined to
the robot's joint log) and iso9283 (the standard's acceptance test: plan and figures)."""
import typer

from ...errors import InputError
from ...settings import Choice, Number, Numbers
from .app import verb
from .options import JSON, ROOT, TIP, out_option, parsed
from .rendering import print_iso9283, print_json, print_result, say

ISO_ACTIONS = ("plan",)


@verb(name="import")
def import_points(
    points: str = typer.Option(..., "--points", help="The tracker's point export: a name and x, y, z per line; any of "
                                                     "; tab , or spaces between fields, decimal commas, // or # "
                                                     "comments; the unit from its header, a comment or --units."),
    joints: str = typer.Option(..., "--joints", help="The robot's joint log (CSV): q1..qN (deg, or tagged such as "
                                                     "q1[rad]) and the point's name, or a time column."),
    out_file: str = out_option("Measurement CSV to write.", ".csv"),
    units: str = typer.Option(None, "--units", help="The points' length unit when the file does not state it: mm, "
                                                    "m, cm, in or um (default mm; a contradiction is refused).",
                              **parsed(Choice(("mm", "m", "cm", "in", "um")))),
    by: str = typer.Option(None, "--by", help="Join by point name (default when the log has a name column) or by "
                                              "time (the nearest timestamp within --max-dt).",
                           **parsed(Choice(("name", "time")))),
    max_dt: float = typer.Option(0.5, "--max-dt", help="By time: the largest gap between a joint row and its point, "
                                                       "in seconds.", **parsed(Number(at_least=0, at_most=3600))),
    as_json: bool = JSON,
):
    """Join a tracker's named points to the robot's joint log into a measurement file.

    A joint row with no point, or a point with no joint row, is reported and left out, never
    guessed; points measured more than once are averaged and their spread reported.

    Example: robocal import --points tracker.txt --joints joints.csv --out meas.csv
    """
    from ...io.point_join import import_points as run

    result = run(points, joints, out_file, units=units, by=by, max_dt=max_dt)
    if as_json:
        print_json(result)
        return
    print_result({k: v for k, v in result.items() if k not in ("joint_rows_without_point", "points_without_joint_row",
                                                               "averaged")}, False,
                 f"{result['matched']} poses joined by {result['by']} -> {out_file}")
    for entry in result["joint_rows_without_point"]:
        say("warning", "yellow", f"joint row on line {entry['line']} ({entry['key']}) has no point: left out")
    for entry in result["points_without_joint_row"]:
        say("warning", "yellow", f"point {entry['name']} (line {entry['line']}) has no joint row: left out")
    for entry in result["averaged"]:
        say("note", "cyan", f"point {entry['name']} measured {entry['count']} times: averaged (spread "
                            f"{entry['spread_mm']:.4f} mm)")


@verb()
def iso9283(
    target: str = typer.Argument(..., help="A campaign CSV to compute the figures of (pose, cycle, x_cmd..z_cmd, "
                                           "x..z, optionally rx_cmd..rz_cmd and rx..rz), or 'plan'."),
    robot: str = typer.Argument(None, help="With plan: the robot (built-in name, .toml or .urdf)."),
    out_file: str = typer.Option(None, "--out", help="With plan: the campaign CSV to write."),
    centre: str = typer.Option(None, "--centre", help="With plan: the cube's centre x,y,z (mm, robot base frame; "
                                                      "default where the robot works most).",
                               **parsed(Numbers(count=3))),
    edge: float = typer.Option(None, "--edge", help="With plan: the cube's edge in mm (default the largest one "
                                                    "reachable).", **parsed(Number(at_least=1))),
    rpy: str = typer.Option(None, "--rpy", help="With plan: the TCP orientation rx,ry,rz in deg (default 180,0,0).",
                            **parsed(Numbers(count=3))),
    cycles: int = typer.Option(30, "--cycles", help="With plan: cycles (the standard: 30).",
                               **parsed(Number(whole=True, at_least=2, at_most=1000))),
    match_mm: float = typer.Option(2.0, "--match-mm", help="Without a pose column: visits whose commands lie within "
                                                           "this (mm) are of one pose.",
                                   **parsed(Number(at_least=1e-6, at_most=1000))),
    model: str = typer.Option(None, "--model", help="With a campaign: a model file; the figures the compensated "
                                                    "robot is predicted to reach, beside the measured ones (needs "
                                                    "the joint command q1..qN in the campaign)."),
    report: str = typer.Option(None, "--report", help="With a campaign: write the ISO page (test conditions, "
                                                      "instrument, before and after) to this .html file."),
    instrument: str = typer.Option(None, "--instrument", help="With --report: the instrument that measured the "
                                                              "campaign (e.g. 'Leica AT960, SMR 1.5 in')."),
    conditions: str = typer.Option(None, "--conditions", help="With --report: the test conditions (load, speed, "
                                                              "temperature, warm-up)."),
    tip: str = TIP,
    root: str = ROOT,
    as_json: bool = JSON,
):
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
            raise InputError(f"{', '.join(given)} concern a measured campaign, not a plan: robocal iso9283 "
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
        print_json(result)
        return
    print_iso9283(result)
    if result["visited_once"]:
        once = result["visited_once"]
        say("note", "cyan", f"{len(once)} commanded pose{'s' if len(once) > 1 else ''} visited once (no repeatability) "
                            f"left out: {', '.join(once[:10])}{' ...' if len(once) > 10 else ''}")
    compensated = result.get("compensated")
    if compensated is not None:
        say("note", "cyan", f"compensated by {model}: {compensated['note']}")
        print_iso9283({**compensated, "file": f"compensated, predicted by {model}"})
        from ..report_iso import largest

        say("note", "cyan", f"largest AP {largest(result, 'AP_mm'):.4f} mm measured -> "
                            f"{largest(compensated, 'AP_mm'):.4f} mm compensated (predicted); largest RP "
                            f"{largest(result, 'RP_mm'):.4f} -> {largest(compensated, 'RP_mm'):.4f} mm")
    if report is not None:
        say("note", "cyan", f"ISO page -> {report}")
