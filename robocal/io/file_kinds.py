"""What a CSV file robocal wrote is, and the one check every reader makes of it.

robocal's outputs look like its inputs: a commands file (``compensate``) has the columns of a
targets file and of a measurement file.  Given back, it would be corrected a second time, or
calibrated as if the nominal robot's own positions had been measured, and either would exit
with 0.  So every CSV file robocal writes that is not what a user gives it says what it is, in a last column
:data:`KIND_COLUMN` whose cells name its kind, and every reader calls :func:`check_kind`
with the kinds it takes.  Files written before the column existed (or with it deleted) are
recognised by the columns only robocal writes (:data:`SIGNATURES`).

JSON and TOML files say what they are in a key of their own (``"schema": "robocal.model"``,
the truth file's ``"format"``); their readers check it.  A file of another format given where a
table belongs (a report, a model file, a robot file, a program) is named by
:func:`text_format` from its first lines, which the bounded reader of tables
(:func:`robocal.io.reading.read_table_text`) asks before any row is read: "an HTML page
(robocal's report?)", not a row count or a parser's complaint about field sizes.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from ..errors import FileFormatError

KIND_COLUMN = "robocal_file"


@dataclass(frozen=True)
class Kind:
    """One kind of CSV robocal writes: its ``name`` (the cells of :data:`KIND_COLUMN`),
    what it is, and the command that writes it."""

    name: str
    what: str
    written_by: str


KINDS = {kind.name: kind for kind in (
    # Simulated measurements are written unmarked (they are read as any measurement file);
    # the kind exists for readers that name what they accept.
    Kind("measurements", "a measurement file", "robocal simulate"),
    Kind("commands", "robocal's joint commands and corrected targets", "robocal compensate"),
    Kind("poses", "robocal's planned poses (what to measure, not measurements)", "robocal design"),
    Kind("evaluation", "robocal's per-pose evaluation", "robocal evaluate --per-pose"),
    Kind("fleet-summary", "robocal's fleet summary", "robocal fleet"),
    # Targets are what a user writes; the examples robocal ships say what they are, so that
    # one given as measurements (its q columns are posture hints, its x, y, z desired) is
    # named, not calibrated on.
    Kind("targets", "a targets file (desired poses; its q columns are posture hints, not joint readings)", ""),
)}
# Columns no user file is expected to hold together, by the kind that writes them.
SIGNATURES = (
    ("commands", ("reachable",)),
    ("commands", ("in_domain", "frame")),
    ("commands", ("uncertainty_mm", "frame")),
    ("poses", ("pose", "x_nominal", "y_nominal", "z_nominal")),
    ("evaluation", ("error_mm", "bound95_mm")),
    ("fleet-summary", ("robot", "status", "method")),
)


def marked(columns: dict[str, list[str]], kind: str) -> dict[str, list[str]]:
    """``columns`` (name -> cells) with the :data:`KIND_COLUMN` saying ``kind`` added last."""
    if kind not in KINDS:
        raise ValueError(f"unknown kind of robocal file {kind!r}")
    rows = len(next(iter(columns.values()), []))
    return {**{k: v for k, v in columns.items() if k != KIND_COLUMN}, KIND_COLUMN: [kind] * rows}


def recognise(header, kind_cells=None) -> str | None:
    """The kind of robocal file with ``header`` (column names) and, when it has
    :data:`KIND_COLUMN`, those cells; None for a file robocal did not write.

    Raises:
        FileFormatError: the kind column holds something robocal never writes, or more
            than one kind (files pasted together).
    """
    names = set(header)
    if KIND_COLUMN in names and kind_cells is not None and len(kind_cells):
        found = sorted(set(str(cell).strip() for cell in kind_cells))
        if len(found) > 1 or found[0] not in KINDS:
            raise FileFormatError(f"its {KIND_COLUMN} column says {', '.join(found)}: robocal writes one of "
                                  f"{', '.join(KINDS)} there, one per file; was it edited or pasted together?")
        return found[0]
    for kind, columns in SIGNATURES:
        if names.issuperset(columns):
            return kind
    return None


def check_kind(path, header, kind_cells, accepts, reading_as: str, instead: str) -> str | None:
    """Refuse a robocal file whose kind is not in ``accepts`` (names of :data:`KINDS`), in
    one line naming what it is; ``reading_as`` says what it was given as ("a targets
    file"), ``instead`` what to give ("the targets themselves (x, y, z, rx, ry, rz)").
    Returns the kind (None: not a file robocal wrote)."""
    try:
        kind = recognise(header, kind_cells)
    except FileFormatError as error:
        raise FileFormatError(f"{path}: {error}") from None
    if kind is None or kind in accepts:
        return kind
    found = KINDS[kind]
    by = f", written by '{found.written_by}'" if found.written_by else ""
    raise FileFormatError(f"{path} is {found.what}{by}, not {reading_as}: give {instead}")


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
