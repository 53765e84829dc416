"""Constraint calibration (ball in sockets): time and accuracy on simulated and real data.

Simulated data: a KUKA KR 150-2 whose every link parameter and ball offset is off as in the
``typical`` preset (sigma 0.2 mm / 0.02 deg on the links, 2 mm / 0.2 deg on the tool; the
base is invisible to constraints and left nominal), rigid joints, a 2-socket (300 mm) or
4-socket (300 x 240 mm, one socket 30 mm higher) fixture placed 3 or 6 times, 10 or 30
configurations per socket, joint readings with 0.005 deg noise.  For each layout it prints
the fit time (median over the runs) with all pairs and with a spanning set, the mean and
largest true error of the ball position over 3 held-out placements (exact readings; the
calibrated model mapped onto the truth by the rigid transform fitted on the training
configurations, since the base frame is unobservable), before (nominal) and after.

Real data: MUKCa (Franka Panda, 2 sockets 50 mm apart) under three protocols: every placement
held out in turn (train on the others), training on one placement alone with the others
held out (the workflow of the MUKCa README), and the split of ``robocal dataset mukca-panda-N
--split 0.5`` (the README's table).  On the same folds: robocal rigid, with joint gains,
with joint compliance and with both, and the MUKCa authors' objective re-implemented from their
paper (bench/mukca_peer.py; needs CasADi, skipped without it).  It prints the socket
consistency (mean distance of each ball centre from the mean of its socket group, as
``robocal evaluate`` reports it) on the training and held-out placements, pooled over the
folds, the largest on the held-out ones, MUKCa's sigma and the socket-distance error there, the worst fold and the median fit time, and the
authors' published panda_1 figures (whose metric and split the data do not state).

    python bench/constraint.py            # about five minutes, most of it the MUKCa objective
    python bench/constraint.py --quick    # the largest layout and MUKCa panda_1 only
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets are stated
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

import mukca_peer  # noqa: E402
from robocal.errors import RobocalWarning  # noqa: E402
from robocal.estimation.constraint import ConstraintCalibration  # noqa: E402
from robocal.estimation.registration import kabsch  # noqa: E402
from robocal.io.datasets import dataset_dir, mukca, split_indices  # noqa: E402
from robocal.io.fixtures import Fixture  # noqa: E402
from robocal.io.library import builtin  # noqa: E402
from robocal.simulation import TrueRobot, make_true_robot  # noqa: E402
from robocal.simulation.sampling import socket_plan  # noqa: E402
from robocal.spatial import compose_pose  # noqa: E402

LAYOUTS = [(k, s, m) for k in (3, 6) for s in (2, 4) for m in (10, 30)]
QUICK_LAYOUTS = [(6, 4, 30)]
JOINT_NOISE_DEG = 0.005
RUNS = 5
FIXTURES = {
    2: Fixture("two sockets", {"A": [0.0, 0.0, 0.0], "B": [300.0, 0.0, 0.0]}),
    4: Fixture("four sockets", {"A": [0.0, 0.0, 0.0], "B": [300.0, 0.0, 0.0], "C": [0.0, 240.0, 0.0],
                                "D": [300.0, 240.0, 30.0]}),
}
# Franka Panda, MUKCa: socket-consistency error (mm), Franzese et al., arXiv:2503.12584.
PUBLISHED = {"panda_1": {"train": (8.28, 0.17), "held_out": (7.79, 0.35)}}


def median_time(func, runs):
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        result = func()
        times.append(time.perf_counter() - t0)
    return result, float(np.median(times))


def simulated(layouts):
    chain = builtin("kr150-2").replace(tool=compose_pose([0.0, 0.0, 150.0], np.zeros(3)))
    deviations = make_true_robot(chain, "typical", seed=1).deviations
    truth = TrueRobot(nominal=chain, deviations={k: v for k, v in deviations.items() if not k.startswith("base")})
    print(f"Simulated {chain.name}, ball 150 mm beyond the flange, joint noise {JOINT_NOISE_DEG} deg; "
          "true ball error on 3 held-out placements (mm)")
    print(f"{'placements x sockets x per socket':>34} {'configs':>8} {'all: s':>8} {'spanning: s':>12} "
          f"{'nominal mean/max':>17} {'all mean/max':>15} {'spanning mean/max':>18}")
    for placements, sockets, per_socket in layouts:
        fixture = FIXTURES[sockets]
        train = socket_plan(truth, fixture, placements, per_socket, rng=10, joint_noise_deg=JOINT_NOISE_DEG)
        test = socket_plan(truth, fixture, 3, 10, rng=20)
        row = []
        for pairs in ("all", "spanning"):
            def fit():
                return ConstraintCalibration(pairs).fit(chain, train.joints, train.fixture_ids, train.socket_ids, fixture)

            cal, seconds = median_time(fit, RUNS)
            row.append((seconds, _true_error(cal.chain_, train, test)))
        nominal = _true_error(chain, train, test)
        print(f"{f'{placements} x {sockets} x {per_socket}':>34} {len(train.joints):>8} {row[0][0]:>8.3f} "
              f"{row[1][0]:>12.3f} {nominal[0]:>8.3f}/{nominal[1]:<8.3f} {row[0][1][0]:>7.4f}/{row[0][1][1]:<7.4f} "
              f"{row[1][1][0]:>9.4f}/{row[1][1][1]:<8.4f}")


def _true_error(chain, train, test):
    rot, shift = kabsch(chain.fk_positions(train.joints), train.ball)
    error = np.linalg.norm(chain.fk_positions(test.joints) @ rot.T + shift - test.ball, axis=1)
    return float(error.mean()), float(error.max())


def consistency(centres, placement, socket, spacing):
    """Socket consistency as ``robocal evaluate`` reports it: ``mean`` and ``max`` distance
    (mm) of ball centres from the mean of their (placement, socket) group; MUKCa's ``sigma``
    (per placement the root of the summed per-socket variances, averaged over placements);
    ``distance``, the mean |distance between a placement's two socket means - spacing|."""
    distances, sigmas, spacing_errors = [], [], []
    for where in dict.fromkeys(placement):
        variance, means = 0.0, []
        for k in dict.fromkeys(socket[placement == where]):
            group = centres[(placement == where) & (socket == k)]
            distances.append(np.linalg.norm(group - group.mean(axis=0), axis=1))
            variance += group.var(axis=0).sum()
            means.append(group.mean(axis=0))
        sigmas.append(np.sqrt(variance))
        if len(means) == 2:
            spacing_errors.append(abs(np.linalg.norm(means[0] - means[1]) - spacing))
    distances = np.concatenate(distances)
    return {"mean": float(distances.mean()), "max": float(distances.max()), "sigma": float(np.mean(sigmas)),
            "distance": float(np.mean(spacing_errors))}


