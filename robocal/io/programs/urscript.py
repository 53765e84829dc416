"""URScript (.script): poses ``p[x, y, z, rx, ry, rz]`` in metres with a rotation vector in
radians, relative to the robot's base with the active TCP.

Targets are pose literals that a motion (movel, movej, movep, movec) takes, or that are
assigned to a name a motion then takes.  The controller picks the inverse kinematics
solution nearest the joints it stands at, so every target follows the posture before it;
joint lists (``movej([0, -1.57, ...])``) stay as they are and set that posture.  Pose
literals inside other calls (``set_tcp``, the offset of ``pose_trans``) are not targets.
Run-time motions: a motion whose pose is an expression (``pose_trans(...)``,
``pose_add(...)``, ``get_inverse_kin(...)``), and names assigned such expressions.
"""
from __future__ import annotations

import re

import numpy as np

from ...errors import InputError
from .core import (
    JointTarget,
    RunTime,
    Target,
    formatted,
    line_of,
    numbers_in,
    parse_each,
)

NAME = "URScript"
COMMENT = "#"
EXTENSIONS = (".script",)
# The unit of the file's positions (a key of robocal.io.units.LENGTH_UNITS), and of its poses.
LENGTH_UNIT = "metres"
UNITS = "metres and radians"
# The unit of its joint values (a key of robocal.io.units.ANGLE_UNITS), and how to fix others.
JOINT_UNIT = "radians"
JOINT_ADVICE = "URScript takes radians: convert them with d2r()"
# What to add when nothing fixes the arm branch of a program's first motion (filter refuses it).
POSTURE_ADVICE = "put a movej([...]) to the joints the robot starts from (radians) before it"
MOTIONS = ("movel", "movej", "movep", "movec")
# Decimals written at least when a number changes: 1e-7 m (0.0001 mm) and 1e-7 rad.
MIN_DECIMALS = 7

_POSE = re.compile(r"\bp\s*\[")
_CALL = re.compile(r"\b(\w+)\s*\($")
_ASSIGN = re.compile(r"^[ \t]*(?:global[ \t]+|local[ \t]+)?(\w+)[ \t]*=(?!=)[ \t]*(.*)$", re.MULTILINE)
_MOTION = re.compile(r"\b(" + "|".join(MOTIONS) + r")\s*\(")


def group(paths):
    return list(paths)


def comment_offset(text) -> int:
    return 0


def _enclosing_call(text, position):
    """(function name, argument index) of the call that encloses ``position``, or None."""
    depth_round, depth_square, commas = 0, 0, 0
    for k in range(position - 1, -1, -1):
        c = text[k]
        if c == ")":
            depth_round += 1
        elif c == "]":
            depth_square += 1
        elif c == "[":
            if depth_square == 0:
                return None  # inside a list
            depth_square -= 1
        elif c == "(":
            if depth_round == 0:
                match = _CALL.search(text, max(0, k - 64), k + 1)
                return (match.group(1), commas) if match else None
            depth_round -= 1
        elif c == "," and depth_round == 0 and depth_square == 0:
            commas += 1
        elif c == "\n" and depth_round == 0:
            line_start = text.rfind("\n", 0, k)
            if not text[line_start + 1:k].rstrip().endswith((",", "(")):
                return None
    return None


def _arguments(text, start):
    """Top-level arguments of the call whose '(' is just before ``start``: [(offset, text)]."""
    out, depth, piece = [], 0, start
    for k in range(start, len(text)):
        c = text[k]
        if c in "[(":
            depth += 1
        elif c in "])":
            if depth == 0:
                out.append((piece, text[piece:k]))
                return out
            depth -= 1
        elif c == "," and depth == 0:
            out.append((piece, text[piece:k]))
            piece = k + 1
    return out


def poses_of(values):
    """(N, 6) x, y, z m, rotation vector rad -> (N, 4, 4) mm."""
    from scipy.spatial.transform import Rotation  # loaded when used: the command line starts faster
    poses = np.tile(np.eye(4), (len(values), 1, 1))
    poses[:, :3, :3] = Rotation.from_rotvec(values[:, 3:]).as_matrix()
    poses[:, :3, 3] = values[:, :3] * 1000.0
    return poses


# A rotation vector turns by its length in radians; one beyond a full turn is not URScript's
# (its poses are canonical, within half a turn): p[..., 180, 0, 0] written in degrees.
LONGEST_ROTATION_RAD = 2.0 * np.pi


