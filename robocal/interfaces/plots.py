"""The report's figures, drawn with matplotlib's Agg backend (no screen needed).

Each function takes plain arrays (mm, degrees) and returns a matplotlib Figure; the report
turns them into embedded PNGs or PDF pages.  matplotlib is imported here only, so the rest of
robocal starts without it.
"""
import warnings

import numpy as np

from ..errors import RobocalWarning

BEFORE = "#c0504d"
AFTER = "#1f77b4"
# A joint whose values span less than this (deg) over the file was held still.
CONSTANT_JOINT_DEG = 1e-6


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def error_distribution(before, after):
    """Histogram and cumulative distribution of the single-point error |e| (mm)."""
    plt = _pyplot()
    fig, (hist, cdf) = plt.subplots(1, 2, figsize=(10, 3.6))
    before, after = np.linalg.norm(before, axis=1), np.linalg.norm(after, axis=1)
    bins = np.linspace(0.0, max(before.max(), after.max()) * 1.02, 40)
    hist.hist(before, bins=bins, color=BEFORE, alpha=0.6, label="nominal")
    hist.hist(after, bins=bins, color=AFTER, alpha=0.8, label="calibrated")
    hist.set_xlabel("position error |e| (mm)")
    hist.set_ylabel("poses")
    hist.legend()
    for values, color, label in ((before, BEFORE, "nominal"), (after, AFTER, "calibrated")):
        ordered = np.sort(values)
        cdf.plot(ordered, np.arange(1, len(ordered) + 1) / len(ordered), color=color, label=label)
    cdf.axhline(0.95, color="grey", lw=0.7, ls=":")
    cdf.set_xscale("log")
    cdf.set_xlabel("position error |e| (mm, log scale)")
    cdf.set_ylabel("share of poses at or below")
    cdf.grid(True, which="both", lw=0.3)
    cdf.legend(loc="lower right")
    fig.tight_layout()
    return fig


def error_vectors(positions, before, after):
    """Error vectors drawn at their poses in three projections, nominal above, calibrated below,
    both on one scale (given in the titles), so that the arrows compare as the errors do."""
    plt = _pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(12, 7.5))
    planes = ((0, 1, "x", "y"), (0, 2, "x", "z"), (1, 2, "y", "z"))
    span = np.ptp(positions, axis=0).max() or 1.0
    biggest = max(np.linalg.norm(before, axis=1).max(), np.linalg.norm(after, axis=1).max()) or 1.0
    scale = 0.08 * span / biggest  # the largest arrow of either row is 8 % of the workspace
    for row, (errors, color, label) in enumerate(((before, BEFORE, "nominal"), (after, AFTER, "calibrated"))):
        for ax, (i, j, a, b) in zip(axes[row], planes):
            ax.scatter(positions[:, i], positions[:, j], s=3, color="0.6")
            ax.quiver(positions[:, i], positions[:, j], errors[:, i] * scale, errors[:, j] * scale,
                      color=color, angles="xy", scale_units="xy", scale=1.0, width=0.003)
            ax.set_xlabel(f"{a} (mm)")
            ax.set_ylabel(f"{b} (mm)")
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_title(f"{label}: 1 mm error drawn as {scale:.0f} mm", fontsize=9)
    fig.tight_layout()
    return fig


def error_against_joints(joints_deg, before, after):
    """|e| against each joint angle: where in the joint space the errors are."""
    plt = _pyplot()
    n = joints_deg.shape[1]
    cols = min(n, 4)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.8 * rows), squeeze=False)
    before, after = np.linalg.norm(before, axis=1), np.linalg.norm(after, axis=1)
    for k, ax in enumerate(axes.flat):
        if k >= n:
            ax.axis("off")
            continue
        ax.scatter(joints_deg[:, k], before, s=4, color=BEFORE, label="nominal")
        ax.scatter(joints_deg[:, k], after, s=4, color=AFTER, label="calibrated")
        ax.set_xlabel(f"q{k + 1} (deg)")
        if np.ptp(joints_deg[:, k]) < CONSTANT_JOINT_DEG:
            # A joint held still: without this the axis would span its rounding noise.
            centre = float(np.median(joints_deg[:, k]))
            ax.set_xlim(centre - 1.0, centre + 1.0)
            ax.set_xlabel(f"q{k + 1} (deg, constant)")
        ax.set_ylabel("|e| (mm)")
    axes.flat[0].legend(fontsize=8)
    fig.tight_layout()
    return fig


