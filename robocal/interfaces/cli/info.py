"""Commands that list and export what robocal ships: robots, show, methods, dataset, demo."""
import typer

from ...methods import get_method, method_names
from ...settings import Choice, Number
from ..jobs import DATASETS, dataset_job
from .app import verb
from .options import JSON, ROBOT, ROOT, SEED, TIP, Prefix, parsed
from .rendering import print_all, print_json, print_result, print_rows


@verb()
def robots():
    """List the built-in robots.

    Example: robocal robots
    """
    from ...io.library import builtin, builtin_description, builtin_names

    rows = []
    for name in builtin_names():
        chain = builtin(name)
        rows.append((name, str(chain.n_joints), chain.convention.upper(), builtin_description(name)))
    print_rows(("name", "joints", "model", "description"), rows)


@verb()
def show(
    robot: str = ROBOT,
    tip: str = TIP,
    root: str = ROOT,
):
    """Print a robot's parameter table (mm, deg), frames and joint limits.

    Example: robocal show kr150-2
    """
    from ...io.library import load_robot
    from ..tables import robot_tables

    print_all(robot_tables(load_robot(robot, root=root, tip=tip)))


@verb()
def methods():
    """List the calibration and compensation methods and the options each takes.

    Example: robocal methods
    """
    rows = []
    for name in method_names():
        method = get_method(name)
        rows.append((name, method.description, ", ".join(s.option for s in method.settings) or "-"))
    print_rows(("method", "description", "options"), rows)


@verb()
def dataset(
    dataset: str = typer.Argument(..., help="ur5-tsinghua, ipa-ur10-a, ipa-ur10-b, ipa-ur10-d (laser tracker; d: ISO "
                                            "cubes, also PREFIX_iso.csv, an ISO 9283 campaign) or mukca-panda-1/2/3 "
                                            "(ball in sockets; split by fixture placement).",
                                 parser=parsed(Choice(DATASETS))["parser"]),
    prefix: str = typer.Option(..., "--out", help="Prefix of the files to write (PREFIX.toml, PREFIX*.csv).",
                               **parsed(Prefix())),
    split: float = typer.Option(None, help="Training fraction of a random train/test split, e.g. 0.5.",
                                **parsed(Number(between=(0, 1)))),
    seed: int = SEED,
    as_json: bool = JSON,
):
    """Export a real dataset shipped with robocal as a robot file and measurement CSVs.

    Example: robocal dataset ur5-tsinghua --out ur5 --split 0.5
    """
    result = dataset_job(dataset, prefix, split=split, seed=seed)
    print_result(result.to_dict(), as_json, f"dataset {dataset}")


@verb()
def demo(as_json: bool = JSON):
    """Run the reference Kriging experiment on built-in data and print what it measured.

    KUKA KR 150-2 with the liu2022 geometric errors: 50 Latin-hypercube points train a Kriging
    model of the position error, 100 held-out targets are compensated and measured, beside
    the published figures (Liu et al. 2022: 1.68 mm before, 0.0018 mm mean / 0.0084 mm max after).

    Example: robocal demo --json
    """
    from ..demo import demo_tables, run_demo

    result = run_demo()
    if as_json:
        print_json(result.to_dict())
    else:
        print_all(demo_tables(result))
