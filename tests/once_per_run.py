"""Folders of files made once per test run.  Under pytest-xdist the workers of one run share
them: the first worker that needs a folder makes it in the run's temporary folder while the
others wait on a lock, then they all read the same files (the folders are read-only for the
tests).  Alone (``pytest -n 0``), or where there are no file locks, each process makes its own."""
import shutil
from pathlib import Path

try:
    import fcntl
except ImportError:  # no flock: each worker makes its own folders, as before
    fcntl = None

_shared = None  # the temporary folder of the run, which every worker's own folder is in


def share_between_workers(config):
    """Called by conftest.pytest_configure: on a pytest-xdist worker, whose ``--basetemp`` is a
    folder of the run's, share the run's folder."""
    global _shared
    if hasattr(config, "workerinput") and config.option.basetemp and fcntl is not None:
        _shared = Path(config.option.basetemp).resolve().parent


def made_once(name, make, new_folder):
    """The folder ``name`` after ``make(folder)`` wrote its files, once per run; ``new_folder()``
    gives a new empty folder of this process's when it is not shared.  A ``make`` that fails
    leaves no mark: the next worker to ask tries again (and fails the same way)."""
    if _shared is None:
        folder = new_folder()
        make(folder)
        return folder
    folder, done = _shared / name, _shared / f"{name}.done"
    with open(_shared / f"{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not done.exists():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            make(folder)
            done.touch()
    return folder
