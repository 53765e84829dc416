"""The ``robocal`` script's entry point (and ``python -m robocal``'s).

The command line imports NumPy, SciPy and typer before it can install its own signal
handling (:func:`robocal.interfaces.cli.app.interruptible`): a second or more on a busy
machine.  A Ctrl-C or SIGTERM in that time ends the process here with one line and the
usual status (130, 143), instead of a ``KeyboardInterrupt`` traceback from an import.
Nothing is read or written before the command line takes over.

The standard streams are made safe for what a user pipes them into first
(:func:`_forgiving_streams`): a reader that stops early (``robocal calibrate ... | head -1``)
must not cost the model being written, and a terminal or log without UTF-8 (``LC_ALL=C``)
must not turn a degree sign into a traceback.
"""
import signal
import sys


def _interrupted_while_starting(signum, frame):
    sys.stderr.write("interrupted\n")
    raise SystemExit(128 + signum)


class _ReaderGone:
    """Standard output whose reader may close it (``| head``): the first broken pipe sends
    the rest of the printing to nowhere, so that the command goes on and writes its files,
    as it would with its output redirected to a file."""

    def __init__(self, stream):
        self._stream = stream
        self._gone = False

    def write(self, text):
        if not self._gone:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._gone = True
        return len(text)

    def flush(self):
        if not self._gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._gone = True

    def __getattr__(self, name):  # encoding, isatty, fileno, ... of the real stream
        return getattr(self._stream, name)


def _forgiving_streams():
    """Characters the stream's encoding lacks (°, σ, box lines under ``LC_ALL=C``) are
    replaced rather than raised; a closed standard output stops the printing, not the
    command."""
    for stream in (sys.stdout, sys.stderr):
        encoding = (getattr(stream, "encoding", None) or "").lower().replace("-", "")
        if not encoding.startswith("utf") and hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="replace")
    sys.stdout = _ReaderGone(sys.stdout)


def main():
    """Console entry point: quiet signals while starting, then the command line."""
    _forgiving_streams()
    for signum in (signal.SIGINT, signal.SIGTERM):
        # A signal the parent ignores (a background job of a script) stays ignored.
        if signal.getsignal(signum) is not signal.SIG_IGN:
            signal.signal(signum, _interrupted_while_starting)
    from .interfaces.cli import main as command_line

    command_line()
