"""The published Kriging compensation experiment on a KUKA KR 150-2 (the "liu2022" case).

The robot is the built-in KR 150-2 model with the geometric deviations below added to its
standard DH parameters, and nothing else (no compliance, backlash or noise).  The targets
are 150 Latin-hypercube points (``scipy.stats.qmc.LatinHypercube(d=3, seed=0)``) in the box
x 1200..2200, y -800..800, z 400..1400 mm of the base frame, all with the flange pointing
down as it does at the controller posture A = (0, -90, 90, 0, 90, 0) deg (DH variable
q = (0, 0, 0, 0, 90, 0) deg); the TCP is the flange centre.  Each target is commanded with
the nominal inverse kinematics on the branch of that posture (A4 = 0, wrist not flipped).
The first 50 points train an error model, the last 100 test it.

Commanding those joints on the true robot gives the published "before compensation"
statistics of the position error e = FK_true(q) - target over **all 150 points**:
mean |e| 1.690 mm, mean |e_y| 1.560 mm, max |e_y| 1.910 mm, mean |e_z| 0.271 mm
(robocal reproduces 1.6900, 1.5604, 1.9099, 0.2705).  Over the 100 test points alone the
mean |e| would be 1.699 mm and over the 50 training points 1.672 mm, so the published
figures are not test-set figures.
"""
import numpy as np

from ..errors import InputError

ROBOT = "kr150-2"
# Per joint: (delta theta deg, delta d mm, delta a mm, delta alpha deg) in the standard DH model.
DEVIATIONS = (
    (0.030, -0.05, -0.30, 0.005),
    (0.010, 0.20, -0.45, 0.030),
    (-0.005, -0.20, 0.15, -0.015),
    (0.020, 0.35, -0.10, -0.010),
    (-0.015, 0.50, 0.25, -0.025),
    (0.005, -0.50, 0.15, -0.030),
)
BOX_LOW = (1200.0, -800.0, 400.0)  # mm, base frame
BOX_HIGH = (2200.0, 800.0, 1400.0)
POSTURE_DEG = (0.0, -90.0, 90.0, 0.0, 90.0, 0.0)  # controller A1..A6, flange pointing down
N_POINTS = 150
N_TRAIN = 50
SEED = 0
# Published before-compensation statistics (mm) over all 150 points, for checking.
PUBLISHED = {"mean": 1.690, "mean_abs_y": 1.560, "max_abs_y": 1.910, "mean_abs_z": 0.271}


def deviations():
    """The published deviations as a parameter-name -> value mapping in file units (mm, deg)."""
    out = {}
    for k, (theta, d, a, alpha) in enumerate(DEVIATIONS, start=1):
        out.update({f"theta{k}": theta, f"d{k}": d, f"a{k}": a, f"alpha{k}": alpha})
    return out


def require_kr150(chain, what):
    """InputError unless ``chain`` is the built-in KR 150-2 model (its limits may differ)."""
    from ..io.library import builtin

    reference = builtin(ROBOT)
    same = (
        chain.convention == reference.convention
        and chain.joint_types == reference.joint_types
        and all(np.allclose(getattr(chain, key), getattr(reference, key), rtol=0, atol=1e-9)
                for key in ("theta", "d", "a", "alpha", "beta", "joint_map", "base", "flange", "tool"))
    )
    if not same:
        raise InputError(
            f"{what} reproduces a published experiment on the KUKA KR 150-2; robot {chain.name!r} "
            f"is not the built-in {ROBOT} model (same DH parameters, joint signs, base and tool). "
            "Use it with the built-in robot 'kr150-2', or use the 'typical' or 'none' errors instead"
        )
