"""Every result the command line prints, rendered here: one JSON object with ``--json``,
tables and one-line notes otherwise.  The commands compute (``robocal.interfaces.jobs`` and
the other jobs) and hand their results to these functions; nothing here computes."""
import contextlib
import json
import sys

import numpy as np
from rich.console import Console
from rich.table import Table
from rich.text import Text

from .layout import fitted

# Run once before the first line of a result is printed: the command line holds a command's
# warnings until then (robocal.interfaces.cli.app.held_warnings), when its data have been
# accepted.
_before_result = []


def before_result(action):
    """Run ``action()`` before the next result line is printed (once)."""
    _before_result.append(action)


def result_starts():
    """Run what waits for the first result line (:func:`before_result`)."""
    while _before_result:
        _before_result.pop(0)()


class _ResultConsole(Console):
    """The console of results: what waits for the first result line runs before it.  No line
    it prints is wider than the console, so that a result reads in an 80-column log: a note
    (one plain text) is wrapped at the console's width, its continuation lines indented under
    its first word, and so is a table's title (the console prints text unwrapped, a title
    included); a table too wide for the line is laid out so that no number is cut
    (:mod:`.layout`: every table robocal prints comes through here), and JSON is
    printed without the console (:func:`print_json`)."""

    def print(self, *args, **kwargs):
        result_starts()
        if len(args) == 1 and not kwargs:
            args = (fitted(args[0], self),)
        super().print(*args, **kwargs)


# No markup: messages and tables carry users' text (file names, "[sockets]") that must print as is.
out = _ResultConsole(highlight=False, soft_wrap=True, markup=False)
err = Console(stderr=True, highlight=False, soft_wrap=True, markup=False)


def say(label, style, message):
    """One line on stderr: a coloured ``label:`` and the message, verbatim."""
    err.print(Text(f"{label}:", style=style) + Text(f" {message}"))


@contextlib.contextmanager
def progress(description, total=None, *, enabled=True):
    """Progress on a long run: yield ``advance(steps=1, **fields)``; a bar on stderr when it
    is a terminal and ``enabled`` (False for --json), plain lines elsewhere
    (:mod:`robocal.interfaces.progress`).
    ``fields`` are shown after the bar (e.g. best=...)."""
    if not enabled:
        yield lambda steps=1, **fields: None
        return
    if not sys.stderr.isatty():  # a pipe or a log: plain lines every few seconds
        from ..progress import plain_progress
        with plain_progress(description, total) as advance:
            yield advance
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    columns = [TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
               TextColumn("{task.fields[info]}")]
    with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(description, total=total, info="")

        def advance(steps=1, **fields):
            info = "  ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in fields.items())
            bar.update(task, advance=steps, info=info)

        yield advance


def print_json(result):
    """A result as one JSON object on stdout (plain print: no console wrapping)."""
    result_starts()
    print(json.dumps(result, indent=2))


def print_result(result, as_json, title):
    """A flat result: JSON, or a two-column table of its entries (nested records are left to
    --json and to the model file, statistics are one sentence)."""
    if as_json:
        print_json(result)
        return
    table = Table(title=title, show_header=False)
    for key, value in result.items():
        if isinstance(value, dict) and "mean_mm" not in value:
            continue  # nested records are in --json and in the model file
        table.add_row(key.replace("_", " "), cell(value))
    out.print(table)


def cell(value):
    """A value as a person reads it: statistics in a sentence, lists joined, no Python reprs."""
    if isinstance(value, dict) and "nominal_mean_mm" in value:
        return (f"mean {value['mean_mm']:.4f} mm, 95 % {value['p95_mm']:.4f} mm over {value['where']} "
                f"(registered nominal robot: mean {value['nominal_mean_mm']:.4f} mm, 95 % "
                f"{value['nominal_p95_mm']:.4f} mm)")
    if isinstance(value, dict):
        if not value.get("n"):
            return "none"
        return (f"mean {value['mean_mm']:.4f} mm, RMS {value['rms_mm']:.4f} mm, "
                f"max {value['max_mm']:.4f} mm (n = {value['n']})")
    if isinstance(value, float):
        return f"{value:.4f}"
    if isinstance(value, (list, tuple)) and value and all(_is_number(v) for v in value):
        # A vector (a centre, rpy angles): every component, a repeated 0.0 too.
        return ", ".join(map(str, value))
    if isinstance(value, (list, tuple)):
        return ", ".join(said_once(value)) or "none"
    return "-" if value is None else str(value)


