"""The ``robocal`` command line: the typer app, its error handling and its interruptions.

Every error a user can cause is a :class:`~robocal.errors.RobocalError`; it is printed as one
line and the command exits with status 2.  ``--debug`` (before or after the command) shows the
traceback instead.  A value the command line itself refuses (a wrong choice, a bad number, a
missing argument) is also one line and status 2.  Ctrl-C and SIGTERM stop a command cleanly
(no half-written file, see :mod:`robocal.io.atomic`), print one line and exit with status 130
and 143.
"""
import contextlib
import functools
import inspect
import os
import signal
import sys
import warnings

import numpy as np
import typer
from rich.table import Table
from rich.text import Text
from typer import rich_utils
from typer.core import TyperCommand, TyperGroup

from ... import __version__
from ...errors import RobocalError, RobocalWarning
from ...io.atomic import outputs_together
from .options import Refused
from .rendering import before_result, err, out, say

# typer.BadParameter is click's; its bases are the errors click raises while parsing.
UsageError = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")
# The commands in the order --help lists them (each module of this package adds its own).
COMMAND_ORDER = ("robots", "show", "simulate", "methods", "calibrate", "evaluate", "compensate", "filter", "serve",
                 "report", "export", "compare", "validate", "dataset", "design", "import", "iso9283", "demo", "fleet")


def _plain_flags(params):
    """Show on/off options as flags (``--json``), not with a value type (``--json <bool>``)."""
    for param in params:
        if getattr(param, "is_flag", False) and getattr(param, "metavar", None) is None:
            param.metavar = ""
    return params


def _longest_word(renderable):
    """The length of the longest word of a cell of --help (a Text, typer's Columns of them,
    Markdown or a string)."""
    if hasattr(renderable, "renderables"):  # typer's help cell: Columns of texts
        return max((_longest_word(item) for item in renderable.renderables), default=0)
    text = getattr(renderable, "plain", getattr(renderable, "markup", renderable))
    return max((len(word) for word in str(text).split()), default=0) if isinstance(text, str) else 0


class _HelpTable(Table):
    """The tables of --help (typer builds them through ``rich_utils.Table``): the columns that
    name options, arguments and commands never wrap, so that a narrow terminal (an 80-column
    log) shrinks the type and help columns and never cuts a name short with "…";
    and the help column gives the type column the width of its longest choice when it can
    keep its own longest word ("full+compliance+gain s" was broken).  Where even that leaves
    a name, a choice or a word of help broken (calibrate's 13 parameter sets, a 60-column
    terminal), the names and the type go in one column, the type under the names, as wide as
    its longest word, and the help takes the rest.  An options
    row is [required marker,] long names, short names, their negations, type, help; a
    commands row is name, help."""

    _stacked = False

    def add_row(self, *renderables, **kwargs):
        super().add_row(*renderables, **kwargs)
        count = len(renderables)
        names = range(count - 2) if count >= 6 else range(1) if count == 2 else ()
        for column in names:
            self.columns[column].no_wrap = True

    def _longest(self, column):
        return max((_longest_word(cell) for cell in self.columns[column].cells), default=0) + \
            self._get_padding_width(column)

    def _calculate_column_widths(self, console, options):
        widths = super()._calculate_column_widths(console, options)
        if len(widths) >= 6 and self.columns and not self._stacked:
            kind, help_ = len(widths) - 2, len(widths) - 1
            longest = [self._longest(c) for c in range(len(widths))]
            need = longest[kind] - widths[kind]
            if need > 0 and widths[help_] - need >= longest[help_]:
                widths[kind] += need
                widths[help_] -= need
            if any(width < need for width, need in zip(widths, longest)):
                self._stack(kind)
                return super()._calculate_column_widths(console, options)
        return widths

    def _stack(self, kind):
        """One column of names in place of the four (long, short, negations) and the type:
        a row's names joined by " / ", its type on the next line; as wide as its longest word,
        wrapped between words."""
        self._stacked = True
        columns, first = self.columns, kind - 4
        for row in range(len(columns[kind]._cells)):
            cells = [columns[c]._cells[row] for c in range(first, kind)]
            names = Text(" / ").join([cell for cell in cells if _longest_word(cell)])
            type_cell = columns[kind]._cells[row]
            columns[first]._cells[row] = Text.assemble(names, "\n", type_cell) if _longest_word(type_cell) else names
        for column in range(kind, first, -1):
            del columns[column]
        columns[first].no_wrap = False
        columns[first].width = self._longest(first) - self._get_padding_width(first)


