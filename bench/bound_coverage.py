"""Coverage of the 95 % bound (robocal.methods.bound) on poses a model was not trained on.

For each case a model is fitted on the training poses, its bound calibrated as ``calibrate``
does (:func:`robocal.methods.bound.fit_bound`), and the held-out poses scored: coverage is
the share whose error lies within their bound (the goal: 0.85 to 0.99), beside the median
bound over the median error (at most 3: a bound that covers by being huge does not count).
Held-out poses are split into those inside the model's training domain and those outside
(:meth:`robocal.methods.domain.Domain.check`).

Cases:

* UR5 (Tsinghua): a random half of the 1,000 poses trains, the other half is held out;
* ipa UR10 series A and B: random halves, and region splits: trained on one side of the
  shoulder (A only: B was measured on one side) or of the elbow, tested on the other side;
* a simulated KUKA KR 150-2 (``--errors typical``, seed 2): trained on 400 joint-uniform
  poses with q2 below the middle of its range, tested on 1,000 joint-uniform poses (inside
  and outside the training domain).

Training sets are capped at MAX_TRAINING poses (a random subset) so that the Kriging-based
models fit in minutes; the held-out sets are whole.

    python bench/bound_coverage.py                      # kinematic, kriging, hybrid
    python bench/bound_coverage.py --methods ann        # the network, few generations
"""
import argparse
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import warnings

import numpy as np

from robocal.io.datasets import ipa_ur10, ur5_tsinghua
from robocal.io.library import builtin
from robocal.io.observations import Observations
from robocal.methods import make_method
from robocal.methods.bound import fit_bound
from robocal.methods.domain import arm_branches
from robocal.simulation import make_true_robot, uniform_joints

MAX_TRAINING = 600
# The network's genetic algorithm: few generations (its default is 300), for time.
NETWORK_GENERATIONS = 20
SETTINGS = {"kinematic": {}, "kriging": {"inputs": "position"}, "hybrid": {},
            "ann": {"generations": NETWORK_GENERATIONS}}


def _capped(index, rng):
    return np.sort(rng.choice(index, MAX_TRAINING, replace=False)) if len(index) > MAX_TRAINING else np.sort(index)


def cases():
    """(label, chain, training Observations, held-out Observations) of every case."""
    rng = np.random.default_rng(0)
    out = []
    for name, dataset, branches in (("UR5", ur5_tsinghua(), ()),
                                    ("UR10 A", ipa_ur10("A"), ("shoulder", "elbow")),
                                    ("UR10 B", ipa_ur10("B"), ("elbow",))):
        chain, obs = dataset.chain, dataset.observations
        order = rng.permutation(obs.n_poses)
        half = obs.n_poses // 2
        out.append((f"{name} random half", chain, obs.subset(_capped(order[:half], rng)),
                    obs.subset(np.sort(order[half:]))))
        _, sides = arm_branches(chain, obs.joints)
        for branch in branches:
            side = sides[branch]
            out.append((f"{name} other {branch} side", chain, obs.subset(_capped(np.flatnonzero(side == 0), rng)),
                        obs.subset(np.flatnonzero(side == 1))))
    chain = builtin("kr150-2")
    truth = make_true_robot(chain, "typical", seed=2)
    q = uniform_joints(chain, 4000, np.random.default_rng(1))
    middle = 0.5 * (chain.lower[1] + chain.upper[1])
    train_q = q[q[:, 1] < middle][:400]
    test_q = uniform_joints(chain, 1000, np.random.default_rng(3))
    out.append(("KR 150-2 q2 lower half -> all", chain,
                Observations.of(train_q, truth.measure(train_q, np.random.default_rng(4))),
                Observations.of(test_q, truth.measure(test_q, np.random.default_rng(5)))))
    return out


def _share(error, bound, mask):
    if not mask.any():
        return "      -      -"
    return f"{np.mean(error[mask] <= bound[mask]):>7.3f}{np.median(bound[mask]) / np.median(error[mask]):>7.2f}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default="kinematic,kriging,hybrid")
    parser.add_argument("--only", default=None, help="cases whose label contains this text")
    parser.add_argument("--seed", type=int, default=0, help="seed of the bound's folds and regions (fit_bound)")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    print(f"{'method':<10}{'case':<32}{'train':>6}{'test':>6}{'all: cov':>10}{'ratio':>7}{'in: cov':>9}{'ratio':>7}"
          f"{'out: cov':>9}{'ratio':>7}{'n out':>7}{'s':>7}")
    for method in args.methods.split(","):
        for label, chain, train, test in cases():
            if args.only and args.only not in label:
                continue
            start = time.process_time()
            fitted = make_method(method, **SETTINGS[method]).fit(chain, train)
            bound_model = fit_bound(fitted, chain, train, seed=args.seed)
            inside = bound_model.inside_mask(test.joints)
            bound = bound_model.predict(test.joints, inside=inside)
            error = np.linalg.norm(test.positions - fitted.predict(test.joints), axis=1)
            everything = np.ones(len(error), dtype=bool)
            print(f"{method:<10}{label:<32}{train.n_poses:>6}{test.n_poses:>6}{'':>3}{_share(error, bound, everything)}"
                  f"{'':>2}{_share(error, bound, inside)}{'':>2}{_share(error, bound, ~inside)}"
                  f"{int((~inside).sum()):>7}{time.process_time() - start:>7.0f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
