"""What a setting may be, declared once, and the one check of a value against it.

A :class:`Setting` is a keyword of a method (or an option of a command) with its default, its
command-line option, its help and its *constraint*, in the manner of scikit-learn's parameter
constraints: :class:`Choice` (one of a few words), :class:`Number` (a number in an interval,
whole or not), :class:`Numbers` (a list of them, e.g. layer widths), :class:`Flag` (on or off)
and :class:`Either` (one of two kinds, e.g. ``'estimate'`` or a number).

A constraint answers two questions the same way:

* :meth:`Constraint.parse` reads what a user typed (a command-line option, a fleet file's
  value written as text) and returns the value;
* :meth:`Constraint.check` checks a Python value (a method's keyword, at the start of ``fit``)
  and returns it in its plain form (a tuple for a list of numbers, an int for a whole number).

Both raise :class:`Refusal`, which says what the value must be; :meth:`Setting.check` words it
as one line naming the option (``--loss must be one of linear, huber, soft_l1, got 'cauchy'``),
and the command line puts its own name in front (``--loss must be one of ...: 'cauchy' is not
available``).  The messages users see come from here and nowhere else.

This module imports nothing of robocal but its errors, so that every layer may use it.
"""
from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass

import numpy as np

from .errors import InputError

# A whole number beyond this is a typo (a count, a size, a seed), and beyond 64 bits it would
# reach NumPy as an object it cannot take.
LARGEST_WHOLE = 10**9


class Refusal(ValueError):
    """A value its constraint refuses: ``expected`` says what it must be (``'one of a, b'``,
    ``'a whole number >= 2'``).  ``unavailable``: a word typed that is not among the choices."""

    def __init__(self, expected, value, *, unavailable=False, advice=""):
        self.expected, self.value, self.unavailable, self.advice = expected, value, unavailable, advice
        super().__init__(self.phrase)

    @property
    def phrase(self):
        """What follows the setting's name: ``must be ..., got ...`` (``: advice``)."""
        if self.unavailable:
            return f"must be {self.expected}: {self.value!r} is not available"
        return f"must be {self.expected}, got {self.value!r}" + (f": {self.advice}" if self.advice else "")


class Constraint:
    """What a value may be; see the module docstring.  ``metavar`` is how --help shows it."""

    metavar = None

    @property
    def expected(self):
        """What a value must be, as a phrase (``'a number >= 0'``)."""
        raise NotImplementedError

    def parse(self, text):
        """The value of ``text`` typed by a user; :class:`Refusal` if it is not one."""
        raise NotImplementedError

    def check(self, value):
        """``value`` (a Python value) in its plain form; :class:`Refusal` if it is not one."""
        raise NotImplementedError


@dataclass(frozen=True)
class Choice(Constraint):
    """One of ``values`` (words); with ``or_file`` also the name of a file ending so."""

    values: tuple
    or_file: str | None = None

    def __post_init__(self):
        object.__setattr__(self, "values", tuple(self.values))

    @property
    def expected(self):
        if len(self.values) == 1 and not self.or_file:
            return repr(self.values[0])
        return f"one of {', '.join(self.values)}" + (f", or a {self.or_file} file" if self.or_file else "")

    @property
    def metavar(self):
        # Spaces around the bars: --help wraps a long list of choices between them, never
        # inside a word (an 80-column terminal gives the metavar column some 25 characters).
        return "<" + " | ".join(self.values + ((f"FILE{self.or_file}",) if self.or_file else ())) + ">"

    def _takes(self, value):
        # Equality for strings only: an array compared with == would give an array.  A file
        # that exists is taken whatever its ending: its reader says what it is if it is not
        # one (robocal.io.file_kinds).
        return isinstance(value, str) and (value in self.values or bool(self.or_file and (
            value.endswith(self.or_file) or os.path.isfile(value))))

    def parse(self, text):
        if self._takes(text):
            return text
        raise Refusal(self.expected, text, unavailable=True)

    def check(self, value):
        if self._takes(value):
            return value
        raise Refusal(self.expected, value)

    def __or__(self, other):
        """The choices of both (the same option of two methods)."""
        return Choice(self.values + tuple(v for v in other.values if v not in self.values), self.or_file)


# The unit a quantity in mm or degrees was most likely typed in when it is implausibly
# small, and that unit's size in mm or degrees: a length typed in metres is a thousandth of
# what it means, an angle typed in radians a 57th.
SMALLER_BY_MISTAKE = {"mm": ("metres", "m", 1000.0), "deg": ("radians", "rad", 180.0 / math.pi)}