def _models(chain, fixture, peer):
    """name -> fit(q, placement, socket) returning a function q -> ball centres (mm)."""
    def robocal(**options):
        def fit(q, placement, socket):
            return ConstraintCalibration(**options).fit(chain, q, placement, socket, fixture).predict
        return fit

    models = {"robocal": robocal(), "robocal +gains": robocal(gains=True),
              "robocal +compliance": robocal(compliance=True),
              "robocal +compl.+gains": robocal(compliance=True, gains=True)}
    if peer is not None:
        def mukca_objective(q, placement, socket):
            groups = [[q[(placement == where) & (socket == k)] for k in ("0", "1")]
                      for where in dict.fromkeys(placement)]
            return peer.fit(groups).ball_centres
        models["MUKCa objective"] = mukca_objective
    return models


def real(units):
    print("\nMUKCa (Franka Panda): socket consistency, mean distance of each ball centre from its socket "
          "group's mean (mm), and MUKCa's sigma")
    print("  leave one out: each placement held out in turn, trained on the others; one placement: "
          "trained on each placement alone (the MUKCa README's workflow), the others held out; "
          "split 0.5: as robocal dataset --split 0.5")
    print("  robocal +gains / +compliance / +compl.+gains: --parameters full+gains, full+compliance (Franka's "
          "link masses, no payload), full+compliance+gains; MUKCa objective: the authors' cost "
          "re-implemented (bench/mukca_peer.py, CasADi + IPOPT)")
    # The one-placement protocol asks for compliance from one placement on purpose, to show
    # what robocal's warning about it means.
    warnings.filterwarnings("ignore", message="joint compliance from one fixture placement", category=RobocalWarning)
    peer = None
    if mukca_peer.available():
        peer = mukca_peer.MukcaObjective(dataset_dir() / "mukca" / "panda.urdf")
    else:
        print("  (CasADi not installed: the MUKCa objective is left out; pip install '.[bench]')")
    print(f"{'unit':>8} {'protocol':>14} {'model':>21} {'train after':>12} {'held-out before':>16} "
          f"{'held-out after mean / max':>25} {'sigma after':>12} {'distance':>9} {'worst fold':>11} "
          f"{'fit s':>7}")
    for unit in units:
        dataset = mukca(unit)
        chain, fixture, obs = dataset.chain, dataset.fixture, dataset.observations
        q = obs.joints
        placement, socket = np.asarray(obs.placement), np.asarray(obs.socket)
        spacing = fixture.distance(*sorted(fixture.sockets)[:2])
        placements = list(dict.fromkeys(placement))
        split = np.zeros(len(placement), dtype=bool)
        split[split_indices(dataset.measurements, 0.5)[0]] = True  # as `robocal dataset --split 0.5` does
        protocols = {"leave one out": [placement != held for held in placements],
                     "one placement": [placement == held for held in placements],
                     "split 0.5": [split]}
        for protocol, trains in protocols.items():
            for name, fit in _models(chain, fixture, peer).items():
                folds = []
                for train in trains:
                    t0 = time.perf_counter()
                    predict = fit(q[train], placement[train], socket[train])
                    seconds = time.perf_counter() - t0
                    test = ~train
                    folds.append({"train": consistency(predict(q[train]), placement[train], socket[train], spacing),
                                  "before": consistency(chain.fk_positions(q[test]), placement[test], socket[test],
                                                        spacing),
                                  "after": consistency(predict(q[test]), placement[test], socket[test], spacing),
                                  "n_train": train.sum(), "n_test": test.sum(), "seconds": seconds})

                def pooled(part, key, size="n_test"):
                    """Fold figures weighted by their numbers of configurations."""
                    return np.average([f[part][key] for f in folds], weights=[f[size] for f in folds])

                print(f"{unit:>8} {protocol:>14} {name:>21} {pooled('train', 'mean', 'n_train'):>12.3f} "
                      f"{pooled('before', 'mean'):>16.3f} {pooled('after', 'mean'):>9.3f} / "
                      f"{max(f['after']['max'] for f in folds):<6.3f} {pooled('after', 'sigma'):>12.3f} "
                      f"{pooled('after', 'distance'):>9.3f} {max(f['after']['mean'] for f in folds):>11.3f} "
                      f"{np.median([f['seconds'] for f in folds]):>7.3f}")
        published = PUBLISHED.get(unit)
        if published:
            print(f"{unit:>8} {'published':>14} {'MUKCa paper':>21} {published['train'][1]:>12.3f} "
                  f"{published['held_out'][0]:>16.3f} {published['held_out'][1]:>9.3f}            "
                  "(metric and split not stated with the data)")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="largest layout and panda_1 only")
    args = parser.parse_args()
    simulated(QUICK_LAYOUTS if args.quick else LAYOUTS)
    real(["panda_1"] if args.quick else ["panda_1", "panda_2", "panda_3"])


if __name__ == "__main__":
    main()
