"""Measurement planning (issue 16): designed poses against random ones, held out.

    python bench/design.py                 # everything (about 5 minutes on one core)
    python bench/design.py kr ur5 box      # some parts: kr, ur5, box, predicted, speed, figaroh

Every figure is held out: a calibration (KinematicCalibration, parameters "full", as
`robocal calibrate` fits by default) is trained on the chosen poses only and scored on a
fixed set the design never saw.

* kr: simulated KUKA KR 150-2 with --errors typical (geometry, gravity compliance, 0.005 deg
  backlash, 0.02 mm noise; seed 0).  10,000 candidates uniform in the joint limits (5 deg
  margin, as `robocal design` draws them); held-out: 1,000 other uniform configurations,
  measured.  Designed sets (5 design seeds) are each measured in their tour order 4 times
  (4 noise draws), and in a random order (backlash: a tour approaches neighbouring poses
  from the same side); random sets are 20 draws of N candidates.  "floor": the calibration trained on 5,000
  candidates, what no choice of poses can beat (compliance and backlash are not in the model).
* ur5: the real UR5 (Tsinghua, 1,000 grid poses); a fixed random 300 held out, the design
  chooses from the other 700 by their joint values alone; random: 20 draws from the 700;
  floor: all 700.
* box: the KR 150-2 of kr restricted to the Kriging paper's box (x 1200..2200, y -800..800,
  z 400..1400 mm, flange down, one IK branch): 10,000 candidates, 1,000 held out in the box.
* predicted: the design's predicted held-out RMS against the measured one, with the stated
  noise (0.02 mm) and with the noise estimated from the designed poses' own residual.
* speed: CPU time of 30 poses out of 10,000 candidates for the full KR 150-2 parameter set.
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


def stats(errors):
    return np.array([errors.mean(), np.sqrt(np.mean(errors ** 2)), errors.max()])


class Case:
    """Candidates, a held-out set and a way to measure: a simulated robot or real data."""

    def __init__(self, chain, candidates, test_q, test_p, measure):
        self.chain, self.candidates, self.test_q, self.test_p, self.measure = chain, candidates, test_q, test_p, measure

    def score(self, index, draw=0):
        """(mean, RMS, max) held-out of a calibration on the candidates ``index`` (in that
        order), the fit's residual sigma per coordinate (dof-corrected), or None if refused."""
        q = self.candidates[index]
        p = self.measure(index, draw)
        try:
            fit = KinematicCalibration("full").fit(self.chain, q, p)
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
    print(f"\n== {name}: held-out mean / RMS / max (mm); {len(case.candidates)} candidates, "
          f"{len(case.test_q)} held out")
    floor_index = np.random.default_rng(7).choice(len(case.candidates), min(floor_count, len(case.candidates)),
                                                  replace=False)
    floor = case.score(floor_index)
    print(f"floor (calibrated on {len(floor_index)} candidates): {fmt(None if floor is None else floor[0])}")
    print(f"{'N':>4}  {'designed, tour (mean of 5)':>26}  {'designed, random order':>26}  {'d-optimal, tour':>26}  "
          f"{'random (mean of 20)':>26}  refused t/o/d/r  gain of tour's mean vs random")
    rows = {}
    for n in SIZES:
        designs = [design_poses(case.chain, n, case.candidates, seed=seed) for seed in range(DESIGN_SEEDS)]
        designed = case.repeated([d.indices for d in designs], draws)
        shuffled = case.repeated([np.random.default_rng(5).permutation(d.indices) for d in designs], draws)
        d_optimal = case.repeated([design_poses(case.chain, n, case.candidates, criterion="d-optimal").indices], draws)
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


def main(parts):
    warnings.simplefilter("ignore")
    parts = set(parts) or {"kr", "ur5", "box", "predicted", "speed", "figaroh"}
    results = {}
    if "kr" in parts or "predicted" in parts:
        results["kr"] = curve("KR 150-2, --errors typical", kr_case(), NOISE_DRAWS, 5000)
    if "ur5" in parts or "predicted" in parts:
        results["ur5"] = curve("UR5 (Tsinghua, real)", ur5_case(), 1, 700)
    if "box" in parts:
        results["box"] = curve("KR 150-2 in the Kriging paper's box, one orientation", kr_case(box=True),
                               NOISE_DRAWS, 5000)
    if "predicted" in parts:
        for name in ("kr", "ur5"):
            predicted(name, results[name])
    if "speed" in parts:
        speed()
    if "figaroh" in parts:
        figaroh()


if __name__ == "__main__":
    main(sys.argv[1:])
