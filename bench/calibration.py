"""Kinematic calibration: robocal beside pybotics and FIGAROH, then robocal on real data.

Simulated data: a KUKA KR 150-2 whose every DH link parameter (theta, d, a, alpha) is off by
a normal deviation of sigma 0.5 mm or 0.05 deg, with a base off by 2 mm and 0.2 deg per axis,
measured by a tracker with 0.02 mm noise per coordinate at joint-uniform poses.  For 100, 500
and 2,000 training poses it prints each tool's fit time (median over the runs shown) and the
mean and largest error of its fitted model over 1,000 other poses, scored against the true
(noise-free) positions, and the RMS residual on its own training readings (equal values
mean the same least-squares optimum was reached).  Every tool gets the same poses and readings.

The peers are used through their own calibration APIs, on one core:

* pybotics: a ``Robot`` on an ``MDHKinematicChain`` (the exact MDH form of the nominal
  model), an ``OptimizationHandler`` whose masks free the world frame, the tool position and
  every MDH parameter that position data can identify, and ``scipy.optimize.least_squares``
  on ``optimize_accuracy``, as its tests do.  Shown with least_squares' default method (trf)
  and with method="lm".
* FIGAROH: the URDF robocal exports (metres), a unified YAML configuration, the readings as
  its CSV, and a ``BaseCalibration`` subclass whose cost function is the one of its UR10
  example; base and marker frames unknown, as its examples set them.  Shown with its
  default parameter selection ("structural") and with "excitation".  Its time covers
  reading its input files, its parameter selection and its fit; writing the files is not timed.

Hayati's beta (a tilt of the parallel axes 2 and 3 that plain (M)DH cannot express) is left
at zero in the simulated robot, so that every tool's model can represent it exactly.

robocal is shown twice: as it calibrates by default (maximum a posteriori, every link
parameter weighed against its manufacturing tolerance) and with ``prior="none"`` (plain
least squares), in the same run, so that the prior's cost and effect read off one table.

Real data: robocal's ``KinematicCalibration()`` (register=True) on the UR5 Tsinghua set
(random half to train, half to test) and the ipa UR10 series B (random 70 / 30, weighted by
the readings' standard deviations), before (nominal geometry with base and tool registered
on the training poses) and after, then the same pooled over a 5-fold cross-validation.

Large data (``--large``): the same simulated robot measured at 1,000,000 joint-uniform poses,
calibrated with ``KinematicCalibration()`` (full parameters, registration) in a child process
whose wall and CPU seconds and peak memory (the whole process, data included) are printed,
with the held-out error on 1,000 other poses.  Above ``least_squares.BLOCK_POSES`` poses the
identification Jacobian is formed over blocks of poses (normal equations for the fit, a
tall-skinny QR for the identifiability analysis and the standard errors); the second line is
the same fit with the whole Jacobian held, as before.

    python bench/calibration.py            # about 11 min with both peers installed
    python bench/calibration.py --quick    # 100 and 500 poses, fewer runs: about 3 min
    python bench/calibration.py --large    # 1,000,000 poses, blocked and whole: about 5 min
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets are stated
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import io  # noqa: E402
import logging  # noqa: E402
import multiprocessing  # noqa: E402
import resource  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from importlib import metadata  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from robocal.errors import InputError  # noqa: E402
from robocal.estimation import least_squares  # noqa: E402
from robocal.estimation.calibration import KinematicCalibration  # noqa: E402
from robocal.estimation.metrics import error_stats  # noqa: E402
from robocal.estimation.registration import register_base_and_tool  # noqa: E402
from robocal.estimation.validation import k_fold  # noqa: E402
from robocal.io.library import builtin  # noqa: E402
from robocal.io.observations import Observations  # noqa: E402
from robocal.kinematics import to_mdh  # noqa: E402
from robocal.methods import KinematicMethod  # noqa: E402
from robocal.methods.validation import method_fitter  # noqa: E402
from robocal.simulation import uniform_joints  # noqa: E402

SIZES = (100, 500, 2000)
QUICK_SIZES = (100, 500)
N_TEST = 1000
LINK_LENGTH_SIGMA_MM = 0.5
LINK_ANGLE_SIGMA_DEG = 0.05
BASE_LENGTH_SIGMA_MM = 2.0
BASE_ANGLE_SIGMA_DEG = 0.2
NOISE_MM = 0.02
ROBOCAL_RUNS = (7, 3)  # full, quick
PEER_RUNS = (3, 1)
PEER_BUDGET_S = 20.0  # no further timing runs of a peer once its runs took this long
MM_PER_M = 1000.0


# ----------------------------------------------------------------------------- data
def simulated_robot(chain, rng):
    """The true robot: link and base deviations drawn once (see the module docstring)."""
    links = [name for name in chain.parameter_names(("links",)) if not name.startswith("beta")]
    base = chain.parameter_names(("base",))
    sigma = [np.radians(LINK_ANGLE_SIGMA_DEG) if chain.is_angular(n) else LINK_LENGTH_SIGMA_MM for n in links]
    sigma += [np.radians(BASE_ANGLE_SIGMA_DEG) if chain.is_angular(n) else BASE_LENGTH_SIGMA_MM for n in base]
    return chain.perturbed(links + base, rng.normal(size=len(sigma)) * np.array(sigma))


def median_time(func, runs, budget=np.inf):
    """(result of the last call, median seconds, runs done): up to ``runs`` calls, fewer
    once they have taken ``budget`` seconds together."""
    times = []
    while len(times) < runs and sum(times) < budget:
        t0 = time.perf_counter()
        result = func()
        times.append(time.perf_counter() - t0)
    return result, float(np.median(times)), len(times)


# ----------------------------------------------------------------------------- tools
class Robocal:
    """robocal's KinematicCalibration with its defaults (full parameters, registration,
    maximum a posteriori under the tolerances), or with ``prior="none"`` (plain least squares)."""

    def __init__(self, chain, prior="tolerances"):
        self.chain = chain
        self.prior = prior
        self.name = "robocal" if prior == "tolerances" else "robocal, plain least squares"

    def prepare(self, joints, measured):
        return joints, measured

    def fit(self, prepared):
        calibration = KinematicCalibration(prior=self.prior).fit(self.chain, *prepared)
        return calibration.predict, len(calibration.names_), calibration, ""


class Pybotics:
    """pybotics' Robot + OptimizationHandler + least_squares(optimize_accuracy)."""

    def __init__(self, chain, method):
        from pybotics.kinematic_chain import MDHKinematicChain
        from pybotics.robot import Robot
        from pybotics.tool import Tool

        self.name = f"pybotics {metadata.version('pybotics')} {method}"
        self.chain, self.method = chain, method
        mdh = to_mdh(chain)
        # The DH -> MDH regrouping is exact; pybotics has no Hayati beta, which is zero here.
        assert not np.any(mdh.beta)
        rows = np.column_stack([mdh.alpha, mdh.a, mdh.theta, mdh.d])  # pybotics' column order
        self.nominal = lambda: Robot(MDHKinematicChain(rows), tool=Tool(mdh.flange @ mdh.tool),
                                     world_frame=mdh.base.copy())
        # Position data identify 26 MDH parameters: link 1 (alpha0, a0, theta1, d1) only moves
        # the world frame, d3 slides along the same direction as d2 (axes 2 and 3 are
        # parallel), and theta6 and d6 move the TCP like the tool position does.
        mask = np.ones((chain.n_joints, 4), dtype=bool)
        mask[0, :] = False
        mask[2, 3] = False
        mask[5, 2:] = False
        self.chain_mask = mask.ravel().tolist()

    def prepare(self, joints, measured):
        # pybotics has no joint signs: it gets the model variables (KUKA's A1, A4, A6 turn the
        # other way round), in the same mm and rad as robocal.
        return self.chain.model_joints(joints), measured

    def fit(self, prepared):
        import scipy.optimize
        from pybotics.optimization import OptimizationHandler, optimize_accuracy

        joints, measured = prepared
        handler = OptimizationHandler(robot=self.nominal(), kinematic_chain_mask=self.chain_mask,
                                      tool_mask=[True] * 3 + [False] * 3, world_mask=True)
        result = scipy.optimize.least_squares(optimize_accuracy, handler.generate_optimization_vector(),
                                              args=(handler, joints, measured), method=self.method)
        robot = handler.robot

        def predict(test_joints):
            return np.array([robot.fk(q)[:3, 3] for q in self.chain.model_joints(test_joints)])

        note = "" if result.status > 0 else f"stopped: {result.message}"
        return predict, int(sum(self.chain_mask)) + 3 + 6, None, note


