"""The shape of a parsed document (TOML or JSON), checked at the edge: the one schema helper.

A reader that gets a document from :func:`robocal.io.reading.load_toml` or ``load_json``
asks here for each value it uses, with ``where`` saying which (``'ur5.toml: joint 3 a'``):
:func:`table`, :func:`tables`, :func:`text`, :func:`number`, :func:`numbers` and
:func:`keys` return the value in its plain form, or raise :class:`FileFormatError` in one
line naming the place, what it must be and what was found (shortened).  So a value of the
wrong type, a missing key or a table nested where a number belongs is one line, never a
``TypeError`` deep in the code that uses it.  A document that states its units (a truth
file's ``units``) has them checked by :func:`stated_units`: a unit robocal does not read
there is refused, never ignored.
"""
from __future__ import annotations

import difflib
import math
import numbers as _numbers

from ..errors import FileFormatError

# A value shown in a message is cut to this many characters: one line, whatever the file holds.
SHOWN_CHARS = 60


def shown(value):
    """``repr(value)``, cut to :data:`SHOWN_CHARS`."""
    text = repr(value)
    return text if len(text) <= SHOWN_CHARS else text[:SHOWN_CHARS - 3] + "..."


def _refuse(where, expected, value):
    raise FileFormatError(f"{where} must be {expected}, got {shown(value)}")


def table(value, where, expected="a table"):
    """``value`` if it is a table (dict); ``expected`` says what it must be, for the refusal
    (``'a table with xyz and rpy'``)."""
    if not isinstance(value, dict):
        _refuse(where, expected, value)
    return value


def tables(value, where, expected="a list of tables"):
    """``value`` if it is a non-empty list of tables ([[name]] in TOML)."""
    if not isinstance(value, list) or not value or not all(isinstance(entry, dict) for entry in value):
        _refuse(where, expected, value)
    return value


def text(value, where, choices=None):
    """``value`` if it is a non-empty text (one of ``choices`` when given)."""
    if choices is not None:
        if not isinstance(value, str) or value not in choices:
            _refuse(where, f"one of {', '.join(repr(c) for c in choices)}", value)
    elif not isinstance(value, str) or not value.strip():
        _refuse(where, "a non-empty text in quotes", value)
    return value


def number(value, where):
    """``value`` as a float if it is a finite number (not a boolean)."""
    if isinstance(value, bool) or not isinstance(value, _numbers.Real):
        _refuse(where, "a number", value)
    if not math.isfinite(value):
        _refuse(where, "finite", value)
    return float(value)


def numbers(value, where, count=None):
    """``value`` as a list of floats if it is a list of finite numbers (``count`` of them)."""
    expected = f"a list of {count} numbers" if count is not None else "a list of numbers"
    if not isinstance(value, (list, tuple)) or (count is not None and len(value) != count):
        _refuse(where, expected, value)
    if not all(isinstance(v, _numbers.Real) and not isinstance(v, bool) for v in value):
        _refuse(where, expected, value)
    return [number(v, f"{where}[{k}]") for k, v in enumerate(value)]


def keys(document, where, allowed, required=()):
    """Refuse a key of ``document`` (a table) not among ``allowed`` (naming the nearest) and
    a ``required`` key it lacks."""
    for key in document:
        if key not in allowed:
            close = difflib.get_close_matches(str(key), list(allowed), n=1)
            hint = f": did you mean {close[0]!r}?" if close else f"; known keys: {', '.join(allowed)}"
            raise FileFormatError(f"{where} has unknown key {shown(key)}{hint}")
    missing = [key for key in required if key not in document]
    if missing:
        raise FileFormatError(f"{where} lacks {', '.join(missing)}")
    return document


def stated_units(value, where, expected):
    """Check the ``units`` entry of a document (``{"lengths": "mm", "angles": "deg"}``):
    ``expected`` maps each quantity to the spellings of the one unit robocal reads it in
    (the first is the one to write).  A quantity robocal does not know, or a unit other than
    its own (metres, radians), is refused in one line: the numbers of the document are read
    in robocal's units whatever the entry says, so an entry saying otherwise must not pass
    unnoticed."""
    first = next(iter(expected))
    table(value, where, f'a table of units such as {{"{first}": "{expected[first][0]}"}}')
    keys(value, where, tuple(expected))
    for quantity, spellings in expected.items():
        if quantity not in value:
            continue
        unit = value[quantity]
        if not isinstance(unit, str) or unit.strip().lower() not in {s.lower() for s in spellings}:
            raise FileFormatError(f"{where} says {quantity} are in {shown(unit)}, but this file's {quantity} are "
                                  f"read in {spellings[0]}: convert the numbers to {spellings[0]} and say "
                                  f"{spellings[0]!r}, or write the file again with robocal")
    return value