def _is_number(value):
    return isinstance(value, (int, float, np.number)) and not isinstance(value, bool)


def said_once(items):
    """The texts of ``items``, each thing said once: ``"who: what"`` texts that say the same
    ``what`` become one (``output 1: s``, ``output 2: s`` -> ``outputs 1, 2: s``), in the order
    they came.  For messages only: the components of a vector are not things said
    (:func:`cell` joins them all)."""
    said = {}
    for item in map(str, items):
        who, colon, what = item.partition(": ")
        said.setdefault(what if colon else item, []).append(who if colon else None)
    texts = []
    for what, whos in said.items():
        if whos[0] is None:
            texts.append(what)
            continue
        words = [who.split(" ", 1) for who in whos]
        if len(whos) > 1 and all(len(w) == 2 and w[0] == words[0][0] for w in words):
            whos = [f"{words[0][0]}s {', '.join(w[1] for w in words)}"]
        texts.append(f"{', '.join(whos)}: {what}")
    return texts


def without_domain(result):
    """The result without the domain's line, which :func:`say_domain` prints below the table."""
    return {key: value for key, value in result.items() if key != "domain_summary"}


def say_domain(result):
    """The domain of validity's one line: a warning when targets lie outside it."""
    summary = result.get("domain_summary")
    if summary:
        say("warning" if result.get("outside_domain") else "note", "yellow", summary)


def print_scored(result, as_json, title):
    """A result scored over targets (evaluate, compensate, filter): its table, then the
    domain of validity's line."""
    print_result(result if as_json else without_domain(result), as_json, title)
    if not as_json:
        say_domain(result)
        bound = result.get("bound95")
        if bound:
            say("note", "yellow", f"{bound['within_share']:.1%} of the {bound['poses']} poses lie within their 95 % "
                f"bound (median bound {bound['median_bound_mm']:.4g} mm, median error "
                f"{bound['median_error_mm']:.4g} mm)")


def print_evaluated(result, measurements, as_json):
    """evaluate (an :class:`~robocal.interfaces.results.Evaluated`): its table, then the
    domain's and the bound's lines."""
    print_scored(result.to_dict(), as_json, f"{result.method} model on {measurements}")


def print_compensated(result, out_file, as_json):
    """compensate (a :class:`~robocal.interfaces.results.Compensated`): a warning naming the
    targets it cannot reach, then the summary."""
    if result.unreachable_rows:
        rows = ", ".join(str(r) for r in result.unreachable_rows[:10])
        more = " ..." if len(result.unreachable_rows) > 10 else ""
        say("warning", "yellow", f"{len(result.unreachable_rows)} target(s) cannot be reached "
                                 f"(rows {rows}{more}): their joint cells are empty and reachable = 0")
    print_scored(result.to_dict(), as_json, f"commands -> {out_file}")


def print_filtered(result, out_dir, as_json):
    """filter (a :class:`~robocal.interfaces.results.Filtered`): a warning per motion left as
    it was, then the summary."""
    for item in result.unfiltered:
        say("warning", "yellow", f"not filtered (computed at run time): {item}")
    shown = result.to_dict()
    print_scored(shown if as_json else {k: v for k, v in shown.items() if k != "unfiltered"}, as_json,
                 f"filtered programs -> {out_dir}")


def print_exported(result, out_file, as_json):
    """export (an :class:`~robocal.interfaces.results.Exported`): a note per thing the robot
    file cannot hold, then the summary."""
    for what in result.left_out:
        say("note", "yellow", f"left out of the {result.format.upper()} file: {what}")
    print_result(result.to_dict(), as_json, f"{result.convention} robot -> {out_file}")


def _stats_row(table, label, stats):
    table.add_row(label, f"{stats['mean_mm']:.4f}", f"{stats['rms_mm']:.4f}", f"{stats['max_mm']:.4f}")


