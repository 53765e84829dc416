"""Progress of a long command where no one watches a bar: a pipe, a log file, a CI job.

On a terminal :func:`robocal.interfaces.cli.rendering.progress` draws a bar; elsewhere it
delegates here.  A bar redrawn in place is a stream of carriage returns and escape codes
in a log, and nothing at all is worse (a ``compare`` that runs for minutes looks hung), so
this writes plain lines to stderr: the first once the command has run for
:data:`FIRST_LINE_SECONDS`, then one every :data:`INTERVAL_SECONDS` at most, and a last one
when a run that printed any ends.  A heartbeat (a thread that wakes every
:data:`HEARTBEAT_SECONDS`) writes the line due even while the command is inside one long step
that reports nothing (a fit, a design's selection).  Each line is printable text of at most
:data:`WIDTH` characters (an 80-column log), and a line that says nothing new (only the
elapsed time moved) is printed once, then again at most every :data:`QUIET_SECONDS`, so
that a log still shows the command alive.
"""
from __future__ import annotations

import contextlib
import re
import sys
import threading
import time

# A short command prints no progress at all; a long one says it is alive this soon.
FIRST_LINE_SECONDS = 5.0
# One line every few seconds: enough to see a command move, few enough to read a log.
INTERVAL_SECONDS = 5.0
# A line that says nothing new is repeated no more often than this.
QUIET_SECONDS = 60.0
# How often the heartbeat looks whether a line is due (it prints by the rules above).
HEARTBEAT_SECONDS = 1.0
# Lines fit an 80-column log (the last column left free: some terminals wrap on it).
WIDTH = 79
# Escape sequences (colours, cursor moves) and control characters: nothing of them in a log.
_CONTROL = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]|[\x00-\x1f\x7f]")


def _shown(value):
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def plain(text):
    """``text`` without escape sequences and control characters (each becomes one space)."""
    return re.sub(r" {2,}", " ", _CONTROL.sub(" ", str(text))).strip()


DONE = " done"


class PlainProgress:
    """The line writer: :meth:`advance` counts steps and keeps ``fields`` (shown after the
    count, e.g. ``best 0.0123``), :meth:`finish` writes the last line.  ``clock`` gives
    seconds (a test passes its own)."""

    def __init__(self, description, total=None, stream=None, clock=None):
        self.description, self.total = plain(description), total
        self.stream = sys.stderr if stream is None else stream
        self.clock = time.monotonic if clock is None else clock
        self.start = self.clock()
        self.done, self.fields = 0, {}
        self.last_time, self.last_said, self.lines = None, None, 0
        # The heartbeat's thread and the command's both write: one at a time.
        self._lock = threading.Lock()

    def advance(self, steps=1, **fields):
        with self._lock:
            self.done += steps
            self.fields.update(fields)
            self._maybe_write(final=False)

    def tick(self):
        """Write the line due now, if one is (the heartbeat's call)."""
        with self._lock:
            self._maybe_write(final=False)

    def finish(self):
        with self._lock:
            if self.lines:
                self._maybe_write(final=True)

    def line(self, final=False):
        """What the writer would print now (without the elapsed time), and with it."""
        # A command that reports stages, not steps, has no count to show.
        count = f" {self.done}" + (f" of {self.total}" if self.total else "") if self.done or self.total else ""
        fields = "  ".join(f"{plain(key)} {plain(_shown(value))}" for key, value in self.fields.items())
        said = f"{self.description}:{count}" + ((" " if not count else "  ") + fields if fields else "")
        elapsed = f" ({self.clock() - self.start:.0f} s)" + (DONE if final else "")
        if len(said) + len(elapsed) > WIDTH:
            said = said[:WIDTH - len(elapsed) - 3].rstrip() + "..."
        return said, said + elapsed

    def _maybe_write(self, final):
        now = self.clock()
        if not final:
            if now - self.start < FIRST_LINE_SECONDS:
                return
            if self.last_time is not None and now - self.last_time < INTERVAL_SECONDS:
                return
        said, text = self.line(final)
        if said == self.last_said and (final or now - self.last_time < QUIET_SECONDS):
            return
        print(text, file=self.stream, flush=True)
        self.last_time, self.last_said, self.lines = now, said, self.lines + 1


def _is_file(stream):
    """Whether ``stream`` writes to a file descriptor (a pipe, a file, a terminal)."""
    try:
        stream.fileno()
    except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is both of the last two
        return False
    return True


@contextlib.contextmanager
def plain_progress(description, total=None, stream=None):
    """Yield ``advance(steps=1, **fields)`` writing :class:`PlainProgress` lines to
    ``stream`` (stderr) when it is a file descriptor (a pipe, a log file; not a stream
    captured in-process, such as a test runner's); the last line when the block ends without
    an error."""
    stream = sys.stderr if stream is None else stream
    if not _is_file(stream):  # a stream captured in-process (a test's runner): no log to keep alive
        yield lambda steps=1, **fields: None
        return
    writer = PlainProgress(description, total, stream)
    stop = threading.Event()

    def beat():
        while not stop.wait(HEARTBEAT_SECONDS):
            writer.tick()

    heartbeat = threading.Thread(target=beat, name="robocal-progress", daemon=True)
    heartbeat.start()
    try:
        yield writer.advance
        stop.set()
        heartbeat.join()
        writer.finish()
    finally:
        stop.set()
