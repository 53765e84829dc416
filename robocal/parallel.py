"""Run one function over many items: in this process, or on a Dask cluster.

``robocal fleet`` runs its robots through this module, and any part of robocal that has
independent pieces of work (the folds of a cross-validation, the starts of a search) can do
the same without knowing where they run::

    results = map_jobs(fit_fold, [{"fold": k, "measurements": path} for k in range(5)])

* With neither ``jobs`` nor ``scheduler`` the items run one after the other in this process,
  unless an :func:`executor` is active (``with executor(jobs=2): ...`` around a whole
  command), in which case they run on it.  Dask is not imported at all on that path.
* ``jobs=N`` starts a local Dask cluster of N worker processes (one thread each) that
  listens on 127.0.0.1 only, and closes it afterwards (also on Ctrl-C).
* ``scheduler="tcp://host:port"`` uses the workers of a running Dask scheduler.

What crosses to a worker is kept to plain data, so that nothing a user wrote is ever
unpickled on another machine and a worker needs nothing but robocal installed:

* ``function`` is a module-level function (found by its module and name: no lambdas,
  closures, methods or partials);
* every item and every result is built from None, bool, int, float, str, bytes, paths,
  NumPy numbers and arrays of numbers or text, and lists, tuples and dicts (with str keys)
  of these.  A model travels as the JSON text of its model file.

A task running on a worker sees no active executor, so a function that itself calls
:func:`map_jobs` runs its items serially there: work is spread once, never nested.

This module sits beside ``robocal.errors`` below every layer (it imports nothing of
robocal's but the errors), so that any layer may use it.
"""
from __future__ import annotations

import contextlib
import contextvars
import importlib
import inspect
import logging
import os
import shutil
import signal
import sys
import tempfile
import threading
from pathlib import PurePath

import numpy as np

from .errors import InputError

INSTALL_HINT = "pip install 'robocal[fleet]' (from a clone of robocal: pip install '.[fleet]')"
# How long a scheduler given by address may take to answer, and to have a worker.
CONNECT_SECONDS = 20
WORKER_WAIT_SECONDS = 20
# Array kinds that are data: booleans, integers, floats, complex numbers, text.
PLAIN_ARRAY_KINDS = "biufcSU"


def require_dask(what="this"):
    """Import dask.distributed, or raise InputError saying how to install it."""
    try:
        import dask.distributed as distributed
    except ImportError:
        raise InputError(f"{what} runs on Dask, which is not installed: {INSTALL_HINT}") from None
    return distributed


def check_function(function):
    """``function`` if a worker can find it by its module and name; else TypeError."""
    name = getattr(function, "__qualname__", None)
    module = getattr(function, "__module__", None)
    if not (inspect.isfunction(function) or inspect.isbuiltin(function)) or name is None or module is None:
        raise TypeError(f"map_jobs runs module-level functions only, not {function!r}")
    found = getattr(importlib.import_module(module), name, None) if "." not in name and "<" not in name else None
    if found is not function:
        raise TypeError(f"map_jobs runs module-level functions only: {module}.{name} is a lambda, a nested "
                        "function or a method; define it at the top of a module")
    return function


def check_plain(value, what="an item"):
    """``value`` if it is plain data (see the module docstring); else TypeError naming the
    offending part, so that no object of ours or a user's is ever pickled to a worker."""
    _check_plain(value, what)
    return value


def _check_plain(value, where):
    if value is None or isinstance(value, (bool, int, float, str, bytes, PurePath)):
        return
    if isinstance(value, np.generic) and value.dtype.kind in PLAIN_ARRAY_KINDS:
        return
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in PLAIN_ARRAY_KINDS:
            raise TypeError(f"{where} holds an array of {value.dtype} (objects): only numbers or text cross to workers")
        return
    if isinstance(value, (list, tuple)):
        for k, entry in enumerate(value):
            _check_plain(entry, f"{where}[{k}]")
        return
    if isinstance(value, dict):
        for key, entry in value.items():
            if not isinstance(key, str):
                raise TypeError(f"{where} has the key {key!r}: only text keys cross to workers")
            _check_plain(entry, f"{where}[{key!r}]")
        return
    raise TypeError(f"{where} is a {type(value).__name__}: only plain data (numbers, text, paths, arrays, "
                    "lists and dicts of them) cross to workers; send a model as its JSON text")