# --------------------------------------------------------------------------- lists of rows
def line_ranges(lines):
    """Line numbers as runs: ``[4, 5, 6, 9]`` -> ``"4-6, 9"``."""
    runs = []
    for line in sorted(set(lines)):
        if runs and line == runs[-1][1] + 1:
            runs[-1][1] = line
        else:
            runs.append([line, line])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def some_names(names, width=50):
    """``names`` joined, or the first ones, "...", and the last when they would pass ``width``
    characters."""
    names = [str(name) for name in names]
    joined = ", ".join(names)
    if len(joined) <= width:
        return joined
    shown = []
    while names[:len(shown) + 1] and len(", ".join(names[:len(shown) + 1])) <= width - len(names[-1]) - 7:
        shown.append(names[len(shown)])
    return ", ".join(shown + ["...", names[-1]])


def say_rows(label, style, rows, one, many):
    """One line for the rows a command left out (``rows``: (line, name)), however many: for
    one, ``one`` (formatted with its ``line`` and ``name``), else ``many`` (with their
    ``count``, ``lines`` as ranges and ``names``, some of them); --json lists every row."""
    if len(rows) == 1:
        say(label, style, one.format(line=rows[0][0], name=rows[0][1]))
    elif rows:
        say(label, style, many.format(count=len(rows), lines=line_ranges(line for line, _ in rows),
                                      names=some_names(name for _, name in rows)))


def print_imported(result, out_file, as_json):
    """import: the join's summary; then, in a line each, the joint rows with no point, the
    points with no joint row (every line, as ranges), and the points measured more than once."""
    if as_json:
        print_json(result)
        return
    lists = ("joint_rows_without_point", "points_without_joint_row", "averaged")
    print_result({k: v for k, v in result.items() if k not in lists}, False,
                 f"{result['matched']} poses joined by {result['by']} -> {out_file}")
    say_rows("warning", "yellow", [(e["line"], e["key"]) for e in result["joint_rows_without_point"]],
             "joint row on line {line} ({name}) has no point: left out",
             "{count} joint rows have no point, left out: lines {lines} ({names})")
    say_rows("warning", "yellow", [(e["line"], e["name"]) for e in result["points_without_joint_row"]],
             "point {name} (line {line}) has no joint row: left out",
             "{count} points have no joint row, left out: lines {lines} ({names})")
    averaged = result["averaged"]
    if len(averaged) == 1:
        entry = averaged[0]
        say("note", "cyan", f"point {entry['name']} measured {entry['count']} times: averaged (spread "
                            f"{entry['spread_mm']:.4f} mm)")
    elif averaged:
        widest = max(averaged, key=lambda entry: entry["spread_mm"])
        say("note", "cyan", f"{len(averaged)} points measured more than once, averaged "
                            f"({some_names(entry['name'] for entry in averaged)}): largest spread "
                            f"{widest['spread_mm']:.4f} mm, of {widest['name']}")


# --------------------------------------------------------------------------- calibrate, compare, validate
def print_calibration(calibration, chain):
    """Identified parameters with standard errors and units, and what could not be identified
    (a :class:`~robocal.methods.CalibrationRecord`; ``chain``, the calibrated model, names the
    units)."""
    from ..tables import parameter_notes, parameter_rows

    ident = calibration.identifiability
    table = Table(title=f"identified parameters ({ident.rank})")
    rows = parameter_rows(calibration, chain)
    columns = ("parameter", "deviation", "std. error", "unit", "prior", "from data")
    for col in columns[:max((len(row) for row in rows), default=4)]:
        table.add_column(col, justify="right")
    for row in rows:
        table.add_row(*row)
    out.print(table)
    for note in parameter_notes(calibration, chain):
        out.print(f"{note}.")
    out.print(f"condition number {ident.condition_number:.3g}, O1 {ident.o1:.3g}, O3 {ident.o3:.3g}, "
              f"noise amplification {ident.noise_amplification:.3g}")
    for name, reason in ident.fixed.items():
        out.print(f"fixed {name}: {reason}")
    for a, b, r in calibration.correlated_pairs:
        out.print(f"strongly correlated: {a} and {b} ({r:+.3f})")
    if calibration.outlier_rows:
        out.print(f"down-weighted as outliers: rows {', '.join(map(str, calibration.outlier_rows))}")


def print_calibrated(result, out_file, as_json, comparison=False):
    """calibrate's result (a job result with ``to_dict``, ``record`` and ``kinematics``):
    the comparison when auto chose, the identified parameters, then the summary."""
    if comparison and not as_json:
        print_reasoning(result.data["comparison"])
    if not as_json and result.record.calibration is not None:
        print_calibration(result.record.calibration, result.kinematics)
    shown = {k: v for k, v in result.to_dict().items() if k != "comparison"}
    print_result(result.to_dict() if as_json else shown, as_json, f"{result.method} model -> {out_file}")


