"""A kinematic chain compiled to a sequence of elementary factors, and its batched evaluation.

Every parameterisation (DH, modified DH, POE) is a product of elementary transforms:
rotations and translations about / along one axis (constant or driven by a joint) and
general constant transforms.  Evaluating that product factor by factor on a frame held as
four column blocks X, Y, Z, t of shape (3, N) costs a handful of vector operations per
factor, and skips the many zero angles of a nominal model for free.  The same pass can take
"marks": snapshots of the running frame that the Jacobians need.
"""
import math
from dataclasses import dataclass

import numpy as np

# Work on blocks of this many configurations so that the (3, N) arrays stay in cache.
CHUNK = 16384


@dataclass(frozen=True)
class Op:
    """One factor.

    kind: 'rx' 'ry' 'rz' 'tx' 'ty' 'tz' (constant ``value``), 'joint' (joint ``index``,
    revolute about z when ``revolute`` else prismatic along z, plus ``value`` as offset),
    'const' (4x4 ``matrix``) or 'mark' (snapshot named ``name``; no motion).
    """

    kind: str
    value: float = 0.0
    index: int = -1
    revolute: bool = True
    matrix: np.ndarray | None = None
    name: str = ""


def half_angle_cos_sin(angle):
    """cos and sin from a single tan call (one libm call instead of two)."""
    t = np.tan(0.5 * angle)
    t2 = t * t
    inv = 1.0 / (1.0 + t2)
    return (1.0 - t2) * inv, 2.0 * t * inv


class Frame:
    """Running frame: columns x, y, z and origin t, each (3, N)."""

    __slots__ = ("x", "y", "z", "t")

    def __init__(self, x, y, z, t):
        self.x, self.y, self.z, self.t = x, y, z, t

    @classmethod
    def identity(cls, n):
        cols = np.zeros((4, 3, n))
        cols[0, 0] = cols[1, 1] = cols[2, 2] = 1.0
        return cls(cols[0], cols[1], cols[2], cols[3])

    def copy(self):
        return Frame(self.x.copy(), self.y.copy(), self.z.copy(), self.t.copy())

    def column(self, axis):
        return (self.x, self.y, self.z)[axis]


def _mix(u, v, c, s):
    """(u, v) -> (c u + s v, c v - s u): rotating a frame by an angle about its third axis."""
    return c * u + s * v, c * v - s * u


def _apply(frame, op, joint_cos, joint_sin, joint_values):
    """Right-multiply the running frame by one factor, in place where possible."""
    kind = op.kind
    if kind == "joint":
        if op.revolute:
            frame.x, frame.y = _mix(frame.x, frame.y, joint_cos[op.index], joint_sin[op.index])
        else:
            frame.t = frame.t + frame.z * (joint_values[op.index] + op.value)
    elif kind == "rz":
        c, s = np.cos(op.value), np.sin(op.value)
        frame.x, frame.y = _mix(frame.x, frame.y, c, s)
    elif kind == "rx":
        c, s = np.cos(op.value), np.sin(op.value)
        frame.y, frame.z = _mix(frame.y, frame.z, c, s)
    elif kind == "ry":
        c, s = np.cos(op.value), np.sin(op.value)
        frame.z, frame.x = _mix(frame.z, frame.x, c, s)
    elif kind == "tx":
        frame.t = frame.t + op.value * frame.x
    elif kind == "ty":
        frame.t = frame.t + op.value * frame.y
    elif kind == "tz":
        frame.t = frame.t + op.value * frame.z
    elif kind == "const":
        m = op.matrix
        cols = (frame.x, frame.y, frame.z)
        new = [sum(cols[k] * m[k, j] for k in range(3) if m[k, j] != 0.0) for j in range(4)]
        frame.t = frame.t + new[3]
        frame.x, frame.y, frame.z = (
            n if not np.isscalar(n) else np.zeros_like(frame.t) for n in new[:3]
        )


def _joint_trig(ops, q_model):
    """cos/sin of every revolute joint angle (including its offset), shape (n, N)."""
    angles = q_model.T.copy()
    for op in ops:
        if op.kind == "joint" and op.revolute and op.value != 0.0:
            angles[op.index] += op.value
    return half_angle_cos_sin(angles)


