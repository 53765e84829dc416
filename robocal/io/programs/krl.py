"""KUKA KRL: a .src with its .dat.

Cartesian targets are E6POS, POS and FRAME aggregates, ``{X 1200.5, Y 0, Z 1500, A 0, B 90,
C 0, S 6, T 27, E1 0}``: X, Y, Z in mm; A, B, C rotations about Z, Y, X in degrees
(R = Rz(A)·Ry(B)·Rx(C)); S and T the posture (status and turn bits); E1..E6 external axes.
They are declared (``DECL E6POS XP1={...}``, in the .dat or the .src) and used by name, or
written inline in a motion (PTP, LIN, CIRC, SPTP, SLIN, SCIRC, SPL).  A motion's tool and
base are its inline form's FDAT (``FDAT_ACT=FP1``, ``DECL FDAT FP1={TOOL_NO 1,BASE_NO 2,...}``)
or the last ``$TOOL=TOOL_DATA[n]`` / ``BAS(#TOOL,n)`` (and the same for the base).  Run-time
motions: ``*_REL`` motions, geometric operators (``P1:P2``), partial aggregates (they keep
the rest of the current position) and Cartesian variables assigned in code.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ...errors import FileFormatError
from ...spatial.rotations import matrix_to_rpy, rpy_to_matrix
from .core import (
    NUMBER,
    JointTarget,
    Number,
    ProgramFile,
    RunTime,
    Target,
    closest_angle,
    fill_poses,
    formatted,
    line_of,
    read_text,
    strip_comments,
)

NAME = "KUKA KRL"
COMMENT = ";"
EXTENSIONS = (".src", ".dat")
# The unit of the file's positions (a key of robocal.io.units.LENGTH_UNITS), and of its poses.
LENGTH_UNIT = "mm"
UNITS = "mm and degrees"
# The unit of its joint values (a key of robocal.io.units.ANGLE_UNITS), and how to fix others.
JOINT_UNIT = "degrees"
JOINT_ADVICE = "KRL takes degrees: convert them with numpy.degrees()"
# What to add when nothing fixes the arm branch of a program's first motion (filter refuses it).
POSTURE_ADVICE = ("start the program with a PTP to joint values (an E6AXIS, as a BCO run needs) or give the point "
                  "S and T")
CARTESIAN_TYPES = ("E6POS", "POS", "FRAME")
POSE_KEYS = ("X", "Y", "Z", "A", "B", "C")
# Motions whose posture is the point's own (S, T); the others keep the posture the robot has.
POSTURE_MOTIONS = ("PTP", "SPTP")
MOTIONS = ("PTP", "LIN", "CIRC", "SPTP", "SLIN", "SCIRC", "SPL")
# Decimals written at least when a number changes: 0.0001 mm and 0.0001 deg.
MIN_DECIMALS = 4

_DECL = re.compile(r"^[ \t]*(?:DECL[ \t]+)?(?:GLOBAL[ \t]+)?(E6POS|POS|FRAME|E6AXIS|AXIS|FDAT)[ \t]+"
                   r"(\w+)[ \t]*(\[[^\]]*\])?[ \t]*(=)?", re.IGNORECASE | re.MULTILINE)
_ASSIGN = re.compile(r"^[ \t]*([\w$]+)[ \t]*(\[[^\]]*\])?[ \t]*(\.[ \t]*\w+)?[ \t]*=(?!=)", re.MULTILINE)
_MOTION = re.compile(r"^[ \t]*(" + "|".join(MOTIONS) + r")(_REL)?\b", re.IGNORECASE | re.MULTILINE)
_TOOL = re.compile(r"\$TOOL\s*=\s*TOOL_DATA\s*\[\s*(\d+)\s*\]|BAS\s*\(\s*#TOOL\s*,\s*(\d+)", re.IGNORECASE)
_BASE = re.compile(r"\$BASE\s*=\s*BASE_DATA\s*\[\s*(\d+)\s*\]|BAS\s*\(\s*#BASE\s*,\s*(\d+)", re.IGNORECASE)
_FDAT_ACT = re.compile(r"FDAT_ACT\s*=\s*(\w+)", re.IGNORECASE)


def group(paths):
    """The files a KRL program is made of: each .src with the .dat beside it (a .dat given
    alone is a data list of its own)."""
    out = []
    for path in paths:
        path = Path(path)
        out.append(path)
        if path.suffix.lower() == ".src":
            dat = data_list_of(path)
            if dat is not None:
                out.append(dat)
    return out


def data_list_of(src):
    """The .dat beside a .src (its name in any case: files copied from a controller's Windows
    disk may be CELL.DAT beside cell.src), or None."""
    src = Path(src)
    for suffix in (".dat", ".DAT"):
        if src.with_suffix(suffix).is_file():
            return src.with_suffix(suffix)
    wanted = src.stem.lower() + ".dat"
    try:
        found = [p for p in src.parent.iterdir() if p.name.lower() == wanted and p.is_file()]
    except OSError:
        return None
    return min(found) if found else None


def comment_offset(text) -> int:
    """Where robocal's line goes: after the leading '&' header lines (the editor needs them
    first)."""
    offset = 0
    while text.startswith("&", offset):
        end = text.find("\n", offset)
        if end < 0:
            return len(text)
        offset = end + 1
    return offset


_PAIR = re.compile(r"([A-Za-z_$][\w$]*)[ \t]+(" + NUMBER + r"|'[^']*')")


_VALUE = r"[ \t]+(" + NUMBER + r"|'[^']*')[ \t]*"
# A Cartesian aggregate as nearly every program writes it, X Y Z A B C (S T) in this order:
# read in one match (the rest of the aggregate, E1..E6, is not needed).
_POSE_AGGREGATE = re.compile(r"\{[ \t]*" + r",[ \t]*".join(f"{k}{_VALUE}" for k in POSE_KEYS)
                             + r"(?:,[ \t]*S" + _VALUE + r",[ \t]*T" + _VALUE + ")?", re.IGNORECASE)


def _aggregate(text, start):
    """The aggregate that opens at ``start`` ('{'): (end, {KEY: Number or str})."""
    end = text.find("}", start)
    if end < 0:
        raise FileFormatError(f"an aggregate opened at line {line_of(text, start)} is not closed")
    fast = _POSE_AGGREGATE.match(text, start, end)
    if fast is not None:
        items = {k: Number(fast.start(g), fast.group(g)) for g, k in enumerate(POSE_KEYS, start=1)}
        for g, k in ((7, "S"), (8, "T")):
            value = fast.group(g)
            if value is not None:
                items[k] = value if value.startswith("'") else Number(fast.start(g), value)
        return end + 1, items
    items = {}
    for match in _PAIR.finditer(text, start + 1, end):
        value = match.group(2)
        items[match.group(1).upper()] = value if value.startswith("'") else Number(match.start(2), value)
    return end + 1, items


def poses_of(values):
    """(N, 6) X, Y, Z mm, A, B, C deg -> (N, 4, 4)."""
    poses = np.tile(np.eye(4), (len(values), 1, 1))
    poses[:, :3, :3] = rpy_to_matrix(np.radians(values[:, [5, 4, 3]]))
    poses[:, :3, 3] = values[:, :3]
    return poses


def _posture(items):
    def bits(key):
        value = items.get(key)
        if value is None:
            return None
        if isinstance(value, str):
            return int(value.strip("'").lstrip("Bb"), 2)
        return round(value.value)
    s, t = bits("S"), bits("T")
    return None if s is None else (s, t)


def _is_cartesian(items):
    return any(k in items for k in POSE_KEYS) and not any(re.fullmatch(r"A\d", k) for k in items)


def frame_of(items):
    """(4, 4) mm of a FRAME aggregate (missing components are 0)."""
    values = [items[k].value if k in items and not isinstance(items[k], str) else 0.0 for k in POSE_KEYS]
    return poses_of(np.array([values]))[0]


def read_config(path):
    """TOOL_DATA[n] and BASE_DATA[n] of a $config.dat: {("TOOL", n): (4, 4), ("BASE", n): ...}."""
    text = strip_comments(read_text(path), COMMENT)
    frames = {}
    for match in re.finditer(r"(TOOL_DATA|BASE_DATA)\s*\[\s*(\d+)\s*\]\s*=\s*\{", text, re.IGNORECASE):
        _, items = _aggregate(text, match.end() - 1)
        frames[(match.group(1).upper()[:4], int(match.group(2)))] = frame_of(items)
    if not frames:
        raise FileFormatError(f"{path} declares no TOOL_DATA[n] or BASE_DATA[n]={{X ..}}: is "
                              "it the robot's $config.dat?")
    return frames


def parse(files):
    """[ProgramFile] of a KRL program's files (a .src and its .dat)."""
    programs = [ProgramFile(str(path), read_text(path), NAME) for path in files]
    declared, fdats = {}, {}
    stripped = {p.path: strip_comments(p.text, COMMENT) for p in programs}
    for program in programs:
        _declarations(program, stripped[program.path], declared, fdats)
    for program in programs:
        if program.path.lower().endswith(".src"):
            undeclared = _code(program, stripped[program.path], declared, fdats)
            _check_data_list(program, files, undeclared)
        fill_poses(program.targets, poses_of)
    return programs