def print_reregistration(result, measurements, out_file, as_json):
    """calibrate --method frames: the model before and after, what moved, what was kept."""
    if as_json:
        print_json(result.to_dict())
        return
    record = result.record.reregistration
    ident = record["identifiability"]
    table = Table(title=f"{result.method} model re-registered on {record['poses']} poses of {measurements} (mm)",
                  show_header=True)
    for col in ("model on these poses", "mean", "RMS", "max"):
        table.add_column(col, justify="left" if col.startswith("model") else "right")
    for label, key in (("as it stood", "residual_before"), ("re-registered", "residual_after"),
                       ("nominal, registered", "residual_reference")):
        _stats_row(table, label, record[key])
    out.print(table)
    tool_change = np.linalg.norm(record["tool_change_mm"])
    out.print(f"tracker moved by {record['tracker_shift_mm']:.1f} mm and turned by "
              f"{record['tracker_turn_deg']:.3f} deg; tool changed by {tool_change:.3f} mm")
    for name, change in record["offset_changes"].items():
        out.print(f"joint offset {name} changed by {change:+.4f}")
    out.print(f"identified {len(ident['identified'])} parameters (rank {ident['rank']}), condition number "
              f"{ident['condition_number']:.3g}")
    if result.record.predicted_error is not None:
        out.print(f"predicted error: {cell(result.record.predicted_error)}")
    for name, reason in ident["fixed"].items():
        out.print(f"kept {name}: {reason}")
    choice = record.get("outside_choice")
    if choice is not None and choice["poses"]:
        rms = choice["rms_mm"]
        out.print(f"outside the domain {choice['answers_outside']} answers ({rms[choice['answers_outside']]:.4f} mm "
                  f"RMS on the {choice['poses']} new poses it answers for, against {rms[choice['alternative']]:.4f} "
                  f"for {choice['alternative']})")
    out.print(f"-> {out_file}")


def print_comparison(comparison):
    """The tables of a comparison (its JSON form): held-out error of every model on each
    split, then the recommendation and why."""
    for split in comparison["splits"]:
        kind = "a region left out at a time" if split["kind"] == "region" else "poses left out at random"
        table = Table(title=f"held-out error on {split['name']} ({kind}), mm")
        for col in ("model", "mean", "RMS", "max", "95 %", "fit s"):
            table.add_column(col, justify="left" if col == "model" else "right")
        best = min(m["scores"][split["name"]]["pooled"]["mean_mm"] for m in comparison["models"])
        for model in comparison["models"]:
            score = model["scores"][split["name"]]
            stats = score["pooled"]
            mark = " *" if model["label"] == comparison["recommended"]["label"] else ""
            table.add_row(model["label"] + mark, f"{stats['mean_mm']:.4f}" + ("<" if stats["mean_mm"] == best else " "),
                          f"{stats['rms_mm']:.4f}", f"{stats['max_mm']:.4f}", f"{stats['p95_mm']:.4f}",
                          f"{score['fit_seconds']:.2f}")
        out.print(table)
    out.print(f"recommended (*): {comparison['recommended']['label']}  (< marks the lowest mean of each split)")
    for line in comparison["reasons"] + comparison["dropped"] + comparison["notes"]:
        out.print(f"  {line}")
    print_advice(comparison)


def print_advice(comparison):
    """What to measure to let a richer model win (robocal.methods.selection.advice)."""
    if comparison.get("advice"):
        out.print("to let a richer model win:")
        for line in comparison["advice"]:
            out.print(f"  {line}")


