"""The folds of compare and validate on a Dask cluster (--jobs, --scheduler): the same
figures as one fit after the other here, plain data across, and the command line's options.
The fleet's own cluster tests are in tests/test_fleet.py; the speed-up is bench/fleet.py's."""
import json

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from robocal import parallel
from robocal.interfaces import cli
from robocal.io.fixtures import Fixture
from robocal.io.library import load_robot
from robocal.io.observations import Observations
from robocal.io.tables import write_measurements
from robocal.methods import make_method, selection
from robocal.methods.validation import cross_validate
from robocal.simulation import make_true_robot
from robocal.simulation.sampling import uniform_joints

from refusals import assert_refused, copy_inputs, run_ok

pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def robot():
    """A UR5 with the typical errors and 100 configurations uniform in joint space."""
    chain = load_robot("ur5")
    return chain, make_true_robot(chain, "typical", seed=5), uniform_joints(chain, 100, np.random.default_rng(5))


@pytest.fixture(scope="module")
def ur5(robot):
    chain, truth, q = robot
    return chain, truth.observations(q, np.random.default_rng(6))


@pytest.fixture(scope="module")
def cluster():
    """A local cluster of two workers, shared by the module's tests."""
    with parallel.executor(jobs=2) as running:
        yield running


def _fields(score):
    return {key: value for key, value in vars(score).items() if key != "fit_seconds"}


def test_chain_and_observations_cross_as_plain_data_exactly(ur5):
    chain, obs = ur5
    parallel.check_plain(chain.to_plain())
    parallel.check_plain(obs.to_plain())
    again = type(chain).from_plain(chain.to_plain())
    np.testing.assert_array_equal(again.fk_positions(obs.joints), chain.fk_positions(obs.joints))
    back = Observations.from_plain(obs.to_plain())
    np.testing.assert_array_equal(back.joints, obs.joints)
    np.testing.assert_array_equal(back.positions, obs.positions)
    fixture = Fixture("plate", {"a": [0.0, 0.0, 0.0], "b": [100.0, 0.0, 0.0]})
    sockets = Observations.of(obs.joints[:4], placement=["p1"] * 4, socket=["a", "b"] * 2, fixture=fixture)
    assert Observations.from_plain(parallel.check_plain(sockets.to_plain())).fixture.distance("a", "b") == 100.0


@pytest.mark.slow
def test_compare_on_a_cluster_scores_exactly_what_it_scores_here(ur5, cluster):
    chain, obs = ur5
    only = ["kinematic full", "kinematic full+compliance", "hybrid full+compliance", "kriging (sincos)"]
    # One fit after the other, in this process, with one BLAS thread as a Dask worker has (the
    # sums of a multi-threaded BLAS differ in their last bits).
    with parallel.executor(), threadpool_limits(1, user_api="blas"):
        here = selection.compare(chain, obs, folds=3, only=only)
    steps = []
    there = selection.compare(chain, obs, folds=3, only=only, on_fit=lambda steps_=1: steps.append(steps_))
    assert list(there.scores) == list(here.scores)
    for label in here.scores:
        assert list(there.scores[label]) == list(here.scores[label])
        for split in here.scores[label]:
            np.testing.assert_equal(_fields(there.scores[label][split]), _fields(here.scores[label][split]),
                                    err_msg=f"{label} on {split}")
    assert there.recommended == here.recommended and there.reasons == here.reasons
    # Every fit is counted once: (nominal + 4 models) x the folds of every split.
    assert sum(steps) == 5 * sum(len(split.tests) for split in here.splits)


def test_network_folds_are_spread_one_split_a_task():
    found = [selection.Candidate("nominal (registered)", "nominal", {}),
             selection.Candidate("kinematic full", "kinematic", {"parameters": "full"}),
             selection.Candidate("hybrid full", "hybrid", {"parameters": "full"}, base="kinematic full"),
             selection.Candidate("ann", "ann", {})]
    split_list = [selection.Split("a", "random", (), ()), selection.Split("b", "region", (), ())]
    pieces = selection._groups(found, split_list)
    assert [[c.label for c in group] for group, _ in pieces] == [
        ["ann"], ["ann"], ["kinematic full", "hybrid full"], ["nominal (registered)"]]
    assert [[s.name for s in splits_] for _, splits_ in pieces][:2] == [["a"], ["b"]]


