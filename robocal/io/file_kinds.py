"""What a file robocal wrote is, and the one check every reader makes of it.

robocal's outputs look like its inputs: a commands file (``compensate``) has the columns of a
targets file and of a measurement file.  Given back, it would be corrected a second time, or
calibrated as if the nominal robot's own positions had been measured, and either would exit
with 0.  A model file given where a robot, a fixture or a truth file belongs is refused by
that reader's parser with a message about the parser ("not valid TOML"), which does not say
what the file is.  So:

* every file robocal writes says what it is: a CSV file that is not what a user gives it in
  a column :data:`KIND_COLUMN` whose cells name its kind, a JSON file in a key of its own
  (``"schema": "robocal.model"``, the truth file's ``"format"``), an HTML page in its title,
  a robot TOML in its ``[[joints]]`` tables;
* :data:`KINDS` is the one table of those kinds and how each is recognised (:class:`Kind`);
  :data:`READERS` the one table of what each reader takes;
* every reader calls :func:`check` with the text it read (or its parsed table's columns),
  before parsing it as its own format, and a file of another kind is refused in one line
  naming what it is and what the reader wants.

CSV files written before the column existed (or with it cut off) are recognised by the
columns only robocal writes (:attr:`Kind.columns`).  A user's files are recognised by their
columns too, where the columns tell them apart: joint columns beside measured positions or
sockets are a measurement file, commanded ``x_cmd, y_cmd, z_cmd`` an ISO 9283 campaign, a
``fixture`` column beside ``x, y, z, rx, ry, rz`` and no joint columns a placements file;
the first kind whose columns a file holds is its kind (robocal's kinds first, so that a
commands file is not taken for measurements).  A placements file without its ``fixture``
column and a targets file without posture hints hold the same columns, ``x, y, z, rx, ry,
rz``: neither is recognised, and a user's file recognised as no kind is never refused here.

A file of another format given where a table belongs, not one of robocal's kinds (a JSON or
XML document, a TOML file, a robot program), is named by :func:`text_format` from its first
lines, which the bounded reader of tables (:func:`robocal.io.reading.read_table_text`) asks
after :func:`check`: "an XML document", not a row count or a parser's complaint.
"""
from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass

from ..errors import FileFormatError

KIND_COLUMN = "robocal_file"
# What the commands file's ``frame`` column says on every row (robocal.io.observations.COMMANDS_FRAME).
COMMANDS_FRAME = "robot base frame; robot-file tool; controller FK of q"
# Text files are recognised by their first this many characters.
_HEAD = 64 * 1024
# Rows of a CSV text whose cells are looked at (a parsed table gives all of them).
_SAMPLE_ROWS = 200


class WrongKind(FileFormatError):
    """A robocal file of a kind the reader does not take (its message names both): a
    reader that adds to a parser's message gives this one as it is."""


@dataclass(frozen=True)
class Kind:
    """One kind of file robocal writes (or ships as an example).

    ``name`` is what :data:`KIND_COLUMN` says (CSV); ``what`` names it in messages;
    ``written_by`` is the command that writes it ("" for a user's kind of file);
    ``form`` is CSV, JSON, HTML, TOML or XML.  A CSV kind is recognised by its
    :data:`KIND_COLUMN` cells or by any of ``columns`` (sets of names the file holds
    together; ``"name=text"`` also needs every cell of that column to say ``text``); every
    other form by ``pattern``, searched in the file's first characters."""

    name: str
    what: str
    written_by: str
    form: str = "CSV"
    columns: tuple = ()
    pattern: str = ""


