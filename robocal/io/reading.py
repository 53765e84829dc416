"""Reading a user's file: the one bounded, decoding reader every format goes through.

Whatever a user names as a file may be anything: a device that never ends (``/dev/zero``),
a pipe, a directory, a spreadsheet workbook, a file saved as UTF-16, a JSON document nested
a million levels deep.  Every reader of robocal (tables, robot, fixture, model, truth,
URDF, robot programs) therefore gets its text here, so that each of these is refused in one
line naming the file and saying what to do, never with a traceback and never after
filling the memory:

* only regular files are read (a device or pipe is refused before a byte is read);
* a file larger than its format's limit is refused from its size alone;
* the bytes are read in slices, so Ctrl-C acts within one slice;
* text is decoded by its byte-order mark (UTF-8, UTF-16, UTF-32), else as UTF-8, else as
  Latin-1 (what Windows spreadsheets export); a NUL byte without a mark means binary;
* a line longer than :data:`MAX_LINE` is refused (no measurement or program line is);
* JSON nested deeper than the parser can follow is refused in one line.
"""
from __future__ import annotations

import codecs
import json
import os
import stat
import sys

from ..errors import FileFormatError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

MiB = 1 << 20
# Per kind of file, the largest that is read.  A million-pose measurement file is about
# 150 MB; a Vecchia model of 100,000 training poses about 40 MB.
LIMITS = {
    "table": 2048 * MiB,
    # A tracker's point export: a line per point, name then x, y, z (about 30 to 80 bytes);
    # its lines are split in Python, about 15 s a million.  Calibration takes thousands of
    # points, and a scan of millions is not a point export.
    "points": 32 * MiB,
    "model": 1024 * MiB,
    "program": 256 * MiB,
    "settings": 16 * MiB,  # robot, fixture, fleet and truth files, URDF
}
# No line of a measurement table, robot program, TOML or URDF file is this long.
MAX_LINE = 1 * MiB
# Bytes read at a time (an interruption is acted on between slices).
_SLICE = 4 * MiB