FIGAROH_CONFIG = """\
robot:
  name: kr150-2
  properties:
    joints:
      active_joints: [{joints}]
tasks:
  calibration:
    enabled: true
    parameters:
      calibration_level: full_params
      include_non_geometric: false
      estimation:
        method: {method}
    kinematics:
      base_frame: universe
      tool_frame: tcp
    measurements:
      markers:
        - name: ball
          reference_joint: joint_{n}
          measurable_dof: [true, true, true, false, false, false]
      poses:
        base_pose: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        tool_pose: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    data:
      source_file: {data}
      number_of_samples: {count}
"""


class Figaroh:
    """FIGAROH's BaseCalibration on robocal's URDF export, files in a scratch folder."""

    def __init__(self, chain, method, folder):
        from figaroh.calibration import BaseCalibration
        from figaroh.calibration.calibration_tools import calc_updated_fkm
        from figaroh.tools.robot import load_robot

        from robocal.io.urdf import write_urdf

        class PositionCalibration(BaseCalibration):
            def cost_function(self, var):
                # As FIGAROH's UR10 example: log-map residuals, position weight 1.
                estimated = calc_updated_fkm(self.model, self.data, var, self.q_measured, self.calib_config)
                residuals = self._compute_logmap_residuals(self.PEE_measured, estimated)
                return self.apply_measurement_weighting(residuals, pos_weight=1.0, orient_weight=0.5)

        self.name = f"FIGAROH {metadata.version('figaroh')} {method}"
        self.chain, self.method, self.folder = chain, method, Path(folder)
        self.calibration_class, self.forward = PositionCalibration, calc_updated_fkm
        # The URDF joint values are the controller's (robocal folds signs into the axes).
        self.robot = load_robot(str(write_urdf(chain, self.folder / "robot.urdf")), load_by_urdf=True)
        self.joint_names = [f"joint_{k}" for k in range(1, chain.n_joints + 1)]

    def prepare(self, joints, measured):
        data = self.folder / f"poses_{len(joints)}.csv"
        header = self.joint_names + ["x1", "y1", "z1"]
        table = np.hstack([joints, measured / MM_PER_M])  # FIGAROH works in metres
        np.savetxt(data, table, delimiter=",", header=",".join(header), comments="")
        config = self.folder / f"config_{self.method}_{len(joints)}.yaml"
        config.write_text(FIGAROH_CONFIG.format(joints=", ".join(self.joint_names), method=self.method,
                                                n=self.chain.n_joints, data=data, count=len(joints)))
        return config

    def fit(self, config):
        calibration = self.calibration_class(self.robot, str(config))
        calibration.calib_config["known_baseframe"] = False
        calibration.calib_config["known_tipframe"] = False
        with contextlib.redirect_stdout(io.StringIO()):  # its quality report
            calibration.initialize()
            result = calibration.solve(enable_logging=False)
        settings = calibration.calib_config

        def predict(test_joints):
            q = np.tile(np.asarray(settings["q0"], dtype=float), (len(test_joints), 1))
            q[:, settings["config_idx"]] = test_joints
            flat = self.forward(calibration.model, calibration.data, result.x, q,
                                dict(settings, NbSample=len(q)))
            return flat.reshape(3, -1).T * MM_PER_M  # component-major, metres

        note = "" if result.success else f"solver failed: {result.message}"
        return predict, len(settings["param_name"]), None, note