KINDS = {kind.name: kind for kind in (
    Kind("commands", "robocal's joint commands and corrected targets", "robocal compensate",
         columns=(("reachable",), ("in_domain", "frame"), ("uncertainty_mm", "frame"), ("frame=" + COMMANDS_FRAME,))),
    Kind("poses", "robocal's planned poses (what to measure, not measurements)", "robocal design",
         columns=(("pose", "x_nominal", "y_nominal", "z_nominal"),)),
    Kind("evaluation", "robocal's per-pose evaluation", "robocal evaluate --per-pose",
         columns=(("error_mm", "bound95_mm"), ("bound95_mm", "in_domain"), ("x_measured", "x_model", "error_mm"))),
    Kind("fleet-summary", "robocal's fleet summary", "robocal fleet",
         columns=(("name", "status", "method", "n_train", "n_test", "mean_mm"),)),
    Kind("iso-plan", "an ISO 9283 campaign plan (the poses to visit; a campaign once measured)",
         "robocal iso9283 plan"),
    Kind("filter-summary", "robocal's filter summary (what filter changed in each program line)", "robocal filter",
         columns=(("file", "line", "status", "moved_mm", "turned_deg"),)),
    # A user's kinds, recognised by their columns after robocal's own (a commands file has a
    # measurement file's columns too).  Measurements are written unmarked, by a user's
    # instrument or 'robocal simulate' alike: their columns say what they are.
    Kind("campaign", "an ISO 9283 campaign (commanded x_cmd, y_cmd, z_cmd of each visit)", "",
         columns=(("x_cmd", "y_cmd", "z_cmd"),)),
    Kind("measurements", "a measurement file (joint columns q1 ... qN beside x, y, z or fixture, socket)",
         "", columns=(("q1", "x", "y", "z"), ("q1", "fixture", "socket"))),
    # After measurements: a file with joint columns is not one.
    Kind("placements", "a placements file (fixture frames: fixture, x, y, z, rx, ry, rz; no joint columns)", "",
         columns=(("fixture", "x", "y", "z", "rx", "ry", "rz"),)),
    # Targets are what a user writes; the examples robocal ships say what they are, so that
    # one given as measurements (its q columns are posture hints, its x, y, z desired) is
    # named, not calibrated on.
    Kind("targets", "a targets file (desired poses; its q columns are posture hints, not joint readings)", ""),
    # The model file is checked first: a model of 'calibrate --method auto' keeps a validation inside.
    Kind("model", "a robocal model file", "robocal calibrate", "JSON", pattern=r'"schema"\s*:\s*"robocal\.model"'),
    Kind("truth", "a truth file (the simulated robot's true errors)", "robocal simulate --truth", "JSON",
         pattern=r'"format"\s*:\s*"robocal-truth"'),
    Kind("validation", "robocal's cross-validation (JSON)", "robocal validate --json", "JSON",
         pattern=r'"nominal_cross_validation"\s*:'),
    Kind("evaluation-json", "robocal's evaluation (JSON)", "robocal evaluate --json", "JSON",
         pattern=r'"nominal"\s*:\s*\{[^{}]*"mean_mm"'),
    Kind("report", "robocal's HTML report", "robocal report", "HTML", pattern=r"<title>robocal report"),
    Kind("iso-page", "robocal's ISO 9283 page (HTML)", "robocal iso9283 --report", "HTML",
         pattern=r"<title>ISO 9283 acceptance"),
    Kind("fleet-page", "robocal's fleet summary page (HTML)", "robocal fleet", "HTML", pattern=r"<title>robocal fleet"),
    Kind("robot", "a robot file", "robocal export", "TOML", pattern=r"(?m)^[ \t]*\[\[joints\]\]"),
    Kind("urdf", "a URDF robot description", "robocal export --format urdf", "XML", pattern=r"<robot[\s>]"),
    Kind("fixture", "a fixture file (socket centres)", "", "TOML", pattern=r"(?m)^[ \t]*\[sockets\]"),
    Kind("fleet", "a fleet file", "", "TOML", pattern=r"(?m)^[ \t]*\[\[robot\]\]"),
)}


@dataclass(frozen=True)
class Reader:
    """What one reader takes: ``reading_as`` names it ("a targets file"), ``instead`` what
    to give, ``accepts`` the kinds (names of :data:`KINDS`) it reads; ``hints`` adds, by
    kind, what to do with that kind instead."""

    reading_as: str
    instead: str
    accepts: tuple = ()
    hints: tuple = ()


READERS = {
    "measurements": Reader("a measurement file", "measured data: q1..qN with the x, y, z the instrument measured",
                           # A design's poses become measurements when the measured x, y, z are
                           # added; a campaign's visits are joint commands and measured positions.
                           ("measurements", "poses", "campaign")),
    "targets": Reader("a targets file", "the targets themselves (x, y, z, rx, ry, rz)", ("measurements", "targets")),
    "configurations": Reader("a file of joint configurations", "measured or planned joint configurations (q1..qN)",
                             ("measurements", "poses", "campaign")),
    "campaign": Reader("an ISO 9283 campaign", "the visits: x_cmd, y_cmd, z_cmd and the measured x, y, z (mm)",
                       # A plan becomes a campaign when the measured x, y, z are added to it; a
                       # measurement file lacks the commanded columns, which the reader names.
                       ("iso-plan", "campaign", "measurements")),
    "joint-log": Reader("a joint log", "the controller's joint log (a name or time column and q1..qN)",
                        ("measurements", "campaign")),
    "points": Reader("a tracker point file", "the tracker's export of named points (name x y z)"),
    "placements": Reader("a placements file", "the fixture's placements: x, y, z (mm) and rx, ry, rz (deg) of the "
                         "fixture frame in the robot base frame, one row each", ("placements",)),
    "model": Reader("a model file", "the model file 'robocal calibrate' wrote (JSON)", ("model",)),
    "truth": Reader("a truth file", "the file 'robocal simulate --truth' wrote, or a preset name", ("truth",)),
    "validation": Reader("a validation file", "what 'robocal validate ... --json > FILE' wrote", ("validation",)),
    "robot": Reader("a robot file", "a built-in robot name, a robot .toml or a .urdf file", ("robot", "urdf"),
                    (("model", "to re-register a model on a new set-up, give it to 'robocal calibrate MODEL.json "
                               "MEAS.csv --method frames'"),)),
    "urdf": Reader("a URDF file", "the robot's URDF (XML with a <robot> element)", ("urdf",)),
    "fixture": Reader("a fixture file", "the fixture's TOML ([sockets] with id = [x, y, z] in mm)", ("fixture",)),
    "fleet": Reader("a fleet file", "the fleet's TOML (one [[robot]] table per robot)", ("fleet",)),
}
# Every CSV reader (robocal.io.csv_table) first: robocal's files of another form, named.
CSV_TABLE = Reader("a CSV table", "a CSV file (comma-separated, a header line, one row per pose)",
                   tuple(kind.name for kind in KINDS.values() if kind.form == "CSV"))