_MARKS = ((codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
          (codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"))


def check_regular_file(path: str | os.PathLike, what: str) -> os.stat_result:
    """The status of ``path`` when it is a regular file; else FileFormatError in one line
    saying what it is (missing, a directory, a device or a pipe, unreadable).  ``what``
    names it: "measurement file"."""
    name = str(path)
    try:
        status = os.stat(name)
    except FileNotFoundError:
        raise FileFormatError(f"{name} does not exist: check the path of the {what}") from None
    except OSError as error:
        raise FileFormatError(f"cannot read {what} {name}: {error.strerror}") from None
    if stat.S_ISDIR(status.st_mode):
        raise FileFormatError(f"{name} is a directory: give the path of the {what}")
    if not stat.S_ISREG(status.st_mode):
        raise FileFormatError(f"{name} is not a regular file (a device or a pipe): save the {what} to a file and give "
                              "its path")
    return status


def read_bytes(path: str | os.PathLike, what: str, kind: str = "table") -> bytes:
    """The bytes of the regular file ``path`` (``what`` names it in messages: "measurement
    file"), at most ``LIMITS[kind]`` of them.

    Raises:
        FileFormatError: the file does not exist, is a directory, a device or pipe, cannot
            be read, or is larger than its kind's limit.
    """
    name = str(path)
    status = check_regular_file(path, what)
    limit = LIMITS[kind]
    if status.st_size > limit:
        raise FileFormatError(f"{name} is {status.st_size / MiB:,.0f} MiB, more than any {what} robocal reads "
                              f"({limit / MiB:,.0f} MiB): is it the right file? Split it into smaller files")
    chunks, total = [], 0
    try:
        with open(name, "rb") as stream:
            while chunk := stream.read(_SLICE):
                total += len(chunk)
                if total > limit:  # it grew while being read
                    raise FileFormatError(f"{name} grows while it is read: give a finished {what}")
                chunks.append(chunk)
    except OSError as error:
        raise FileFormatError(f"cannot read {what} {name}: {error.strerror}") from None
    return b"".join(chunks)


def decode(raw: bytes, path: str | os.PathLike, what: str, form: str = "") -> str:
    """``raw`` as text: by its byte-order mark, else UTF-8, else Latin-1.

    Raises:
        FileFormatError: NUL bytes without a byte-order mark (a binary file or a workbook).
    """
    for mark, encoding in _MARKS:
        if raw.startswith(mark):
            try:
                return raw.decode(encoding)
            except UnicodeDecodeError:
                raise FileFormatError(f"{path} starts as {encoding.upper()} text but is not: save the {what} again "
                                      "as UTF-8") from None
    if raw.startswith(b"PK\x03\x04") or b"\x00" in raw:
        raise FileFormatError(f"{path} is not a text {form + ' ' if form else ''}file "
                              "(a spreadsheet workbook or another "
                              f"binary file?): save the {what} as text{' CSV' if form == 'CSV' else ''} (UTF-8)")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        # Spreadsheets on Windows export in a legacy 8-bit encoding; the names that matter
        # are ASCII either way, and Latin-1 decodes any byte.
        return raw.decode("latin-1")


def check_line_lengths(raw: bytes, path: str | os.PathLike, what: str) -> None:
    """Refuse bytes with a line longer than :data:`MAX_LINE` bytes (the newlines are found
    in NumPy, slice by slice: a million-line file costs milliseconds)."""
    import numpy as np

    newlines = [np.array([-1])]
    for begin in range(0, len(raw), _SLICE):
        count = min(_SLICE, len(raw) - begin)
        newlines.append(np.flatnonzero(np.frombuffer(raw, np.uint8, count, begin) == ord("\n")) + begin)
    newlines.append(np.array([len(raw)]))
    lengths = np.diff(np.concatenate(newlines)) - 1
    too_long = np.flatnonzero(lengths > MAX_LINE)
    if too_long.size:
        raise FileFormatError(f"{path}, line {too_long[0] + 1} is over {MAX_LINE // MiB} MiB long: this is not "
                              f"a {what}")


def read_text(path: str | os.PathLike, what: str, kind: str = "table", *, lines: bool = True, form: str = "") -> str:
    """The text of ``path`` (:func:`read_bytes`, :func:`decode`, and with ``lines`` the
    line-length check); ``form`` names the text format in messages ("CSV")."""
    raw = read_bytes(path, what, kind)
    if lines:
        check_line_lengths(raw, path, what)
    return decode(raw, path, what, form)


def read_table_text(path: str | os.PathLike, what: str = "CSV file", reader: str | None = None,
                    kind: str = "table") -> str:
    """The text of the table ``path`` (:func:`read_text`), refused in one line when it is
    one of robocal's files that is not a table (:func:`robocal.io.file_kinds.check`) or
    plainly a file of another format (:func:`robocal.io.file_kinds.text_format`: a report,
    a model, a robot or fixture file, a program): every reader of tables (measurements,
    targets, candidates, placements, ISO campaigns, joint logs, tracker points) reads here;
    ``reader``: the :data:`~robocal.io.file_kinds.READERS` entry that names what it wants
    (default: any CSV table); ``kind``: the :data:`LIMITS` entry of its size."""
    from .file_kinds import CSV_TABLE, check, text_format

    text = read_text(path, what, kind, form="CSV")
    check(path, reader or CSV_TABLE, text=text)  # robocal's own files, named by kind
    found = text_format(text)
    if found is not None:
        raise FileFormatError(f"{path} is {found}, not a table: give the {what} (a table of numbers, one row per "
                              "line, with a header line naming the columns)")
    return text


def parse_json(text: str, path: str | os.PathLike, what: str):
    """The JSON document ``text`` of ``path``, refused in one line when it is not JSON or
    nests deeper than Python's recursion allows (a hostile file, never one robocal wrote)."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise FileFormatError(f"{path} is not a JSON {what} ({error})") from None
    except RecursionError:
        raise FileFormatError(
            f"{path} nests its lists or objects thousands of levels deep: it is not a {what} robocal wrote"
        ) from None


def load_json(path: str | os.PathLike, what: str, kind: str = "model", *, reader: str | None = None):
    """Read and parse the JSON file ``path`` (every check of this module); ``reader`` (a key
    of robocal.io.file_kinds.READERS) refuses robocal's files of other kinds, named."""
    text = read_text(path, what, kind, lines=False)
    if reader is not None:
        from .file_kinds import check

        check(path, reader, text=text)
    return parse_json(text, path, what)


def load_toml(path: str | os.PathLike, what: str, hint: str = "", *, reader: str | None = None) -> dict:
    """Read and parse the TOML file ``path``; ``hint`` is added to a syntax error's line
    ("fix the file or regenerate it with 'robocal export'"); ``reader`` as for :func:`load_json`."""
    text = read_text(path, what, "settings")
    if reader is not None:
        from .file_kinds import check

        check(path, reader, text=text)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise FileFormatError(f"{path} is not valid TOML ({error}){': ' + hint if hint else ''}") from None
    except RecursionError:  # the parser recurses into nested arrays and tables, as JSON's does
        raise FileFormatError(
            f"{path} nests its arrays or tables thousands of levels deep: it is not a {what} robocal reads"
        ) from None
