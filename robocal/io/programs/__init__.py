"""Robot programs in and out: KUKA KRL, ABB RAPID and URScript.

One module per language (``krl``, ``rapid``, ``urscript``) with the same functions:
``group(paths)`` (the files a program is made of), ``parse(files)`` ([ProgramFile] with the
Cartesian targets, run-time motions and joint targets), ``comment_offset(text)`` (where
robocal's line goes), ``new_numbers(target, pose)`` (the file's numbers for a new pose) and
``COMMENT``, ``NAME``, ``EXTENSIONS``, ``LENGTH_UNIT`` and ``UNITS`` (the file's units),
``POSTURE_ADVICE`` (how a program fixes the arm branch of its first motion); ``core`` holds
what they share.
"""
from pathlib import Path

from ...errors import InputError
from . import krl, rapid, urscript

LANGUAGES = {"krl": krl, "rapid": rapid, "urscript": urscript}


def language_of(path, language=None):
    """The language module of a program file: ``language`` (a key of LANGUAGES) or by its
    extension."""
    if language is not None:
        if language not in LANGUAGES:
            raise InputError(f"unknown --language {language!r}: choose one of {', '.join(LANGUAGES)}")
        return LANGUAGES[language]
    suffix = Path(path).suffix.lower()
    for module in LANGUAGES.values():
        if suffix in module.EXTENSIONS:
            return module
    known = ", ".join(e for m in LANGUAGES.values() for e in m.EXTENSIONS)
    raise InputError(f"{path}: cannot tell the robot language from '{suffix or 'no extension'}' ({known}); "
                     "give --language krl|rapid|urscript")