def run(ops, q_model, marks=()):
    """Evaluate the factor product for (N, n) model joint values.

    Returns the final Frame and a dict of Frame snapshots for the mark names in ``marks``
    (``True`` for all of them).
    """
    n_conf = q_model.shape[0]
    cos_q, sin_q = _joint_trig(ops, q_model)
    values = q_model.T
    frame = Frame.identity(n_conf)
    snapshots = {}
    for op in ops:
        if op.kind == "mark":
            if marks is True or op.name in marks:
                snapshots[op.name] = frame.copy()
            continue
        _apply(frame, op, cos_q, sin_q, values)
    return frame, snapshots


def forward(ops, q_model):
    """(N, n) model joint values -> (N, 4, 4) poses, in cache-sized chunks."""
    n_conf = q_model.shape[0]
    out = np.empty((n_conf, 4, 4))
    out[:, 3, :3] = 0.0
    out[:, 3, 3] = 1.0
    for start in range(0, n_conf, CHUNK):
        stop = min(start + CHUNK, n_conf)
        frame, _ = run(ops, q_model[start:stop])
        block = out[start:stop]
        block[:, :3, 0] = frame.x.T
        block[:, :3, 1] = frame.y.T
        block[:, :3, 2] = frame.z.T
        block[:, :3, 3] = frame.t.T
    return out


def _apply_to_point(p, op, joint_cos, joint_sin, joint_values):
    """Left-multiply points p = (px, py, pz) by one factor (the backward pass)."""
    px, py, pz = p
    kind = op.kind
    if kind == "joint":
        if op.revolute:
            c, s = joint_cos[op.index], joint_sin[op.index]
            return (c * px - s * py, s * px + c * py, pz)
        return (px, py, pz + (joint_values[op.index] + op.value))
    if kind in ("rx", "ry", "rz"):
        c, s = np.cos(op.value), np.sin(op.value)
        if kind == "rz":
            return (c * px - s * py, s * px + c * py, pz)
        if kind == "rx":
            return (px, c * py - s * pz, s * py + c * pz)
        return (c * px + s * pz, py, c * pz - s * px)
    if kind == "tx":
        return (px + op.value, py, pz)
    if kind == "ty":
        return (px, py + op.value, pz)
    if kind == "tz":
        return (px, py, pz + op.value)
    if kind == "const":
        m = op.matrix
        return tuple(
            sum((m[i, k] * (px, py, pz)[k] for k in range(3) if m[i, k] != 0.0), m[i, 3])
            for i in range(3)
        )
    return p


def positions(ops, q_model):
    """(N, n) model joint values -> (N, 3) TCP positions by a backward pass on points only."""
    n_conf = q_model.shape[0]
    out = np.empty((n_conf, 3))
    for start in range(0, n_conf, CHUNK):
        stop = min(start + CHUNK, n_conf)
        block = q_model[start:stop]
        cos_q, sin_q = _joint_trig(ops, block)
        values = block.T
        p = (0.0, 0.0, 0.0)
        for op in reversed(ops):
            if op.kind != "mark":
                p = _apply_to_point(p, op, cos_q, sin_q, values)
        for i in range(3):
            out[start:stop, i] = p[i]
    return out


# ------------------------------------------------------------------ one configuration
# A batch of one pays numpy's per-call overhead (about a microsecond per operation on (3, 1)
# arrays, some 60 operations for a 6R chain: 71 us).  For one configuration at a time (a
# controller asking point by point) the same factors are turned once into straight-line
# Python on floats, constants written in and zero terms left out: about 5 us.

_NAMES = ("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz", "tx", "ty", "tz")
_COLUMNS = {"x": ("xx", "xy", "xz"), "y": ("yx", "yy", "yz"), "z": ("zx", "zy", "zz"), "t": ("tx", "ty", "tz")}


def _term(coefficient, name):
    """Source of coefficient * name, or None for a zero coefficient."""
    if coefficient == 0.0:
        return None
    if coefficient == 1.0:
        return name
    if coefficient == -1.0:
        return f"-{name}"
    return f"{coefficient!r} * {name}"


