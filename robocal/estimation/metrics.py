"""Positioning-error statistics, the same everywhere a figure is printed or saved."""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np


@dataclass(frozen=True)
class ErrorStats:
    """Statistics of position errors, in mm (the unit is in every name, as in the JSON keys).

    Attributes
    ----------
    n : int
        How many errors; 0 leaves every other attribute None.
    mean_mm, rms_mm, max_mm, p95_mm : float or None
        Of the single-point error |e|.
    x_mean_mm, x_max_mm, y_mean_mm, y_max_mm, z_mean_mm, z_max_mm : float or None
        Of |e_x|, |e_y|, |e_z|.
    """

    n: int
    mean_mm: float | None = None
    rms_mm: float | None = None
    max_mm: float | None = None
    p95_mm: float | None = None
    x_mean_mm: float | None = None
    x_max_mm: float | None = None
    y_mean_mm: float | None = None
    y_max_mm: float | None = None
    z_mean_mm: float | None = None
    z_max_mm: float | None = None

    def to_dict(self):
        """JSON-ready: ``{"n": 0}`` for no errors, else every attribute by its name."""
        if self.n == 0:
            return {"n": 0}
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, document):
        """The statistics :meth:`to_dict` wrote (other keys, e.g. orientation figures, are left out)."""
        names = {f.name for f in fields(cls)}
        return cls(**{key: value for key, value in document.items() if key in names})


def error_stats(errors) -> ErrorStats:
    """:class:`ErrorStats` of (N, 3) position errors (mm): single-point and per-axis."""
    errors = np.asarray(errors, dtype=float).reshape(-1, 3)
    norm = np.linalg.norm(errors, axis=1)
    if norm.size == 0:
        return ErrorStats(n=0)
    per_axis = {}
    for k, axis in enumerate("xyz"):
        # Column by column, as the figures always were (a reduction along axis 0 sums in
        # another order and can differ in the last digit).
        magnitude = np.abs(errors[:, k])
        per_axis[f"{axis}_mean_mm"] = float(magnitude.mean())
        per_axis[f"{axis}_max_mm"] = float(magnitude.max())
    return ErrorStats(n=int(norm.size), mean_mm=float(norm.mean()), rms_mm=float(np.sqrt(np.mean(norm**2))),
                      max_mm=float(norm.max()), p95_mm=float(np.percentile(norm, 95)), **per_axis)


def iso9283_position(joints, attained, commanded):
    """ISO 9283-style position accuracy AP and repeatability RP (mm) of the poses in a file.

    Rows with the same joint command (to 1e-6) are visits of one pose.  Per pose, AP is the
    distance from the mean attained position to the commanded one (what the model says the
    command reaches); RP = mean(l) + 3 std(l), l the distance of each visit from that mean,
    for poses visited at least twice.  Returns {"poses", "ap_mean_mm", "ap_max_mm",
    "repeated_poses", "rp_max_mm" (None when no pose was repeated)}.
    """
    joints = np.asarray(joints, dtype=float)
    attained, commanded = (np.asarray(a, dtype=float).reshape(-1, 3) for a in (attained, commanded))
    _, pose_of = np.unique(np.round(joints, 6), axis=0, return_inverse=True)
    pose_of = pose_of.reshape(-1)
    count = np.bincount(pose_of)
    mean = np.array([np.bincount(pose_of, attained[:, k]) for k in range(3)]).T / count[:, None]
    target = np.array([np.bincount(pose_of, commanded[:, k]) for k in range(3)]).T / count[:, None]
    ap = np.linalg.norm(mean - target, axis=1)
    spread = np.linalg.norm(attained - mean[pose_of], axis=1)
    spread_mean = np.bincount(pose_of, spread) / count
    repeated = count >= 2
    squares = np.bincount(pose_of, (spread - spread_mean[pose_of]) ** 2)
    rp = spread_mean[repeated] + 3.0 * np.sqrt(squares[repeated] / (count[repeated] - 1))
    return {"poses": int(len(count)), "ap_mean_mm": float(ap.mean()), "ap_max_mm": float(ap.max()),
            "repeated_poses": int(repeated.sum()), "rp_max_mm": float(rp.max()) if rp.size else None}
