"""The fleet command: every robot of a fleet file calibrated, evaluated and reported on Dask
(the work is :mod:`robocal.interfaces.fleet`'s)."""
import typer

from .app import verb
from .options import JOBS, JSON, SCHEDULER
from .rendering import print_fleet, print_json, progress, say


@verb()
def fleet(
    fleet_file: str = typer.Argument(..., help="Fleet file (TOML): one [[robot]] table per robot with name, robot, "
                                     "train, and optionally test, method, fixture, options (calibrate's options); "
                                     "paths relative to it."),
    # No <name> in help texts: their markdown reads it as a tag and drops it.
    out_dir: str = typer.Option(..., "--out", metavar="<DIR>", help="Folder to write: DIR/NAME/model.json and "
                                "report.html per robot (NAME: its name in the fleet file), DIR/summary.csv and "
                                "DIR/summary.html (created if missing)."),
    scheduler: str = SCHEDULER,
    jobs: int = JOBS,
    as_json: bool = JSON,
):
    """Calibrate, evaluate and report every robot of a fleet, in parallel on Dask.

    For each robot: calibrate on train, evaluate on test when given, write the report.  A
    mistake in the fleet file stops everything before any work starts; a robot whose data
    are bad fails alone (the summary says why) and the exit status is then 1.  Needs Dask:
    pip install 'robocal[fleet]'.

    Example: robocal fleet fleet.toml --out results --jobs 2
    """
    from ..fleet import OK, SUMMARY_COLUMNS, default_workers, fleet_job

    if jobs is None and scheduler is None:
        jobs = default_workers()
    with progress("robots", None, enabled=not as_json) as advance:
        result = fleet_job(fleet_file, out_dir, jobs=jobs, scheduler=scheduler,
                           on_robot=lambda row, done, total: advance(robots=f"{done} of {total}",
                                                                     last=f"{row['name']} {row['status']}"))
    if as_json:
        print_json(result.to_dict())
    else:
        print_fleet(result, [c for c in SUMMARY_COLUMNS if c != "message"], OK)
    if result.failed:
        say("error", "red", f"{result.failed} of {len(result.robots)} robots failed: the message column of "
                            f"{result.summary_csv} says why")
        raise typer.Exit(1)