def kriging_uncertainty(model, positions):
    """Predicted standard deviation of the Kriging error model over the horizontal plane
    through the median height of the poses, with the training points that lie near it."""
    plt = _pyplot()
    low, high = positions.min(axis=0), positions.max(axis=0)
    pad = 0.05 * (high - low)
    x = np.linspace(low[0] - pad[0], high[0] + pad[0], 60)
    y = np.linspace(low[1] - pad[1], high[1] + pad[1], 60)
    gx, gy = np.meshgrid(x, y)
    z = float(np.median(positions[:, 2]))
    grid = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, z)])
    with warnings.catch_warnings():
        # Showing where the model extrapolates is the point of this plot, not a mistake.
        warnings.simplefilter("ignore", RobocalWarning)
        _, mse = model.predict(grid, return_mse=True)
    std = np.sqrt(np.clip(np.asarray(mse).reshape(len(grid), -1), 0.0, None).sum(axis=1)).reshape(gx.shape)
    fig, ax = plt.subplots(figsize=(6.5, 5))
    shade = ax.contourf(gx, gy, std, levels=20, cmap="viridis")
    fig.colorbar(shade, ax=ax, label="predicted standard deviation of |e| (mm)")
    near = np.abs(positions[:, 2] - z) < 0.1 * max(np.ptp(positions[:, 2]), 1.0)
    ax.scatter(positions[near, 0], positions[near, 1], s=6, color="white", edgecolor="black", lw=0.3,
               label="poses within 10 % of the height")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"Kriging uncertainty at z = {z:.0f} mm", fontsize=10)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return fig


def fitness_history(history):
    """Best fitness of the genetic algorithm against the generation."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    ax.plot(np.arange(1, len(history) + 1), history, color=AFTER)
    ax.set_xlabel("generation")
    ax.set_ylabel("best fitness")
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    return fig


def learning_curve(curve, nominal=None):
    """Held-out error against the number of training poses (``robocal validate --sizes``):
    mean, RMS and max, the spread of the mean over the repeated draws (shaded), and the
    registered nominal robot's cross-validated mean (``nominal``, mm) as the baseline."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    sizes = [entry["n_train"] for entry in curve]
    for key, style, label in (("mean_mm", "-o", "mean"), ("rms_mm", "-s", "RMS"), ("max_mm", "-^", "max")):
        ax.plot(sizes, [entry["held_out"][key] for entry in curve], style, label=label)
    means = [[r["mean_mm"] for r in entry.get("per_repeat", [entry["held_out"]])] for entry in curve]
    ax.fill_between(sizes, [min(m) for m in means], [max(m) for m in means], color="C0", alpha=0.2,
                    label="mean, spread over draws")
    if nominal is not None:
        ax.axhline(nominal, color=BEFORE, ls="--", lw=1.0, label="nominal (registered), mean")
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter, NullLocator

    ax.set_xscale("log")
    ax.set_yscale("log")
    # Plain numbers at 1-2-5 steps, not powers of ten: the range is often under a decade.
    ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xticks(sizes)
    ax.xaxis.set_major_formatter(FormatStrFormatter("%d"))
    ax.xaxis.set_minor_locator(NullLocator())
    ax.set_xlabel("training poses")
    ax.set_ylabel("held-out |e| (mm)")
    ax.grid(True, which="both", lw=0.3)
    ax.legend()
    fig.tight_layout()
    return fig


