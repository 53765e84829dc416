"""ABB RAPID modules (.mod, .modx, .prg).

A robtarget is ``[[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a,...,eax_f]]``: position in
mm, orientation as a unit quaternion with q1 its scalar, confdata the posture (quadrants of
axes 1, 4 and 6, and cfx the arm's configuration), external axes.  Targets are declared
(``CONST|PERS|VAR robtarget p10 := [...]``, arrays too) and used by name, or written inline in
a motion (MoveL, MoveJ, MoveC and their kin).  A motion's tool (its fourth argument, the fifth
for MoveC) and ``\\WObj`` are looked up among the module's tooldata and wobjdata; tool0 and
wobj0 are the flange and the robot's base.  Run-time motions: a target that is an expression
(``Offs(p10,0,0,50)``, ``RelTool(...)``, ``CRobT()``) and robtargets assigned in code.
"""
from __future__ import annotations

import bisect
import re

import numpy as np

from ...errors import FileFormatError
from .core import (
    NUMBER_RE,
    JointTarget,
    Number,
    RunTime,
    Target,
    formatted,
    line_of,
    parse_each,
)

NAME = "ABB RAPID"
COMMENT = "!"
EXTENSIONS = (".mod", ".modx", ".prg")
# The unit of the file's positions (a key of robocal.io.units.LENGTH_UNITS), and of its poses.
LENGTH_UNIT = "mm"
UNITS = "mm and unit quaternions"
# The unit of its joint values (a key of robocal.io.units.ANGLE_UNITS), and how to fix others.
JOINT_UNIT = "degrees"
JOINT_ADVICE = "RAPID takes degrees: convert them with numpy.degrees()"
# What to add when nothing fixes the arm branch of a program's first motion (filter refuses it).
POSTURE_ADVICE = "give the robtarget its confdata"
# Decimals written at least when a number changes: 0.0001 mm, and 1e-7 of a quaternion (1e-5 deg).
MIN_DECIMALS = {"mm": 4, "quaternion": 7}

_DECL = re.compile(r"\b(?:LOCAL\s+|TASK\s+)*(CONST|PERS|VAR)\s+(robtarget|jointtarget|tooldata|wobjdata)\s+"
                   r"(\w+)\s*(\{[^}]*\})?\s*(:=)?", re.IGNORECASE)
_MOTION = re.compile(r"\b(Move(?:L|J|C|AbsJ|ExtJ)\w*|Trigg(?:L|J|C)|SearchL|SearchC)\b", re.IGNORECASE)
_ASSIGN = re.compile(r"(?:^|;)\s*(\w+)\s*(\{[^}]*\})?\s*((?:\.\s*\w+\s*)*):=", re.MULTILINE)


def group(paths):
    return list(paths)


def comment_offset(text) -> int:
    """After the MODULE line (a comment before it would break a .prg's header)."""
    match = re.search(r"^[ \t]*MODULE\b[^\n]*\n", text, re.IGNORECASE | re.MULTILINE)
    return match.end() if match else 0


def _tree(text, start):
    """The bracketed list that opens at ``start`` ('['): (end, [children]); a child is a
    list, a :class:`Number` or a string (TRUE, names, "text")."""
    items, position, token_start = [], start + 1, None
    while position < len(text):
        c = text[position]
        if c == "[":
            position, child = _tree(text, position)
            items.append(child)
            continue
        if c == '"':
            close = text.find('"', position + 1)
            position = (close if close >= 0 else len(text)) + 1
            items.append("string")
            continue
        if c in ",]":
            if token_start is not None:
                items.append(_token(text, token_start, position))
                token_start = None
            if c == "]":
                return position + 1, items
        elif token_start is None and not c.isspace():
            token_start = position
        position += 1
    raise FileFormatError(f"a bracket opened at line {line_of(text, start)} is not closed")


def _token(text, start, end):
    raw = text[start:end]
    lead = len(raw) - len(raw.lstrip())
    word = raw.strip()
    if NUMBER_RE.fullmatch(word):
        return Number(start + lead, word)
    return word


