"""What robocal's Python API refuses: estimators, methods, chains, observations and the
simulation, each with one RobocalError (an InputError) that says what is wrong, including what
NumPy would let through (text, complex numbers, NaN, wrong shapes)."""
import warnings

import numpy as np
import pytest

from refusals import EXAMPLES, PLATE
from robocal.errors import InputError, RobocalError
from robocal.io.library import builtin
from robocal.io.observations import Observations
from robocal.methods import make_method

UR5 = builtin("ur5")


def _api_rows():
    from robocal.estimation.calibration import KinematicCalibration
    from robocal.estimation.constraint.estimator import ConstraintCalibration
    from robocal.estimation.kriging import Kriging
    from robocal.estimation.network.model import NetworkErrorModel
    from robocal.io.fixtures import read_fixture
    from robocal.io.library import builtin, load_robot
    from robocal.io.observations import Observations
    from robocal.methods import make_method

    chain = builtin("ur5")
    q = chain.random_configurations(60, rng=1)
    # Measured positions: the nominal robot's own (which the data check refuses as targets,
    # not measurements) plus an instrument's 0.05 mm noise.
    p = chain.fk_positions(q) + np.random.default_rng(2).normal(0.0, 0.05, (60, 3))
    q_nan, p_nan, p_inf = q.copy(), p.copy(), p.copy()
    q_nan[3, 2], p_nan[4, 1], p_inf[4, 1] = np.nan, np.nan, np.inf
    rng = np.random.default_rng(0)
    X, Y = rng.normal(size=(40, 6)), rng.normal(size=(40, 3))
    X_nan = X.copy()
    X_nan[0, 5] = np.nan
    Y_inf = Y.copy()
    Y_inf[1, 2] = np.inf
    plate = read_fixture(PLATE)
    ids = ["A", "B", "C"] * 20

    def fit(name, joints, positions, **settings):
        return lambda: make_method(name, **settings).fit(chain, Observations.of(joints, positions))

    def kin(**settings):
        return lambda: KinematicCalibration(**settings).fit(chain, q, p)

    return [
        ("method positions (N, 2)", fit("kinematic", q, p[:, :2]), "positions must have shape"),
        ("method positions too short", fit("kinematic", q, p[:50]), "positions must have shape"),
        ("kinematic NaN joint", fit("kinematic", q_nan, p), "NaN or infinite"),
        ("kinematic NaN position", fit("kinematic", q, p_nan), "NaN or infinite"),
        ("kinematic inf position", fit("kinematic", q, p_inf), "NaN or infinite"),
        ("kriging NaN position", fit("kriging", q, p_nan), "NaN or infinite"),
        ("ann NaN joint", fit("ann", q_nan, p, generations=2), "NaN or infinite"),
        ("kinematic 5 poses", fit("kinematic", q[:5], p[:5]), "at least 12 different poses"),
        ("kriging 2 poses", fit("kriging", q[:2], p[:2]), "at least 5 different poses"),
        ("ann 3 poses", fit("ann", q[:3], p[:3], generations=2), "at least 5 different poses"),
        ("kinematic 7 joint columns", fit("kinematic", np.c_[q, q[:, :1]], p), r"\(60, 7\)"),
        ("kinematic 5 joint columns", fit("kinematic", q[:, :5], p), r"\(60, 5\)"),
        ("kinematic one 1-D pose", fit("kinematic", q[0], p[:1]), "1 distinct poses"),
        ("make_method setting of another method", lambda: make_method("kinematic", nugget=1), "does not apply"),
        ("make_method unknown name", lambda: make_method("magic"), "'magic' is not available"),
        ("make_method None", lambda: make_method(None), "None is not available"),
        ("kinematic parameters=everything", fit("kinematic", q, p, parameters="everything"), "everything"),
        ("kinematic loss=cauchy", fit("kinematic", q, p, loss="cauchy"), "cauchy"),
        ("kriging trend=cubic", fit("kriging", q, p, trend="cubic"), "cubic"),
        ("kriging nugget=-1", fit("kriging", q, p, nugget=-1), "nugget"),
        ("ann hidden=(0, 4)", fit("ann", q, p, hidden=(0, 4), generations=2), "hidden"),
        ("constraint on position data", fit("constraint", q, p), "fixture and socket"),
        ("kriging on constraint data",
         lambda: make_method("kriging").fit(chain, Observations.of(q, placement=["P1"] * 60, socket=["A"] * 60,
                                                                    fixture=plate)), "x, y, z"),
        ("Observations.of joints only", lambda: Observations.of(q), "measured positions or ball-in-socket"),
        ("Observations.of rotations (N, 3)", lambda: Observations.of(q, p, rotations=np.zeros((60, 3))),
         "rotations must have shape"),
        ("negative sigmas",
         lambda: make_method("kinematic").fit(chain, Observations.of(q, p, sigmas=-np.ones((60, 3)))), "must be > 0"),
        ("Kriging regression=cubic", lambda: Kriging(regression="cubic").fit(X, Y), "regression"),
        ("Kriging correlation=exp", lambda: Kriging(correlation="exp").fit(X, Y), "correlation"),
        ("Kriging nugget=-1", lambda: Kriging(nugget=-1).fit(X, Y), "nugget"),
        ("Kriging nugget=nan", lambda: Kriging(nugget=float("nan")).fit(X, Y), "nugget"),
        ("Kriging theta_bounds reversed", lambda: Kriging(theta_bounds=(1e2, 1e-6)).fit(X, Y), "theta_bounds"),
        ("Kriging theta0 negative", lambda: Kriging(theta0=-1.0).fit(X, Y), "theta0"),
        ("Kriging theta0 wrong length", lambda: Kriging(theta0=[1.0, 2.0]).fit(X, Y), "theta0"),
        ("Kriging n_starts=0 without theta0", lambda: Kriging(n_starts=0).fit(X, Y), "theta0"),
        ("Kriging X and Y lengths", lambda: Kriging().fit(X, Y[:30]), "40 rows but Y has 30"),
        ("Kriging NaN in X", lambda: Kriging().fit(X_nan, Y), "NaN or infinite"),
        ("Kriging inf in Y", lambda: Kriging().fit(X, Y_inf), "NaN or infinite"),
        ("Kriging one sample", lambda: Kriging().fit(X[:1], Y[:1]), "at least 2 points"),
        ("Kriging 3-D X", lambda: Kriging().fit(X.reshape(40, 2, 3), Y), "2-D"),
        ("Kriging predict unfitted", lambda: Kriging().predict(X), "not fitted"),
        ("Kriging predict wrong width", lambda: Kriging().fit(X, Y).predict(X[:, :4]), "4 columns"),
        ("Kriging predict NaN", lambda: Kriging().fit(X, Y).predict(np.full((2, 6), np.nan)), "NaN or infinite"),
        ("Network hidden=()", lambda: NetworkErrorModel(hidden=()).fit(X, Y), "hidden"),
        ("Network hidden=(0, 3)", lambda: NetworkErrorModel(hidden=(0, 3), generations=2).fit(X, Y), "hidden"),
        ("Network trainer=sgd", lambda: NetworkErrorModel(trainer="sgd").fit(X, Y), "trainer"),
        ("Network refine=adam", lambda: NetworkErrorModel(refine="adam").fit(X, Y), "refine"),
        ("Network generations=-1", lambda: NetworkErrorModel(generations=-1).fit(X, Y), "generations"),
        ("Network populations=0", lambda: NetworkErrorModel(populations=0, generations=2).fit(X, Y), "populations"),
        ("Network bits=0", lambda: NetworkErrorModel(bits=0, generations=2).fit(X, Y), "bits"),
        ("Network X and Y lengths", lambda: NetworkErrorModel(generations=2).fit(X, Y[:10]), "40 rows but Y has 10"),
        ("Network NaN X", lambda: NetworkErrorModel(generations=2).fit(np.full((40, 6), np.nan), Y), "NaN"),
        ("Network predict unfitted", lambda: NetworkErrorModel().predict(X), "not fitted"),
        ("Network too few poses", lambda: NetworkErrorModel(trainer="lbfgs").fit(X, Y), "smaller hidden layers"),
        ("Network inputs=cartesian", lambda: NetworkErrorModel(inputs="cartesian", generations=2).fit(X, Y), "inputs"),
        ("KinematicCalibration parameters", kin(parameters="bogus"), "bogus"),
        ("KinematicCalibration loss", kin(loss="cauchy"), "cauchy"),
        ("KinematicCalibration position_sigma=0", kin(position_sigma=0), "position_sigma"),
        ("KinematicCalibration position_sigma=-1", kin(position_sigma=-1), "position_sigma"),
        ("KinematicCalibration payload=-1", kin(parameters="full+compliance", payload=-1), "payload"),
        ("KinematicCalibration lengths", lambda: KinematicCalibration().fit(chain, q, p[:40]), r"\(40, 3\)"),
        ("KinematicCalibration positions (N, 2)", lambda: KinematicCalibration().fit(chain, q, p[:, :2]), r"\(60, 2\)"),
        ("KinematicCalibration 5 joints", lambda: KinematicCalibration().fit(chain, q[:, :5], p), r"\(60, 5\)"),
        ("KinematicCalibration NaN", lambda: KinematicCalibration().fit(chain, q, p_nan), "NaN or infinite"),
        ("KinematicCalibration predict unfitted", lambda: KinematicCalibration().predict(q), "not fitted"),
        ("ConstraintCalibration pairs", lambda: ConstraintCalibration(pairs="some").fit(chain, q, ["P1"] * 60, ids,
                                                                                        plate), "pairs"),
        ("ConstraintCalibration id lengths", lambda: ConstraintCalibration().fit(chain, q, ["P1"] * 10, ids, plate),
         "one entry per configuration"),
        ("ConstraintCalibration unknown socket",
         lambda: ConstraintCalibration().fit(chain, q, ["P1"] * 60, ["Z"] * 60, plate), "socket id"),
        ("ConstraintCalibration NaN joints", lambda: ConstraintCalibration().fit(chain, q_nan, ["P1"] * 60, ids, plate),
         "NaN or infinite"),
        ("ConstraintCalibration payload=-1",
         lambda: ConstraintCalibration(compliance=True, payload=-1).fit(chain, q, ["P1"] * 60, ids, plate), "payload"),
        ("Chain.fk 5 columns", lambda: chain.fk(np.zeros((3, 5))), "6 joints"),
        ("Chain.fk 3-D", lambda: chain.fk(np.zeros((2, 3, 6))), "6 joints"),
        ("Chain.fk scalar", lambda: chain.fk(1.0), "6 joints"),
        ("Chain.fk_positions 7 values", lambda: chain.fk_positions(np.zeros(7)), "6 joints"),
        ("joints_from_file text", lambda: chain.joints_from_file([["a"] * 6]), "must be numbers"),
        ("joints_from_file None", lambda: chain.joints_from_file(None), "one number"),
        ("load_robot unknown", lambda: load_robot("nosuch"), "no built-in robot"),
        ("load_robot None", lambda: load_robot(None), "no built-in robot"),
        ("load_robot csv", lambda: load_robot(str(EXAMPLES / "ur5-targets.csv")), "targets file.*not a robot file"),
        ("load_robot directory", lambda: load_robot(str(EXAMPLES)), ".toml or .urdf"),
        ("load_robot missing toml", lambda: load_robot(str(EXAMPLES / "none.toml")), "does not exist"),
    ]