def parse(files):
    """[ProgramFile] of the program's files, targets found and their poses filled; InputError
    for a pose whose rotation vector is longer than a turn (degrees where radians belong)."""
    programs = parse_each(files, NAME, COMMENT, _parse, poses_of)
    for program in programs:
        if not program.targets:
            continue
        turns = np.linalg.norm([[n.value for n in t.numbers[3:6]] for t in program.targets], axis=1)
        beyond = np.flatnonzero(turns > LONGEST_ROTATION_RAD)
        if len(beyond):
            target = program.targets[beyond[0]]
            raise InputError(f"{program.path}, line {target.line}: the rotation vector of {target.name} turns "
                             f"{turns[beyond[0]]:.4g} rad, more than a full turn: URScript poses take radians "
                             "(these look like degrees); convert them with d2r()")
    return programs


def _literal(text, match):
    close = text.index("]", match.end())
    numbers = numbers_in(text, match.end(), close)
    return (numbers if len(numbers) == 6 and text[match.end():close].count(",") == 5 else None), close + 1


def _parse(program, text):
    # Pose literals: in a motion's pose arguments, or assigned to a name.
    literals = {}  # start offset -> Target
    named = {}  # name -> [(offset, Target or None)] in order: None for an expression
    for match in _POSE.finditer(text):
        numbers, _ = _literal(text, match)
        if numbers is None:
            continue
        call = _enclosing_call(text, match.start())
        line = line_of(text, match.start())
        if call is not None:
            function, index = call
            if function in MOTIONS and index < (2 if function == "movec" else 1):
                target = Target(program.path, line, "inline", numbers, follows=True, language=NAME)
                program.targets.append(target)
                literals[match.start()] = target
            continue
        line_start = text.rfind("\n", 0, match.start()) + 1
        assign = _ASSIGN.match(text, line_start)
        if assign and assign.start(2) == match.start():
            target = Target(program.path, line, assign.group(1), numbers, follows=True, language=NAME)
            program.targets.append(target)
            named.setdefault(assign.group(1), []).append((match.start(), target))
    for assign in _ASSIGN.finditer(text):
        rhs = assign.group(2).strip()
        if _POSE.match(rhs) or not re.search(r"\b(pose_\w+|get_\w+_pose|get_forward_kin|interpolate_pose)\s*\(",
                                             rhs):
            continue
        named.setdefault(assign.group(1), []).append((assign.start(), None))
        program.run_time.append(RunTime(program.path, line_of(text, assign.start()),
                                        f"{assign.group(1)} = {rhs}: computed at run time"))
    joint_lists = {a.group(1): a.start(2) for a in _ASSIGN.finditer(text) if a.group(2).strip().startswith("[")}
    order = 0
    for match in _MOTION.finditer(text):
        order += 1
        function = match.group(1)
        arguments = _arguments(text, match.end())
        line = line_of(text, match.start())
        for at, argument in arguments[:2 if function == "movec" else 1]:
            word = argument.strip()
            lead = at + len(argument) - len(argument.lstrip())
            if word.startswith("["):  # a joint list
                values = [n.value for n in numbers_in(text, lead, lead + len(word))]
                program.joint_targets.append(JointTarget(program.path, order, tuple(np.degrees(values)), line))
            elif word in joint_lists and word not in named:
                at_list = joint_lists[word]
                close = text.index("]", at_list)
                values = [n.value for n in numbers_in(text, at_list, close)]
                program.joint_targets.append(JointTarget(program.path, order, tuple(np.degrees(values)), line))
            elif lead in literals:
                literals[lead].order = order
            elif re.fullmatch(r"\w+", word) and word in named:
                before = [t for offset, t in named[word] if offset < match.start()]
                target = before[-1] if before else None
                if target is None:
                    program.run_time.append(RunTime(program.path, line, f"{function}({word}): computed at run time"))
                elif target.order == np.inf:
                    target.order = order
            else:
                program.run_time.append(RunTime(program.path, line, f"{function}({word}): computed at run time"))

    # A pose assigned to a name no motion takes is an offset or a frame (pose_trans's second
    # argument, set_tcp's), not a target: it stays as it is.
    program.targets = [t for t in program.targets if t.name == "inline" or t.order != np.inf]


def new_numbers(targets, poses):
    """[(Number, text)] writing ``poses`` into x, y, z (m) and the rotation vectors (rad),
    each the equivalent vector nearest the file's."""
    from scipy.spatial.transform import Rotation  # loaded when used: the command line starts faster
    if not targets:
        return []
    old = np.array([[n.value for n in t.numbers[3:]] for t in targets])
    vectors = Rotation.from_matrix(poses[:, :3, :3]).as_rotvec()
    angle = np.linalg.norm(vectors, axis=1, keepdims=True)
    other = vectors * (1.0 - 2.0 * np.pi / np.maximum(angle, 1e-12))
    nearer = (np.linalg.norm(other - old, axis=1) < np.linalg.norm(vectors - old, axis=1)) & (angle[:, 0] > 1e-9)
    vectors = np.where(nearer[:, None], other, vectors)
    return formatted(targets, np.column_stack([poses[:, :3, 3] / 1000.0, vectors]), [MIN_DECIMALS] * 6)