_N = r"\s*(" + NUMBER_RE.pattern + r")\s*"
# A robtarget literal as it is nearly always written: read in one match (the general bracket
# reader, _tree, takes the rest).
_ROBTARGET = re.compile(r"\[\s*\[" + ",".join([_N] * 3) + r"\]\s*,\s*\[" + ",".join([_N] * 4) + r"\]\s*,\s*\["
                        + ",".join([_N] * 4) + r"\]\s*,\s*\[[^\[\]]*\]\s*\]")


def _literal_at(text, start):
    """(end, node) of the bracketed literal at ``start``, a robtarget read by one regex."""
    match = _ROBTARGET.match(text, start)
    if match is None:
        return _tree(text, start)
    numbers = [Number(match.start(k), match.group(k)) for k in range(1, 12)]
    return match.end(), [numbers[:3], numbers[3:7], numbers[7:], ["external axes"] * 6]


def _is_robtarget(node):
    return (isinstance(node, list) and len(node) == 4 and all(isinstance(c, list) for c in node)
            and [len(c) for c in node[:3]] == [3, 4, 4]
            and all(isinstance(v, Number) for c in node[:3] for v in c))


def poses_of(values):
    """(N, 7) x, y, z mm, q1 (scalar), q2, q3, q4 -> (N, 4, 4)."""
    from scipy.spatial.transform import Rotation  # loaded when used: the command line starts faster
    poses = np.tile(np.eye(4), (len(values), 1, 1))
    poses[:, :3, :3] = Rotation.from_quat(values[:, [4, 5, 6, 3]]).as_matrix()
    poses[:, :3, 3] = values[:, :3]
    return poses


def _frame(node, path, line, what):
    """[[x,y,z],[q1..q4]] -> (4, 4); FileFormatError for a quaternion that is not unit."""
    if len(not_unit([node[1]])):
        _refuse_quaternion(path, line, what, node[1])
    return poses_of(np.array([[v.value for v in node[0] + node[1]]]))[0]


def _robtargets(node):
    """Every robtarget literal in a (possibly nested, for arrays) list, in order."""
    if _is_robtarget(node):
        return [node]
    if isinstance(node, list):
        return [t for child in node for t in _robtargets(child)]
    return []


def _split_arguments(text, start, end):
    """Top-level comma-separated arguments of an instruction: [(offset, text)]."""
    segment = text[start:end]
    if "[" not in segment and "(" not in segment:
        out, at = [], start
        for piece in segment.split(","):
            out.append((at, piece))
            at += len(piece) + 1
        return out
    out, depth, piece = [], 0, start
    for k in range(start, end):
        c = text[k]
        if c in "[(":
            depth += 1
        elif c in "])":
            depth -= 1
        elif c == "," and depth == 0:
            out.append((piece, text[piece:k]))
            piece = k + 1
    out.append((piece, text[piece:end]))
    return out


def parse(files):
    """[ProgramFile] of the program's files, targets found and their poses filled;
    FileFormatError for a quaternion that is not unit (:func:`not_unit`)."""
    programs = parse_each(files, NAME, COMMENT, _parse, poses_of)
    for program in programs:
        bad = not_unit([t.numbers[3:7] for t in program.targets])
        if len(bad):
            target = program.targets[bad[0]]
            _refuse_quaternion(program.path, target.line, f"robtarget {target.name}", target.numbers[3:7],
                               len(bad))
    return programs


