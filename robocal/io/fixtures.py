"""Fixture files (TOML): socket centres of a calibration fixture in its own frame, in mm.

The constraint calibration uses only the pairwise socket distances, so a fixture needs at
least two distinct sockets.  See docs/ARCHITECTURE.md, "File formats".
"""

from __future__ import annotations

import difflib
import itertools
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robocal.errors import FileFormatError, InputError
from robocal.io.atomic import write_text_atomic
from robocal.io import schema
from robocal.io.reading import load_toml
from robocal.io.units import check_lengths

# Two sockets closer than this are the same socket typed twice, not a usable distance.
_SAME_POSITION_MM = 1e-6
# A ball-in-socket fixture spans tens to hundreds of mm (MUKCa: 50 mm; the balls alone are
# several mm across); sockets all closer than this are a fixture written in metres.
_SMALLEST_FIXTURE_MM = 1.0
_BARE_TOML_KEY = re.compile(r"[A-Za-z0-9_-]+")


@dataclass(frozen=True, eq=False)
class Fixture:
    """A calibration fixture: named socket centres in the fixture frame (mm).

    Construction checks that there are at least two sockets, each at three finite
    coordinates, and no two at the same place; it raises :class:`InputError` otherwise.
    """

    name: str
    sockets: dict[str, np.ndarray]

    def __post_init__(self) -> None:
        sockets = {
            str(socket_id): _socket_position(socket_id, position) for socket_id, position in self.sockets.items()
        }
        if len(sockets) < 2:
            raise InputError(
                f"fixture '{self.name}' has {len(sockets)} socket{'' if len(sockets) == 1 else 's'}: "
                f"the calibration uses distances between sockets, so it needs at least two"
            )
        for (first, a), (second, b) in itertools.combinations(sockets.items(), 2):
            if np.linalg.norm(a - b) < _SAME_POSITION_MM:
                raise InputError(
                    f"fixture '{self.name}': sockets {first} and {second} are both at {a.tolist()}: "
                    f"each socket needs its own position"
                )
        largest = max(np.linalg.norm(a - b) for a, b in itertools.combinations(sockets.values(), 2))
        # The one test of typed lengths (robocal.io.units), against a fixture's smallest span.
        check_lengths(largest, _SMALLEST_FIXTURE_MM, f"fixture '{self.name}': the socket spacing",
                      "a ball-in-socket fixture (tens of mm)")
        object.__setattr__(self, "name", str(self.name))
        object.__setattr__(self, "sockets", sockets)

    @property
    def ids(self) -> tuple[str, ...]:
        """Socket ids in file order; these are what a measurement file's ``socket`` column holds."""
        return tuple(self.sockets)

    def distance(self, a: str, b: str) -> float:
        """Distance in mm between the centres of sockets ``a`` and ``b``."""
        return float(np.linalg.norm(self._position(a) - self._position(b)))

    def distances(self) -> dict[tuple[str, str], float]:
        """Distance of every pair of distinct sockets, keyed ``(a, b)`` with ``a`` before ``b`` in file order."""
        return {(a, b): self.distance(a, b) for a, b in itertools.combinations(self.ids, 2)}

    def _position(self, socket_id: str) -> np.ndarray:
        try:
            return self.sockets[str(socket_id)]
        except KeyError:
            raise InputError(
                f"fixture '{self.name}' has no socket '{socket_id}' (it has {', '.join(self.ids)}): "
                f"check the socket column of the measurements against the fixture file"
            ) from None


def _socket_position(socket_id: str, position) -> np.ndarray:
    """Three finite floats, refusing what TOML can hold but a position cannot (text, booleans, tables)."""
    values = list(position) if isinstance(position, (list, tuple, np.ndarray)) else None
    valid = (
        values is not None
        and len(values) == 3
        and all(
            isinstance(value, (int, float, np.number)) and not isinstance(value, (bool, np.bool_)) for value in values
        )
        and all(math.isfinite(value) for value in values)
    )
    if not valid:
        raise InputError(f"socket {socket_id} = {position!r} is not three finite numbers: write it as [x, y, z] in mm")
    return np.array(values, dtype=float)


def read_fixture(path: str | os.PathLike) -> Fixture:
    """Read a fixture TOML file (``name`` and a ``[sockets]`` table of ``id = [x, y, z]``).

    The name defaults to the file name without extension.

    Raises:
        FileFormatError: the file is missing, is not TOML, or does not describe a usable
            fixture; the message names the file and says what to change.
    """
    document = load_toml(path, "fixture file", reader="fixture")
    sockets = document.get("sockets")
    if not isinstance(sockets, dict):
        raise FileFormatError(
            f"{path} has no [sockets] table{_suggestion(document)}: list the sockets as id = [x, y, z] (mm)"
        )
    try:
        name = schema.text(document["name"], f"{path}: name") if "name" in document else Path(path).stem
        return Fixture(name=name, sockets=sockets)
    except InputError as error:
        raise FileFormatError(f"{path}: {error}") from None


def _suggestion(document: dict) -> str:
    """Point at a table that is probably a misspelt ``[sockets]``."""
    by_lower_case = {key.lower(): key for key in document if isinstance(document[key], dict)}
    close = difflib.get_close_matches("sockets", list(by_lower_case), n=1)
    return f" (is [{by_lower_case[close[0]]}] meant to be [sockets]?)" if close else ""


def write_fixture(path: str | os.PathLike, fixture: Fixture) -> Path:
    """Write ``fixture`` as TOML that :func:`read_fixture` reads back exactly, atomically."""
    lines = [f"name = {_toml_string(fixture.name)}", "", "[sockets]"]
    for socket_id, position in fixture.sockets.items():
        key = socket_id if _BARE_TOML_KEY.fullmatch(socket_id) else _toml_string(socket_id)
        # repr is the shortest text that reads back as the same float, and valid TOML.
        lines.append(f"{key} = [{', '.join(repr(value) for value in position.tolist())}]")
    return write_text_atomic(path, "\n".join(lines) + "\n")


def _toml_string(text: str) -> str:
    """A TOML basic string; control characters, quotes and backslashes escaped."""
    escaped = []
    for character in text:
        if character in '"\\':
            escaped.append("\\" + character)
        elif ord(character) < 0x20 or ord(character) == 0x7F:
            escaped.append(f"\\u{ord(character):04X}")
        else:
            escaped.append(character)
    return '"' + "".join(escaped) + '"'


def fixture_to_dict(fixture: Fixture) -> dict:
    """The fixture as JSON-ready data (a model file keeps the fixture it was calibrated with)."""
    return {"name": fixture.name, "sockets": {k: v.tolist() for k, v in fixture.sockets.items()}}


def fixture_from_dict(document, path) -> Fixture:
    """Rebuild a fixture saved by :func:`fixture_to_dict`; ``path`` names the file in messages."""
    try:
        return Fixture(name=document["name"], sockets=document["sockets"])
    except (KeyError, TypeError, InputError) as exc:
        raise FileFormatError(
            f"{path}: the fixture stored in the model is damaged ({exc}); regenerate the file"
        ) from None