def _check_data_list(program, files, undeclared):
    """FileFormatError when a .src moves to names that no file given declares and its .dat
    is not among them: the data list was left behind (not a run-time value)."""
    if not undeclared:
        return
    stem = Path(program.path).stem.lower()
    if any(Path(f).suffix.lower() == ".dat" and Path(f).stem.lower() == stem for f in files):
        return
    names = list(dict.fromkeys(name for _, name in undeclared))
    lines = sorted({line for line, _ in undeclared})
    src = Path(program.path)
    raise FileFormatError(
        f"{src.name} moves to {', '.join(names[:5])}{' ...' if len(names) > 5 else ''} (line{'s' * (len(lines) > 1)} "
        f"{', '.join(map(str, lines[:5]))}{' ...' if len(lines) > 5 else ''}) without declaring "
        f"{'them' if len(names) > 1 else 'it'}, and its data "
        f"list is missing: no {src.with_suffix('.dat').name} (in any case) in {src.resolve().parent}; put the .dat "
        "beside the .src, or give it too; nothing was written")


def _declarations(program, text, declared, fdats):
    """Declared Cartesian targets, joint targets and FDATs (initialised in the declaration,
    or assigned an aggregate in a data list)."""
    is_dat = program.path.lower().endswith(".dat")
    types = {}
    for match in _DECL.finditer(text):
        kind, name = match.group(1).upper(), match.group(2)
        types[name.upper()] = kind
        if match.group(4) is None:
            continue
        brace = text.find("{", match.end())
        if brace < 0 or text[match.end():brace].strip():
            continue
        _declared(program, text, kind, name + (match.group(3) or ""), brace, declared, fdats, match.start())
    if is_dat:  # array elements assigned in the data list: P[1]={...}
        for match in re.finditer(r"^[ \t]*(\w+)[ \t]*(\[[^\]]*\])[ \t]*=[ \t]*\{", text, re.MULTILINE):
            kind = types.get(match.group(1).upper())
            if kind is not None:
                _declared(program, text, kind, match.group(1) + match.group(2), match.end() - 1, declared, fdats,
                          match.start())
    program.types = types