def not_unit(quaternions):
    """Indices of the quaternions (each 4 :class:`Number` as written) that are no unit
    quaternion rounded to the decimals written.

    An ABB controller refuses an orientation whose squares do not sum to 1, and programs
    write 4 to 9 decimals: the tolerance is the file's own precision.  The digits stand for
    any value within half a unit of the last decimal of the quaternion's finest component (a
    writer that drops trailing zeros writes 0 for 0.000000 and 0.5 for 0.500000; whole
    numbers alone are exact), so a quaternion passes when that box of values meets the unit
    sphere: its nearest point to the origin within 1, its farthest beyond.  Written to 6
    decimals, a quaternion may be off 1 by about 1e-6; one doubled or halved by a generator's
    mistake is refused whatever its digits."""
    if not len(quaternions):
        return np.zeros(0, dtype=int)
    values = np.abs(np.array([[n.value for n in q] for q in quaternions], dtype=float))
    decimals = np.array([max(n.decimals for n in q) for q in quaternions], dtype=float)
    half = np.where(decimals > 0, 0.5 * 10.0 ** -decimals, 0.0)[:, None]
    nearest = np.sqrt((np.maximum(values - half, 0.0) ** 2).sum(axis=1))
    farthest = np.sqrt(((values + half) ** 2).sum(axis=1))
    # 1e-12: the sums of squares in floating point, far below any decimals written.
    return np.flatnonzero((nearest > 1.0 + 1e-12) | (farthest < 1.0 - 1e-12))


def _refuse_quaternion(path, line, what, numbers, count=1):
    norm = float(np.linalg.norm([n.value for n in numbers]))
    others = f" ({count - 1} more robtarget(s) alike)" if count > 1 else ""
    raise FileFormatError(
        f"{path} line {line}: the quaternion of {what} [{', '.join(n.text for n in numbers)}] has norm {norm:.6g}, "
        f"not 1 at the decimals written{others}: an ABB controller refuses an orientation that is not normalised, so "
        "robocal does not filter it into one; normalise it in the program (RAPID's NOrient); nothing was written")


def _parse(program, text):
    declared, order = {}, 0
    declaration_spans = []
    for match in _DECL.finditer(text):
        kind, name = match.group(2).lower(), match.group(3)
        if match.group(5) is None:
            declared.setdefault(name.upper(), (kind, None))
            continue
        bracket = text.find("[", match.end())
        if bracket < 0 or text[match.end():bracket].strip():
            declared[name.upper()] = (kind, None)
            continue
        end, node = _literal_at(text, bracket)
        declaration_spans.append((match.start(), end))
        line = line_of(text, match.start())
        if kind == "robtarget":
            literals = _robtargets(node)
            for k, literal in enumerate(literals):
                label = name if match.group(4) is None else f"{name}{{{k + 1}}}"
                target = _target(program, literal, line_of(text, literal[0][0].start), label)
                declared[label.upper()] = ("robtarget", target)
        elif kind == "jointtarget":
            declared[name.upper()] = (kind, tuple(v.value for v in node[0]) if isinstance(node[0], list) else None)
        elif kind == "tooldata":
            program.frames[("tool", name.upper())] = _frame(node[1], program.path, line, f"tooldata {name}")
        elif kind == "wobjdata":
            user, frame = (_frame(node[k], program.path, line, f"wobjdata {name} ({part})")
                           for k, part in ((3, "uframe"), (4, "oframe")))
            program.frames[("wobj", name.upper())] = user @ frame
    starts = [start for start, _ in declaration_spans]
    for match in _MOTION.finditer(text):
        k = bisect.bisect_right(starts, match.start()) - 1
        if k >= 0 and match.start() < declaration_spans[k][1]:
            continue
        end = text.find(";", match.end())
        end = len(text) if end < 0 else end
        order += 1
        _motion(program, text, match, end, declared, order)
    for match in _ASSIGN.finditer(text):
        name = match.group(1).upper()
        entry = declared.get(name)
        if entry is None or entry[0] != "robtarget":
            continue
        line = line_of(text, match.start(1))
        rhs_end = text.find(";", match.end())
        rhs = text[match.end():rhs_end].strip()
        if not match.group(3) and rhs.startswith("["):
            _, node = _literal_at(text, text.index("[", match.end()))
            if _is_robtarget(node):
                _target(program, node, line, match.group(1))
                continue
        program.run_time.append(RunTime(program.path, line, f"{match.group(1)}{match.group(2) or ''}"
                                                            f"{match.group(3).replace(' ', '')} := {rhs}: assigned "
                                                            "in code"))


