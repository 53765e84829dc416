"""The one check every table of hostile command lines applies: the command is refused with a
non-zero exit and one error line (plus at most the usage hint), no traceback, no file left
behind (no ``.tmp`` either) and no input rewritten; and its counterpart, :func:`run_ok`, for
the command lines that must succeed."""
import shutil
import warnings

from typer.testing import CliRunner

from robocal.interfaces.cli import app

runner = CliRunner()


def run_ok(*args):
    """Run ``robocal ARGS`` (each turned into text); assert it exits with 0; the result."""
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result


def copy_inputs(files, folder, monkeypatch):
    """Copy the prepared inputs into a fresh ``folder`` and work there; returns their
    modification times, to tell a rewritten input from an untouched one."""
    for path in files.iterdir():
        (shutil.copytree if path.is_dir() else shutil.copy)(path, folder / path.name)
    monkeypatch.chdir(folder)
    return {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}


def assert_refused(args, says, folder, before):
    """Run ``args`` in ``folder`` (prepared by :func:`copy_inputs`) and check the refusal;
    ``says`` must stand in the error line."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # warnings are the CLI's business, not the tables'
        result = runner.invoke(app, args)
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code != 0, result.output
    assert "Traceback" not in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    errors = [line for line in lines if line.lower().lstrip("│ ").startswith("error")]
    assert len(errors) == 1 and len(lines) <= 2, result.output
    assert says in errors[0], result.output
    after = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    assert set(after) == set(before), f"left behind: {set(after) - set(before)}"
    assert after == before, "an input file was rewritten"
