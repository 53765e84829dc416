"""Kriging and the hybrid over the TCP position, the joints and their sines and cosines,
held out where it matters: beside the kinematic calibration and the registered nominal.

Cases (each fitted on the training part only, scored on the test part):

* ``ur5-random``: UR5 Tsinghua, a random half of the 1,000 poses to train, the other half to test;
* ``ur10B-elbow``: UR10 series B, trained on the poses with the elbow (q3) one way, tested
  on those with it the other way: the arm branch the models never saw;
* ``ur10B-q1``: UR10 series B, trained on the lower half of the base joint's range, tested on
  the upper half;
* ``sim-q2``: a simulated UR10 with the typical errors (geometry, gravity compliance,
  backlash, tracker noise), 400 poses uniform in joint space, trained on the lower half of
  the shoulder's (q2) range and tested on the upper half.

Then the fit time of each input kind at n = 200 and 800 UR5 poses (the Kriging method,
one core).  Prints two tables: held-out mean, RMS and max (mm) and the fit time (s).

    python bench/error_model_inputs.py          # --quick: the cases without the timing table
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the speed targets are stated
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from robocal import methods  # noqa: E402
from robocal.errors import RobocalWarning  # noqa: E402
from robocal.estimation.metrics import error_stats  # noqa: E402
from robocal.io.datasets import ipa_ur10, ur5_tsinghua  # noqa: E402
from robocal.io.library import builtin  # noqa: E402
from robocal.io.observations import Observations  # noqa: E402
from robocal.methods.frames import registered_nominal  # noqa: E402
from robocal.simulation import make_true_robot, uniform_joints  # noqa: E402

INPUTS = ("position", "joints", "sincos")
MODELS = [("kinematic", {})] + [(name, {"inputs": inputs}) for name in ("kriging", "hybrid") for inputs in INPUTS]


def cases():
    """(name, chain, joints (N, n) rad, positions (N, 3) mm, train mask) of each case."""
    dataset = ur5_tsinghua()
    chain, obs = dataset.chain, dataset.observations
    train = np.zeros(obs.n_poses, bool)
    train[np.random.default_rng(0).permutation(obs.n_poses)[:obs.n_poses // 2]] = True
    yield "ur5-random", chain, obs.joints, obs.positions, train

    dataset = ipa_ur10("B")
    chain, obs = dataset.chain, dataset.observations
    elbow = obs.joints[:, 2] > 0
    yield "ur10B-elbow", chain, obs.joints, obs.positions, elbow if elbow.sum() >= (~elbow).sum() else ~elbow
    q1 = obs.joints[:, 0]
    yield "ur10B-q1", chain, obs.joints, obs.positions, q1 < np.median(q1)

    chain = builtin("ur10")
    truth = make_true_robot(chain, "typical", seed=2)
    q = uniform_joints(chain, 400, np.random.default_rng(5))
    yield "sim-q2", chain, q, truth.measure(q, np.random.default_rng(6)), q[:, 1] < np.median(q[:, 1])


def score(chain, q, p, train):
    """Rows (model, held-out stats, fit seconds) for one case."""
    test = ~train
    nominal = registered_nominal(chain, q[train], p[train])
    rows = [("registered nominal", error_stats(p[test] - nominal.fk_positions(q[test])).to_dict(), None)]
    for name, settings in MODELS:
        start = time.perf_counter()
        fitted = methods.make_method(name, **settings).fit(chain, Observations.of(q[train], p[train]))
        seconds = time.perf_counter() - start
        label = name + (f" {settings['inputs']}" if settings else "")
        rows.append((label, error_stats(p[test] - fitted.predict(q[test])).to_dict(), seconds))
    return rows


def fit_times():
    """Fit seconds of the Kriging method per input kind at n = 200 and 800 UR5 poses."""
    dataset = ur5_tsinghua()
    chain, obs = dataset.chain, dataset.observations
    order = np.random.default_rng(0).permutation(obs.n_poses)
    for n in (200, 800):
        q, p = obs.joints[order[:n]], obs.positions[order[:n]]
        for inputs in INPUTS:
            start = time.perf_counter()
            methods.make_method("kriging", inputs=inputs).fit(chain, Observations.of(q, p))
            yield n, inputs, time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the timing table")
    args = parser.parse_args()
    warnings.simplefilter("ignore", RobocalWarning)  # extrapolation is what the held-out regions test
    print(f"{'case':<12} {'train':>5} {'test':>5}  {'model':<18} {'mean':>7} {'rms':>7} {'max':>7} {'fit s':>6}")
    for name, chain, q, p, train in cases():
        for label, stats, seconds in score(chain, q, p, train):
            fit = "" if seconds is None else f"{seconds:6.1f}"
            print(f"{name:<12} {train.sum():>5} {(~train).sum():>5}  {label:<18} {stats['mean_mm']:7.3f} "
                  f"{stats['rms_mm']:7.3f} {stats['max_mm']:7.3f} {fit:>6}", flush=True)
    if args.quick:
        return
    print(f"\n{'poses':>5}  {'inputs':<9} {'fit s':>6}   (kriging method, UR5 Tsinghua, one core)")
    for n, inputs, seconds in fit_times():
        print(f"{n:>5}  {inputs:<9} {seconds:6.1f}", flush=True)


if __name__ == "__main__":
    main()
