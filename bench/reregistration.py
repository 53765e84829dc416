"""Re-registration on a new set-up: UR10 series B -> series A (ipa), whose tracker stood
elsewhere (a B-trained model is metres off on A as it stands).

Each method is trained on all of series B, then re-registered (frames, and frames+offsets)
on 10 or 25 poses of series A spread evenly over its acquisition order, and scored on every
other A pose (held out: in neither selection).  Beside each: the model as it stands (no
re-registration) and the nominal robot registered to the same A poses.

    python bench/reregistration.py            # every method (Kriging and the hybrid on 1,495
                                              # poses take minutes each)
    python bench/reregistration.py kinematic  # some of them
"""
import sys
import time
import warnings

import numpy as np

from robocal.estimation.metrics import error_stats
from robocal.io.datasets import ipa_ur10
from robocal.methods import make_method
from robocal.methods.reregistration import reregister

METHODS = {
    "kinematic": ("kinematic", {"parameters": "full"}),
    "kinematic+compliance": ("kinematic", {"parameters": "full+compliance"}),
    "hybrid": ("hybrid", {}),
    "kriging": ("kriging", {}),
    # Small settings: the L-BFGS-trained network fits 1,495 poses in about a minute.
    "ann": ("ann", {"trainer": "lbfgs", "hidden": (16, 16)}),
}
POSE_COUNTS = (10, 25)
PARAMETERS = ("frames", "frames+offsets")


def evenly(count, total):
    """``count`` row indices spread evenly over ``total`` rows in acquisition order."""
    return np.unique(np.linspace(0, total - 1, count).round().astype(int))


def line(label, stats, extra=""):
    print(f"  {label:<34} {stats['mean_mm']:>9.3f} {stats['rms_mm']:>9.3f} {stats['max_mm']:>9.3f} "
          f"{stats['p95_mm']:>9.3f}  {extra}", flush=True)


def main(names):
    series_b = ipa_ur10("B")
    chain_b, train = series_b.chain, series_b.observations
    new = ipa_ur10("A").observations
    selections = {n: evenly(n, new.n_poses) for n in POSE_COUNTS}
    held = np.setdiff1d(np.arange(new.n_poses), np.concatenate(list(selections.values())))
    test = new.subset(held)
    print(f"UR10 B ({train.n_poses} poses) -> A: re-registered on {' or '.join(map(str, POSE_COUNTS))} A poses, "
          f"tested on the other {test.n_poses}")
    print(f"  {'held-out error (mm)':<34} {'mean':>9} {'RMS':>9} {'max':>9} {'95 %':>9}")
    for name in names:
        method, settings = METHODS[name]
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fitted = make_method(method, **settings).fit(chain_b, train)
        print(f"{name} (fit {time.perf_counter() - start:.1f} s)", flush=True)
        line("as it stands", error_stats(test.positions - fitted.predict(test.joints)).to_dict())
        for count, index in selections.items():
            for parameters in PARAMETERS:
                start = time.perf_counter()
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    again = reregister(fitted, new.subset(index), parameters)
                seconds = time.perf_counter() - start
                record = again.reregistration_
                said = f"rank {record.identifiability.rank}, cond {record.identifiability.condition_number:.0f}"
                if record.identifiability.fixed:
                    said += f", kept {', '.join(record.identifiability.fixed)}"
                said += f", {seconds:.2f} s" + (f", {len(caught)} warning(s)" if caught else "")
                line(f"{count} poses, {parameters}",
                     error_stats(test.positions - again.predict(test.joints)).to_dict(), said)
                if parameters == PARAMETERS[0]:
                    line(f"{count} poses, re-registered nominal",
                         error_stats(test.positions - again.reference_.fk_positions(test.joints)).to_dict())


if __name__ == "__main__":
    chosen = sys.argv[1:] or list(METHODS)
    unknown = [n for n in chosen if n not in METHODS]
    if unknown:
        sys.exit(f"unknown method(s) {', '.join(unknown)}; choose from {', '.join(METHODS)}")
    main(chosen)