API = _api_rows()


@pytest.mark.parametrize("call, says", [row[1:] for row in API], ids=[row[0] for row in API])
def test_python_call_raises_a_robocal_error(call, says):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(RobocalError, match=says) as caught:
            call()
    assert isinstance(caught.value, InputError)


# ---------------------------------------------------------------- joints that are not numbers
@pytest.mark.parametrize("call", [
    lambda: Observations.of([["a"] * 6], np.zeros((1, 3))),
    lambda: UR5.fk([["a"] * 6]),
    lambda: UR5.fk_positions([["a"] * 6]),
    lambda: UR5.fk_jacobian([["a"] * 6]),
], ids=["Observations.of", "fk", "fk_positions", "fk_jacobian"])
def test_text_joints_are_one_clear_input_error(call):
    with pytest.raises(InputError, match="must be numbers"):
        call()


def test_text_positions_are_one_clear_input_error():
    with pytest.raises(InputError, match="positions must be numbers"):
        Observations.of(np.zeros((1, 6)), [["x", 1, 2]])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("fk", ["fk", "fk_positions"])
def test_fk_refuses_a_missing_or_infinite_joint_value(fk, bad):
    q = UR5.random_configurations(4, rng=0)
    q[2, 3] = bad
    with pytest.raises(InputError, match="configuration 2"):
        getattr(UR5, fk)(q)