def peers(chain, folder):
    """The peer tools that import, and a note for each one that does not."""
    tools, notes = [], []
    try:
        import pybotics  # noqa: F401
        tools += [Pybotics(chain, "trf"), Pybotics(chain, "lm")]
    except ImportError:
        notes.append("pybotics is not installed: pip install pybotics to compare")
    try:
        with warnings.catch_warnings():
            # pinocchio and ndcurves both register the same converters at import.
            warnings.simplefilter("ignore", RuntimeWarning)
            tools += [Figaroh(chain, "structural", folder), Figaroh(chain, "excitation", folder)]
        logging.getLogger("figaroh").setLevel(logging.ERROR)
    except ImportError as why:
        notes.append(f"FIGAROH is not available ({why}): pip install figaroh to compare")
    return tools, notes


# ----------------------------------------------------------------------------- simulation
def simulated_benchmark(sizes, robocal_runs, peer_runs):
    chain = builtin("kr150-2")
    rng = np.random.default_rng(2024)
    truth = simulated_robot(chain, rng)
    # The full set is drawn even for --quick, so that both runs score the same data.
    joints = uniform_joints(chain, max(SIZES), rng)
    measured = truth.fk_positions(joints) + rng.normal(scale=NOISE_MM, size=(len(joints), 3))
    test_joints = uniform_joints(chain, N_TEST, rng)
    test_true = truth.fk_positions(test_joints)

    nominal = np.linalg.norm(test_true - chain.fk_positions(test_joints), axis=1)
    print(f"KUKA KR 150-2, {LINK_LENGTH_SIGMA_MM} mm / {LINK_ANGLE_SIGMA_DEG} deg link deviations, base off by "
          f"{BASE_LENGTH_SIGMA_MM} mm / {BASE_ANGLE_SIGMA_DEG} deg, {NOISE_MM} mm tracker noise, joint-uniform poses")
    print(f"nominal model on the {N_TEST} test poses: mean {nominal.mean():.3f} mm, max {nominal.max():.3f} mm")
    print(f"train RMS: residual on the training readings; held-out: error against the true positions of "
          f"{N_TEST} other poses (mm); one core\n")

    with tempfile.TemporaryDirectory(prefix="robocal-bench-") as folder:
        tools, notes = peers(chain, folder)
        for note in notes:
            print(note)
        header = (f"{'n':>5}  {'tool':<28}{'params':>7}{'fit s':>10}{'runs':>6}{'train RMS':>11}"
                  f"{'held-out mean':>15}{'max mm':>9}")
        print(header)
        print("-" * len(header))
        largest = None
        for n in sizes:
            for tool in [Robocal(chain), Robocal(chain, "none")] + tools:
                runs, budget = (robocal_runs, np.inf) if isinstance(tool, Robocal) else (peer_runs, PEER_BUDGET_S)
                prepared = tool.prepare(joints[:n], measured[:n])
                try:
                    (predict, n_params, calibration, note), seconds, done = median_time(
                        lambda: tool.fit(prepared), runs, budget)
                except Exception as error:  # a peer that fails is reported, the table goes on
                    print(f"{n:>5}  {tool.name:<28}failed: {type(error).__name__}: {error}")
                    continue
                train_rms = error_stats(measured[:n] - predict(joints[:n])).rms_mm
                error = np.linalg.norm(predict(test_joints) - test_true, axis=1)
                print(f"{n:>5}  {tool.name:<28}{n_params:>7}{seconds:>10.3f}{done:>6}{train_rms:>11.4f}"
                      f"{error.mean():>15.4f}{error.max():>9.4f}  {note}".rstrip(), flush=True)
                if calibration is not None and tool.name == "robocal":
                    largest = calibration
    report = largest.result_.identifiability
    print(f"\nrobocal's identifiability report at n = {max(sizes)}: {len(report.identified)} parameters "
          f"identified, condition number {report.condition_number:.0f}; fixed:")
    for name, reason in report.fixed.items():
        print(f"  {name}: {reason}")


