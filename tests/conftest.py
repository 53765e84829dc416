"""Fixtures shared by the test modules.  The session-scoped ones simulate and calibrate once per
run; their folders are read-only for the tests: a test that writes copies the files first
(``refusals.copy_inputs`` or ``shutil.copy`` into its own ``tmp_path``)."""
import pytest
from threadpoolctl import threadpool_limits

import once_per_run
from refusals import PLATE, copy_files, run_ok, write_refusal_inputs


# One BLAS thread in the test process, as robocal's command line runs (cli._one_blas_thread) and
# as a Dask worker does: the tests' fits are many small solves, which OpenBLAS's threads do not
# speed up, and on a busy 2-core machine (or with pytest-xdist's two workers) its idle threads
# spin: one Kriging test took 240 s with two threads and 7 s with one.  Set at import, before any
# test computes; subprocesses and Dask workers set their own.
_ONE_BLAS_THREAD = threadpool_limits(limits=1, user_api="blas")


def pytest_configure(config):
    # The session fixtures below (and user_files.base_files) are made once per run, not once
    # per pytest-xdist worker.
    once_per_run.share_between_workers(config)


@pytest.fixture(scope="session")
def ur5_files(tmp_path_factory):
    """A folder with meas.csv, 60 simulated UR5 poses (seed 1), and model.json, the kinematic
    model ``robocal calibrate`` fits to them."""
    def make(root):
        run_ok("simulate", "ur5", "--n", "60", "--seed", "1", "--out", root / "meas.csv")
        run_ok("calibrate", "ur5", root / "meas.csv", "--out", root / "model.json")
    return once_per_run.made_once("ur5", make, lambda: tmp_path_factory.mktemp("ur5"))


@pytest.fixture(scope="session")
def kr150_socket_files(tmp_path_factory):
    """A folder with sockets.csv, a KR 150-2's balls in the plate fixture's sockets (3
    placements, 6 configurations per socket), and cmodel.json, the constraint calibration
    ``robocal calibrate --method constraint`` fits to them."""
    def make(root):
        run_ok("simulate", "kr150-2", "--sampling", "sockets", "--fixture", PLATE, "--placements", "3",
               "--per-socket", "6", "--out", root / "sockets.csv")
        run_ok("calibrate", "kr150-2", root / "sockets.csv", "--method", "constraint", "--fixture", PLATE,
               "--out", root / "cmodel.json")
    return once_per_run.made_once("kr150_sockets", make, lambda: tmp_path_factory.mktemp("kr150_sockets"))


@pytest.fixture(scope="session")
def refusal_inputs(tmp_path_factory, ur5_files, kr150_socket_files):
    """The inputs every refusal table (tests/test_refusals_*.py) breaks: the UR5 and KR 150-2
    files above and their broken and legitimate variants (:func:`refusals.write_refusal_inputs`)."""
    def make(root):
        copy_files(ur5_files, root)
        copy_files(kr150_socket_files, root)
        write_refusal_inputs(root)
    return once_per_run.made_once("refusals", make, lambda: tmp_path_factory.mktemp("refusals"))


# The files that take longest, longest first (about 105 s down to 11 s on a quiet 2-core machine
# at eccff67): they are handed out first.  With --dist loadfile a file runs whole on one worker,
# and pytest-xdist's own order (most tests first) hands out the files of a few long tests
# (test_serve.py, test_report.py, test_network_cli.py) last, where one worker runs them while
# the other has nothing left.  The other files follow, most tests first, as pytest-xdist orders
# them; a file missing here only starts later, which costs time, never a test.  test_readme.py
# (its walkthrough, 44 s) runs only where the robocal command is installed, as in CI: started
# last there, it ran while the other worker had nothing left.
LONGEST_FIRST = ["test_fleet.py", "test_readme.py", "test_pipe_output.py", "test_failed_commands_leave_nothing.py",
                 "test_serve.py",
                 "test_small_campaigns.py", "test_training_poses_recognised.py", "test_report.py",
                 "test_parallel_fits.py", "test_network_cli.py", "test_wrong_kind_of_file.py", "test_bound.py",
                 "test_moved_bound.py", "test_cli_conventions.py", "test_unbounded_work.py"]


def pytest_collection_modifyitems(items):
    """The files in the order above (addopts: --no-loadscope-reorder); the tests of a file in
    their own order."""
    files = [item.path.name for item in items]
    count, first = {}, {}
    for k, name in enumerate(files):
        count[name] = count.get(name, 0) + 1
        first.setdefault(name, k)

    def key(k):
        name = files[k]
        rank = LONGEST_FIRST.index(name) if name in LONGEST_FIRST else len(LONGEST_FIRST)
        return rank, -count[name], first[name], k

    items[:] = [items[k] for k in sorted(range(len(items)), key=key)]
