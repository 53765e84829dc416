"""The ``robocal`` command line (the script runs :func:`robocal.entry.main`, which starts it).

* :mod:`.app`: the typer app, one-line errors, Ctrl-C and SIGTERM, the entry point;
* :mod:`.options`: the options generated from the methods' settings and those commands share;
* :mod:`.rendering`: every result printed (tables, JSON);
* one module per group of commands: :mod:`.info` (robots, show, methods, dataset, demo),
  :mod:`.plan` (simulate, design), :mod:`.fit` (calibrate, compare, validate), :mod:`.use`
  (evaluate, compensate, filter, serve, report, export), :mod:`.metrology` (import, iso9283) and
  :mod:`.fleet`.

A new command goes in the module of its group, decorated with :func:`.app.verb`, and its
name in :data:`.app.COMMAND_ORDER` (the order --help lists it in).
"""
from . import fit, fleet, info, metrology, plan, use  # noqa: F401  (each module registers its commands)
from .app import THREAD_VARIABLES, Interrupted, app, interruptible, main, user_errors
from .app import _one_blas_thread  # noqa: F401  (where it was before the package)

__all__ = ["THREAD_VARIABLES", "Interrupted", "app", "interruptible", "main", "user_errors"]