def _declared(program, text, kind, name, brace, declared, fdats, at):
    _, items = _aggregate(text, brace)
    key = re.sub(r"\s+", "", name).upper()
    if kind == "FDAT":
        fdats[key] = items
    elif kind in ("E6AXIS", "AXIS"):
        declared[key] = ("axis", items)
    elif all(k in items for k in POSE_KEYS):
        target = Target(program.path, line_of(text, at), name, [items[k] for k in POSE_KEYS],
                        posture=_posture(items), language=NAME)
        program.targets.append(target)
        declared[key] = ("target", target)
    else:
        declared[key] = ("partial", line_of(text, at))


def _code(program, text, declared, fdats):
    """Motions (in order), frames in force and Cartesian variables assigned in code."""
    types = dict(getattr(program, "types", {}))
    state = {"tool": None, "base": None, "fdat": None, "undeclared": []}
    order, offset = 0, 0
    for number, line in enumerate(text.split("\n"), start=1):
        line_start, offset = offset, offset + len(line) + 1
        stripped = line.strip()
        if not stripped:
            continue
        for pattern, key in ((_TOOL, "tool"), (_BASE, "base")):
            found = pattern.search(line)
            if found:
                state[key] = int(found.group(1) or found.group(2))
        found = _FDAT_ACT.search(line)
        if found:
            state["fdat"] = found.group(1).upper()
        motion = _MOTION.match(line)
        if motion:
            order += 1
            _motion(program, text, line, line_start, number, motion, declared, fdats, state, order)
            continue
        if re.match(r"^\s*(DECL\b|GLOBAL\b|(E6POS|POS|FRAME)\s)", stripped, re.IGNORECASE):
            continue
        assign = _ASSIGN.match(line)
        if assign:
            name = assign.group(1).upper()
            kind = types.get(name) or {"$POS_ACT": None}.get(name)
            if name in (k.split("[")[0] for k in declared if declared[k][0] != "axis") or kind in CARTESIAN_TYPES:
                program.run_time.append(RunTime(program.path, number, f"{assign.group(1)}{assign.group(2) or ''}"
                                                                      f"{assign.group(3) or ''} assigned in code"))
    return state["undeclared"]


