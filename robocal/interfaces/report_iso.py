"""The ISO 9283 page of the report: the test conditions, the instrument, and the pose and
distance characteristics before and after compensation (the latter predicted, and labelled
so).  ``robocal iso9283 CAMPAIGN.csv --report R.html`` writes it as one self-contained HTML
file; :func:`iso_section` is the same page as a section of a larger report.
"""
from __future__ import annotations

import html

import numpy as np

from .. import __version__
from ..io.atomic import write_text_atomic
from .html_style import STYLE

# The figures of a pose (robocal.acceptance.iso9283.PoseCharacteristics) in the tables' order.
POSITION = ("AP", "APx", "APy", "APz", "RP")
ORIENTATION = ("APa", "APb", "APc", "RPa", "RPb", "RPc")


def _table(header, rows):
    """An HTML table, every column but the first right-aligned."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td class=\"{'num' if k else ''}\">{html.escape(str(v))}</td>"
                                    for k, v in enumerate(row)) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _number(value, digits=4):
    return "" if value is None else f"{value:.{digits}f}"


def test_conditions(campaign, result):
    """(label, value) rows: what the campaign file says of how the test was run (``result``:
    an :class:`~robocal.interfaces.results.Iso9283Figures`)."""
    poses = result.figures.poses
    cycles = max(p.n for p in poses)
    low, high = campaign.commanded.min(axis=0), campaign.commanded.max(axis=0)
    rows = [("campaign file", campaign.path), ("visits", str(len(campaign.attained))),
            ("commanded poses", f"{len(poses)} ({', '.join(p.pose for p in poses)})"),
            ("cycles (visits per pose)", str(cycles) + ("" if cycles >= 30 else " (the standard asks for 30)")),
            ("visits matched by", result.figures.matched_by),
            ("poses visited once (no repeatability: left out)", str(len(result.figures.visited_once))),
            ("commanded positions span (mm)", " x ".join(f"{v:.1f}" for v in high - low)),
            ("largest spread of one pose's commands (mm)",
             f"{max(p.command_spread_mm for p in poses):.4f}")]
    if campaign.commanded_angles is not None:
        first = campaign.commanded_angles[0]
        rows.append(("commanded orientation of the first visit rx, ry, rz (deg)",
                     ", ".join(f"{v:.3f}" for v in first)))
    rows.append(("orientation characteristics", "measured" if campaign.attained_angles is not None
                 else "not measured (no rx, ry, rz columns)"))
    if campaign.joints is not None:
        rows.append(("joint command", f"q1..q{campaign.joints.shape[1]} in the file"))
    return rows


def _figures_tables(figures, label):
    """The pose tables (mm, and deg when present) and the distance line of one set of figures
    (an :class:`~robocal.acceptance.iso9283.Iso9283Result`)."""
    poses = figures.poses
    parts = [_table(["pose", "n"] + [f"{name} (mm)" for name in POSITION],
                    [[p.pose, p.n] + [_number(getattr(p, name)) for name in POSITION] for p in poses])]
    if any(p.APa is not None for p in poses):
        parts.append(_table(["pose"] + [f"{name} (deg)" for name in ORIENTATION],
                            [[p.pose] + [_number(getattr(p, name)) for name in ORIENTATION] for p in poses]))
    distance = figures.distance
    if distance is not None:
        parts.append(f"<p>{html.escape(label)}: distance {'-'.join(distance.between)} "
                     f"({distance.commanded_mm:.3f} mm commanded, {distance.n} cycles): AD "
                     f"{distance.AD:.4f} mm, RD {distance.RD:.4f} mm</p>")
    return "".join(parts)


def _before_after(result):
    """Per pose, AP and RP (mm) measured beside the compensated robot's predicted ones."""
    after = {p.pose: p for p in result.compensated.figures.poses}
    rows = []
    for pose in result.figures.poses:
        other = after[pose.pose]
        rows.append([pose.pose, _number(pose.AP), _number(other.AP), _number(pose.RP), _number(other.RP)])
    return _table(["pose", "AP measured (mm)", "AP compensated, predicted (mm)", "RP measured (mm)",
                   "RP compensated, predicted (mm)"], rows)


def iso_section(campaign, result, *, instrument=None, conditions=None):
    """The ISO page's HTML (no document around it): test conditions, instrument, the
    measured figures and, when ``result`` (an :class:`~robocal.interfaces.results.Iso9283Figures`)
    has them, the compensated robot's predicted ones."""
    if instrument is None and campaign.instrument:
        instrument = "; ".join(campaign.instrument) + " (the campaign's instrument column)"
    stated = [("instrument", instrument or "not stated (give --instrument, or an instrument column)"),
              ("conditions stated by the tester", conditions or "not stated (give --conditions: load, speed, "
                                                                "temperature, warm-up)")]
    parts = ["<h2>ISO 9283 pose characteristics</h2>",
             "<p class=note>AP: distance from the barycentre of a pose's attained positions to the commanded one; "
             "RP = l&#772; + 3 S<sub>l</sub> of the visits' distances from that barycentre; AD, RD the same for the "
             "distance between two poses (ISO 9283:1998, 7.2, 7.3 and 7.5).</p>",
             "<h3>Test conditions and instrument</h3>",
             _table(["", ""], stated + test_conditions(campaign, result)),
             "<h3>Before: measured</h3>", _figures_tables(result.figures, "measured")]
    compensated = result.compensated
    if compensated is not None:
        parts += [f"<h3>After: compensated by {html.escape(compensated.model)} "
                  f"({html.escape(compensated.method)}), predicted</h3>",
                  f"<p class=note>{html.escape(compensated.note)}.</p>",
                  _before_after(result), _figures_tables(compensated.figures, "compensated, predicted")]
    else:
        parts.append("<p class=note>No compensated figures: give --model MODEL.json to predict them.</p>")
    return "".join(parts)


def write_iso_page(path, campaign, result, *, instrument=None, conditions=None):
    """Write the ISO page as one HTML file (atomically) and return its path."""
    title = f"ISO 9283 acceptance: {campaign.path}"
    body = (f"<h1>{html.escape(title)}</h1><p class=note>robocal {html.escape(__version__)}</p>"
            + iso_section(campaign, result, instrument=instrument, conditions=conditions))
    return write_text_atomic(path, f"<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>{html.escape(title)}"
                                   f"</title><style>{STYLE}</style></head><body>{body}</body></html>\n")


def largest(figures, name):
    """The largest figure ``name`` (``AP``, ``RP``, mm) over the poses of an
    :class:`~robocal.acceptance.iso9283.Iso9283Result`, NaN without poses."""
    values = [getattr(p, name) for p in figures.poses if getattr(p, name) is not None]
    return float(np.max(values)) if values else float("nan")