def test_a_row_of_nan_is_still_no_configuration():
    """The IK answers NaN rows for unreachable targets, and its solver steps through them:
    such a row gives a NaN pose, the other rows their poses."""
    q = UR5.random_configurations(3, rng=0)
    q[1] = np.nan
    poses = UR5.fk(q)
    assert np.isnan(poses[1, :3]).all() and np.isfinite(poses[[0, 2]]).all()


@pytest.mark.parametrize("call, says", [
    (lambda: UR5.fk(np.zeros(6) + 1j), "must be numbers"),
    (lambda: UR5.perturbed({"a2": np.nan}), "deviation of 'a2' is nan"),
    (lambda: Observations.of(np.zeros((2, 2, 6)), np.zeros((2, 3))), r"joints must be \(N, n\)"),
], ids=["complex joints", "NaN deviation", "3-D joints"])
def test_chain_and_observations_refuse_what_numpy_lets_through(call, says):
    with pytest.raises(InputError, match=says):
        call()


# ---------------------------------------------------------------- error models, constraint calibration, simulation
@pytest.mark.parametrize("name", ["kriging", "ann"])
def test_error_models_refuse_one_pose_repeated(name):
    chain = builtin("ur5")
    q = np.repeat(chain.random_configurations(1, rng=0), 50, axis=0)
    with pytest.raises(InputError, match="1 distinct pose"):
        # One measured point (0.05 mm off the nominal robot's: a measurement, not its FK).
        make_method(name).fit(chain, Observations.of(q, chain.fk_positions(q) + 0.05))


