"""Measurement planning (issue 16): designed poses against random ones and against a bound, held out.

    python bench/design.py                 # everything (about 30 minutes on one core)
    python bench/design.py kr ur5 box      # some parts: kr, ur5, box, predicted, speed, variance, sockets, figaroh
    python bench/design.py kr --parameters full+compliance --sizes 15,30   # one parameter set, some sizes

Every figure is held out: a calibration (KinematicCalibration) is trained on the chosen poses
only and scored on a fixed set the design never saw.  Each curve runs twice: with parameters
"full" (what `robocal calibrate` fits by default) and "full+compliance" (designed for, and
calibrated with, the gravity compliances; the simulated KR 150-2 has them).  Designed sets,
random draws, the bound and the floor of a curve are all calibrated with its set.

The columns (held-out mean, mm, ± its standard error over the calibrations averaged):
* designed, tour: `robocal design` as it is by default (5 design seeds, each measured in its
  tour order NOISE_DRAWS times); random order: the same sets measured in a random order
  (backlash: a tour approaches neighbouring poses from the same side, while the held-out poses
  are measured in a random order);
* stated: designed with --joint-noise JOINT_NOISE and --sag SAG deg (the simulated backlash
  and sag; on the UR5 its calibrated residual put at the joints; the sag only counts for
  "full"), tour and random order;
* d-optimal (one design, tour);
* bound: the set an oracle that knows the simulated truth chooses (:func:`simulated_oracle`;
  on the real UR5 one that knows what every candidate measures, :func:`data_oracle`),
  measured like the designs in a random order: what a choice of poses can do here.  It is the
  optimum of the linearised calibration's expected error found by exchange from several
  starts, not a proof: where nonlinearity or the calibration's own choices (a compliance left
  out, a refusal) matter, at 15-20 poses, a design can come out level with it within the
  standard errors;
* random: RANDOM_DRAWS random sets of N candidates (random order).

A calibration that is refused (too few independent equations, or a fit beyond manufacturing
tolerances) counts as the registered nominal robot of its poses (base and tool fitted, what
its user has until measuring again), in every column alike, and the refusals are printed
beside (refused/tried).  Leaving them out, as this bench did before, flattered whichever
column was refused more often: random sets of 15 poses in the box (12-15 of 100; there, with
one TCP orientation, the fit slides the base and the tool position together by hundreds of
mm), designed sets on the UR5 (2 of 5 at 30 poses with "full", 3 of 5 at 20 with
"full+compliance": the fit slides theta5 by 11-32 deg into a second minimum as good as the
first, whose model predicts all 1,000 poses within 0.06 mm of the all-pose calibration, and
the plausibility check refuses it; leaving out almost any one of the 30 poses avoids it).

* kr: simulated KUKA KR 150-2 with --errors typical (geometry, gravity compliance, 0.005 deg
  backlash, 0.02 mm noise; seed 0).  10,000 candidates uniform in the joint limits (5 deg
  margin, as `robocal design` draws them); held-out: 1,000 other uniform configurations,
  measured in a random order.  "floor": the calibration trained on 5,000 candidates (backlash
  is in neither model, compliance not in "full"; the held-out poses' own backlash is about
  0.2 mm mean, which no calibration removes).
* ur5: the real UR5 (Tsinghua, 1,000 grid poses); a fixed random 300 held out, the design
  chooses from the other 700 by their joint values alone; floor: all 700.
* box: the KR 150-2 of kr restricted to the Kriging paper's box (x 1200..2200, y -800..800,
  z 400..1400 mm, flange down, one IK branch): 10,000 candidates, 1,000 held out in the box.
* predicted: the design's predicted held-out RMS against the measured one (calibrations
  made), with the stated noise (0.02 mm), with the noise estimated from the designed poses'
  own residual, and as the stated designs predict (joint noise and sag).
* speed: CPU time of 30 poses out of 10,000 candidates for the full KR 150-2 parameter set,
  without and with the stated joint noise and sag.
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
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import dataclasses  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from robocal.errors import InputError  # noqa: E402
from robocal.estimation.calibration import KinematicCalibration  # noqa: E402
from robocal.estimation.registration import register_base_and_tool  # noqa: E402
from robocal.io.datasets import ur5_tsinghua  # noqa: E402
from robocal.io.library import builtin  # noqa: E402
from robocal.planning import box_candidates, design_poses, information_model, joint_candidates  # noqa: E402
from robocal.planning.criteria import SandwichState, information_start  # noqa: E402
from robocal.planning.exchange import exchange, select  # noqa: E402
from robocal.simulation import liu2022, make_true_robot  # noqa: E402

SIZES = (15, 20, 30, 50, 100)
# Noise draws per designed set of a simulated robot, and random sets per size: at 15 poses one
# calibration's held-out mean varies by 10-20 % with the noise draw and by more between random
# sets, so the means need this many to tell 5 % apart (their standard errors are printed).
NOISE_DRAWS = 8
RANDOM_DRAWS = 100
# A design depends on its seed (the k-means start of its strata): the designed figures are
# the mean over these seeds, as the random ones are over their draws.
DESIGN_SEEDS = 5
# Every curve runs with each set: "full", as `robocal calibrate` fits by default, and
# "full+compliance", what a user who knows the robot sags under gravity fits (the simulated
# KR 150-2 has gravity compliance).  `--parameters SET` runs one of them only.
PARAMETER_SETS = ("full", "full+compliance")
# What the "stated" designs are told: the joint noise (deg; the simulated KR 150-2's
# backlash, on the UR5 about its calibrated residual put at the joints, 0.1 mm RMS over a 1 m
# lever) and, for "full", the sag (deg; the simulated KR 150-2's second joint bends 0.013 deg
# at most; the UR5's 0.08).
JOINT_NOISE = 0.005
SAG = 0.01
# The reading noise the data oracle of real data assumes beside the residuals it knows (mm).
ORACLE_NOISE = 0.001


def standard_error(found):
    """Standard error of the mean held-out mean over calibrations ``found`` (Case.score's)."""
    means = np.array([f[0][0] for f in found])
    return float(means.std(ddof=1) / np.sqrt(len(means))) if len(means) > 1 else 0.0


def stats(errors):
    return np.array([errors.mean(), np.sqrt(np.mean(errors ** 2)), errors.max()])


class Case:
    """Candidates, a held-out set and a way to measure: a simulated robot (``truth``) or real
    data."""

    def __init__(self, chain, candidates, test_q, test_p, measure, parameters="full", truth=None):
        self.chain, self.candidates, self.test_q, self.test_p, self.measure = chain, candidates, test_q, test_p, measure
        self.truth = truth
        # The parameter set both the design and every calibration (designed, random, floor) use.
        self.parameters = parameters

    def with_parameters(self, parameters):
        return Case(self.chain, self.candidates, self.test_q, self.test_p, self.measure, parameters, self.truth)

    def score(self, index, draw=0):
        """((mean, RMS, max) held out, the fit's residual sigma per coordinate (dof-corrected),
        refused) of a calibration on the candidates ``index`` (in that order).  A refused
        calibration scores as the registered nominal robot of those poses (what its user has
        until they measure again), with sigma None."""
        q = self.candidates[index]
        p = self.measure(index, draw)
        try:
            fit = KinematicCalibration(self.parameters).fit(self.chain, q, p)
        except InputError:
            nominal = register_base_and_tool(self.chain, q, p)[0]
            return stats(np.linalg.norm(nominal.fk_positions(self.test_q) - self.test_p, axis=1)), None, True
        residual = p - fit.predict(q)
        dof = max(residual.size - len(fit.names_), 1)
        return (stats(np.linalg.norm(fit.predict(self.test_q) - self.test_p, axis=1)),
                np.sqrt(np.sum(residual ** 2) / dof), False)

    def repeated(self, indices, draws, shuffle=False):
        """(mean figures, mean residual sigma of the calibrations made, refused, tried, mean
        figures of the calibrations made or None) over designs (``indices``, one array each)
        and noise draws; with ``shuffle`` each set is measured in a random order."""
        if shuffle:
            indices = [np.random.default_rng(5 + k).permutation(index) for k, index in enumerate(indices)]
        found = [self.score(index, draws * k + d) for k, index in enumerate(indices) for d in range(draws)]
        made = [f for f in found if not f[2]]
        return (np.mean([f[0] for f in found], axis=0), np.mean([f[1] for f in made]) if made else None,
                sum(f[2] for f in found), len(found), np.mean([f[0] for f in made], axis=0) if made else None,
                standard_error(found))

    def random(self, n):
        rng = np.random.default_rng(1000 + n)
        found = [self.score(rng.choice(len(self.candidates), n, replace=False), d) for d in range(RANDOM_DRAWS)]
        return np.mean([f[0] for f in found], axis=0), sum(f[2] for f in found), standard_error(found)

    def oracle(self):
        """A state factory for the bound (:func:`simulated_oracle` or :func:`data_oracle`)."""
        return simulated_oracle(self) if self.truth is not None else data_oracle(self)


def simulated_oracle(case):
    """The bound's criterion on a simulated robot: the expected held-out mean squared error of
    the (linearised) calibration on a set of candidates, knowing the truth.

    The oracle knows the deviations and the compliance (what the parameter set cannot model
    of them is a known systematic error b_i of each pose), the tracker noise and the
    backlash: measured in a random order of poses spread like the candidates, joint j stands
    at +b on a pose when it came from below, so its offset has the mean b (2 F_j(q_j) - 1)
    (F_j: the share of candidates below q_j), systematic and partly calibrated away, and the
    variance b^2 (1 - (2 F_j - 1)^2) about it.  Greedy selection and exchange on that
    (:class:`~robocal.planning.criteria.SandwichState` with the bias) give the set a design
    would choose if it knew all this; measured as the designs are (random order, noise
    draws), it bounds what a choice of poses can do here."""
    chain, truth, q = case.chain, case.truth, case.candidates
    both = np.concatenate([q, case.test_q])
    clean = dataclasses.replace(truth, backlash=None, noise=0.0)
    half = chain.joints_from_file(truth.backlash) if truth.backlash is not None else np.zeros(chain.n_joints)
    below = np.column_stack([np.searchsorted(np.sort(q[:, j]), both[:, j]) / len(q) for j in range(chain.n_joints)])
    mean = 2 * below - 1
    jac = chain.rigid.jacobian(both)[:, :3, :]
    effective = clean.positions(both) + np.einsum("kij,kj->ki", jac, mean * half)
    fit = KinematicCalibration(case.parameters).fit(chain, both, effective)
    bias = effective - fit.predict(both)
    C = truth.noise ** 2 * np.eye(3) + np.einsum("kij,kj,klj->kil", jac, half ** 2 * (1 - mean ** 2), jac)
    info = information_model(chain, q, case.parameters, noise=1.0)
    rows = info.rows_of(case.test_q)
    W = np.einsum("tip,tiq->pq", rows, rows) / len(rows)
    r = np.einsum("tip,ti->p", rows, bias[len(q):]) / len(rows)
    start = information_start(info.blocks)
    return lambda: SandwichState(info.blocks, start, W, C[:len(q)], bias=bias[:len(q)], r=r)


def data_oracle(case):
    """The bound's criterion on real data: the oracle knows what every candidate measures.
    The calibration on all candidates leaves each a residual b_i; a subset's (linearised)
    calibration moves from the all-candidate one by P A^T b, and the oracle minimises the
    mean squared change of the TCP over the candidates it makes (ORACLE_NOISE beside)."""
    chain, q = case.chain, case.candidates
    p = case.measure(np.arange(len(q)), 0)
    fit = KinematicCalibration(case.parameters).fit(chain, q, p)
    bias = p - fit.predict(q)
    info = information_model(chain, q, case.parameters, noise=1.0)
    W = np.einsum("tip,tiq->pq", info.blocks, info.blocks) / len(q)
    r = np.einsum("tip,ti->p", info.blocks, bias) / len(q)
    C = np.broadcast_to(ORACLE_NOISE ** 2 * np.eye(3), (len(q), 3, 3))
    start = information_start(info.blocks)
    return lambda: SandwichState(info.blocks, start, W, C, bias=bias, r=r)


# The bound's exchange starts from the greedy choice and from this many designs of each kind
# (default and stated): exchange is a local search, and from the stratified designs it
# finds better sets of its criterion than from its own greedy start.
BOUND_STARTS = 2


def bound_set(oracle, n, starts):
    """The set of ``n`` candidates with the best oracle criterion found by exchange from the
    greedy choice and from each of ``starts`` (index arrays)."""
    state = oracle()
    count = len(state.blocks)
    best = select(state, n, np.ones(count, dtype=bool))[0], state.score
    for start in starts:
        state = oracle()
        available = np.ones(count, dtype=bool)
        for i in start:
            state.add(i)
            available[i] = False
        exchange(state, available)
        if state.score > best[1]:
            best = np.array(state.chosen), state.score
    return best[0]


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

    return Case(chain, cand, test_q, test_p, measure, truth=truth)


def ur5_case():
    dataset = ur5_tsinghua()
    chain, data = dataset.chain, dataset.observations
    q = data.joints
    order = np.random.default_rng(0).permutation(len(q))
    test, pool = order[:300], np.sort(order[300:])
    cand, positions = q[pool], data.positions[pool]
    return Case(chain, cand, q[test], data.positions[test], lambda index, draw: positions[index])


def gain(value, reference):
    return f"{100 * (1 - value / reference):+5.1f}"


COLUMNS = ("designed, tour", "random order", "stated, tour", "random order", "d-optimal", "bound", "random")


def curve(name, case, draws, floor_count, sizes=SIZES):
    print(f"\n== {name}, parameters {case.parameters}: held-out mean (mm); {len(case.candidates)} candidates, "
          f"{len(case.test_q)} held out; refused calibrations count as the registered nominal robot")
    floor_index = np.random.default_rng(7).choice(len(case.candidates), min(floor_count, len(case.candidates)),
                                                  replace=False)
    floor = case.score(floor_index)
    print(f"floor (calibrated on {len(floor_index)} candidates): mean {floor[0][0]:.4f}, RMS {floor[0][1]:.4f} mm")
    oracle = case.oracle()
    print(f"{'N':>4}  " + "  ".join(f"{c:>17}" for c in COLUMNS)
          + "  refused (of tried, per column)           "
          + "gain vs random %: tour / random order / stated r.o. / bound")
    rows = {}
    for n in sizes:
        designs = [design_poses(case.chain, n, case.candidates, parameters=case.parameters, seed=seed)
                   for seed in range(DESIGN_SEEDS)]
        noisy = [design_poses(case.chain, n, case.candidates, parameters=case.parameters, seed=seed,
                              joint_noise_deg=JOINT_NOISE, sag_deg=SAG) for seed in range(DESIGN_SEEDS)]
        d_optimal = design_poses(case.chain, n, case.candidates, criterion="d-optimal", parameters=case.parameters)
        bound = bound_set(oracle, n, [d.indices for d in designs[:BOUND_STARTS] + noisy[:BOUND_STARTS]])
        found = [case.repeated([d.indices for d in designs], draws),
                 case.repeated([d.indices for d in designs], draws, shuffle=True),
                 case.repeated([d.indices for d in noisy], draws),
                 case.repeated([d.indices for d in noisy], draws, shuffle=True),
                 case.repeated([d_optimal.indices], draws),
                 case.repeated([bound] * DESIGN_SEEDS, draws, shuffle=True)]
        rand, refused, rand_error = case.random(n)
        means = [f"{f[0][0]:.4f} ±{f[5]:.4f}" for f in found] + [f"{rand[0]:.4f} ±{rand_error:.4f}"]
        refusals = " ".join(f"{f[2]}/{f[3]}" for f in found) + f" {refused}/{RANDOM_DRAWS}"
        print(f"{n:>4}  " + "  ".join(f"{m:>17}" for m in means) + f"  {refusals:<40} "
              + " / ".join(gain(found[k][0][0], rand[0]) for k in (0, 1, 3, 5)), flush=True)
        rows[n] = (designs, found[0], noisy, found[3], rand)
    return rows


def predicted(name, rows):
    print(f"\n== {name}: predicted against measured held-out RMS (mm) of the designed poses (mean over the designs; "
          f"calibrations refused left out)")
    print(f"{'N':>4}  {'measured':>9}  {'stated 0.02':>12}  {'ratio':>6}  {'own residual':>13}  {'ratio':>6}  "
          f"{'stated: measured':>21}  {'predicted':>9}  {'ratio':>6}")
    for n, (designs, (_, sigma, _, _, measured, _), noisy, (_, _, _, _, noisy_measured, _), _) in rows.items():
        if measured is None or noisy_measured is None:
            continue
        stated = np.mean([d.held_out_rms for d in designs])
        own = np.nan if sigma is None else np.mean(
            [np.sqrt((d.model_rms * sigma / d.noise) ** 2 + 3 * sigma ** 2) for d in designs])
        with_joints = np.mean([d.held_out_rms for d in noisy])
        print(f"{n:>4}  {measured[1]:9.4f}  {stated:12.4f}  {stated / measured[1]:6.2f}  {own:13.4f}  "
              f"{own / measured[1]:6.2f}  {noisy_measured[1]:21.4f}  {with_joints:9.4f}  "
              f"{with_joints / noisy_measured[1]:6.2f}")


def speed():
    chain = builtin("kr150-2")
    for joint_noise, sag in ((0.0, 0.0), (JOINT_NOISE, SAG)):
        runs = []
        for _ in range(3):
            start = time.process_time()
            cand = joint_candidates(chain, 10_000, seed=0)
            drawn = time.process_time()
            design = design_poses(chain, 30, cand, joint_noise_deg=joint_noise, sag_deg=sag)
            runs.append((drawn - start, time.process_time() - drawn))
        best = min(runs, key=sum)
        print(f"\n== speed: 30 of 10,000 candidates, KR 150-2 full set ({len(design.names)} identifiable parameters), "
              f"joint noise {joint_noise:g} deg, sag {sag:g} deg: {best[0]:.2f} s to draw the candidates + "
              f"{best[1]:.2f} s to design "
              f"(CPU, one thread, best of 3; {design.exchanges} exchanges; load average "
              f"{os.getloadavg()[0]:.1f})")


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
    sizes = SIZES
    if "--sizes" in args:
        at = args.index("--sizes")
        sizes, args = tuple(int(v) for v in args[at + 1].split(",")), args[:at] + args[at + 2:]
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
                results[key, parameters] = curve(name, case.with_parameters(parameters), draws, floor_count, sizes)
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
