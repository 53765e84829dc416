"""Measurement planning (issue 16): designed poses against random ones, held out.

    python bench/design.py                 # everything (about 20 minutes on one core)
    python bench/design.py kr ur5 box      # some parts: kr, ur5, box, predicted, speed, variance, sockets, figaroh
    python bench/design.py kr --parameters full+compliance   # one parameter set only

Every figure is held out: a calibration (KinematicCalibration) is trained on the chosen poses
only and scored on a fixed set the design never saw.  Each curve runs twice: with parameters
"full" (what `robocal calibrate` fits by default) and "full+compliance" (designed for, and
calibrated with, the gravity compliances; the simulated KR 150-2 has them).  Designed sets,
random draws and the floor of a curve are all calibrated with its set.

* kr: simulated KUKA KR 150-2 with --errors typical (geometry, gravity compliance, 0.005 deg
  backlash, 0.02 mm noise; seed 0).  10,000 candidates uniform in the joint limits (5 deg
  margin, as `robocal design` draws them); held-out: 1,000 other uniform configurations,
  measured.  Designed sets (5 design seeds) are each measured in their tour order 4 times
  (4 noise draws), and in a random order (backlash: a tour approaches neighbouring poses
  from the same side); random sets are 20 draws of N candidates.  "floor": the calibration trained on 5,000
  candidates, what no choice of poses can beat (backlash is in neither model, compliance not in "full").
* ur5: the real UR5 (Tsinghua, 1,000 grid poses); a fixed random 300 held out, the design
  chooses from the other 700 by their joint values alone; random: 20 draws from the 700;
  floor: all 700.
* box: the KR 150-2 of kr restricted to the Kriging paper's box (x 1200..2200, y -800..800,
  z 400..1400 mm, flange down, one IK branch): 10,000 candidates, 1,000 held out in the box.
* predicted: the design's predicted held-out RMS against the measured one, with the stated
  noise (0.02 mm) and with the noise estimated from the designed poses' own residual.
* speed: CPU time of 30 poses out of 10,000 candidates for the full KR 150-2 parameter set.
* variance: the largest predictive variance left over the KR 150-2's 10,000 candidates (the
  fixed sincos prior, relative to the process variance) by the variance criterion, by
  space filling and by random poses (mean of 20), and the variance design's CPU time.
* sockets: ball in sockets on a simulated Panda (geometric errors of the 'typical' preset,
  0.005 deg joint-reading noise, the three-socket plate of the tests): 8 candidate
  placements, 3 chosen with 3/4/6/8 configurations per socket, the true robot's readings
  with the ball seated where the design says (4 noise draws), against random placements and
  configurations from the same candidates (20 draws); held out: socket consistency (mean, mm)
  of the calibrated model on 3 other placements with 8 configurations per socket.
* figaroh: FIGAROH's D-optimal selection beside it, where FIGAROH is installed.

Random sets whose calibration is refused (too few independent equations, or a fit beyond
manufacturing tolerances) are counted as "refused" and left out of the means.
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from robocal.errors import InputError  # noqa: E402
from robocal.estimation.calibration import KinematicCalibration  # noqa: E402
from robocal.io.datasets import ur5_tsinghua  # noqa: E402
from robocal.io.library import builtin  # noqa: E402
from robocal.planning import box_candidates, design_poses, joint_candidates  # noqa: E402
from robocal.simulation import liu2022, make_true_robot  # noqa: E402

SIZES = (15, 20, 30, 50, 100)
NOISE_DRAWS = 4
RANDOM_DRAWS = 20
# A design depends on its seed (the k-means start of its strata): the designed figures are
# the mean over these seeds, as the random ones are over their draws.
DESIGN_SEEDS = 5
# Every curve runs with each set: "full", as `robocal calibrate` fits by default, and
# "full+compliance", what a user who knows the robot sags under gravity fits (the simulated
# KR 150-2 has gravity compliance).  `--parameters SET` runs one of them only.
PARAMETER_SETS = ("full", "full+compliance")


def stats(errors):
    return np.array([errors.mean(), np.sqrt(np.mean(errors ** 2)), errors.max()])


class Case:
    """Candidates, a held-out set and a way to measure: a simulated robot or real data."""

    def __init__(self, chain, candidates, test_q, test_p, measure, parameters="full"):
        self.chain, self.candidates, self.test_q, self.test_p, self.measure = chain, candidates, test_q, test_p, measure
        # The parameter set both the design and every calibration (designed, random, floor) use.
        self.parameters = parameters

    def with_parameters(self, parameters):
        return Case(self.chain, self.candidates, self.test_q, self.test_p, self.measure, parameters)

    def score(self, index, draw=0):
        """(mean, RMS, max) held-out of a calibration on the candidates ``index`` (in that
        order), the fit's residual sigma per coordinate (dof-corrected), or None if refused."""
        q = self.candidates[index]
        p = self.measure(index, draw)
        try:
            fit = KinematicCalibration(self.parameters).fit(self.chain, q, p)
        except InputError:
            return None
        residual = p - fit.predict(q)
        dof = max(residual.size - len(fit.names_), 1)
        return stats(np.linalg.norm(fit.predict(self.test_q) - self.test_p, axis=1)), np.sqrt(np.sum(residual ** 2) / dof)

    def repeated(self, indices, draws):
        """Mean figures over designs (``indices``, one array each) and noise draws."""
        found = [self.score(index, d) for index in indices for d in range(draws)]
        kept = [f for f in found if f is not None]
        if not kept:
            return None, None, len(found)
        return np.mean([k[0] for k in kept], axis=0), np.mean([k[1] for k in kept]), len(found) - len(kept)

    def random(self, n):
        rng = np.random.default_rng(1000 + n)
        found = [self.score(rng.choice(len(self.candidates), n, replace=False), d) for d in range(RANDOM_DRAWS)]
        kept = [f[0] for f in found if f is not None]
        return (np.mean(kept, axis=0) if kept else None), RANDOM_DRAWS - len(kept)


