"""The ``robocal`` script's entry point (and ``python -m robocal``'s).

The command line imports NumPy, SciPy and typer before it can install its own signal
handling (:func:`robocal.interfaces.cli.app.interruptible`): a second or more on a busy
machine.  A Ctrl-C or SIGTERM in that time ends the process here with one line and the
usual status (130, 143), instead of a ``KeyboardInterrupt`` traceback from an import.
Nothing is read or written before the command line takes over.
"""
import signal
import sys


def _interrupted_while_starting(signum, frame):
    sys.stderr.write("interrupted\n")
    raise SystemExit(128 + signum)


def main():
    """Console entry point: quiet signals while starting, then the command line."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        # A signal the parent ignores (a background job of a script) stays ignored.
        if signal.getsignal(signum) is not signal.SIG_IGN:
            signal.signal(signum, _interrupted_while_starting)
    from .interfaces.cli import main as command_line

    command_line()
