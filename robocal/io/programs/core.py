"""What every robot-program language shares: numbers with their exact byte spans and
precision, the Cartesian targets found in a file, the run-time motions that cannot be
filtered, the comment line robocal adds and its recogniser.

A program is read as bytes and decoded as Latin-1, a one-to-one map of bytes to characters,
so that a character offset is a byte offset and writing back the untouched characters gives
back the original bytes whatever the file's real encoding (KRL and RAPID files are often
Windows-1252).  Only the characters of the numbers of Cartesian targets are replaced, and one
comment line is inserted.

Units at this edge: a :class:`Target` holds its pose in mm and a rotation matrix (the
language module converts from the file's degrees, quaternions or metres and radians) and
turns a new pose back into numbers in the file's units.
"""
from __future__ import annotations

import bisect
import hashlib
import re
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ...errors import FileFormatError
from .. import reading
from ..units import ANGLE_UNITS, check_posture_units

ENCODING = "latin-1"
# A number as the three languages write it: sign, digits, optional fraction and exponent.
NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
NUMBER_RE = re.compile(NUMBER)
# The text that marks a file robocal wrote (after the language's comment sign).
MARK = "robocal filter:"


class Number(NamedTuple):
    """One number of a file: its characters ``text`` at ``start`` (character = byte offset)
    and its value."""

    start: int
    text: str

    @property
    def end(self) -> int:
        return self.start + len(self.text)

    @property
    def value(self) -> float:
        return float(self.text)

    @property
    def decimals(self) -> int:
        """Digits after the decimal point (0 without one; an exponent counts against them)."""
        text = self.text
        if "e" not in text and "E" not in text:
            point = text.find(".")
            return 0 if point < 0 else len(text) - point - 1
        mantissa, _, exponent = text.lower().partition("e")
        return max(0, len(mantissa.partition(".")[2]) - int(exponent))


def number_at(text, start) -> Number:
    """The number that begins at ``start`` (after optional blanks) in ``text``."""
    match = NUMBER_RE.match(text, start)
    if match is None:
        raise FileFormatError(f"expected a number at {text[start:start + 20]!r}")
    return Number(match.start(), match.group())


def numbers_in(text, start, end) -> list[Number]:
    """Every number between ``start`` and ``end`` of ``text``, in order."""
    return [Number(m.start(), m.group()) for m in NUMBER_RE.finditer(text, start, end)]


def format_like(value, original: Number, min_decimals: int) -> str:
    """``value`` written as the file writes ``original``: the original characters when the
    value is the original's at the precision written below (so a target that does not move
    stays byte for byte), else fixed point with the original's decimals or ``min_decimals``,
    whichever is finer; a leading '+' is kept."""
    decimals = original.decimals
    decimals = max(decimals, min_decimals)
    if abs(value - float(original.text)) < 0.5 * 10.0 ** -decimals:
        return original.text
    text = f"{value:.{decimals}f}"
    if text[0] == "-" and float(text) == 0.0:
        text = text[1:]
    if original.text[0] == "+" and text[0] != "-":
        text = "+" + text
    if decimals == 0 and "." in original.text:
        text += "."
    return text


_LINES = {"text": None, "newlines": None}


def line_of(text, offset) -> int:
    """1-based line number of a character offset (the line starts of the last text asked
    about are kept: a program's targets are looked up one after the other)."""
    if _LINES["text"] is not text:
        _LINES["text"], _LINES["newlines"] = text, [m.start() for m in re.finditer("\n", text)]
    return bisect.bisect_left(_LINES["newlines"], offset) + 1


@dataclass
class Target:
    """One Cartesian target of a program.

    file, line, name: where it is (name: the variable, or "inline");
    numbers: the file's numbers for the pose, in the language's order; pose: (4, 4) mm in the
    program's base frame with the program's tool, as the file says; posture: the language's
    posture (KRL (S, T), RAPID (cf1, cf4, cf6, cfx)) or None; follows: True when the robot
    arrives with the posture it had (KRL LIN/CIRC, URScript), False when the posture is the
    point's; base, tool: names or numbers of the frames the motion uses (None: the defaults);
    order: position of its first use in the program (for the posture of the previous motion).
    """

    file: str
    line: int
    name: str
    numbers: list
    pose: np.ndarray = None
    posture: object = None
    follows: bool = False
    base: object = None
    tool: object = None
    order: float = np.inf
    language: str = ""


@dataclass(frozen=True)
class RunTime:
    """A motion or assignment whose target is computed when the program runs."""

    file: str
    line: int
    what: str


@dataclass(frozen=True)
class JointTarget:
    """A joint-space motion: the posture the robot is in afterwards (controller degrees), at
    ``line`` of ``file``."""

    file: str
    order: float
    joints: tuple
    line: int = 0


def check_joint_targets(programs, chain):
    """InputError in one line naming the file and line when the joint values of a program's
    joint motion are not in its language's unit (``JOINT_UNIT``) for ``chain``: beyond the
    joint limits where the other unit brings them within (degrees in a URScript movej), or,
    in degrees, looking like radians; :func:`robocal.io.units.check_posture_units`, the one
    check of a posture's units."""
    for program in programs:
        module = program.module
        revolute = np.asarray(chain.revolute, dtype=bool)
        for joint in program.joint_targets:
            values = np.asarray(joint.joints, dtype=float)
            if values.shape != (chain.n_joints,):
                continue
            # The file's numbers: the controller degrees back in the language's unit.
            written = np.where(revolute, values / ANGLE_UNITS[module.JOINT_UNIT], values)
            check_posture_units(chain, written, module.JOINT_UNIT, f"{program.path}, line {joint.line}",
                                module.JOINT_ADVICE)