# Every command's help is drawn by typer's rich_utils: one change covers them all.
rich_utils.Table = _HelpTable


class _Command(TyperCommand):
    def get_params(self, ctx):
        return _plain_flags(super().get_params(ctx))


class _App(TyperGroup):
    """The ``robocal`` group: usage errors (a wrong choice, a missing argument) are one line."""

    def get_params(self, ctx):
        return _plain_flags(super().get_params(ctx))

    def list_commands(self, ctx):
        listed = super().list_commands(ctx)
        return sorted(listed, key=lambda name: COMMAND_ORDER.index(name) if name in COMMAND_ORDER else len(listed))

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except UsageError as exc:
            if not standalone_mode:
                raise
            _usage_error(exc)
            sys.exit(exc.exit_code)
        except typer.Abort:
            if not standalone_mode:
                raise
            err.print("aborted")
            sys.exit(1)
        if not standalone_mode:
            return code
        sys.exit(code if isinstance(code, int) else 0)


def _usage_error(exc):
    """One line: the option or argument, what it must be; other usage errors add the usage."""
    if type(exc).__name__ == "NoArgsIsHelpError":  # the help has been shown
        return
    param = getattr(exc, "param", None)
    if isinstance(exc, Refused) and param is not None:
        say("error", "red", f"{_param_label(param)} {exc.message}")
        return
    if isinstance(exc, typer.BadParameter) and param is not None and type(exc) is typer.BadParameter:
        message = exc.message[:1].lower() + exc.message[1:]
        say("error", "red", f"{_param_label(param)}: {message.rstrip('.')}")
        return
    message = exc.format_message()
    say("error", "red", message[:1].lower() + message[1:].rstrip("."))
    ctx = getattr(exc, "ctx", None)
    if ctx is not None:
        err.print(f"{ctx.get_usage()}  (see '{ctx.command_path} --help')")


def _param_label(param):
    """How the user wrote it: the long option, or the argument's name."""
    names = [opt for opt in param.opts if opt.startswith("--")] or list(param.opts)
    if getattr(param, "param_type_name", "") == "option" and names:
        return names[0]
    return param.name or "the value"


app = typer.Typer(
    cls=_App,
    help="robocal: calibrate industrial robots and compensate their positioning errors.\n\n"
         "Try: robocal demo; robocal calibrate ur5 meas.csv --out model.json; "
         "robocal report model.json test.csv --out report.html",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="markdown",  # reflow docstring paragraphs in --help
)
command = functools.partial(app.command, cls=_Command)
_state = {"debug": False}


# The warnings the running command has printed: the same warning raised again (by every fold
# of a comparison, every robot of a fleet run here) is printed once.
_warned = set()


def _show_warning(message, category, filename, lineno, file=None, line=None):
    key = (category, str(message))
    if key in _warned:
        return
    _warned.add(key)
    if issubclass(category, RobocalWarning):
        say("warning", "yellow", message)
    else:
        err.print(f"warning: {category.__name__}: {message}")


@contextlib.contextmanager
def held_warnings():
    """Hold the warnings raised in the body until its data are accepted: until the first
    line of its result is printed (:func:`robocal.interfaces.cli.rendering.before_result`)
    or the body ends without an error.  A body that ends in an error (a refusal) or an
    interruption drops them: a warning about data that are then refused is not printed
    before the refusal (a reader's "rows 2..41 are identical", then "1 distinct pose"), the
    refusal is the one line.  Warnings raised after the release are shown as they come."""
    shown = warnings.showwarning
    held, state = [], {"released": False}

    def hold(message, category, filename, lineno, file=None, line=None):
        if state["released"]:
            shown(message, category, filename, lineno, file, line)
        else:
            held.append((message, category, filename, lineno, file, line))

    def release():
        state["released"] = True
        while held:
            shown(*held.pop(0))

    warnings.showwarning = hold
    before_result(release)
    try:
        yield
    except typer.Exit:  # a status of the command's own (fleet: a robot failed): its results stand
        release()
        raise
    else:
        release()
    finally:
        held.clear()
        if warnings.showwarning is hold:
            warnings.showwarning = shown
        state["released"] = True


# --------------------------------------------------------------------------- errors and interruptions
DEBUG = typer.Option(False, "--debug", help="Show tracebacks of errors.")