OUTSIDE = "#d62728"
TRAINING = "#7f7f7f"


def domain_coverage(training, low, high, margin, joints, inside, units):
    """Training coverage against the evaluated configurations, one panel per joint.

    training: (M, n) training configurations (deg; mm for prismatic joints), drawn as a grey
    histogram; low, high, margin: (n,) each joint's training range and the margin that still
    counts as inside (shaded band, dashed edges); joints: (N, n) the evaluated configurations,
    with ``inside`` (N,) bool: those inside the domain as a blue outline, those flagged as red
    bars (all on the same bins); units: (n,) "deg" or "mm".
    ``Domain.coverage`` gives these arguments.
    """
    plt = _pyplot()
    training, joints = np.asarray(training, dtype=float), np.asarray(joints, dtype=float)
    inside = np.asarray(inside, dtype=bool)
    n = training.shape[1]
    cols = min(n, 3)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 2.6 * rows), squeeze=False)
    finite = np.all(np.isfinite(joints), axis=1)
    for k, ax in enumerate(axes.flat):
        if k >= n:
            ax.axis("off")
            continue
        values = np.concatenate([training[:, k], joints[finite, k]])
        lo, hi = float(values.min()), float(values.max())
        if hi - lo < CONSTANT_JOINT_DEG:
            # A joint held still everywhere: one bin around it instead of rounding noise.
            lo, hi = lo - 1.0, hi + 1.0
        bins = np.linspace(lo, hi, 31)
        ax.axvspan(low[k] - margin[k], high[k] + margin[k], color=TRAINING, alpha=0.12, lw=0)
        for edge in (low[k], high[k]):
            ax.axvline(edge, color=TRAINING, ls="--", lw=0.8)
        ax.hist(training[:, k], bins=bins, color=TRAINING, alpha=0.5, label="training")
        ax.hist(joints[finite & inside, k], bins=bins, histtype="step", lw=1.4, color=AFTER,
                label="evaluated, inside")
        ax.hist(joints[finite & ~inside, k], bins=bins, color=OUTSIDE, alpha=0.75, label="evaluated, outside")
        ax.set_xlabel(f"q{k + 1} ({units[k]})")
        ax.set_ylabel("poses")
    axes.flat[0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def bound_against_error(error, bound, inside):
    """The 95 % bound against the error at each pose (mm, log-log), inside the training
    domain (blue) and outside it (red), with the line bound = error: a pose below the line
    lies within its bound.  error, bound: (N,) mm; inside: (N,) bool.  The title gives the
    share within, which should be about 0.95."""
    plt = _pyplot()
    error, bound = np.asarray(error, dtype=float), np.asarray(bound, dtype=float)
    inside = np.asarray(inside, dtype=bool)
    known = np.isfinite(bound) & (error > 0) & (bound > 0)
    fig, ax = plt.subplots(figsize=(5.2, 4.6))
    for mask, color, label in ((inside, AFTER, "inside the training domain"),
                               (~inside, OUTSIDE, "outside the training domain")):
        chosen = known & mask
        if chosen.any():
            share = np.mean(error[chosen] <= bound[chosen])
            ax.scatter(bound[chosen], error[chosen], s=6, color=color, alpha=0.6,
                       label=f"{label}: {share:.1%} within ({chosen.sum()} poses)")
    if known.any():
        low = min(error[known].min(), bound[known].min()) * 0.8
        high = max(error[known].max(), bound[known].max()) * 1.2
        ax.plot([low, high], [low, high], color="grey", lw=0.8, ls="--", label="error = bound")
        ax.set_xlim(low, high)
        ax.set_ylim(low, high)
        ax.set_title(f"{np.mean(error[known] <= bound[known]):.1%} of the poses within their 95 % bound",
                     fontsize=10)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("95 % bound (mm)")
    ax.set_ylabel("position error |e| (mm)")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    return fig