def kr_case(box=False):
    chain = builtin("kr150-2")
    truth = make_true_robot(chain, "typical", seed=0)
    if box:
        posture = np.radians(liu2022.POSTURE_DEG)
        down = chain.fk(posture)[:3, :3]
        cand = box_candidates(chain, 10_000, liu2022.BOX_LOW, liu2022.BOX_HIGH, down, seed=0, hint=posture)
        test_q = box_candidates(chain, 1000, liu2022.BOX_LOW, liu2022.BOX_HIGH, down, seed=1, hint=posture)
    else:
        cand = joint_candidates(chain, 10_000, seed=0)
        test_q = chain.random_configurations(1000, np.random.default_rng(2024))
    test_p = truth.measure(test_q, np.random.default_rng(2025))

    def measure(index, draw):
        return truth.measure(cand[index], np.random.default_rng(draw))

    return Case(chain, cand, test_q, test_p, measure)


def ur5_case():
    chain, data = ur5_tsinghua()
    q = chain.joints_from_file(data.joints)
    order = np.random.default_rng(0).permutation(len(q))
    test, pool = order[:300], np.sort(order[300:])
    cand, positions = q[pool], data.positions[pool]
    return Case(chain, cand, q[test], data.positions[test], lambda index, draw: positions[index])


def fmt(values):
    return "   refused  " if values is None else f"{values[0]:.4f} / {values[1]:.4f} / {values[2]:.4f}"


def curve(name, case, draws, floor_count):
    print(f"\n== {name}, parameters {case.parameters}: held-out mean / RMS / max (mm); {len(case.candidates)} "
          f"candidates, {len(case.test_q)} held out")
    floor_index = np.random.default_rng(7).choice(len(case.candidates), min(floor_count, len(case.candidates)),
                                                  replace=False)
    floor = case.score(floor_index)
    print(f"floor (calibrated on {len(floor_index)} candidates): {fmt(None if floor is None else floor[0])}")
    print(f"{'N':>4}  {'designed, tour (mean of 5)':>26}  {'designed, random order':>26}  {'d-optimal, tour':>26}  "
          f"{'random (mean of 20)':>26}  refused t/o/d/r  gain of tour's mean vs random")
    rows = {}
    for n in SIZES:
        designs = [design_poses(case.chain, n, case.candidates, parameters=case.parameters, seed=seed)
                   for seed in range(DESIGN_SEEDS)]
        designed = case.repeated([d.indices for d in designs], draws)
        shuffled = case.repeated([np.random.default_rng(5).permutation(d.indices) for d in designs], draws)
        d_optimal = case.repeated([design_poses(case.chain, n, case.candidates, criterion="d-optimal",
                                                parameters=case.parameters).indices], draws)
        rand, refused = case.random(n)
        best = designed[0]
        gain = "-" if best is None or rand is None else f"{100 * (1 - best[0] / rand[0]):+.1f} %"
        print(f"{n:>4}  {fmt(best):>26}  {fmt(shuffled[0]):>26}  {fmt(d_optimal[0]):>26}  {fmt(rand):>26}  "
              f"{designed[2]}/{shuffled[2]}/{d_optimal[2]}/{refused:<6}  {gain}", flush=True)
        rows[n] = (designs, designed, rand)
    return rows