def verb(*args, hold_warnings=True, **kwargs):
    """Decorator of a command: registered on the app, its user errors one line
    (:func:`user_errors`), its warnings held until its data are accepted
    (:func:`held_warnings`; ``hold_warnings=False`` for a command that runs until stopped)."""
    def decorate(func):
        command(*args, **kwargs)(user_errors(func, hold_warnings))
        return func

    return decorate


def user_errors(func, hold_warnings=False):
    """Turn RobocalError (and a system's refusal of a file) into one line on stderr and exit
    status 2; add ``--debug`` to the command (it is also accepted before the command).  The
    command's outputs are one unit (:func:`robocal.io.atomic.outputs_together`): a command
    that fails or is interrupted leaves none of the files or folders it wrote; one that
    exits with a status of its own (fleet: a robot failed) keeps them."""

    @functools.wraps(func)
    def wrapper(*args, debug=False, **kwargs):
        if debug:
            _state["debug"] = True
        _warned.clear()  # once per command: a command run again (in one process) warns again
        try:
            with held_warnings() if hold_warnings else contextlib.nullcontext(), \
                    outputs_together(keep_on=(typer.Exit,)):
                return func(*args, **kwargs)
        except RobocalError as exc:
            if _state["debug"]:
                raise
            say("error", "red", exc)
            raise typer.Exit(2) from None
        except OSError as exc:  # a file the system would not read or write: the user's to fix
            if _state["debug"]:
                raise
            where = f" {exc.filename}" if exc.filename else ""
            say("error", "red", f"cannot use{where}: {exc.strerror or exc}; check the path and its permissions")
            raise typer.Exit(2) from None

    signature = inspect.signature(func)
    debug = inspect.Parameter("debug", inspect.Parameter.KEYWORD_ONLY, default=DEBUG, annotation=bool)
    wrapper.__signature__ = signature.replace(parameters=[*signature.parameters.values(), debug])
    wrapper.__annotations__ = {**func.__annotations__, "debug": bool}
    return wrapper


class Interrupted(SystemExit):
    """SIGINT (Ctrl-C) or SIGTERM: raised in the running code so that it unwinds like any
    error (an atomic write removes its temporary file); exit status 128 + the signal."""

    def __init__(self, signum):
        super().__init__(128 + signum)
        self.signum = signum


def _raise_interrupted(signum, frame):
    raise Interrupted(signum)


@contextlib.contextmanager
def interruptible():
    """Run the body with SIGINT and SIGTERM turned into :class:`Interrupted`; on one, print
    one line (which file was left as it was) and exit with status 130 (SIGINT) / 143 (SIGTERM)."""
    # A signal the parent ignores (Ctrl-C for a background job of a script) stays ignored.
    signals = [s for s in (signal.SIGINT, signal.SIGTERM) if signal.getsignal(s) is not signal.SIG_IGN]
    previous = {s: signal.signal(s, _raise_interrupted) for s in signals}
    try:
        yield
    except (Interrupted, KeyboardInterrupt) as exc:
        for s in signals:  # a second signal while reporting the first just ends the process
            signal.signal(s, signal.SIG_DFL)
        unwritten = getattr(exc, "unwritten_file", None)
        if unwritten is None:
            err.print("interrupted")
        elif unwritten.exists():
            say("interrupted", "yellow", f"{unwritten} was left as it was")
        else:
            say("interrupted", "yellow", f"nothing was written to {unwritten}")
        sys.exit(exc.code if isinstance(exc, Interrupted) else 128 + signal.SIGINT)
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _print_version(value: bool):
    if value:
        out.print(f"robocal {__version__}")
        raise typer.Exit()


@app.callback()
def _main(debug: bool = DEBUG,
          version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                       help="Print the version and exit.")):
    _state["debug"] = debug


# Variables by which a user sets how many threads the linear algebra library runs.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


def _one_blas_thread():
    """Limit the linear algebra library (OpenBLAS, MKL) to one thread unless the user set how
    many it runs.  robocal's fits are many small solves (a Kriging search, one calibration per
    fold), which threads do not speed up, and on a machine whose cores are busy the library's
    threads wait for each other: ``compare`` on 200 UR5 poses took 137 s with OpenBLAS's
    default threads on a loaded 2-core machine and 8 s with one.  Parallel work is --jobs."""
    if any(name in os.environ for name in THREAD_VARIABLES):
        return None
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def main():
    """Console entry point."""
    warnings.showwarning = _show_warning
    np.seterr(all="ignore")  # NaNs are checked explicitly where they matter
    _one_blas_thread()
    with interruptible():
        app()