def marked(columns: dict[str, list[str]], kind: str) -> dict[str, list[str]]:
    """``columns`` (name -> cells) with the :data:`KIND_COLUMN` saying ``kind`` added last."""
    if kind not in KINDS or KINDS[kind].form != "CSV":
        raise ValueError(f"unknown kind of robocal CSV file {kind!r}")
    rows = len(next(iter(columns.values()), []))
    return {**{k: v for k, v in columns.items() if k != KIND_COLUMN}, KIND_COLUMN: [kind] * rows}


def marked_rows(header, rows, kind: str):
    """(header, rows) of a table with the :data:`KIND_COLUMN` saying ``kind`` added last."""
    if kind not in KINDS or KINDS[kind].form != "CSV":
        raise ValueError(f"unknown kind of robocal CSV file {kind!r}")
    return [*header, KIND_COLUMN], [[*row, kind] for row in rows]


# A header cell's unit tag ("q2[rad]", "x [m]"; robocal.io.csv_table), not part of its name.
_UNIT_TAG = re.compile(r"\s*\[[^\]]*\]\s*$")


def recognise(header, column=None) -> str | None:
    """The kind of CSV robocal file with ``header`` (column names); ``column(name)`` gives
    a column's cells (for :data:`KIND_COLUMN` and the columns recognised by their text).
    None: a file robocal did not write.

    Raises:
        FileFormatError: the kind column holds something robocal never writes, or more
            than one kind (files pasted together).
    """
    names = {_UNIT_TAG.sub("", str(name)).strip() for name in header}
    if KIND_COLUMN in names and column is not None:
        found = sorted({str(cell).strip() for cell in column(KIND_COLUMN)} - {""})
        if found:
            if len(found) > 1 or found[0] not in KINDS or KINDS[found[0]].form != "CSV":
                raise FileFormatError(f"its {KIND_COLUMN} column says {', '.join(found)}: robocal writes one of "
                                      f"{', '.join(k.name for k in KINDS.values() if k.form == 'CSV')} there, one per "
                                      "file; was it edited or pasted together?")
            return found[0]
    for kind in KINDS.values():
        if any(_has_columns(names, signature, column) for signature in kind.columns):
            return kind.name
    return None


def _has_columns(names, signature, column):
    for entry in signature:
        name, _, text = entry.partition("=")
        if name not in names:
            return False
        if text:
            cells = {str(cell).strip() for cell in column(name)} if column is not None else set()
            if cells != {text}:
                return False
    return True


def identify(text: str) -> str | None:
    """The kind of the file whose text is ``text`` (a name of :data:`KINDS`), or None for a
    file robocal did not write (or cannot tell)."""
    head = text[:_HEAD]
    first = head.lstrip("\ufeff \t\r\n")[:1]
    for kind in KINDS.values():
        if kind.pattern and re.search(kind.pattern, head) and _form_fits(kind.form, first):
            return kind.name
    if first in ("{", "<") or not first:
        return None
    lines = head.splitlines()
    header_line = next((line for line in lines if line.strip() and not line.lstrip().startswith("#")), "")
    delimiter = ";" if header_line.count(";") > header_line.count(",") else ","
    sample = text[:_HEAD * 4]
    if len(text) > len(sample):  # whole lines only: a cut kind cell is no kind robocal writes
        sample = sample[:sample.rfind("\n") + 1]
    rows = []
    reader = csv.reader(io.StringIO(sample), delimiter=delimiter)
    try:
        for row in reader:
            if row and any(cell.strip() for cell in row) and not row[0].lstrip().startswith("#"):
                rows.append(row)
            if len(rows) > _SAMPLE_ROWS:
                break
    except csv.Error:
        return None
    if not rows:
        return None
    header = [cell.strip() for cell in rows[0]]
    body = [row for row in rows[1:] if len(row) == len(header)]

    def column(name):
        k = header.index(name)
        return [row[k] for row in body]

    return recognise(header, column)