@pytest.mark.slow
def test_cross_validation_on_a_cluster_equals_the_one_here(ur5, cluster):
    chain, obs = ur5
    method = make_method("kinematic", parameters="full+compliance")
    there = cross_validate(method, chain, obs, folds=4, seed=2)
    with parallel.executor(), threadpool_limits(1, user_api="blas"):
        here = cross_validate(method, chain, obs, folds=4, seed=2)
    np.testing.assert_equal(there, here)


@pytest.fixture(scope="module")
def files(robot, tmp_path_factory):
    _, truth, q = robot
    folder = tmp_path_factory.mktemp("parallel")
    write_measurements(folder / "meas.csv", truth.measurements(q, np.random.default_rng(6)))
    return folder


@pytest.mark.slow
def test_validate_and_compare_with_jobs_print_what_they_print_without(files):
    meas = str(files / "meas.csv")
    for command in (["validate", "ur5", meas, "--method", "kinematic", "--folds", "3"],
                    ["compare", "ur5", meas, "--folds", "3", "--no-network"]):
        with threadpool_limits(1, user_api="blas"):  # as robocal's main() and a Dask worker run
            here = json.loads(run_ok(*command, "--json").stdout)
        there = json.loads(run_ok(*command, "--json", "--jobs", "2").stdout)
        if command[0] == "compare":
            for result in (here, there):
                for model in result["models"]:
                    model.pop("seconds")
                    for split in model["scores"].values():
                        split.pop("fit_seconds")
        assert here == there, command[0]


@pytest.mark.slow
def test_jobs_and_scheduler_together_or_no_scheduler_are_refused(files, tmp_path, monkeypatch):
    before = copy_inputs(files, tmp_path, monkeypatch)
    for command in ("compare", "validate"):
        assert_refused([command, "ur5", "meas.csv", "--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"], "not both",
                       tmp_path, before)
    # Dask tries for CONNECT_SECONDS (20 s) before it gives up: one command is enough, and 2 s
    # to give up on a port where nothing listens are enough too.
    monkeypatch.setattr(parallel, "CONNECT_SECONDS", 2)
    assert_refused(["validate", "ur5", "meas.csv", "--scheduler", "tcp://127.0.0.1:1"],
                   "cannot reach the Dask scheduler", tmp_path, before)


def test_the_command_line_runs_one_blas_thread_unless_told(monkeypatch):
    from threadpoolctl import threadpool_info

    for name in cli.THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    limits = cli._one_blas_thread()
    try:
        assert all(pool["num_threads"] == 1 for pool in threadpool_info() if pool["user_api"] == "blas")
    finally:
        limits.restore_original_limits()
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    assert cli._one_blas_thread() is None


@pytest.mark.slow
@pytest.mark.parametrize("approximation", ["exact", "vecchia"])
def test_kriging_searches_its_components_on_a_cluster_as_it_does_here(approximation, cluster):
    from robocal.estimation.kriging import Kriging

    rng = np.random.default_rng(7)
    X = rng.uniform(-1.0, 1.0, (150, 3))
    Y = (np.column_stack([np.sin(3 * X[:, 0]), X[:, 1] * X[:, 2], np.cos(2 * X[:, 2])])
         + 0.01 * rng.normal(size=(150, 3)))
    settings = dict(random_state=3, nugget="estimate", n_starts=3, approximation=approximation, neighbours=20)
    # One BLAS thread on both sides, as the command line runs (the final factorisation is here).
    with threadpool_limits(1, user_api="blas"):
        there = Kriging(**settings).fit(X, Y)
        with parallel.executor():
            here = Kriging(**settings).fit(X, Y)
    np.testing.assert_array_equal(there.theta_, here.theta_)
    np.testing.assert_array_equal(there.nugget_, here.nugget_)
    with threadpool_limits(1, user_api="blas"):
        np.testing.assert_array_equal(there.predict(X[:20]), here.predict(X[:20]))


@pytest.mark.slow
def test_calibrate_takes_jobs_only_where_there_is_something_to_spread(files, tmp_path, monkeypatch):
    before = copy_inputs(files, tmp_path, monkeypatch)
    for method in ("kinematic", "ann"):
        assert_refused(["calibrate", "ur5", "meas.csv", "--method", method, "--jobs", "2", "--out", "m.json"],
                       f"the {method} method has none", tmp_path, before)