def _sum(terms):
    terms = [t for t in terms if t is not None]
    return " + ".join(terms) if terms else "0.0"


def _mix_source(u, v, c, s):
    """Lines for (u, v) -> (c u + s v, c v - s u), per component; c, s are source names."""
    left = ", ".join(_COLUMNS[u] + _COLUMNS[v])
    right = ", ".join([f"{c} * {a} + {s} * {b}" for a, b in zip(_COLUMNS[u], _COLUMNS[v])]
                      + [f"{c} * {b} - {s} * {a}" for a, b in zip(_COLUMNS[u], _COLUMNS[v])])
    return [f"{left} = {right}"]


def _shift_source(column, amount):
    """Lines for t += amount * column; amount is a source expression."""
    return ["tx, ty, tz = " + ", ".join(f"t{a} + {amount} * {c}" for a, c in zip("xyz", _COLUMNS[column]))]


def _op_source(op, constants):
    """Lines that right-multiply the frame held in the 12 locals by one factor."""
    kind = op.kind
    if kind == "joint":
        if op.revolute:
            return _mix_source("x", "y", f"c{op.index}", f"s{op.index}")
        return _shift_source("z", f"(m{op.index} + {float(op.value)!r})" if op.value else f"m{op.index}")
    if kind in ("rx", "ry", "rz"):
        c, s = f"k{len(constants)}", f"k{len(constants) + 1}"
        constants += [np.cos(op.value), np.sin(op.value)]
        pair = {"rz": ("x", "y"), "rx": ("y", "z"), "ry": ("z", "x")}[kind]
        return _mix_source(*pair, c, s)
    if kind in ("tx", "ty", "tz"):
        return _shift_source(kind[1], repr(float(op.value)))
    if kind == "const":
        m = op.matrix
        cols = ("x", "y", "z")
        new = [[_term(float(m[k, j]), c) for k in range(3) for c in [_COLUMNS[cols[k]][a]]]
               for j in range(4) for a in range(3)]
        # new[3 * j + a]: component a of new column j, from the terms over k.
        rotation = [_sum(new[3 * j + a]) for j in range(3) for a in range(3)]
        shift = [_sum([f"t{'xyz'[a]}"] + new[9 + a]) for a in range(3)]
        # One assignment: the new origin is made of the old columns.
        return [", ".join(_NAMES) + " = " + ", ".join(rotation + shift)]
    return []


