"""Positioning-error statistics, the same everywhere a figure is printed or saved."""
import numpy as np


def error_stats(errors):
    """Statistics of (N, 3) position errors (mm): single-point and per-axis.

    Returns a JSON-ready dict: n, mean_mm, rms_mm, max_mm, p95_mm of the single-point error
    |e|, and per axis the mean and max of |e_x|, |e_y|, |e_z|.
    """
    errors = np.asarray(errors, dtype=float).reshape(-1, 3)
    norm = np.linalg.norm(errors, axis=1)
    if norm.size == 0:
        return {"n": 0}
    out = {
        "n": int(norm.size),
        "mean_mm": float(norm.mean()),
        "rms_mm": float(np.sqrt(np.mean(norm**2))),
        "max_mm": float(norm.max()),
        "p95_mm": float(np.percentile(norm, 95)),
    }
    for k, axis in enumerate("xyz"):
        magnitude = np.abs(errors[:, k])
        out[f"{axis}_mean_mm"] = float(magnitude.mean())
        out[f"{axis}_max_mm"] = float(magnitude.max())
    return out
