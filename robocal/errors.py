"""Errors a user can cause.

Every exception raised for bad input derives from :class:`RobocalError`; its message says
what is wrong and what to do.  The command line prints that one line and exits non-zero,
so nothing here should need a traceback to be understood.
"""


class RobocalError(Exception):
    """Base class of every user-facing error."""


class InputError(RobocalError, ValueError):
    """Arguments or data that cannot be used as given."""


class FileFormatError(InputError):
    """A file that cannot be read: missing columns, bad cells, wrong units, corrupted."""


class RobocalWarning(UserWarning):
    """Data that can be used but look suspicious (radians where degrees are expected, duplicates)."""