def print_reasoning(comparison):
    """calibrate --method auto's choice in one screen: one table of every model's held-out
    mean on each split and what the random folds told of it against the baseline, then why
    the winner, and what to measure to let a richer model win."""
    verdicts = {v["label"]: v for v in comparison.get("verdicts", [])}
    chosen, outside = comparison["recommended"]["label"], (comparison.get("outside_domain") or {}).get("label")
    dropped = {line.split(" dropped:")[0] for line in comparison["dropped"]}
    table = Table(title=f"auto on {comparison['poses']} poses: held-out mean (mm, every held-out pose; the choice "
                        "weighs those inside each fold's training domain) on each split, and what the random folds "
                        "tell of each model against the baseline")
    table.add_column("model")
    for split in comparison["splits"]:
        table.add_column(split["name"], justify="right")
    table.add_column("verdict (gain ± fold-to-fold spread, mm)")
    for model in comparison["models"]:
        label, verdict = model["label"], verdicts.get(model["label"])
        said = "" if verdict is None else verdict["verdict"]
        if verdict is not None and said != "baseline":
            said += f" ({verdict['gain_mm']:+.4f} ± {verdict['spread_mm']:.4f})"
        said += "; chosen" if label == chosen else "; answers outside the domain" if label == outside else ""
        said += "; dropped (no gain over its base on the regions)" if label in dropped else ""
        table.add_row(label + (" *" if label == chosen else ""),
                      *[f"{model['scores'][s['name']]['pooled']['mean_mm']:.4f}" for s in comparison["splits"]],
                      said.lstrip("; "))
    out.print(table)
    out.print(f"chosen (*): {chosen}")
    for line in comparison["reasons"]:
        out.print(f"  {line}")
    # Candidates left out by their minimum are named in the advice; the other notes say which
    # splits could not be made.
    for line in comparison["notes"]:
        if " fit needs " not in line:
            out.print(f"  {line}")
    print_advice(comparison)


def print_validation(result, method, by_placement, as_json):
    """validate (a :class:`~robocal.interfaces.results.Validated`): the cross-validation beside
    the registered nominal's, and the learning curve."""
    if as_json:
        print_json(result.to_dict())
        return
    kind = ("leave-one-placement-out socket consistency" if by_placement
            else f"{result.folds}-fold cross-validation")
    table = Table(title=f"{method}, {kind} on {result.poses} poses (mm)")
    for col in ("model", "mean", "RMS", "max"):
        table.add_column(col, justify="right")
    nominal = "nominal" if by_placement else "nominal, registered"
    for label, figures in ((method, result.cross_validation), (nominal, result.nominal_cross_validation)):
        _stats_row(table, label, figures.get("pooled", figures))
    out.print(table)
    if result.learning_curve is not None:
        curve = Table(title="learning curve: held-out error against training poses (mm)")
        for col in ("training poses", "mean", "RMS", "max"):
            curve.add_column(col, justify="right")
        for point in result.learning_curve:
            _stats_row(curve, str(point["n_train"]), point["held_out"])
        out.print(curve)


# --------------------------------------------------------------------------- design
def print_socket_design(result, out_file):
    """design --fixture (a :class:`~robocal.planning.job.SocketsDesigned`): the placements and
    configurations chosen, and what they predict."""
    design = result.design
    versus = design.random_model_rms
    table = Table(title=f"{len(design.joints)} configurations in {len(design.poses)} placements of "
                        f"fixture {result.fixture} ({design.criterion}) -> {out_file}", show_header=False)
    for key, value in (("robot", result.robot), ("candidate placements", result.placements_from),
                       ("reachable placements", result.reachable_placements),
                       ("chosen placements", ", ".join(design.poses)),
                       ("configurations per socket", design.per_socket),
                       ("candidate configurations", design.n_candidates),
                       ("ball-centre error after calibration", f"{design.model_rms:.4f} mm RMS predicted"
                        + ("" if versus is None else f" (random choices of the same number: {versus:.4f} mm)")),
                       ("identifiable parameters", len(design.names)),
                       ("exchanges", design.exchanges)):
        table.add_row(key, str(value))
    out.print(table)