# ----------------------------------------------------------------------------- real data
def _split(n, fraction, seed=0):
    order = np.random.default_rng(seed).permutation(n)
    cut = int(round(fraction * n))
    return order[:cut], order[cut:]


def _nominal_fitter(chain, joints, positions):
    """The "before" model as a fitter: nominal geometry, base and tool registered on the
    training poses."""
    def fit(train):
        reference, _ = register_base_and_tool(chain, joints[train], positions[train])
        return lambda test: reference.fk_positions(joints[test])
    return fit


def _stats(stats):
    return f"{stats['mean_mm']:>8.4f}{stats['rms_mm']:>8.4f}{stats['max_mm']:>8.4f}"


def real_data_benchmark():
    from robocal.io.datasets import ipa_ur10, ur5_tsinghua

    datasets = (("UR5 Tsinghua", ur5_tsinghua, 0.5), ("ipa UR10 series B", lambda: ipa_ur10("B"), 0.7))
    print("\nrobocal KinematicCalibration() on real data, held-out poses only (mm)")
    header = (f"{'dataset':<19}{'validation':<17}{'train/test':>11}   {'before: mean':>12}{'RMS':>8}{'max':>8}"
              f"   {'after: mean':>11}{'RMS':>8}{'max':>8}")
    print(header)
    print("-" * len(header))
    for label, load, fraction in datasets:
        try:
            dataset = load()
        except InputError as why:
            print(f"{label:<19}skipped: {why}")
            continue
        chain, data = dataset.chain, dataset.observations
        joints, positions, sigmas = data.joints, data.positions, data.sigmas
        train, test = _split(data.n_poses, fraction)
        reference, _ = register_base_and_tool(chain, joints[train], positions[train])
        before = error_stats(positions[test] - reference.fk_positions(joints[test])).to_dict()
        calibration = KinematicCalibration().fit(chain, joints[train], positions[train],
                                                 sigmas=None if sigmas is None else sigmas[train])
        after = error_stats(positions[test] - calibration.predict(joints[test])).to_dict()
        split = f"random {fraction:.0%}/{1 - fraction:.0%}"
        print(f"{label:<19}{split:<17}{f'{train.size}/{test.size}':>11}   {_stats(before):>28}   {_stats(after):>27}")
        folds = 5
        cv_before = k_fold(data.n_poses, _nominal_fitter(chain, joints, positions), positions, k=folds)
        fitter = method_fitter(KinematicMethod(), chain, Observations.of(joints, positions, sigmas=sigmas))
        cv_after = k_fold(data.n_poses, fitter, positions, k=folds)
        counts = f"{data.n_poses - data.n_poses // folds}/{data.n_poses // folds}"
        print(f"{'':<19}{f'{folds}-fold, pooled':<17}{counts:>11}   {_stats(cv_before['pooled']):>28}   "
              f"{_stats(cv_after['pooled']):>27}", flush=True)