def _target(program, literal, line, name):
    numbers = list(literal[0]) + list(literal[1])
    target = Target(program.path, line, name, numbers, posture=tuple(round(c.value) for c in literal[2]),
                    language=NAME)
    program.targets.append(target)
    return target


def _motion(program, text, match, end, declared, order):
    instruction = match.group(1)
    line = line_of(text, match.start())
    arguments = [(at, arg) for at, arg in _split_arguments(text, match.end(), end) if not arg.strip().startswith("\\")]
    if instruction.lower().startswith("moveabsj"):
        if arguments:
            at, arg = arguments[0]
            name = arg.split("\\")[0].strip().upper()
            joints = declared.get(name, (None, None))[1] if not arg.strip().startswith("[") else None
            if arg.strip().startswith("["):
                _, node = _tree(text, text.index("[", at))
                joints = tuple(v.value for v in node[0]) if isinstance(node[0], list) else None
            if joints is not None:
                program.joint_targets.append(JointTarget(program.path, order, joints, line))
        return
    if instruction.lower().startswith("moveext"):
        return
    circular = instruction.lower()[4:5] == "c" or instruction.lower().startswith(("triggc", "searchc"))
    count = 2 if circular else 1
    tool_at = count + 2
    tool = wobj = None
    if len(arguments) > tool_at:
        tool = arguments[tool_at][1].split("\\")[0].strip().upper()
    found = re.search(r"\\\s*WObj\s*:=\s*(\w+)", text[match.end():end], re.IGNORECASE)
    if found:
        wobj = found.group(1).upper()
    for at, arg in arguments[:count]:
        arg_text = arg.split("\\")[0].strip() if not arg.strip().startswith("[") else arg.strip()
        if arg_text.startswith("["):
            _, node = _literal_at(text, text.index("[", at))
            if _is_robtarget(node):
                target = _target(program, node, line, "inline")
                target.order, target.tool, target.base = order, tool, wobj
                continue
        key = re.sub(r"\s+", "", arg_text).upper()
        entry = declared.get(key)
        element = re.fullmatch(r"(\w+)\{[^}]*\}", key)
        if entry is None and element is not None and f"{element.group(1)}{{1}}" in declared:
            # An array indexed at run time: every element of a literal array is a target.
            elements = [e[1] for k, e in declared.items() if k.startswith(element.group(1) + "{")]
        else:
            elements = [entry[1]] if entry is not None and entry[0] == "robtarget" and entry[1] is not None else []
        for target in elements:
            if target.order == np.inf:
                target.order, target.tool, target.base = order, tool, wobj
        if not elements:
            program.run_time.append(RunTime(program.path, line, f"{instruction} {arg_text}: computed at run time"))


def new_numbers(targets, poses):
    """[(Number, text)] writing ``poses`` into x, y, z and the quaternions (the sign nearest
    the file's); a quaternion that has not turned keeps its characters (written to few
    decimals, it is not quite unit)."""
    from scipy.spatial.transform import Rotation  # loaded when used: the command line starts faster
    if not targets:
        return []
    old = np.array([[n.value for n in t.numbers[3:]] for t in targets])
    xyzw = Rotation.from_matrix(poses[:, :3, :3]).as_quat()
    quaternions = xyzw[:, [3, 0, 1, 2]]
    dot = (quaternions * old).sum(axis=1)
    quaternions = np.where(dot[:, None] < 0, -quaternions, quaternions)
    turned = 2 * np.arccos(np.minimum(1.0, np.abs(dot) / np.linalg.norm(old, axis=1)))
    values = np.column_stack([poses[:, :3, 3], quaternions])
    out = formatted(targets, values, [MIN_DECIMALS["mm"]] * 3 + [MIN_DECIMALS["quaternion"]] * 4)
    still = np.repeat(turned < 10.0 ** -MIN_DECIMALS["quaternion"], 7) & np.tile([False] * 3 + [True] * 4, len(targets))
    return [(n, n.text) if keep else (n, text) for (n, text), keep in zip(out, still)]