class Executor:
    """Where :meth:`map` runs its items: serially here (``client`` None) or on the workers
    of a Dask client.  Made by :func:`executor`; ``workers`` is how many run at once."""

    def __init__(self, client=None, description="this process"):
        self.client = client
        self.description = description

    @property
    def workers(self):
        if self.client is None:
            return 1
        return max(1, len(self.client.scheduler_info().get("workers", {})))

    def map(self, function, items, *, on_done=None, on_error=None):
        """``[function(item) for item in items]``, in the order of ``items``.

        ``on_done(index, result)`` is called as each item finishes (in the order they finish
        on a cluster).  An item whose function raises stops the whole map with that exception
        (the others are cancelled), unless ``on_error(index, exception)`` returns a result to
        put in its place; it also sees a worker that died under the item."""
        check_function(function)
        items = list(items)
        for index, item in enumerate(items):
            check_plain(item, f"item {index}")
        run = self._serial if self.client is None else self._distributed
        return run(function, items, on_done, on_error)

    def _finish(self, index, result, on_done):
        check_plain(result, f"the result of item {index}")
        if on_done is not None:
            on_done(index, result)
        return result

    def _serial(self, function, items, on_done, on_error):
        results = []
        for index, item in enumerate(items):
            try:
                result = function(item)
            except Exception as exc:
                if on_error is None:
                    raise
                result = on_error(index, exc)
            results.append(self._finish(index, result, on_done))
        return results

    def _distributed(self, function, items, on_done, on_error):
        from dask.distributed import as_completed

        run = f"{function.__name__}-{os.urandom(4).hex()}"  # the keys of this map's tasks on the scheduler
        futures = [self.client.submit(function, item, pure=False, key=f"{run}-{index}")
                   for index, item in enumerate(items)]
        index_of = {future.key: index for index, future in enumerate(futures)}
        results = [None] * len(items)
        try:
            for future in as_completed(futures):
                index = index_of[future.key]
                try:
                    result = future.result()
                except Exception as exc:
                    if on_error is None:
                        raise
                    result = on_error(index, exc)
                results[index] = self._finish(index, result, on_done)
        finally:
            pending = [future for future in futures if not future.done()]
            if pending:
                self.client.cancel(pending)
        return results


SERIAL = Executor()
_active = contextvars.ContextVar("robocal_executor", default=SERIAL)


def current():
    """The executor of the innermost active :func:`executor` block (serial outside one)."""
    return _active.get()


@contextlib.contextmanager
def executor(*, jobs=None, scheduler=None):
    """An :class:`Executor`, active in the block (:func:`map_jobs` without arguments uses it):
    serial with neither argument; a local cluster of ``jobs`` worker processes on 127.0.0.1;
    or the workers of the Dask scheduler at ``scheduler``.  A cluster it started is closed at
    the end of the block, also on an error or Ctrl-C."""
    if jobs is not None and scheduler is not None:
        raise InputError("give --jobs (a local cluster of that many workers) or --scheduler (an existing "
                         "cluster), not both")
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, (int, np.integer)) or jobs < 1):
        raise InputError(f"--jobs must be a whole number >= 1, got {jobs!r}")
    with contextlib.ExitStack() as stack:
        if jobs is None and scheduler is None:
            chosen = SERIAL
        elif scheduler is None:
            chosen = Executor(stack.enter_context(_local_client(int(jobs))), f"a local cluster of {jobs} workers")
        else:
            chosen = Executor(stack.enter_context(_remote_client(str(scheduler))), f"the Dask cluster at {scheduler}")
        token = _active.set(chosen)
        try:
            yield chosen
        finally:
            _active.reset(token)


@contextlib.contextmanager
def _local_client(jobs):
    """A Client of a new local cluster: ``jobs`` processes of one thread, every socket (the
    scheduler, the workers, their HTTP endpoints) on 127.0.0.1, no dashboard.  Its scratch
    space (Dask's ``dask-scratch-space``: lock files, a folder per worker) is a temporary
    folder of its own, removed when the cluster closes, on success, an error, Ctrl-C or
    SIGTERM alike: Dask's default, the system's temporary folder, is shared and kept."""
    distributed = require_dask("a local cluster")
    import dask

    scratch, cluster = tempfile.mkdtemp(prefix="robocal-dask-"), None
    try:
        # Dask starts its workers with MALLOC_TRIM_THRESHOLD_=65536 (to give memory back sooner).
        # Setting it at all fixes glibc's mmap threshold, so every large temporary array becomes a
        # fresh mapping with its page faults, and robocal's fits make many such arrays: compare on
        # the 1,000 UR5 poses took 96 s on one worker with it, 70 s without (63 s here).
        # Each worker runs this module's dask_setup as it starts (a Dask preload), which ignores
        # Ctrl-C there: a terminal sends it to the whole process group, and every worker would print
        # its own traceback; the command line answers it once and closes the cluster.  Ignoring it
        # here instead, for the children to inherit, would lose a Ctrl-C given while the cluster
        # starts.  That one is held until the cluster stands (_signals_held), then acted on, so
        # that the cluster is closed: stopped half-built, it left its workers and scratch behind.
        with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
                              "distributed.worker.preload": [__name__], "temporary-directory": scratch}), \
                _signals_held(), _stderr_to(os.path.join(scratch, "workers.log")):
            cluster = distributed.LocalCluster(
                n_workers=jobs, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
                scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}, silence_logs=logging.CRITICAL,
                local_directory=scratch)
        with distributed.Client(cluster) as client:
            yield client
    finally:
        if cluster is not None:
            cluster.close()
        shutil.rmtree(scratch, ignore_errors=True)


