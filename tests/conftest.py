"""Fixtures shared by the test modules.  The session-scoped ones simulate and calibrate once per
run; their folders are read-only for the tests: a test that writes copies the files first
(``refusals.copy_inputs`` or ``shutil.copy`` into its own ``tmp_path``)."""
import pytest
from threadpoolctl import threadpool_limits

from refusals import PLATE, copy_files, run_ok, write_refusal_inputs


# One BLAS thread in the test process, as robocal's command line runs (cli._one_blas_thread) and
# as a Dask worker does: the tests' fits are many small solves, which OpenBLAS's threads do not
# speed up, and on a busy 2-core machine (or with pytest-xdist's two workers) its idle threads
# spin: one Kriging test took 240 s with two threads and 7 s with one.  Set at import, before any
# test computes; subprocesses and Dask workers set their own.
_ONE_BLAS_THREAD = threadpool_limits(limits=1, user_api="blas")


@pytest.fixture(scope="session")
def ur5_files(tmp_path_factory):
    """A folder with meas.csv, 60 simulated UR5 poses (seed 1), and model.json, the kinematic
    model ``robocal calibrate`` fits to them."""
    root = tmp_path_factory.mktemp("ur5")
    run_ok("simulate", "ur5", "--n", "60", "--seed", "1", "--out", root / "meas.csv")
    run_ok("calibrate", "ur5", root / "meas.csv", "--out", root / "model.json")
    return root


@pytest.fixture(scope="session")
def kr150_socket_files(tmp_path_factory):
    """A folder with sockets.csv, a KR 150-2's balls in the plate fixture's sockets (3
    placements, 6 configurations per socket), and cmodel.json, the constraint calibration
    ``robocal calibrate --method constraint`` fits to them."""
    root = tmp_path_factory.mktemp("kr150_sockets")
    run_ok("simulate", "kr150-2", "--sampling", "sockets", "--fixture", PLATE, "--placements", "3",
           "--per-socket", "6", "--out", root / "sockets.csv")
    run_ok("calibrate", "kr150-2", root / "sockets.csv", "--method", "constraint", "--fixture", PLATE,
           "--out", root / "cmodel.json")
    return root


@pytest.fixture(scope="session")
def refusal_inputs(tmp_path_factory, ur5_files, kr150_socket_files):
    """The inputs every refusal table (tests/test_refusals_*.py) breaks: the UR5 and KR 150-2
    files above and their broken and legitimate variants (:func:`refusals.write_refusal_inputs`)."""
    root = tmp_path_factory.mktemp("refusals")
    copy_files(ur5_files, root)
    copy_files(kr150_socket_files, root)
    write_refusal_inputs(root)
    return root