# ----------------------------------------------------------------------------- large data
LARGE_POSES = 1_000_000


def _large_fit(results, n, block):
    """In a child process: simulate, calibrate ``n`` poses with blocks of ``block`` poses, and
    put (wall s, CPU s, peak MB, iterations, parameters, held-out mean and max mm)."""
    least_squares.BLOCK_POSES = block
    chain = builtin("kr150-2")
    rng = np.random.default_rng(2024)
    truth = simulated_robot(chain, rng)
    joints = uniform_joints(chain, n, rng)
    measured = truth.fk_positions(joints) + rng.normal(scale=NOISE_MM, size=(n, 3))
    test = uniform_joints(chain, N_TEST, rng)
    cpu, t0 = time.process_time(), time.perf_counter()
    calibration = KinematicCalibration().fit(chain, joints, measured)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - cpu
    error = np.linalg.norm(calibration.predict(test) - truth.fk_positions(test), axis=1)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    results.put((seconds, cpu, peak, calibration.result_.iterations, len(calibration.names_), error.mean(),
                 error.max()))


def large_benchmark(n=LARGE_POSES):
    print(f"\nKinematicCalibration() on {n:,} simulated KR 150-2 poses ({NOISE_MM} mm noise), one core; "
          f"peak memory of the whole process, data included; held-out error on {N_TEST} other poses (mm)")
    header = f"{'Jacobian':<32}{'fit s':>8}{'(CPU s)':>9}{'peak MB':>9}{'iterations':>11}{'params':>7}{'mean':>9}{'max':>9}"
    print(header)
    print("-" * len(header))
    context = multiprocessing.get_context("fork")
    for label, block in ((f"blocks of {least_squares.BLOCK_POSES:,} poses", least_squares.BLOCK_POSES),
                         ("whole (held at once)", n)):
        results = context.Queue()
        child = context.Process(target=_large_fit, args=(results, n, block))
        child.start()
        row = results.get()
        child.join()
        seconds, cpu, peak, iterations, count, mean, worst = row
        print(f"{label:<32}{seconds:>8.1f}{cpu:>9.1f}{peak:>9.0f}{iterations:>11}{count:>7}{mean:>9.4f}{worst:>9.4f}",
              flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="100 and 500 training poses, fewer runs")
    parser.add_argument("--large", action="store_true", help=f"only the {LARGE_POSES:,}-pose calibration")
    args = parser.parse_args()
    if args.large:
        large_benchmark()
        return
    simulated_benchmark(QUICK_SIZES if args.quick else SIZES, ROBOCAL_RUNS[args.quick], PEER_RUNS[args.quick])
    real_data_benchmark()


if __name__ == "__main__":
    main()