def predicted(name, rows):
    print(f"\n== {name}: predicted against measured held-out RMS (mm) of the designed poses (mean over the designs)")
    print(f"{'N':>4}  {'measured':>9}  {'stated 0.02':>12}  {'ratio':>6}  {'own residual':>13}  {'ratio':>6}")
    for n, (designs, (measured, sigma, _), _) in rows.items():
        if measured is None:
            continue
        stated = np.mean([d.held_out_rms for d in designs])
        own = np.mean([np.sqrt((d.model_rms * sigma / d.noise) ** 2 + 3 * sigma ** 2) for d in designs])
        print(f"{n:>4}  {measured[1]:9.4f}  {stated:12.4f}  {stated / measured[1]:6.2f}  {own:13.4f}  "
              f"{own / measured[1]:6.2f}")


def speed():
    chain = builtin("kr150-2")
    runs = []
    for _ in range(3):
        start = time.process_time()
        cand = joint_candidates(chain, 10_000, seed=0)
        drawn = time.process_time()
        design = design_poses(chain, 30, cand)
        runs.append((drawn - start, time.process_time() - drawn))
    best = min(runs, key=sum)
    print(f"\n== speed: 30 of 10,000 candidates, KR 150-2 full set ({len(design.names)} identifiable parameters): "
          f"{best[0]:.2f} s to draw the candidates + {best[1]:.2f} s to design (CPU, one thread, best of 3; "
          f"{design.exchanges} exchanges)")


def figaroh():
    try:
        import figaroh  # noqa: F401
    except ImportError:
        print("\n== FIGAROH is not installed here (optional: pip install figaroh); its paper reports about 41 s "
              "for a D-optimal selection from 1,000 candidates")
        return
    print("\n== FIGAROH is installed, but this bench does not drive it yet: its selection needs a URDF and its own "
          "calibration configuration")


def variance():
    from robocal.planning.criteria import VarianceKernel, VarianceState

    chain = builtin("kr150-2")
    cand = joint_candidates(chain, 10_000, seed=0)
    kernel = VarianceKernel.default(chain, cand)
    points = kernel.points(chain, cand)

    def left(index):
        state = VarianceState(points, kernel)
        for i in index:
            state.add(i)
        return -state.score

    print("\n== variance: largest predictive variance left over 10,000 KR 150-2 candidates (relative to the prior's)")
    print(f"{'N':>4}  {'variance':>9}  {'space-filling':>13}  {'random (mean of 20)':>20}  {'CPU s':>6}")
    rng = np.random.default_rng(0)
    for n in SIZES:
        start = time.process_time()
        design = design_poses(chain, n, cand, criterion="variance")
        seconds = time.process_time() - start
        spread = left(design_poses(chain, n, cand, criterion="space-filling").indices)
        rand = np.mean([left(rng.choice(len(cand), n, replace=False)) for _ in range(RANDOM_DRAWS)])
        print(f"{n:>4}  {design.max_variance:9.3f}  {spread:13.3f}  {rand:20.3f}  {seconds:6.2f}", flush=True)


