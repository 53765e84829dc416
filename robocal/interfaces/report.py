"""robocal report: one self-contained HTML file (images embedded, opens offline) that an
integrator can hand to a customer, and optionally the same figures and tables as a PDF.

Every number comes from the same functions ``evaluate --json`` uses, so the two agree.
"""
import base64
import datetime as _dt
import html
import io
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import FileFormatError, InputError, RobocalWarning
from ..estimation.metrics import iso9283_position
from ..io.fingerprint import seen_by_model
from ..io.atomic import check_outputs, write_bytes_atomic, write_text_atomic
from . import plots
from .html_style import STYLE
from ..methods.evaluation import position_scores, socket_residuals, socket_scores, with_fixture
from .jobs import load_fitted, read_model_data
from .results import Reported
from .tables import parameter_notes, parameter_rows

# How each kind of method diagnostic (robocal.methods.ReportFigure) is drawn.
DIAGNOSTIC_PLOTS = {
    "kriging_uncertainty": lambda data: plots.kriging_uncertainty(data["model"], data["points"]),
    "fitness_history": lambda data: plots.fitness_history(data["history"]),
}

STATS = (("n", "poses", "{:d}"), ("mean_mm", "mean", "{:.4f}"), ("rms_mm", "RMS", "{:.4f}"),
         ("max_mm", "max", "{:.4f}"), ("p95_mm", "95 %", "{:.4f}"), ("x_mean_mm", "|x| mean", "{:.4f}"),
         ("y_mean_mm", "|y| mean", "{:.4f}"), ("z_mean_mm", "|z| mean", "{:.4f}"))