def _form_fits(form, first):
    if form == "JSON":
        return first == "{"
    if form in ("HTML", "XML"):
        return first == "<"
    return first not in ("{", "<")


def check(path, reader: str | Reader, *, text: str | None = None, header=None, column=None) -> str | None:
    """Refuse the file ``path`` if it is a robocal file of a kind ``reader`` (a key of
    :data:`READERS`) does not take, in one line naming what it is, what the reader wants
    and what to give.  Give the ``text`` read (before parsing it), or the parsed table's
    ``header`` and ``column(name)`` (its cells).  Returns the kind (None: not a file
    robocal wrote, or one it cannot tell)."""
    wants = reader if isinstance(reader, Reader) else READERS[reader]
    try:
        kind = identify(text) if text is not None else recognise(header, column)
    except FileFormatError as error:
        raise FileFormatError(f"{path}: {error}") from None
    if kind is None or kind in wants.accepts:
        return kind
    found = KINDS[kind]
    by = f", written by '{found.written_by}'" if found.written_by else ""
    hint = dict(wants.hints).get(kind)
    raise WrongKind(f"{path} is {found.what}{by}, not {wants.reading_as}: give {wants.instead}"
                    + (f"; {hint}" if hint else ""))


def check_kind(path, header, kind_cells, accepts, reading_as: str, instead: str) -> str | None:
    """:func:`check` as callers written before it call it (a reader that names what it takes
    itself and has the :data:`KIND_COLUMN` cells only); new readers call :func:`check`."""
    return check(path, Reader(reading_as, instead, tuple(accepts)), header=header,
                 column=(lambda name: kind_cells if name == KIND_COLUMN else []) if kind_cells is not None else None)


# What robocal's other files and a user's other files begin with (their first non-blank
# characters), and what to call them: checked in this order.
_TOML_HEADER = re.compile(r"^\s*\[\[?\s*[A-Za-z_][\w.\-\"' ]*\]\]?\s*(#.*)?$", re.M)
# A key and a TOML value (text, number, list, table, boolean): not Excel's "sep=," line.
_TOML_KEY = re.compile(r"^\s*[A-Za-z_][\w\-]*\s*=\s*([\"'\[{0-9+\-]|true\b|false\b|inf\b|nan\b)", re.M)
_PROGRAM = re.compile(r"^\s*(def\s+\w+\s*\(|&ACCESS\b|&REL\b|DEF\s+\w+\s*\(|MODULE\s+\w+)", re.I | re.M)
# How much of a file is looked at: the signs of a format are in its first lines.
_HEAD_CHARS = 4096


def text_format(text: str) -> str | None:
    """What the text of a file is when it is plainly not a table, as a phrase ("an HTML
    page (robocal's report?)", "a JSON document (a robocal model file?)"); None when it may
    be one.  Only what a table cannot begin with is named: a table's first line is a header
    of names, which none of these is."""
    head = text[:_HEAD_CHARS].lstrip("\ufeff \t\r\n")
    lowered = head[:200].lower()
    if lowered.startswith(("<!doctype html", "<html")):
        return "an HTML page (robocal's report?)" if "robocal" in head.lower() else "an HTML page"
    if lowered.startswith("<"):
        return "a URDF robot description (XML)" if "<robot" in head.lower() else "an XML document"
    if head.startswith("{") or (head.startswith("[") and not _TOML_HEADER.match(head.splitlines()[0])):
        if '"robocal.model"' in head:
            return "a robocal model file (JSON)"
        if '"robocal-truth"' in head:
            return "robocal's truth file (JSON, written by simulate --truth)"
        return "a JSON document (a robocal model file?)"
    # TOML files often open with comments; a table's first line is its header.
    first = next((line for line in head.splitlines() if line.strip() and not line.lstrip().startswith("#")), "")
    if _TOML_HEADER.match(first) or _TOML_KEY.match(first):
        if re.search(r"^\s*\[\[\s*joints\s*\]\]", head, re.M):
            return "a robot file (TOML)"
        if re.search(r"^\s*\[\s*sockets\s*\]", head, re.M):
            return "a fixture file (TOML)"
        return "a TOML file (settings, a robot or a fixture?)"
    if _PROGRAM.match(head):
        return "a robot program"
    return None