def sockets():
    from robocal.estimation.constraint import ConstraintCalibration, socket_errors
    from robocal.io.fixtures import Fixture
    from robocal.kinematics.ik import solve_ik
    from robocal.planning import design_sockets, socket_candidates
    from robocal.simulation import TrueRobot
    from robocal.simulation.sampling import socket_plan
    from robocal.spatial import compose_pose

    plate = Fixture("plate", {"A": [0.0, 0.0, 0.0], "B": [150.0, 0.0, 0.0], "C": [0.0, 120.0, 0.0]})
    chain = builtin("panda").replace(tool=compose_pose([0.0, 0.0, 133.4], np.zeros(3)))
    deviations = make_true_robot(chain, "typical", 6).deviations
    truth = TrueRobot(nominal=chain, deviations={k: v for k, v in deviations.items() if not k.startswith("base")})
    cand = socket_candidates(chain, plate, socket_plan(chain, plate, 8, 1, rng=20).placements)
    test = socket_plan(truth, plate, 3, 8, rng=4)
    centres = np.array([plate.sockets[s] for s in plate.ids])
    target = chain.fk(cand.joints)
    poses = cand.poses[cand.placement]
    target[:, :3, 3] = np.einsum("kij,kj->ki", poses[:, :3, :3], centres[cand.socket]) + poses[:, :3, 3]
    seated = solve_ik(truth.actual, target, cand.joints).q  # the true robot's joints with the ball in the socket

    def held_out(index, draw):
        q = seated[index] + np.random.default_rng(draw).normal(size=(len(index), chain.n_joints)) * np.radians(0.005)
        try:
            fit = ConstraintCalibration().fit(chain, q, np.array(cand.names)[cand.placement[index]],
                                              np.array(plate.ids)[cand.socket[index]], plate)
        except InputError:
            return np.nan
        return socket_errors(fit.chain_, test.joints, test.fixture_ids, test.socket_ids, plate)["mean_mm"]

    print(f"\n== sockets: simulated Panda, 3 of {len(cand.poses)} placements ({len(cand.joints)} candidate "
          "configurations); held-out socket consistency, mean mm")
    print(f"{'per socket':>10}  {'prediction':>10}  {'d-optimal':>10}  {'random (mean of 20)':>20}  gain")
    for per_socket in (3, 4, 6, 8):
        found = {}
        for criterion in ("prediction", "d-optimal"):
            index = design_sockets(chain, cand, per_socket, 3, criterion=criterion).indices
            found[criterion] = np.nanmean([held_out(index, d) for d in range(NOISE_DRAWS)])
        rng = np.random.default_rng(per_socket)
        usable = [k for k in range(len(cand.poses))
                  if np.bincount(cand.socket[cand.placement == k], minlength=3).min() >= per_socket]
        draws = []
        for d in range(RANDOM_DRAWS):
            places = rng.choice(usable, 3, replace=False)
            index = np.concatenate([rng.choice(np.flatnonzero(cand.group == k * 3 + s), per_socket, replace=False)
                                    for k in places for s in range(3)])
            draws.append(held_out(index, d))
        rand = np.nanmean(draws)
        print(f"{per_socket:>10}  {found['prediction']:10.4f}  {found['d-optimal']:10.4f}  {rand:20.4f}  "
              f"{100 * (1 - found['prediction'] / rand):+.1f} %", flush=True)


def main(args):
    warnings.simplefilter("ignore")
    sets = PARAMETER_SETS
    if "--parameters" in args:
        at = args.index("--parameters")
        sets, args = (args[at + 1],), args[:at] + args[at + 2:]
    parts = set(args) or {"kr", "ur5", "box", "predicted", "speed", "variance", "sockets", "figaroh"}
    results = {}
    cases = {"kr": ("KR 150-2, --errors typical", kr_case, NOISE_DRAWS, 5000),
             "ur5": ("UR5 (Tsinghua, real)", ur5_case, 1, 700),
             "box": ("KR 150-2 in the Kriging paper's box, one orientation", lambda: kr_case(box=True), NOISE_DRAWS,
                     5000)}
    for key, (name, make, draws, floor_count) in cases.items():
        if key in parts or (key != "box" and "predicted" in parts):
            case = make()
            for parameters in sets:
                results[key, parameters] = curve(name, case.with_parameters(parameters), draws, floor_count)
    if "predicted" in parts:
        for (name, parameters), rows in results.items():
            if name != "box":
                predicted(f"{name}, {parameters}", rows)
    if "speed" in parts:
        speed()
    if "variance" in parts:
        variance()
    if "sockets" in parts:
        sockets()
    if "figaroh" in parts:
        figaroh()


if __name__ == "__main__":
    main(sys.argv[1:])