def print_design(result, out_file):
    """design (a :class:`~robocal.planning.job.Designed`): the poses chosen, the noise assumed,
    the predicted error beside random poses, and the predicted standard error of every
    identifiable parameter."""
    design = result.design
    versus = design.random_model_rms
    table = Table(title=f"{len(design.joints)} poses of {design.n_candidates} candidates ({design.criterion}) "
                        f"-> {out_file}", show_header=False)
    for key, value in (("robot", result.robot), ("candidates", result.candidates_from),
                       ("working volume", result.working_volume), ("targets", result.targets),
                       ("measured before", design.n_existing),
                       ("noise", f"{design.noise:.4f} mm ({result.noise_from})"
                        + (f", {design.joint_noise_deg:g} deg at every joint" if design.joint_noise_deg else "")
                        + (f", sag {design.sag_deg:g} deg left out" if design.sag_deg else "")),
                       ("calibrated TCP error at the targets", f"{design.model_rms:.4f} mm RMS predicted"
                        + ("" if versus is None else f" (random poses of the same number: {versus:.4f} mm)")),
                       ("held-out error with a reading's noise",
                        f"mean {design.held_out_mean:.4f} mm, RMS {design.held_out_rms:.4f} mm predicted"),
                       ("O1, noise amplification", f"{design.o1:.4g}, {design.noise_amplification:.4g}"),
                       ("condition number", f"{design.condition_number:.4g}"),
                       ("motion", f"{design.tour_length:.0f} deg of the largest joint's motion "
                                f"({design.given_length:.0f} in the order of choice)"),
                       ("exchanges after the greedy selection", str(design.exchanges))):
        table.add_row(key, str(value))
    if design.max_variance is not None:
        table.add_row("largest predictive variance left", f"{design.max_variance:.3g} of the prior's "
                                                            f"({design.variance_prior})")
    out.print(table)
    std_errors = design.std_errors_as_files_show()
    parameters_table = Table(title=f"predicted standard errors ({len(std_errors)} identifiable parameters)")
    for column in ("parameter", "std. error", "unit"):
        parameters_table.add_column(column, justify="right")
    for name, entry in std_errors.items():
        parameters_table.add_row(name, f"{entry['std_error']:.3g}", entry["unit"])
    out.print(parameters_table)
    for name, reason in design.fixed.items():
        out.print(f"not identifiable from these candidates, {name}: {reason}")


# --------------------------------------------------------------------------- fleet, listings
def print_fleet(result, columns, ok):
    """The fleet's summary (a :class:`~robocal.interfaces.results.FleetRun`): a row per robot
    (failed ones in red), their notes, the files."""
    table = Table(title=f"fleet of {len(result.robots)} robots on {result.ran_on} (mm)")
    for column in columns:
        table.add_column(column, justify="right" if column.endswith(("_mm", "train", "test")) else "left")
    for row in result.robots:
        table.add_row(*[cell(row[c]) if row[c] is not None else "" for c in columns],
                      style=None if row["status"] == ok else "red")
    out.print(table)
    for row in result.robots:
        if row["message"]:
            out.print(Text(f"{row['name']}: {row['message']}", style="" if row["status"] == ok else "red"))
    out.print(f"-> {result.summary_csv}, {result.summary_html}")


def print_rows(columns, rows):
    """A plain table: ``columns`` and one row of texts per entry of ``rows``."""
    table = Table(*columns)
    for row in rows:
        table.add_row(*row)
    out.print(table)


def print_all(renderables):
    """Tables built elsewhere (a robot's parameter table, the demo's)."""
    for renderable in renderables:
        out.print(renderable)


def print_iso9283(figures, label=None):
    """iso9283: a row per pose of the position figures (mm), of the orientation figures (deg)
    when the campaign has them, then the distance figures (``figures``: an
    :class:`~robocal.acceptance.iso9283.Iso9283Result`; ``label`` names them in the titles,
    by default its file)."""
    tables = [("mm", ("AP", "APx", "APy", "APz", "RP"))]
    if any(p.APa is not None for p in figures.poses):
        tables.append(("deg", ("APa", "APb", "APc", "RPa", "RPb", "RPc")))
    for unit, names in tables:
        table = Table(title=f"ISO 9283 pose characteristics, {unit} ({label or figures.path}; visits matched by "
                            f"{figures.matched_by})")
        for column in ("pose", "n") + names + (("command spread",) if unit == "mm" else ()):
            table.add_column(column, justify="right")
        for pose in figures.poses:
            cells = [pose.pose, str(pose.n)] + [f"{getattr(pose, name):.4f}" for name in names]
            table.add_row(*cells, *([f"{pose.command_spread_mm:.4f}"] if unit == "mm" else []))
        out.print(table)
    distance = figures.distance
    if distance is not None:
        out.print(f"distance {'-'.join(distance.between)} ({distance.commanded_mm:.3f} mm commanded, "
                  f"{distance.n} cycles): AD {distance.AD:.4f} mm, RD {distance.RD:.4f} mm")