@dataclass(frozen=True)
class Plausible:
    """The physically plausible least of a quantity in ``unit`` ("mm" or "deg"): a value
    above zero and below ``least`` is refused, naming the unit that makes it one
    (:data:`SMALLER_BY_MISTAKE`); ``why``: why nothing smaller is physical.  Zero is left to
    the constraint's bounds (no noise, a tool straight down)."""

    least: float
    unit: str
    why: str = ""

    def refusal(self, number, given, zero):
        """The :class:`Refusal` of ``number`` (typed ``given``), or None when plausible;
        ``zero``: whether the setting takes 0."""
        if not 0.0 < number < self.least:
            return None
        word, symbol, size = SMALLER_BY_MISTAKE[self.unit]
        why = f" ({self.why})" if self.why else ""
        return Refusal(f"{'0 or ' if zero else ''}at least {self.least:g} {self.unit}{why}", given,
                       advice=f"is it in {word}? ({number:g} {symbol} is {number * size:.3g} {self.unit}); give it in "
                              f"{'degrees' if self.unit == 'deg' else self.unit}")


# A standard deviation of a length or an angle below these is no instrument's (the best
# coordinate measuring machines read to a micrometre; the best angle encoders and 6-D probes to
# tenths of an arcsecond): one typed in metres or radians is.
LENGTH_SIGMA = Plausible(1e-3, "mm", "no instrument reads to better than a micrometre")
ANGLE_SIGMA = Plausible(1e-4, "deg", "no instrument or encoder reads an angle to better than 0.4 arcsec")


@dataclass(frozen=True)
class Number(Constraint):
    """A number (``whole``: a whole number) ``>= at_least``, ``<= at_most`` (whole numbers:
    :data:`LARGEST_WHOLE` unless told) or strictly ``between`` two bounds; always finite.
    ``advice``: what the refusal of a value beyond ``at_most`` adds (an amount of work: what
    the largest costs, what to do instead).  ``plausible``: a quantity in mm or degrees whose
    implausibly small values are refused as another unit (:class:`Plausible`)."""

    whole: bool = False
    at_least: float | None = None
    at_most: float | None = None
    between: tuple | None = None
    advice: str = ""
    plausible: Plausible | None = None

    @property
    def _most(self):
        return LARGEST_WHOLE if self.whole and self.at_most is None else self.at_most

    @property
    def expected(self):
        kind = "a whole number" if self.whole else "a number"
        if self.at_least is not None:
            kind += f" >= {self.at_least}"
        if self.between is not None:
            kind += f" between {self.between[0]} and {self.between[1]} (exclusive)"
        return kind

    @property
    def metavar(self):
        return "<int>" if self.whole else "<float>"

    def _bounded(self, number, given):
        if self._most is not None and number > self._most:
            raise Refusal(f"{self.expected} and <= {self._most:,}" + (f" ({self.advice})" if self.advice else ""),
                          given)
        if (not math.isfinite(number) or (self.at_least is not None and number < self.at_least)
                or (self.between is not None and not self.between[0] < number < self.between[1])):
            raise Refusal(self.expected, given)
        if self.plausible is not None:
            zero = ((self.at_least is not None and self.at_least <= 0)
                    or (self.between is not None and self.between[0] < 0 < self.between[1]))
            refusal = self.plausible.refusal(number, given, zero)
            if refusal is not None:
                raise refusal
        return number

    def parse(self, text):
        try:
            number = int(str(text).strip()) if self.whole else float(str(text).strip())
        except ValueError:
            raise Refusal(self.expected, text) from None
        return self._bounded(number, text)

    def check(self, value):
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise Refusal(self.expected, value)
        if self.whole:
            if not (math.isfinite(value) and float(value).is_integer()):
                raise Refusal(self.expected, value)
            return self._bounded(int(value), value)
        return self._bounded(float(value), value)


