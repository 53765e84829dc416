"""The ``robocal`` command line.

Every error a user can cause is a :class:`~robocal.errors.RobocalError`; it is printed as one
line and the command exits with status 2.  ``--debug`` shows the traceback instead.
"""
import functools
import json
import sys
import warnings

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from ..errors import RobocalError, RobocalWarning

app = typer.Typer(
    help="robocal: calibrate industrial robots and compensate their positioning errors.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
out = Console(highlight=False, soft_wrap=True)
err = Console(stderr=True, highlight=False, soft_wrap=True)
_state = {"debug": False}


def _show_warning(message, category, filename, lineno, file=None, line=None):
    if issubclass(category, RobocalWarning):
        err.print(f"[yellow]warning:[/] {message}")
    else:
        err.print(f"warning: {category.__name__}: {message}")


def user_errors(func):
    """Turn RobocalError into one line on stderr and exit status 2."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except RobocalError as exc:
            if _state["debug"]:
                raise
            err.print(f"[red]error:[/] {exc}")
            raise typer.Exit(2) from None

    return wrapper


@app.callback()
def _main(debug: bool = typer.Option(False, "--debug", help="Show tracebacks of errors.")):
    _state["debug"] = debug


@app.command()
@user_errors
def robots():
    """List the built-in robots.

    Example: robocal robots
    """
    from ..io.library import builtin, builtin_description, builtin_names

    table = Table("name", "joints", "model", "description")
    for name in builtin_names():
        chain = builtin(name)
        table.add_row(name, str(chain.n_joints), chain.convention.upper(), builtin_description(name))
    out.print(table)


@app.command()
@user_errors
def show(
    robot: str = typer.Argument(..., help="Built-in name, robot .toml or .urdf file."),
    tip: str = typer.Option(None, help="URDF only: the tip link."),
    root: str = typer.Option(None, help="URDF only: the root link."),
):
    """Print a robot's parameter table (mm, deg), frames and joint limits.

    Example: robocal show kr150-2
    """
    from ..io.library import load_robot
    from .tables import robot_tables

    chain = load_robot(robot, root=root, tip=tip)
    for renderable in robot_tables(chain):
        out.print(renderable)


@app.command()
@user_errors
def demo(
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object instead of tables."),
    n: int = typer.Option(10000, help="Number of random configurations."),
    seed: int = typer.Option(0, help="Random seed."),
):
    """Run the reference job on built-in data (KUKA KR 150-2) and print what it measured.

    Forward kinematics of random configurations, closed-form inverse kinematics of every
    branch, numerical IK on a perturbed model, with round-trip errors and throughput.

    Example: robocal demo --json
    """
    from .demo import run_demo, demo_tables

    result = run_demo(n=n, seed=seed)
    if as_json:
        print(json.dumps(result, indent=2))
    else:
        for renderable in demo_tables(result):
            out.print(renderable)


def main():
    """Console entry point."""
    warnings.showwarning = _show_warning
    np.seterr(all="ignore")  # NaNs are checked explicitly where they matter
    try:
        app()
    except KeyboardInterrupt:
        err.print("interrupted")
        sys.exit(130)


if __name__ == "__main__":
    main()