def test_constraint_calibration_needs_a_distance_between_sockets():
    from robocal.estimation.constraint.estimator import ConstraintCalibration
    from robocal.io.fixtures import read_fixture
    from robocal.simulation import make_true_robot
    from robocal.simulation.sampling import socket_plan

    chain = builtin("kr150-2")
    plate = read_fixture(EXAMPLES / "plate-fixture.toml")
    plan = socket_plan(make_true_robot(chain, "typical", seed=3), plate, 2, 12, rng=1)
    one = plan.socket_ids == "A"
    args = (chain, plan.joints[one], plan.fixture_ids[one], plan.socket_ids[one], plate)
    with pytest.raises(InputError, match="2 placements, one socket each.*distances between sockets are needed"):
        ConstraintCalibration().fit(*args)
    # Asked for explicitly, the shape alone is still fitted, its scale said to be unobservable.
    assert "scale" in ConstraintCalibration(distance=False).fit(*args).result_.unobservable


def test_simulating_a_robot_in_metres_is_refused():
    from robocal.simulation import TrueRobot, make_true_robot

    metres = UR5.replace(d=UR5.d / 1000, a=UR5.a / 1000)
    for make in (lambda: make_true_robot(metres, "typical"), lambda: TrueRobot(metres)):
        with pytest.raises(InputError, match="looks like metres"):
            make()
    assert TrueRobot(UR5).nominal is UR5  # the same robot in mm passes


def test_simulation_refuses_text_joints_a_text_seed_and_an_absurd_plan():
    from robocal.estimation.constraint.estimator import ConstraintCalibration
    from robocal.io.fixtures import read_fixture
    from robocal.simulation import TrueRobot, make_true_robot
    from robocal.simulation.sampling import socket_plan

    plate = read_fixture(EXAMPLES / "plate-fixture.toml")
    with pytest.raises(InputError, match="must be numbers"):
        TrueRobot(UR5).measurements([["a"] * 6], np.random.default_rng(0))
    with pytest.raises(InputError, match="seed must be a whole number"):
        make_true_robot(UR5, "typical", seed="x")
    with pytest.raises(InputError, match="more than the 10,000"):
        socket_plan(builtin("kr150-2"), plate, 3, 100_000, rng=0)
    with pytest.raises(InputError, match="joints must be numbers"):
        ConstraintCalibration().fit(UR5, [["a"] * 6] * 30, ["P"] * 30, ["A", "B", "C"] * 10, plate)