def _table(header, rows, numeric_from=1):
    """An HTML table; ``header`` None for a two-column key/value table."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header or ())
    body = "".join(
        "<tr>" + "".join(f"<td class=\"{'num' if k >= numeric_from else ''}\">{html.escape(str(v))}</td>"
                         for k, v in enumerate(row)) + "</tr>" for row in rows)
    return f"<table>{f'<tr>{head}</tr>' if head else ''}{body}</table>"


def _stats_row(label, stats):
    return [label] + [fmt.format(stats[key]) if key in stats else "" for key, _, fmt in STATS]


def _png(fig):
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _read_validation(path):
    from ..io.file_kinds import check
    from ..io.reading import parse_json, read_text

    if not os.path.exists(path):
        raise FileFormatError(f"{path} does not exist: write it with 'robocal validate ... --json > FILE'")
    # A device, a pipe, a folder or a file over the limit: the one bounded reader says which.
    text = read_text(path, "validation file", "settings", lines=False)
    check(path, "validation", text=text)  # robocal's files of other kinds, named
    try:
        doc = parse_json(text, path, "validation file")
    except FileFormatError as exc:
        raise FileFormatError(f"{path}: not the JSON 'robocal validate --json' prints ({exc})") from None
    if not isinstance(doc, dict) or "cross_validation" not in doc:
        raise FileFormatError(f"{path}: no 'cross_validation' in it: write it with "
                              "'robocal validate ... --json > FILE'")
    # What the report reads from it, so that a hand-edited file fails here in one line.
    for key in ("cross_validation", "nominal_cross_validation"):
        pooled = doc.get(key)
        mean = pooled.get("pooled") if isinstance(pooled, dict) else None
        if not isinstance(mean, dict) or not isinstance(mean.get("mean_mm"), (int, float)):
            raise FileFormatError(f"{path}: no {key}.pooled.mean_mm in it: write it afresh with "
                                  "'robocal validate ... --json > FILE'")
    for key in ("method", "file", "folds"):
        if key not in doc:
            raise FileFormatError(f"{path}: no '{key}' in it: write it afresh with "
                                  "'robocal validate ... --json > FILE'")
    return doc


def _check_validation_matches(cv, model, path):
    """A cross-validation of another method or robot describes another model: InputError.
    One of another data file (or the same name with another number of poses) may be a
    deliberate choice (the whole file, where the model saw a training split): RobocalWarning."""
    if cv.get("method") != model.method:
        raise InputError(f"{path} cross-validates the {cv.get('method')!r} method but the model is {model.method!r}: "
                         f"run 'robocal validate ... --method {model.method} --json > FILE' for this report, or "
                         "leave out --validation")
    if "robot" in cv and cv["robot"] != model.nominal.name:
        raise InputError(f"{path} cross-validates the robot {cv['robot']!r} but the model is of "
                         f"{model.nominal.name!r}: validate this robot's data, or leave out --validation")
    trained, validated = str(model.training.get("file", "")), str(cv.get("file", ""))
    same_file = trained == validated or Path(trained).resolve() == Path(validated).resolve()
    if not same_file or cv.get("poses", model.training.get("n_poses")) != model.training.get("n_poses"):
        warnings.warn(RobocalWarning(
            f"{path} cross-validates {validated} ({cv.get('poses', '?')} poses) but the model was trained on "
            f"{trained} ({model.training.get('n_poses', '?')} poses): the report shows it as it is; validate the "
            "training file if it should describe this model"), stacklevel=2)


def _figures(fitted, observations, positions, before, after, validation):
    """(title, caption, Figure) for every plot that applies to this model."""
    joints_deg = fitted.compensator_.chain.joints_to_file(observations.joints)
    what = ("error" if observations.positions is not None
            else "deviation of the ball centre from its socket group's mean")
    figures = [
        ("Error distribution", f"Single-point {what}, every pose in the file.",
         plots.error_distribution(before, after)),
        ("Error vectors over the workspace", f"Arrows: the {what} at each position, scaled "
         "as the titles say; grey dots: the poses.", plots.error_vectors(positions, before, after)),
        ("Error against the joint angles", "Where in the joint space the error comes from "
         "(joint values as in the file).", plots.error_against_joints(joints_deg, before, after)),
    ]
    figures += [(item.title, item.caption, DIAGNOSTIC_PLOTS[item.kind](item.data))
                for item in fitted.report_figures(observations.joints)]
    domain = getattr(fitted, "domain_", None)
    if domain is not None:
        check = domain.check(observations.joints, observations.positions)
        figures.append(("Training coverage", "Each joint's training range (shaded; dashed: the margin that still "
                        "counts as inside) and histogram (grey), against the configurations of this file: inside "
                        f"the domain of validity (blue outline) or outside it (red). {check.summary}.",
                        plots.domain_coverage(**domain.coverage(observations.joints, observations.positions))))
    bound = getattr(fitted, "bound_", None)
    if bound is not None and observations.positions is not None:
        inside = (domain.check(observations.joints, observations.positions).inside if domain is not None
                  else np.ones(observations.n_poses, dtype=bool))
        figures.append(("95 % bound against error", ("Each pose's position error against the 95 % bound the model "
                        "states there (robocal evaluate --per-pose writes both): calibrated when the model was fitted, "
                        "on held-out folds, to cover 95 % of poses like these; poses below the dashed line lie within "
                        "it. On the training poses themselves the share is higher than on held-out ones."),
                        plots.bound_against_error(np.linalg.norm(after, axis=1),
                                                  bound.predict(observations.joints, inside=inside), inside)))
    if validation is not None and validation.get("learning_curve"):
        figures.append(("Learning curve", "Held-out error against the number of training poses "
                        f"({validation['method']}, from {validation['file']}).",
                        plots.learning_curve(validation["learning_curve"],
                                             validation["nominal_cross_validation"]["pooled"]["mean_mm"])))
    return figures


def _comparison_section(comparison):
    """The model choice a ``calibrate --method auto`` kept in its model file: held-out error of
    every model compared on each split, the recommendation and why."""
    if not comparison:
        return ""
    parts = ["<h2>Model choice</h2><p class=note>Every method compared on poses it never saw (robocal compare), "
             "split at random and by regions of configuration space left out whole; this model is the one "
             f"recommended: <b>{html.escape(comparison['recommended']['label'])}</b>.</p>"]
    for split in comparison["splits"]:
        rows = [[model["label"]] + [f"{model['scores'][split['name']]['pooled'][key]:.4f}"
                                    for key in ("mean_mm", "rms_mm", "max_mm", "p95_mm")]
                for model in comparison["models"]]
        parts.append(f"<p class=note>Held-out error on {html.escape(split['name'])} (mm)</p>"
                     + _table(["model", "mean", "RMS", "max", "95 %"], rows))
    lines = comparison["reasons"] + comparison.get("dropped", []) + comparison.get("notes", [])
    parts.append("<ul>" + "".join(f"<li>{html.escape(line)}</li>" for line in lines) + "</ul>")
    return "".join(parts)


def _iso_section(iso_before, iso_after):
    rows = [(name, r["poses"], f"{r['ap_mean_mm']:.4f}", f"{r['ap_max_mm']:.4f}", r["repeated_poses"],
             "" if r["rp_max_mm"] is None else f"{r['rp_max_mm']:.4f}")
            for name, r in (("nominal", iso_before), ("calibrated", iso_after))]
    return ("<h3>ISO 9283-style position accuracy</h3><p class=note>Rows with the same joint command are "
            "visits of one pose; AP = distance from the mean attained position to the commanded one "
            "(the model's), RP = mean + 3 σ of the visits' spread (poses visited twice or more).</p>"
            + _table(("model", "poses", "AP mean (mm)", "AP max (mm)", "repeated poses", "RP max (mm)"), rows))


def _socket_distance_section(stats):
    rows = []
    for name, entry in (("nominal", stats["nominal"]["socket_distance"]), ("calibrated", stats["socket_distance"])):
        rows.append([name, entry["n"]] + [f"{entry[k]:.4f}" if k in entry else ""
                                          for k in ("mean_mm", "rms_mm", "max_mm", "signed_mean_mm")])
    return ("<h3>Socket distances</h3><p class=note>For each placement and pair of sockets: distance between "
            "the mean ball centres minus the fixture's distance (mm).</p>"
            + _table(("model", "pairs", "mean |error|", "RMS", "max |error|", "mean signed"), rows))


def _calibration_section(calibration, chain):
    """The identified parameters of a :class:`~robocal.methods.CalibrationRecord` (or nothing),
    with the units of ``chain``'s parameters."""
    if calibration is None:
        return ""
    ident = calibration.identifiability
    rows = parameter_rows(calibration, chain)
    notes = "".join(f"<p class=note>{html.escape(n)}.</p>" for n in parameter_notes(calibration, chain))
    parts = [f"<h2>Identified parameters</h2><p class=note>Deviations from the starting model "
             f"({html.escape(calibration.units)}) with their standard errors; "
             f"{ident.rank} parameters from {ident.rows} equations; "
             f"{calibration.iterations} iterations, "
             f"{'converged' if calibration.converged else 'stopped at the iteration limit'}.</p>",
             _table(("parameter", "deviation", "standard error", "unit", "prior", "from data")[:max(map(len, rows),
                                                                                                  default=4)], rows),
             notes,
             "<h3>Identifiability</h3>",
             _table(("condition number", "O1", "O3", "noise amplification"),
                    [(f"{ident.condition_number:.3g}", f"{ident.o1:.3g}", f"{ident.o3:.3g}",
                      f"{ident.noise_amplification:.3g}")], numeric_from=0)]
    if ident.fixed:
        parts.append("<p>Fixed, because the data cannot determine them:</p><ul>"
                     + "".join(f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>" for k, v in ident.fixed.items())
                     + "</ul>")
    if calibration.correlated_pairs:
        parts.append("<p>Strongly correlated pairs: " + ", ".join(
            f"{html.escape(a)} / {html.escape(b)} ({r:+.3f})" for a, b, r in calibration.correlated_pairs) + "</p>")
    if calibration.outlier_rows:
        parts.append(f"<p>Rows down-weighted as outliers: {', '.join(map(str, calibration.outlier_rows))}</p>")
    return "".join(parts)


@dataclass(frozen=True)
class Scores:
    """What the report shows of a model on a file: per-pose ``before`` / ``after`` (N, 3) mm
    (errors, or deviations from the socket group's mean), the ``positions`` (N, 3) mm they are
    drawn at, the statistics ``stats`` (as ``evaluate --json`` prints them after its model,
    method and file), the ISO 9283
    figures (position data), and a sentence on the ``metric``."""

    before: np.ndarray
    after: np.ndarray
    positions: np.ndarray
    stats: dict
    iso: dict | None
    metric: str


def _scores(model, fitted, data, model_path):
    if data.positions is None:
        data = with_fixture(fitted, data, model_path)
        before, after, centres = socket_residuals(fitted, data)
        return Scores(before, after, centres, socket_scores(fitted, data), None,
                      "Socket consistency: distance of each computed ball centre from the mean of its socket "
                      "group, in mm (no instrument: the data are joint angles only)")
    before, after, scores = position_scores(fitted, data, model.nominal.name)
    file_joints = model.kinematics.joints_to_file(data.joints)
    iso = {"nominal": iso9283_position(file_joints, data.positions, fitted.reference_.fk_positions(data.joints)),
           "calibrated": iso9283_position(file_joints, data.positions, fitted.predict(data.joints))}
    return Scores(before, after, data.positions, scores, iso,
                  "Single-point error |e| = |measured − model| in mm; 'nominal' is the uncalibrated robot "
                  "(registered in the measurement frame when the model was).")


def _summary(model, fitted, data, label, cv, model_path):
    training = model.training
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    summary = [
        ("robot", model.nominal.name), ("method", model.method), ("model file", str(model_path)),
        ("model created", model.created), ("trained on", f"{training.get('file', '?')} "
                                                         f"({training.get('n_poses', '?')} poses, "
                                                          f"{training.get('kind', '?')} data)"),
        ("scored on", f"{data.path} ({data.n_poses} poses, {data.kind} data): {label}"),
        ("frame", "measurement frame; base and tool registered to the data" if fitted.record_.registered
         else "measurement frame = robot base frame as given"),
        ("units", "mm and degrees"), ("report written", f"{now} by robocal {__version__}"),
    ]
    predicted = fitted.record_.predicted_error
    if predicted:
        summary.append(("error to expect", f"{predicted['mean_mm']:.4f} mm mean, "
                                           f"{predicted['p95_mm']:.4f} mm 95 % over "
                        f"{predicted['where']} (registered nominal robot: {predicted['nominal_mean_mm']:.4f} mm mean, "
                        f"{predicted['nominal_p95_mm']:.4f} mm 95 %)"))
    if cv is not None:
        pooled, nominal = cv["cross_validation"]["pooled"], cv["nominal_cross_validation"]["pooled"]
        summary.append(("cross-validation", f"{cv['folds']}-fold on {cv['file']}: {pooled['mean_mm']:.4f} mm mean "
                        f"(nominal {nominal['mean_mm']:.4f} mm)"))
    return summary


def _held_out(model, data, measurements, model_path):
    """(held out?, the label of the poses scored): decided by content, the rows the model
    file's fingerprints say it was fitted to (robocal.io.fingerprint: its calibration's
    poses and a re-registration's); for a model file written before it kept one, by the
    training file's name."""
    seen = seen_by_model(model.training, model.kinematics, data, where=str(model_path))
    if seen is None:
        fitted_to = {Path(str(model.training[key])).resolve() for key in ("file", "reregistration_file")
                     if key in model.training}
        held_out = Path(str(measurements)).resolve() not in fitted_to
        return held_out, ("held-out poses (judged by the file name: this model file keeps no fingerprint of its "
                          "training rows)" if held_out else "training poses (not held out: scores what the model has "
                          "seen)")
    if not seen.any():
        return True, "held-out poses (none of them is a training pose)"
    if seen.all():
        return False, "training poses (not held out: every one is a pose the model was trained on)"
    return False, (f"{int(seen.sum())} of {len(seen)} poses are training poses: not held out (score the others "
                   "alone for a held-out figure)")


def _accuracy_rows(record, stats, held_out):
    rows = []
    if record.residual_before:
        rows.append(_stats_row("training, nominal", record.residual_before))
    if record.residual_after_training:
        rows.append(_stats_row("training, calibrated", record.residual_after_training))
    where = "held-out" if held_out else "this file"
    return rows + [_stats_row(f"{where}, nominal", stats["nominal"]), _stats_row(f"{where}, calibrated", stats)]


def report_job(model_path, measurements, out, *, validation=None, pdf=None, beyond_limits=False, iso=None):
    """Write the HTML report (and the PDF when ``pdf`` is a path), with the ISO page of the
    campaign file ``iso`` when given; returns what was written and the numbers it shows (a
    :class:`.results.Reported`)."""
    if not str(out).lower().endswith((".html", ".htm")):
        raise InputError(f"the report is HTML: give --out a .html file name, got {out}")
    if pdf is not None and not str(pdf).lower().endswith(".pdf"):
        raise InputError(f"--pdf needs a .pdf file name, got {pdf}")
    check_outputs([out, pdf], [model_path, measurements, validation, iso])
    model, fitted = load_fitted(model_path)
    cv = _read_validation(validation) if validation else None
    if cv is not None:
        _check_validation_matches(cv, model, validation)
    data = read_model_data(model, model_path, measurements, beyond_limits=beyond_limits)
    scores = _scores(model, fitted, data, model_path)
    held_out, label = _held_out(model, data, measurements, model_path)
    figures = _figures(fitted, data, scores.positions, scores.before, scores.after, cv)
    summary = _summary(model, fitted, data, label, cv, model_path)
    accuracy_rows = _accuracy_rows(fitted.record_, scores.stats, held_out)
    body = [f"<h1>Accuracy report: {html.escape(model.nominal.name)}</h1>",
            f"<p class=note>{html.escape(model.method)} model, scored on {html.escape(label)}.</p>",
            "<h2>Summary</h2>", _table(None, summary, numeric_from=2),
            f"<h2>Position error</h2><p class=note>{html.escape(scores.metric)}</p>",
            _table(["data"] + [name for _, name, _ in STATS], accuracy_rows),
            _socket_distance_section(scores.stats) if scores.iso is None
            else _iso_section(scores.iso["nominal"], scores.iso["calibrated"]),
            _calibration_section(fitted.record_.calibration, fitted.compensator_.chain),
            _comparison_section(model.training.get("comparison"))]
    if iso is not None:
        from .metrology_jobs import model_iso_section

        body.append(model_iso_section(iso, model_path))
    for title, caption, fig in figures:
        body.append(f"<h2>{html.escape(title)}</h2><p class=note>{html.escape(caption)}</p>"
                    f"<img alt=\"{html.escape(title)}\" src=\"data:image/png;base64,{_png(fig)}\">")
    write_text_atomic(out, f"<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>robocal report: "
                           f"{html.escape(model.nominal.name)}</title><style>{STYLE}</style></head><body>"
                      + "".join(body) + "</body></html>\n")
    if pdf is not None:
        _write_pdf(pdf, summary, accuracy_rows, [fig for _, _, fig in figures])
    import matplotlib.pyplot as plt

    for _, _, fig in figures:
        plt.close(fig)
    return Reported(out=str(out), pdf=None if pdf is None else str(pdf), figures=[t for t, _, _ in figures],
                    held_out=held_out, model=str(model_path), method=model.method, file=data.path,
                    scores=scores.stats, iso9283=scores.iso)


def _write_pdf(path, summary, accuracy_rows, figures):
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    buffer = io.BytesIO()
    with PdfPages(buffer) as pages:
        cover = plt.figure(figsize=(8.27, 11.69))
        lines = [f"{k}: {v}" for k, v in summary] + ["", "position error (mm): " + ", ".join(n for _, n, _ in STATS)]
        lines += [" | ".join(str(v) for v in row) for row in accuracy_rows]
        cover.text(0.06, 0.95, "robocal accuracy report", fontsize=16, va="top")
        cover.text(0.06, 0.9, "\n".join(lines), fontsize=7.5, va="top", family="monospace", wrap=True)
        pages.savefig(cover)
        plt.close(cover)
        for fig in figures:
            pages.savefig(fig)
    write_bytes_atomic(path, buffer.getvalue())
