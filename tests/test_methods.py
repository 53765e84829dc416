"""The method protocol and its registry: settings refused or validated, every method round
trips through a model file, and a new method needs nothing but its class and a registry line."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal import methods
from robocal.compensation import Compensator
from robocal.errors import FileFormatError, InputError
from robocal.estimation.metrics import error_stats
from robocal.interfaces import jobs
from robocal.interfaces.cli import app
from robocal.io.library import builtin
from robocal.io.model_file import load_model, save_model
from robocal.io.observations import Observations
from robocal.io.tables import Measurements, write_measurements
from robocal.methods import FitRecord
from robocal.methods.base import Method
from robocal.methods.frames import registered_nominal
from robocal.simulation import make_true_robot, uniform_joints

runner = CliRunner()
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
# Settings that keep each method's fit to a fraction of a second on 120 poses.
QUICK = {"ann": {"hidden": (6, 6), "generations": 3}}


@pytest.fixture(scope="module")
def ur5_data():
    chain = builtin("ur5")
    truth = make_true_robot(chain, "typical", seed=1)
    q = uniform_joints(chain, 160, np.random.default_rng(4))
    return chain, truth, q, truth.positions(q)


def test_every_registered_method_describes_itself():
    assert set(methods.method_names()) == {"kinematic", "kriging", "hybrid", "constraint", "ann"}
    for name in methods.method_names():
        cls = methods.get_method(name)
        assert cls.name == name and cls.description
        names = [s.name for s in cls.settings]
        assert len(names) == len(set(names)), name
        assert cls.data_kind in ("position", "sockets")
        # Defaults are the settings of a method made with none.
        assert cls().get_settings() == {s.name: list(s.default) if isinstance(s.default, tuple) else s.default
                                        for s in cls.settings}


def test_settings_a_method_does_not_take_are_refused_at_once():
    with pytest.raises(InputError, match="--payload does not apply to the kriging method"):
        methods.make_method("kriging", payload=2.0)
    with pytest.raises(InputError, match="--seed does not apply to the kinematic method"):
        methods.make_method("kinematic", random_state=1)
    with pytest.raises(InputError, match="'nope' is not available.*kinematic"):
        methods.get_method("nope")


@pytest.mark.parametrize("name, settings, message", [
    ("kinematic", {"loss": "cauchy"}, "--loss must be one of linear"),
    ("kinematic", {"register": "maybe"}, "--register must be one of auto"),
    ("kinematic", {"payload": 2.0}, "--payload applies to the compliance parameter sets"),
    ("kinematic", {"parameters": "everything"}, "--parameters must be one of offsets"),
    ("ann", {"parameters": "full+gains"}, "--parameters set the network's kinematic base model"),
    ("ann", {"refine": "adam"}, "--refine must be one of lbfgs, none"),
    ("kriging", {"trend": "cubic"}, "--trend must be one of constant, linear"),
])
def test_setting_values_are_validated_in_fit(ur5_data, name, settings, message):
    chain, _, q, p = ur5_data
    method = methods.make_method(name, **settings)  # stored unchanged: no error yet
    with pytest.raises(InputError, match=message):
        method.fit(chain, Observations.of(q, p))


@pytest.mark.parametrize("name", ["kinematic", "kriging", "hybrid", "ann"])
def test_each_method_round_trips_through_a_model_file(tmp_path, ur5_data, name):
    chain, truth, q, p = ur5_data
    train, test = slice(0, 120), slice(120, None)
    fitted = methods.make_method(name, **QUICK.get(name, {})).fit(chain, Observations.of(q[train], p[train]))
    path = tmp_path / f"{name}.json"
    save_model(fitted.to_model_file(chain, {"file": "memory"}), path)
    model = load_model(path, robot=chain)
    loaded = methods.fitted_from_model_file(model, path)
    assert type(loaded) is type(fitted) and loaded.get_settings() == fitted.get_settings()
    np.testing.assert_allclose(loaded.predict(q[test]), fitted.predict(q[test]), atol=1e-9)
    np.testing.assert_allclose(loaded.reference_.fk_positions(q[test]), fitted.reference_.fk_positions(q[test]),
                               atol=1e-9)
    assert loaded.record_ == fitted.record_
    # Held out, every method beats the registered nominal robot on this simulated UR5.
    nominal = error_stats(p[test] - fitted.reference_.fk_positions(q[test])).mean_mm
    assert error_stats(p[test] - fitted.predict(q[test])).mean_mm < nominal


def test_a_model_file_of_an_unknown_method_or_a_foreign_error_model_is_refused(tmp_path, ur5_data):
    chain, _, q, p = ur5_data
    fitted = methods.make_method("kriging").fit(chain, Observations.of(q[:60], p[:60]))
    model = fitted.to_model_file(chain)
    for method, message in (("teleport", "unknown method 'teleport'"), ("kinematic", "has no error model")):
        with pytest.raises(FileFormatError, match=message):
            methods.fitted_from_model_file(replace(model, method=method), tmp_path / "m.json")
    # a Kriging document where a network belongs
    with pytest.raises(FileFormatError, match="error model is damaged"):
        methods.fitted_from_model_file(replace(model, method="ann"), tmp_path / "m.json")


def test_command_line_refuses_an_option_of_another_method_and_writes_nothing(tmp_path, ur5_data):
    chain, _, q, p = ur5_data
    meas = tmp_path / "meas.csv"
    write_measurements(meas, Measurements("", chain.joints_to_file(q), positions=p))
    out = tmp_path / "m.json"
    for extra, message in ((["--method", "kriging", "--payload", "2"], "--payload does not apply to the kriging"),
                           (["--method", "kinematic", "--trend", "linear"], "--trend does not apply to the kinematic"),
                           (["--method", "kinematic", "--fixture", str(EXAMPLES / "plate-fixture.toml")],
                            "applies to ball-in-socket data only")):
        result = runner.invoke(app, ["calibrate", "ur5", str(meas), "--out", str(out), *extra])
        assert result.exit_code == 2, result.output
        assert message in result.output and "Traceback" not in result.output
        assert len(result.output.strip().splitlines()) == 1
        assert not out.exists()


def test_version_and_methods_commands():
    from robocal import __version__

    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.output.strip() == f"robocal {__version__}"
    listing = runner.invoke(app, ["methods"])
    assert listing.exit_code == 0
    for name in methods.method_names():
        assert name in listing.output


class RegisteredNominal(Method):
    """The simplest model as a method: the nominal robot, base and tool registered."""

    name = "nominal-test"
    description = "nominal geometry registered in the measurement frame"

    def _fit(self, chain, observations, progress):
        registered = registered_nominal(chain, observations.joints, observations.positions)
        stats = error_stats(observations.positions - registered.fk_positions(observations.joints)).to_dict()
        self.compensator_ = Compensator(registered, nominal=chain)
        self.reference_ = registered
        self.record_ = FitRecord(residual_before=stats, residual_after_training=stats, registered=True)
        return self


def test_a_new_method_is_one_class_and_one_registry_line(tmp_path, ur5_data, monkeypatch):
    """Every verb works with a method it has never heard of, once it is registered."""
    chain, truth, q, p = ur5_data
    monkeypatch.setitem(methods.REGISTRY, RegisteredNominal.name, RegisteredNominal)
    meas, out = tmp_path / "meas.csv", tmp_path / "m.json"
    write_measurements(meas, Measurements("", chain.joints_to_file(q), positions=p))
    jobs.calibrate_job("ur5", meas, out, method=RegisteredNominal.name)
    evaluation = jobs.evaluate_job(out, meas).to_dict()
    # It is its own reference: the error equals the nominal's, to the last digit.
    assert evaluation["method"] == RegisteredNominal.name
    assert evaluation["mean_mm"] == pytest.approx(evaluation["nominal"]["mean_mm"], abs=1e-12)
    cv = jobs.validate_job("ur5", meas, method=RegisteredNominal.name, folds=3).to_dict()
    assert cv["cross_validation"]["pooled"]["mean_mm"] == pytest.approx(
        cv["nominal_cross_validation"]["pooled"]["mean_mm"], abs=1e-9)
    compensated = jobs.compensate_job(out, EXAMPLES / "ur5-targets.csv", tmp_path / "c.csv")
    assert compensated.reachable > 0


def test_the_constraint_method_round_trips_and_beats_the_nominal_on_a_placement_it_never_saw(tmp_path):
    from robocal.io.fixtures import read_fixture
    from robocal.methods.evaluation import socket_scores
    from robocal.simulation.sampling import socket_plan

    chain = builtin("kr150-2")
    truth = make_true_robot(chain, "typical", seed=2)
    fixture = read_fixture(EXAMPLES / "plate-fixture.toml")
    observations = socket_plan(truth, fixture, 4, 8, rng=3).observations(fixture)
    held_out = observations.placement == observations.placement[-1]
    fitted = methods.make_method("constraint").fit(chain, observations.subset(~held_out))
    path = tmp_path / "sockets.json"
    save_model(fitted.to_model_file(chain), path)
    loaded = methods.fitted_from_model_file(load_model(path), path)
    q = observations.joints
    np.testing.assert_allclose(loaded.predict(q), fitted.predict(q), atol=1e-9)
    assert loaded.record_ == fitted.record_ and loaded.record_.fixture["name"] == fixture.name
    scores = socket_scores(loaded, observations.subset(held_out))
    assert scores["mean_mm"] < scores["nominal"]["mean_mm"] / 5
