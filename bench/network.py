"""Network error model (GA-trained, joint-space compensation): GA alone, GA then L-BFGS, and
L-BFGS from random starts, on the same data and splits.

Simulated data: a KUKA KR 150-2 with the ``typical`` preset's link deviations and joint
compliance (base and tool registered, so the data are in the robot's base frame), measured by
a tracker with 0.02 mm noise at joint-uniform poses.  For 200, 1,000 and 5,000 training
poses each trainer's time, and over 1,000 other poses the true error of the nominal robot
("before") and of the robot after joint-space compensation with the trained network
(``correct_joints``, one step as specified; "after").

Beside them, on the same poses, the kinematic calibration and Kriging, each compensating
through its own IK of the same targets (Kriging up to 1,000 poses).

Real data: held-out residuals (measured minus model) on UR5 Tsinghua (random half to train,
half to test) and ipa UR10 series B (random 70 / 30), the splits of bench/calibration.py:
the network alone on the nominal geometry with base and tool registered on the training
poses, and the network on top of robocal's KinematicCalibration fitted on the same poses.
Every network is shown with the joint values as inputs (the method as specified) and with
their cosines and sines ("trig").

Last, the time of one GA run of 300 generations (4 × 30 individuals, (16, 16) network) on
1,000 poses.

    python bench/network.py            # about 10 min on one core
    python bench/network.py --quick    # 1,000 simulated poses only, joint inputs only
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets are stated
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from robocal.compensation.joint_space import correct_joints  # noqa: E402
from robocal.errors import InputError  # noqa: E402
from robocal.estimation.calibration import KinematicCalibration  # noqa: E402
from robocal.estimation.metrics import error_stats  # noqa: E402
from robocal.estimation.network import NetworkErrorModel  # noqa: E402
from robocal.estimation.network.genetic import Encoding, Fitness, GeneticAlgorithm  # noqa: E402
from robocal.estimation.network.mlp import Layout  # noqa: E402
from robocal.estimation.registration import register_base_and_tool  # noqa: E402
from robocal.io.library import builtin  # noqa: E402
from robocal.simulation import TrueRobot, make_true_robot, uniform_joints  # noqa: E402

SIZES = (200, 1000, 5000)
QUICK_SIZES = (1000,)
N_TEST = 1000
KRIGING_MAX = 1000
HIDDEN = (16, 16)
TRAINERS = (
    ("GA alone", dict(trainer="ga", refine=None)),
    ("GA + L-BFGS", dict(trainer="ga", refine="lbfgs")),
    ("L-BFGS", dict(trainer="lbfgs")),
)


def _stats(stats):
    return f"{stats['mean_mm']:>8.4f}{stats['rms_mm']:>8.4f}{stats['max_mm']:>8.4f}"


def _hidden_for(n_poses, inputs, n_joints=6):
    """HIDDEN, or the widest equal layers the poses allow (3 equations per weight)."""
    width = HIDDEN[0]
    d = 2 * n_joints if inputs == "trig" else n_joints
    while width > 2 and Layout(d, (width, width), 3).n_weights > n_poses:
        width -= 2
    return (width, width)


def train(q, dp, inputs, settings):
    hidden = _hidden_for(len(q), inputs, q.shape[1])
    model = NetworkErrorModel(hidden=hidden, inputs=inputs, random_state=0, **settings)
    t0 = time.perf_counter()
    model.fit(q, dp)
    return model, time.perf_counter() - t0


def _note(model):
    info = model.training_
    hidden = "x".join(str(h) for h in model.hidden)
    note = f"{hidden}, {info['active_weights']} active weights"
    if "generations" in info:
        note += f", {info['generations']} generations ({info['stopped']})"
    return note


# ----------------------------------------------------------------------------- simulation
def simulated_benchmark(sizes, inputs_list):
    chain = builtin("kr150-2")
    typical = make_true_robot(chain, "typical", seed=1)
    links = {k: v for k, v in typical.deviations.items() if not k.startswith(("base_", "tool_"))}
    truth = TrueRobot(nominal=chain, deviations=links, compliance=typical.compliance, noise=0.02)
    rng = np.random.default_rng(2024)
    joints = uniform_joints(chain, max(SIZES), rng)
    measured = truth.measure(joints, rng)
    test = uniform_joints(chain, N_TEST, rng)
    target = chain.fk_positions(test)
    before = error_stats(truth.positions(test) - target).to_dict()
    print("KUKA KR 150-2, typical link deviations + joint compliance, base frame, 0.02 mm noise, "
          "joint-uniform poses")
    print(f"true error on {N_TEST} held-out poses (mm); after = the real robot commanded with "
          f"correct_joints(…, iterations=1); one core\n")
    header = (f"{'n':>5}  {'trainer':<14}{'inputs':<8}{'fit s':>8}   {'before: mean':>12}{'RMS':>8}"
              f"{'max':>8}   {'after: mean':>11}{'RMS':>8}{'max':>8}  {'ratio':>6}  network")
    print(header)
    print("-" * len(header))
    poses = chain.fk(test)
    for n in sizes:
        q, dp = joints[:n], measured[:n] - chain.fk_positions(joints[:n])
        for label, seconds, commands in other_methods(chain, q, measured[:n], poses, test):
            after = error_stats(truth.positions(commands) - target).to_dict()
            print(f"{n:>5}  {label:<22}{seconds:>8.2f}   {_stats(before):>28}   "
                  f"{_stats(after):>27}  {before['mean_mm'] / after['mean_mm']:>5.1f}x", flush=True)
        for inputs in inputs_list:
            for label, settings in TRAINERS:
                model, seconds = train(q, dp, inputs, settings)
                after = error_stats(truth.positions(correct_joints(chain, model, test)) - target).to_dict()
                print(f"{n:>5}  {label:<14}{inputs:<8}{seconds:>8.2f}   {_stats(before):>28}   "
                      f"{_stats(after):>27}  {before['mean_mm'] / after['mean_mm']:>5.1f}x  "
                      f"{_note(model)}", flush=True)


def other_methods(chain, q, measured, poses, hint):
    """(label, fit seconds, joint commands for ``poses``) of the kinematic calibration and of
    Kriging on the same training poses, each compensating through its own IK."""
    from robocal.compensation import Compensator
    from robocal.estimation.kriging import Kriging

    t0 = time.perf_counter()
    calibrated = KinematicCalibration().fit(chain, q, measured).chain_
    seconds = time.perf_counter() - t0
    yield "kinematic", seconds, Compensator(calibrated, nominal=chain).commands(poses, hint=hint).q
    if len(q) > KRIGING_MAX:
        print(f"{len(q):>5}  {'Kriging':<22}skipped: above {KRIGING_MAX} poses its O(n^3) fit takes minutes")
        return
    t0 = time.perf_counter()
    kriging = Kriging(nugget="estimate", random_state=0).fit(chain.fk_positions(q), measured - chain.fk_positions(q))
    seconds = time.perf_counter() - t0
    yield "Kriging", seconds, Compensator(chain, kriging, nominal=chain).commands(poses, hint=hint).q


# ----------------------------------------------------------------------------- real data
def _split(n, fraction, seed=0):
    order = np.random.default_rng(seed).permutation(n)
    cut = int(round(fraction * n))
    return order[:cut], order[cut:]


def real_data_benchmark(inputs_list):
    from robocal.io.datasets import ipa_ur10, ur5_tsinghua

    datasets = (("UR5 Tsinghua", ur5_tsinghua, 0.5), ("UR10 series B", lambda: ipa_ur10("B"), 0.7))
    print("\nreal data, held-out poses only: measured minus model (mm); the network is trained on "
          "the training poses' residual of its base model")
    header = (f"{'dataset':<15}{'base model':<13}{'trainer':<14}{'inputs':<8}{'fit s':>8}   "
              f"{'before: mean':>12}{'RMS':>8}{'max':>8}   {'after: mean':>11}{'RMS':>8}{'max':>8}"
              f"  network")
    print(header)
    print("-" * len(header))
    for name, load, fraction in datasets:
        try:
            dataset = load()
        except InputError as why:
            print(f"{name:<15}skipped: {why}")
            continue
        chain, data = dataset.chain, dataset.observations
        joints, positions = data.joints, data.positions
        train_idx, test_idx = _split(data.n_poses, fraction)
        registered, _ = register_base_and_tool(chain, joints[train_idx], positions[train_idx])
        sigmas = None if data.sigmas is None else data.sigmas[train_idx]
        calibrated = KinematicCalibration().fit(chain, joints[train_idx], positions[train_idx],
                                                sigmas=sigmas).chain_
        for base_label, base in (("registered", registered), ("calibrated", calibrated)):
            residual = positions - base.fk_positions(joints)
            before = error_stats(residual[test_idx]).to_dict()
            print(f"{name:<15}{base_label:<13}{'(none)':<14}{'':<8}{'':>8}   {_stats(before):>28}",
                  flush=True)
            for inputs in inputs_list:
                for label, settings in TRAINERS:
                    model, seconds = train(joints[train_idx], residual[train_idx], inputs, settings)
                    after = error_stats(residual[test_idx] - model.predict(joints[test_idx])).to_dict()
                    print(f"{'':<15}{'':<13}{label:<14}{inputs:<8}{seconds:>8.2f}   "
                          f"{_stats(before):>28}   {_stats(after):>27}  {_note(model)}", flush=True)


# ----------------------------------------------------------------------------- GA speed
def ga_speed(generations=300, n_poses=1000):
    rng = np.random.default_rng(0)
    X = rng.normal(size=(n_poses, 6))
    Y = np.column_stack([np.sin(X[:, 0] + X[:, 1]), np.cos(X[:, 2]) * X[:, 3], X[:, 4] * X[:, 5]])
    Y = (Y - Y.mean(axis=0)) / Y.std(axis=0)
    layout = Layout(6, HIDDEN, 3)
    # tolerance < 0: the convergence stop never fires, every generation runs.
    ga = GeneticAlgorithm(Fitness(layout, X, Y, np.ones(3)), Encoding(), populations=4,
                          population_size=30, generations=generations, tolerance=-1.0)
    t0 = time.perf_counter()
    result = ga.run(rng)
    seconds = time.perf_counter() - t0
    print(f"\nGA speed: {result['generations']} generations of 4 x 30 individuals, a {HIDDEN} "
          f"network, {n_poses} poses: {seconds:.2f} s ({1000 * seconds / result['generations']:.1f} "
          f"ms per generation), one core")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1,000 simulated poses, joint inputs")
    quick = parser.parse_args().quick
    inputs_list = ("joints",) if quick else ("joints", "trig")
    simulated_benchmark(QUICK_SIZES if quick else SIZES, inputs_list)
    real_data_benchmark(inputs_list)
    ga_speed()


if __name__ == "__main__":
    main()