@dataclass
class ProgramFile:
    """One file read: ``path``, ``text`` (Latin-1 decoded bytes), its ``language``, its
    Cartesian ``targets``, ``run_time`` motions and ``joint_targets``; ``frames`` the tool and
    base data the file itself declares ({name: (4, 4) mm})."""

    path: str
    text: str
    language: str
    targets: list = field(default_factory=list)
    run_time: list = field(default_factory=list)
    joint_targets: list = field(default_factory=list)
    frames: dict = field(default_factory=dict)

    @property
    def newline(self) -> str:
        """The file's line ending (of its first line; LF for a one-line file)."""
        end = self.text.find("\n")
        return "\r\n" if end > 0 and self.text[end - 1] == "\r" else "\n"


def parse_each(files, language, comment, parse_one, poses_of):
    """[ProgramFile] of a language whose files stand alone (RAPID, URScript): each read,
    ``parse_one(program, text without comments)`` finding its targets, their poses filled by
    ``poses_of`` (values (N, k) in the language's units -> (N, 4, 4) mm)."""
    programs = []
    for path in files:
        program = ProgramFile(str(path), read_text(path), language)
        parse_one(program, strip_comments(program.text, comment))
        fill_poses(program.targets, poses_of)
        programs.append(program)
    return programs


def fill_poses(targets, poses_of):
    """Set every target's pose at once from its numbers (``poses_of``: (N, k) file values ->
    (N, 4, 4), the language's conversion)."""
    if targets:
        poses = poses_of(np.array([[n.value for n in t.numbers] for t in targets], dtype=float))
        for target, pose in zip(targets, poses):
            target.pose = pose


def formatted(targets, values, min_decimals):
    """[(Number, text)] for (N, k) new values of the targets' numbers (``min_decimals`` one
    per column), as :func:`format_like` writes each, the unchanged ones found at once."""
    numbers = [n for t in targets for n in t.numbers]
    if not numbers:
        return []
    old = np.array([float(n.text) for n in numbers])
    decimals = np.maximum([n.decimals for n in numbers], np.tile(min_decimals, len(targets)))
    new = np.asarray(values, dtype=float).ravel()
    keep = np.abs(new - old) < 0.5 * 10.0 ** -decimals.astype(float)
    out = []
    for number, value, places, kept in zip(numbers, new.tolist(), decimals.tolist(), keep.tolist()):
        if kept:
            out.append((number, number.text))
        elif places and number.text[0] != "+":  # the common case, as format_like writes it
            text = f"{value:.{places}f}"
            out.append((number, text[1:] if text[0] == "-" and not float(text) else text))
        else:
            out.append((number, format_like(value, number, places)))
    return out


def read_text(path) -> str:
    """A program file's bytes as Latin-1 text (one character per byte: written back, every
    byte is what it was), read by robocal's one bounded reader."""
    raw = reading.read_bytes(path, "robot program", "program")
    reading.check_line_lengths(raw, path, "robot program")
    if b"\x00" in raw or raw.startswith(b"PK\x03\x04"):
        # No robot language writes NUL bytes: an archive, a backup image or a binary file.
        raise FileFormatError(f"{path} is not a text program (it holds NUL bytes: an archive or a binary file?): "
                              "give the program's source files (.src/.dat, .mod/.prg, .script)")
    return raw.decode(ENCODING)


def model_digest(model_path) -> str:
    """The first 16 hex digits of the model file's SHA-256 (read by the one bounded reader,
    as the model was)."""
    return hashlib.sha256(reading.read_bytes(model_path, "model file", "model")).hexdigest()[:16]


def comment_text(model_name, digest) -> str:
    """The words of robocal's line, without the language's comment sign."""
    return f"{MARK} targets compensated with model {model_name} (sha256 {digest})"


def is_filtered(text, comment_sign) -> bool:
    """Whether a file carries robocal's line (it was filtered already)."""
    pattern = re.compile(r"^[ \t]*" + re.escape(comment_sign) + r"[ \t]*" + re.escape(MARK), re.MULTILINE)
    return pattern.search(text) is not None


def rewrite(program: ProgramFile, replacements, comment_at: int, comment: str) -> str:
    """The file's text with ``replacements`` ([(Number, new text)]) applied and the line
    ``comment`` (with its comment sign) inserted at character ``comment_at`` (a line start)."""
    pieces, position = [], 0
    edits = [(n.start, n.start + len(n.text), new) for n, new in replacements if new != n.text]
    edits.append((comment_at, comment_at, comment + program.newline))
    edits.sort()
    for start, end, new in edits:
        if start < position:
            raise FileFormatError(f"{program.path}: overlapping edits at character {start}")
        pieces.append(program.text[position:start])
        pieces.append(new)
        position = end
    pieces.append(program.text[position:])
    return "".join(pieces)


def strip_comments(text, sign) -> str:
    """``text`` with comments (from ``sign`` to the line end, outside double-quoted strings)
    blanked by spaces, so that offsets stay and no pattern matches inside a comment."""
    pattern = re.compile(r'"[^"\n]*"|' + re.escape(sign) + r"[^\r\n]*")

    def blank(match):
        found = match.group()
        return found if found.startswith('"') else " " * len(found)

    return pattern.sub(blank, text)


def closest_angle(angle, reference):
    """``angle`` (rad) plus the multiple of 2 pi that brings it nearest ``reference``."""
    return angle + 2 * np.pi * np.round((reference - angle) / (2 * np.pi))