@dataclass(frozen=True)
class Numbers(Constraint):
    """Comma-separated numbers: ``count`` of them (any number when 0, at least
    ``at_least_count``, at most ``at_most_count``), each whole if ``whole``, ``>= at_least``
    and ``<= at_most`` (whole numbers: :data:`LARGEST_WHOLE` unless told); ``example`` shows
    one."""

    count: int = 0
    whole: bool = False
    at_least: float | None = None
    at_least_count: int = 0
    example: str = ""
    at_most: float | None = None
    at_most_count: int | None = None

    @property
    def expected(self):
        what = ("whole numbers" if self.whole else "numbers") + (
            f" >= {self.at_least}" if self.at_least is not None else "")
        if self.count:
            return f"{self.count} comma-separated {what}"
        if self.at_least_count:
            return f"at least {self.at_least_count} comma-separated {what}"
        return f"comma-separated {what}"

    @property
    def _hint(self):
        return f", e.g. {self.example}" if self.example else ""

    @property
    def metavar(self):
        return "<" + ",".join(["x"] * self.count) + ">" if self.count else "<x,y,...>"

    def _checked(self, values, given):
        most = LARGEST_WHOLE if self.whole and self.at_most is None else self.at_most
        if most is not None and max(values, default=0) > most:
            raise Refusal(f"{self.expected} <= {most:,}{self._hint}", given)
        if self.at_most_count is not None and len(values) > self.at_most_count:
            raise Refusal(f"{self.expected}, at most {self.at_most_count} of them{self._hint}", given)
        if ((self.count and len(values) != self.count) or len(values) < self.at_least_count
                or not all(math.isfinite(v) and (self.at_least is None or v >= self.at_least) for v in values)):
            raise Refusal(self.expected + self._hint, given)
        return values

    def parse(self, text):
        if not isinstance(text, str):  # already a list (a default, or a value passed on)
            return text
        try:
            values = [(int if self.whole else float)(v.strip()) for v in text.split(",")]
        except ValueError:
            raise Refusal(self.expected + self._hint, text) from None
        return self._checked(values, text)

    def check(self, value):
        refusal = Refusal(self.expected + self._hint, value)
        if not isinstance(value, (list, tuple, np.ndarray)):
            raise refusal
        values = list(value)
        if not all(isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)) and math.isfinite(v)
                   for v in values):
            raise refusal
        if self.whole and not all(float(v).is_integer() for v in values):
            raise refusal
        return tuple(self._checked([int(v) if self.whole else float(v) for v in values], value))


@dataclass(frozen=True)
class Flag(Constraint):
    """On or off."""

    expected = "true or false"

    def parse(self, text):
        if isinstance(text, bool):
            return text
        raise Refusal(self.expected, text)

    def check(self, value):
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        raise Refusal(self.expected, value)


@dataclass(frozen=True)
class Either(Constraint):
    """A value of the first constraint that takes it (``'estimate'`` or a number >= 0)."""

    first: Constraint
    second: Constraint

    @property
    def expected(self):
        return f"{self.first.expected} or {self.second.expected}"

    @property
    def metavar(self):
        return "<" + " | ".join(c.metavar.strip("<>") for c in (self.first, self.second)) + ">"

    def _either(self, how, value):
        for constraint in (self.first, self.second):
            try:
                return getattr(constraint, how)(value)
            except Refusal:
                pass
        raise Refusal(self.expected, value)

    def parse(self, text):
        return self._either("parse", text)

    def check(self, value):
        return self._either("check", value)


@dataclass(frozen=True)
class Setting:
    """One setting: its keyword ``name``, ``default``, command-line ``option``, ``help`` (a
    phrase without the default, which the command line adds) and ``constraint`` (None: any
    value).  ``optional``: None is also a value (it is whenever the default is None)."""

    name: str
    default: object
    option: str
    help: str
    constraint: Constraint | None = None
    optional: bool = False

    @property
    def takes_none(self):
        return self.optional or self.default is None

    def check(self, value):
        """The one validation of a setting's value: ``value`` in its plain form, or an
        InputError in one line naming the option (``--loss must be one of ..., got 'x'``)."""
        if (value is None and self.takes_none) or self.constraint is None:
            return value
        try:
            return self.constraint.check(value)
        except Refusal as refusal:
            raise InputError(f"{self.option} {refusal.phrase}") from None

    def parse(self, text):
        """The value of ``text`` as typed by a user (:class:`Refusal` if it is none)."""
        return text if self.constraint is None else self.constraint.parse(text)


def merged_constraint(settings):
    """The constraint of one option that several ``settings`` (of several methods) declare:
    their choices together, else the one constraint they share."""
    constraints = list(dict.fromkeys(setting.constraint for setting in settings))
    merged = constraints[0]
    for other in constraints[1:]:
        if not (isinstance(merged, Choice) and isinstance(other, Choice)):
            raise TypeError(f"{settings[0].option} is declared with different constraints: {constraints}")
        merged = merged | other
    return merged


def check_settings(settings, values):
    """Each of ``values`` (a dict by keyword) checked against its setting of ``settings``;
    the first refusal is an InputError naming the option."""
    by_name = {setting.name: setting for setting in settings}
    return {name: by_name[name].check(value) if name in by_name else value for name, value in values.items()}