class PointProgram:
    """The factor program of a chain for one configuration at a time, on Python floats.

    ``pose(q)`` takes the n controller joints (a sequence of floats, rad / mm) and returns
    the TCP pose as 12 floats: the columns x, y, z of the rotation, then the origin.
    ``pose_jacobian(q)`` returns them and the geometric Jacobian with respect to the
    controller joints, column after column in one tuple of 6 n floats (column k, the
    derivative [dp; dw] of the pose by joint k as in ``fk_jacobian``, at [6 k, 6 k + 6]):
    ``np.array(columns).reshape(n, 6).T`` is the (6, n) Jacobian, in the column-major order
    LAPACK takes without a copy.  Built with ``marks`` (names of mark factors),
    ``pose_marks(q)`` returns the pose and the frame at each of those marks (12 floats each,
    in the order of ``marks``), for the identification Jacobian of one configuration.
    Equal to :func:`forward` to rounding (cos and sin from ``math`` instead of half-angle
    tangents).
    """

    @classmethod
    def of(cls, chain):
        """The point program of a (rigid) chain, built once and kept on the chain (which is
        immutable), as :func:`robocal.kinematics.ik.closed_form` keeps its solver."""
        program = chain.__dict__.get("_point_program")
        if program is None:
            program = cls(chain._compiled[0], chain.joint_map, chain.revolute)
            chain.__dict__["_point_program"] = program
        return program

    def __init__(self, ops, joint_map, revolute, marks=()):
        joint_map = np.asarray(joint_map, dtype=float)
        n = joint_map.shape[0]
        self.n_joints = n
        constants = []
        head = [f"q{i}" for i in range(n)]
        lines = [("(" + ", ".join(head) + ",) = q") if n else "pass"]
        for i in range(n):
            lines.append(f"m{i} = " + _sum([_term(float(joint_map[i, k]), f"q{k}") for k in range(n)]))
        offsets = {op.index: op.value for op in ops if op.kind == "joint" and op.revolute}
        for i, offset in offsets.items():
            angle = f"m{i} + {float(offset)!r}" if offset else f"m{i}"
            lines.append(f"c{i} = cos({angle}); s{i} = sin({angle})")
        lines.append(", ".join(_NAMES) + " = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0")
        body, marks, named = [], {}, tuple(marks)
        snapshots = {}
        for op in ops:
            if op.kind == "mark" and op.name.startswith("J") and op.name[1:].isdigit():
                k = int(op.name[1:]) - 1
                marks[k] = True
                body.append(f"j{k} = (zx, zy, zz, tx, ty, tz)")
            if op.kind == "mark" and op.name in named:
                snapshots[op.name] = f"n{len(snapshots)}"
                body.append(f"{snapshots[op.name]} = (" + ", ".join(_NAMES) + ")")
            body += _op_source(op, constants)
        result = "(" + ", ".join(_NAMES) + ")"
        namespace = {"cos": math.cos, "sin": math.sin}
        namespace.update({f"k{i}": float(v) for i, v in enumerate(constants)})
        pose_lines = lines + [b for b in body if not b.startswith(("j", "n"))] + [f"return {result}"]
        source = "def pose(q):\n" + "\n".join("    " + line for line in pose_lines) + "\n"
        jac = self._jacobian_source(n, marks, revolute, joint_map) if len(marks) == n else None
        if jac is not None:
            source += ("def pose_jacobian(q):\n"
                       + "\n".join("    " + line for line in lines + [b for b in body if not b.startswith("n")] + jac
                                    + [f"return {result}, columns"]) + "\n")
        if named:
            missing = set(named) - set(snapshots)
            if missing:
                raise ValueError(f"no mark {sorted(missing)[0]!r} in the program")
            listed = ", ".join(snapshots[m] for m in named)
            source += ("def pose_marks(q):\n" + "\n".join(
                "    " + line for line in lines + [b for b in body if not b.startswith("j")]
                + [f"return {result}, ({listed},)"]) + "\n")
        exec(compile(source, "<robocal point program>", "exec"), namespace)  # noqa: S102 - our own source
        self.pose = namespace["pose"]
        self.pose_marks = namespace.get("pose_marks")
        self.pose_jacobian = namespace.get("pose_jacobian")
        self.source = source

    @staticmethod
    def _jacobian_source(n, marks, revolute, joint_map):
        """Lines that build ``columns``: the Jacobian's columns from each joint's z axis and
        origin (marks J1..Jn), then times the joint map, one after the other."""
        lines = []
        for k in range(n):
            if revolute[k]:
                lines.append(f"a, b, c, ox, oy, oz = j{k}; dx, dy, dz = tx - ox, ty - oy, tz - oz")
                lines.append(f"v{k} = (b * dz - c * dy, c * dx - a * dz, a * dy - b * dx, a, b, c)")
            else:
                lines.append(f"v{k} = (j{k}[0], j{k}[1], j{k}[2], 0.0, 0.0, 0.0)")
        if np.array_equal(joint_map, np.eye(n)):
            lines.append("columns = " + " + ".join(f"v{k}" for k in range(n)))
        else:
            flat = [_sum([_term(float(joint_map[i, k]), f"v{i}[{r}]") for i in range(n)])
                    for k in range(n) for r in range(6)]
            lines.append("columns = (" + ", ".join(flat) + ",)")
        return lines

    def matrix(self, q):
        """The TCP pose (4, 4) of one configuration."""
        xx, xy, xz, yx, yy, yz, zx, zy, zz, tx, ty, tz = self.pose(q)
        return np.array([[xx, yx, zx, tx], [xy, yy, zy, ty], [xz, yz, zz, tz], [0.0, 0.0, 0.0, 1.0]])