@contextlib.contextmanager
def _stderr_to(path):
    """File descriptor 2 goes to ``path`` in the block, for the processes started there to
    inherit: a local cluster's workers, which a terminal's Ctrl-C to the process group reaches
    while they still import Dask, before their preload ignores it, and which would each print
    that KeyboardInterrupt's traceback (the command line answers it once, held by
    _signals_held).  Their logs are silenced and their errors reach this process through
    their results; this process's own stderr is back when the block ends."""
    sys.stderr.flush()
    saved = os.dup(2)
    target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600)
    try:
        os.dup2(target, 2)
        yield
    finally:
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(saved)
        os.close(target)


@contextlib.contextmanager
def _signals_held():
    """Hold a SIGINT or SIGTERM that arrives in the block until it ends, then act on it as
    this process would have (its handler, e.g. the command line's interruption), whether the
    block succeeded or failed; a second one acts at once.  Outside the main thread (no signal
    arrives there) the block just runs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending, previous = [], {}

    def hold(signum, frame):
        pending.append(signum)
        signal.signal(signum, previous[signum])

    for number in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(number)
        if handler in (signal.SIG_IGN, None):  # ignored stays ignored; None: not Python's to hold
            continue
        previous[number] = handler
        signal.signal(number, hold)
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        # Also when the block failed: a Ctrl-C to the process group stops a worker that is still
        # starting, and the cluster's "Nanny failed to start" is that Ctrl-C's doing.
        if pending:
            signal.raise_signal(pending[0])


def dask_setup(worker):
    """Run by each worker of a local cluster as it starts (see :func:`_local_client`): Ctrl-C is
    ignored in the worker process, whose main thread runs this."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _remote_client(address):
    """A Client of the scheduler at ``address`` with at least one worker that runs this
    version of robocal; InputError in one line otherwise."""
    distributed = require_dask("--scheduler")
    try:
        client = distributed.Client(address, timeout=CONNECT_SECONDS)
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"cannot reach the Dask scheduler at {address} ({_first_line(exc)}): start one with "
                         "'dask scheduler' and give the address it prints, e.g. tcp://127.0.0.1:8786") from None
    with client:
        try:
            client.wait_for_workers(1, timeout=WORKER_WAIT_SECONDS)
        except (OSError, TimeoutError) as exc:
            raise InputError(f"the Dask scheduler at {address} has no workers ({_first_line(exc)}): start some "
                             f"with 'dask worker {address}'") from None
        _check_workers(client, address)
        yield client


def robocal_version():
    """This process's robocal version (asked of every worker of a scheduler given by address)."""
    from . import __version__

    return __version__


def _check_workers(client, address):
    """Every worker imports robocal, the same version as here."""
    from . import __version__

    try:
        versions = client.run(robocal_version)
    except Exception as exc:  # a worker without robocal fails to unpickle the function
        raise InputError(f"the workers of the Dask cluster at {address} cannot run robocal ({_first_line(exc)}): "
                         f"install robocal {__version__} where they run") from None
    other = {worker: v for worker, v in versions.items() if v != __version__}
    if other:
        listed = ", ".join(f"{worker} has {v}" for worker, v in sorted(other.items()))
        raise InputError(f"the workers of the Dask cluster at {address} must run robocal {__version__}, as here: "
                         f"{listed}")


def _first_line(exc):
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


def map_jobs(function, items, *, jobs=None, scheduler=None, on_done=None, on_error=None):
    """``[function(item) for item in items]`` on the executor the arguments name (see
    :func:`executor`; with neither, the active one, else serially here).  See
    :meth:`Executor.map` for ``on_done`` and ``on_error``."""
    if jobs is None and scheduler is None:
        return current().map(function, items, on_done=on_done, on_error=on_error)
    with executor(jobs=jobs, scheduler=scheduler) as chosen:
        return chosen.map(function, items, on_done=on_done, on_error=on_error)
