"""Progress on long runs: a rich bar on a terminal, nothing in a pipe or with --json."""
import contextlib
import sys


@contextlib.contextmanager
def progress(description, total=None, *, enabled=True):
    """Yield ``advance(steps=1, **fields)``; a bar on stderr when it is a terminal and
    ``enabled`` (False for --json), else a function that does nothing.  ``fields`` are shown
    after the bar (e.g. best=...)."""
    if not (enabled and sys.stderr.isatty()):
        yield lambda steps=1, **fields: None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    columns = [TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
               TextColumn("{task.fields[info]}")]
    with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(description, total=total, info="")

        def advance(steps=1, **fields):
            info = "  ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in fields.items())
            bar.update(task, advance=steps, info=info)

        yield advance