def _motion(program, text, line, base_offset, number, motion, declared, fdats, state, order):
    kind = motion.group(1).upper()
    if motion.group(2):
        program.run_time.append(RunTime(program.path, number, f"{kind}_REL: relative to where the robot is"))
        return
    rest = line[motion.end():]
    rest_at = base_offset + motion.end()
    count = 2 if kind in ("CIRC", "SCIRC") else 1
    # An inline form's FDAT makes its tool and base the active ones, for this motion and the
    # motions after it, as $TOOL = TOOL_DATA[n] does.
    fdat = fdats.get(state["fdat"] or "")
    if fdat is not None:
        for key, item in (("tool", "TOOL_NO"), ("base", "BASE_NO")):
            if item in fdat and not isinstance(fdat[item], str):
                state[key] = int(fdat[item].value)
    state["fdat"] = None
    tool, base = state["tool"], state["base"]
    position = 0
    for _ in range(count):
        while position < len(rest) and rest[position] in " \t,":
            position += 1
        if position >= len(rest):
            break
        if rest[position] == "{":
            end, items = _aggregate(text, rest_at + position)
            if not _is_cartesian(items):
                program.joint_targets.append(JointTarget(program.path, order, _axes(items), number))
            elif all(k in items for k in POSE_KEYS):
                target = Target(program.path, number, "inline", [items[k] for k in POSE_KEYS],
                                posture=_posture(items), follows=kind not in POSTURE_MOTIONS, base=base, tool=tool,
                                order=order, language=NAME)
                program.targets.append(target)
            else:
                program.run_time.append(RunTime(program.path, number, f"{kind} to a partial position: the rest is "
                                                                      "the robot's at run time"))
            position = end - rest_at
            continue
        token = re.match(r"[\w$]+(\s*\[[^\]]*\])?", rest[position:])
        after = rest[position + token.end():] if token else rest[position:]
        if token is None or re.match(r"\s*[:+\-*/(]", after):
            program.run_time.append(RunTime(program.path, number, f"{kind} {rest.strip()}: computed at run time"))
            return
        key = re.sub(r"\s+", "", token.group()).upper()
        entry = declared.get(key)
        if entry is None:
            state["undeclared"].append((number, token.group()))
            program.run_time.append(RunTime(program.path, number, f"{kind} {token.group()}: declared in none of the "
                                                                  "program's files (a global of another data list, "
                                                                  "or assigned at run time)"))
        elif entry[0] == "axis":
            program.joint_targets.append(JointTarget(program.path, order, _axes(entry[1]), number))
        elif entry[0] == "partial":
            program.run_time.append(RunTime(program.path, number, f"{kind} {token.group()}: a partial position"))
        else:
            target = entry[1]
            if target.order == np.inf:
                target.order, target.follows = order, kind not in POSTURE_MOTIONS
                target.base, target.tool = base, tool
        position += token.end()


def _axes(items):
    return tuple(items[f"A{k}"].value if f"A{k}" in items else np.nan for k in range(1, 7))


def new_numbers(targets, poses):
    """[(Number, text)] writing ``poses`` (N, 4, 4 mm, program frames) into the targets'
    X..C, with A, B, C the equivalent triple nearest to the file's."""
    if not targets:
        return []
    old = np.radians([[n.value for n in t.numbers[3:]] for t in targets])  # A, B, C
    c, b, a = np.moveaxis(matrix_to_rpy(poses[:, :3, :3]), -1, 0)
    first = closest_angle(np.column_stack([a, b, c]), old)
    second = closest_angle(np.column_stack([a + np.pi, np.pi - b, c + np.pi]), old)
    nearer = np.abs(second - old).sum(axis=1) < np.abs(first - old).sum(axis=1)
    angles = np.where(nearer[:, None], second, first)
    values = np.column_stack([poses[:, :3, 3], np.degrees(angles)])
    return formatted(targets, values, [MIN_DECIMALS] * 6)
