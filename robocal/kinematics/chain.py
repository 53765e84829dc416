"""One serial-chain abstraction with three parameterisations.

T(q) = base · links(q) · flange · tool, with links in one of

* ``"dh"``  (standard Denavit–Hartenberg): Rz(theta + q) Tz(d) Tx(a) Rx(alpha) Ry(beta)
* ``"mdh"`` (Craig's modified DH):         Rx(alpha) Tx(a) Ry(beta) Rz(theta + q) Tz(d)
* ``"poe"`` (product of exponentials):     exp([S_i](q_i + theta_i)) ... M, each joint
  given by a unit axis and a point on it in the base frame at the zero configuration and
  M the flange pose there.

``beta`` is Hayati's extra rotation, zero in nominal models; it keeps near-parallel axes
identifiable and converts exactly between DH and MDH.  Prismatic joints translate along z
by q + d (DH/MDH) or along the axis by q + theta (POE).

Units inside: mm and radians.  Joint values ``q`` are the controller's (rad or mm); the model
variable is ``q_model = q @ joint_map.T`` (a per-joint sign on the diagonal, a coupling such
as FANUC's J2/J3 off it).  A joint's gain g (parameter ``gain<k>``) scales its row of the map
by e^g: a transmission-ratio or encoder-scale error, g = ln of the row's length, so that a
deviation of 1e-4 is 100 ppm.
"""
from dataclasses import dataclass, field, fields, replace
from functools import cached_property

import numpy as np

from ..errors import InputError
from ..spatial import make_transform, matrix_to_rpy, so3_exp
from . import program
from .compile import compile_chain
from .parameters import FRAME_KINDS, LINK_KINDS, ParameterSpace

CONVENTIONS = ("dh", "mdh", "poe")
# Where random configurations stop on a prismatic joint without limits.
UNLIMITED_STROKE_MM = 1000.0


def _as_array(values, n, default=0.0):
    if values is None:
        return np.full(n, default, dtype=float)
    out = np.array(values, dtype=float).reshape(-1)
    if out.shape != (n,):
        raise InputError(f"expected {n} values, got {out.size}")
    return out


def _axis_frame(axis, point):
    """A frame whose z is ``axis`` and origin ``point`` (x chosen deterministically)."""
    z = axis / np.linalg.norm(axis)
    helper = np.eye(3)[np.argmin(np.abs(z))]
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return make_transform(np.column_stack([x, np.cross(z, x), z]), point)


@dataclass(frozen=True, eq=False)
class Chain:
    """A serial robot: geometry, joint map and limits, base and tool.  Immutable."""

    name: str
    convention: str
    joint_types: tuple
    theta: np.ndarray
    d: np.ndarray | None = None
    a: np.ndarray | None = None
    alpha: np.ndarray | None = None
    beta: np.ndarray | None = None
    axes: np.ndarray | None = None
    points: np.ndarray | None = None
    home: np.ndarray | None = None
    joint_map: np.ndarray | None = None
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    flange: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    # (n,) kg, link i's mass (the body joint i moves), for gravity loads; None: unknown.
    masses: np.ndarray | None = None
    # The robot file's [tolerances]: {kind: one standard deviation, internal units} for the kinds
    # it gives (robocal.kinematics.tolerances); None: the defaults for all.
    tolerances: dict | None = None
    # (n,) the joints' own names (a URDF's, or the robot file's [[joints]] name), which
    # measurement files may use for their joint columns; None: q1..qN only.
    joint_names: tuple | None = None

    def __post_init__(self):
        if self.convention not in CONVENTIONS:
            raise InputError(
                f"unknown convention {self.convention!r}: use one of {', '.join(CONVENTIONS)}"
            )
        n = len(self.joint_types)
        if n == 0:
            raise InputError(f"robot {self.name!r} has no joints")
        bad = [t for t in self.joint_types if t not in ("revolute", "prismatic")]
        if bad:
            raise InputError(f"joint type {bad[0]!r} is not 'revolute' or 'prismatic'")
        set_ = object.__setattr__
        set_(self, "joint_types", tuple(self.joint_types))
        set_(self, "theta", _as_array(self.theta, n))
        if self.convention == "poe":
            axes = np.array(self.axes, dtype=float).reshape(n, 3)
            norms = np.linalg.norm(axes, axis=1)
            if np.any(norms < 1e-9):
                raise InputError(f"robot {self.name!r}: a POE joint axis has zero length")
            set_(self, "axes", axes / norms[:, None])
            set_(self, "points", np.array(self.points, dtype=float).reshape(n, 3))
            set_(self, "home", np.array(self.home if self.home is not None else np.eye(4), float))
        else:
            for key in ("d", "a", "alpha", "beta"):
                set_(self, key, _as_array(getattr(self, key), n))
        jm = np.eye(n) if self.joint_map is None else np.array(self.joint_map, dtype=float)
        if jm.shape != (n, n):
            raise InputError(f"robot {self.name!r}: joint_map must be {n}x{n}")
        set_(self, "joint_map", jm)
        set_(self, "lower", _as_array(self.lower, n, -np.inf))
        set_(self, "upper", _as_array(self.upper, n, np.inf))
        if np.any(self.lower > self.upper):
            j = int(np.argmax(self.lower > self.upper)) + 1
            raise InputError(f"robot {self.name!r}: joint {j} has min > max")
        for key in ("base", "flange", "tool"):
            set_(self, key, np.array(getattr(self, key), dtype=float).reshape(4, 4))
        if self.joint_names is not None:
            names = tuple(str(v) for v in self.joint_names)
            if len(names) != n or len(set(names)) != n or not all(names):
                raise InputError(f"robot {self.name!r}: joint names must be {n} different non-empty names, got "
                                 f"{list(names)}")
            set_(self, "joint_names", names)
        if self.masses is not None:
            masses = np.array(self.masses, dtype=float).reshape(-1)
            if masses.shape != (n,) or not np.all(np.isfinite(masses)) or np.any(masses < 0):
                raise InputError(f"robot {self.name!r}: masses must be {n} finite values >= 0 kg, got "
                                 f"{masses.tolist()}")
            set_(self, "masses", masses)

    def to_plain(self) -> dict:
        """The chain as plain data (its fields: text and arrays in internal units), exactly:
        what crosses to another process (:mod:`robocal.parallel`); :meth:`from_plain` reads it."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_plain(cls, plain):
        """The chain :meth:`to_plain` made."""
        return cls(**plain)

    # ----------------------------------------------------------------- basic facts
    @property
    def n_joints(self):
        return len(self.joint_types)

    @property
    def rigid(self):
        """The rigid chain: this one (a :class:`CompliantChain` returns its geometry)."""
        return self

    @cached_property
    def parameters(self):
        """The :class:`~robocal.kinematics.parameters.ParameterSpace` of this chain."""
        return ParameterSpace.of_chain(self.convention, self.joint_types)

    @property
    def revolute(self):
        """Boolean mask of revolute joints."""
        return np.array([t == "revolute" for t in self.joint_types])

    def replace(self, **changes):
        """A copy with some fields changed (the chain itself is immutable)."""
        return replace(self, **changes)

    def joints_from_file(self, values):
        """Joint values in file units (deg, mm) -> internal units (rad, mm); one joint vector
        (n,) or a batch (..., n).  InputError for another width."""
        values = self._joint_vectors(values)
        values[..., self.revolute] = np.radians(values[..., self.revolute])
        return values

    def joints_to_file(self, values):
        """Joint values in internal units (rad, mm) -> file units (deg, mm); one joint vector
        (n,) or a batch (..., n).  InputError for another width."""
        values = self._joint_vectors(values)
        values[..., self.revolute] = np.degrees(values[..., self.revolute])
        return values

    def _joint_vectors(self, values):
        """``values`` as a float array whose last axis has one value per joint."""
        try:
            values = np.array(values, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"joint values for the robot {self.name!r} must be numbers in rows of "
                             f"{self.n_joints}") from None
        if values.ndim == 0:
            raise InputError(f"one number for the {self.n_joints}-joint robot {self.name!r}: give joint vectors of "
                             f"{self.n_joints} values, q1 to q{self.n_joints}")
        width = values.shape[-1]
        if width != self.n_joints:
            raise InputError(f"{width} joint value{'s' if width != 1 else ''} for the {self.n_joints}-joint robot "
                             f"{self.name!r}: give one value per joint, q1 to q{self.n_joints}")
        return values

    def within_limits(self, q, tol=1e-9):
        """(N,) mask of configurations inside the joint limits."""
        q = np.atleast_2d(q)
        return np.all((q >= self.lower - tol) & (q <= self.upper + tol), axis=-1)

    def random_configurations(self, count, rng=None):
        """Uniform joint vectors within the limits; an unlimited side stands at ±pi for a
        revolute joint and ±UNLIMITED_STROKE_MM for a prismatic one."""
        rng = np.random.default_rng(rng)
        span = np.where(self.revolute, np.pi, UNLIMITED_STROKE_MM)
        lo = np.where(np.isfinite(self.lower), self.lower, -span)
        hi = np.where(np.isfinite(self.upper), self.upper, span)
        return lo + rng.random((count, self.n_joints)) * (hi - lo)

    def model_joints(self, q):
        """Controller joint values -> the model variables of the link transforms."""
        return np.atleast_2d(np.asarray(q, dtype=float)) @ self.joint_map.T

    def joint_batch(self, q):
        """``q`` as an (N, n) float array of configurations (rad; mm for prismatic joints);
        InputError, in one line, for text or another number of joints."""
        return self._check_q(q)[0]

    def _check_q(self, q, finite=False):
        """``q`` as ((N, n) float array, whether one configuration (n,) was given); InputError
        for text or another width, and with ``finite`` for a row with some NaN or an infinite
        value (a missing reading would otherwise pass on as a NaN pose).  A row of NaN only is
        robocal's "no configuration" (the IK's answer for a target it cannot reach) and gives
        a NaN pose, as the IK solvers rely on."""
        try:
            if np.iscomplexobj(q):  # numpy would drop the imaginary part with a mere warning
                raise TypeError
            q = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"joint values for the robot {self.name!r} must be numbers (rad; mm for prismatic "
                             f"joints), one configuration (n,) or a batch (N, n) with n = {self.n_joints}") from None
        single = q.ndim == 1
        q2 = np.atleast_2d(q)
        if q2.ndim != 2 or q2.shape[1] != self.n_joints:
            raise InputError(
                f"robot {self.name!r} has {self.n_joints} joints; got joint values of shape {q.shape}"
            )
        if finite and not np.isfinite(q2).all():
            missing = np.isnan(q2)
            bad = np.flatnonzero((missing.any(axis=1) & ~missing.all(axis=1)) | np.isinf(q2).any(axis=1))
            if bad.size:
                raise InputError(
                    f"joint values for the robot {self.name!r} are NaN or infinite in configuration {int(bad[0])} "
                    f"({q2[bad[0]].tolist()}): give finite joint values (rad; mm for prismatic joints)")
        return q2, single

    # ------------------------------------------------------------ compiled program
    def poe_frames(self):
        """(n, 4, 4) joint frames F_i of a POE chain (z = axis, origin = point)."""
        return np.stack([_axis_frame(w, p) for w, p in zip(self.axes, self.points)])

    @cached_property
    def _compiled(self):
        """(ops, tags): the factor program and, per parameter, where it acts
        (:func:`robocal.kinematics.compile.compile_chain`)."""
        return compile_chain(self)

    # ---------------------------------------------------------- forward kinematics
    def fk(self, q):
        """Pose of the TCP in the world frame: (N, n) -> (N, 4, 4), or (n,) -> (4, 4)."""
        q2, single = self._check_q(q, finite=True)
        if q2.shape[0] == 1:
            # One configuration: straight-line code on floats, not 60 numpy calls on (3, 1).
            pose = program.PointProgram.of(self).matrix(q2[0].tolist())
            return pose if single else pose[None]
        out = program.forward(self._compiled[0], self.model_joints(q2))
        return out[0] if single else out

    def fk_positions(self, q):
        """TCP positions only: (N, n) -> (N, 3), or (n,) -> (3,).  Faster than :meth:`fk`."""
        q2, single = self._check_q(q, finite=True)
        if q2.shape[0] == 1:
            pose = program.PointProgram.of(self).pose(q2[0].tolist())
            out = np.array([pose[9:]])
            return out[0] if single else out
        out = program.positions(self._compiled[0], self.model_joints(q2))
        return out[0] if single else out

    def joint_frames(self, q):
        """Frames right after each joint's motion: rotations (N, n, 3, 3), origins (N, n, 3),
        and the TCP pose (N, 4, 4).  Joint i turns about the z column of its frame."""
        q2, _ = self._check_q(q)
        names = [f"J{k}" for k in range(1, self.n_joints + 1)]
        point = self.__dict__.get("_joint_frames_program")
        if point is None and q2.shape[0] == 1 and self.__dict__.get("_joint_frames_once"):
            # One configuration again (a compliant model's torque, a dozen times a target):
            # floats.  Not at the first: building the program costs some 7 ms, and a chain made
            # for one look at its frames (link lengths, its POE form) would pay it every fit.
            point = program.PointProgram(self._compiled[0], self.joint_map, self.revolute, marks=names)
            self.__dict__["_joint_frames_program"] = point
        self.__dict__["_joint_frames_once"] = True
        if point is not None and q2.shape[0] == 1 and np.all(np.isfinite(q2)):
            pose, frames = point.pose_marks(q2[0].tolist())
            cols = np.array(frames).reshape(1, -1, 4, 3)  # (1, n, columns x y z t, rows)
            tcp = np.array([*pose[0:3], 0.0, *pose[3:6], 0.0, *pose[6:9], 0.0, *pose[9:], 1.0]).reshape(1, 4, 4)
            return np.swapaxes(cols[:, :, :3], 2, 3), cols[:, :, 3], np.swapaxes(tcp, 1, 2)
        frame, marks = program.run(self._compiled[0], self.model_joints(q2), marks=names)
        # (n, 3 columns, 3 rows, N) -> (N, n, rows, columns)
        cols = np.array([[marks[m].x, marks[m].y, marks[m].z] for m in names])
        rot = np.transpose(cols, (3, 0, 2, 1))
        origins = np.transpose(np.array([marks[m].t for m in names]), (2, 0, 1))
        return rot, origins, _frame_to_matrix(frame)

    # ---------------------------------------------------------------- parameters
    def parameter_names(self, groups=("links", "base", "tool")):
        """Names of the model parameters, in a fixed order.

        groups: 'links' (per-joint parameters), 'offsets' (theta only), 'gains' (joint
        scale, see the module notes), 'base', 'tool', 'home' (POE flange pose).
        """
        space = self.parameters
        names = []
        for g in groups:
            if g == "links":
                names += space.of_group("link")
            elif g == "offsets":
                names += [p.name for p in space if p.group == "link" and p.kind == "theta"]
            elif g in ("gains", "base", "tool"):
                names += space.of_group(g)
            elif g == "home":
                if self.convention != "poe":
                    raise InputError("'home' parameters exist only in POE models")
                names += space.of_group(g)
            else:
                raise InputError(f"unknown parameter group {g!r}")
        return names

    def is_angular(self, name):
        """True for parameters measured in radians (reported in degrees)."""
        return self.parameters[name].angular

    def parameter_values(self, names=None):
        """Current values of named parameters (frames as xyz and rpy)."""
        names = self.parameter_names() if names is None else names
        out = []
        for p in self.parameters.records(names):
            if p.joint is None:
                frame = getattr(self, p.group)
                k = FRAME_KINDS.index(p.kind)
                out.append(frame[k, 3] if k < 3 else matrix_to_rpy(frame[:3, :3])[k - 3])
            elif p.group == "gains":
                out.append(np.log(np.linalg.norm(self.joint_map[p.joint - 1])))
            else:
                # POE axis placements are deviations from the current axis: always 0.
                values = getattr(self, p.kind, None) if p.kind in LINK_KINDS["dh"] else None
                out.append(0.0 if values is None else values[p.joint - 1])
        return np.array(out, dtype=float)

    def identification_jacobian(self, q, names=None):
        """d[TCP position; TCP orientation] / d(parameter deviation): (N, 6, P).

        The orientation rows are the world-frame rotation vector.  Deviations are those
        :meth:`perturbed` applies, so a Gauss–Newton step on them is consistent.
        """
        names = self.parameter_names() if names is None else list(names)
        q2, _ = self._check_q(q)
        space = self.parameters
        gains = [j for j, name in enumerate(names) if name in space and space[name].group == "gains"]
        if gains:
            return self._with_gain_columns(q2, names, gains)
        ops, tags = self._compiled
        unknown = [name for name in names if name not in tags]
        if unknown:
            raise InputError(
                f"parameter {unknown[0]!r} does not exist in a {self.convention} model; "
                f"known: {', '.join(self.parameter_names(self._groups()))}"
            )
        # Every tag of every requested parameter as flat arrays, so that all columns come
        # out of a handful of whole-array operations.
        flat = [(j, mark, motion == "rot", axis, coef)
                for j, name in enumerate(names) for mark, motion, axis, coef in tags[name]]
        column, mark_of, rotational, axis_of, coef = (np.array(v) for v in zip(*flat))
        needed = sorted(set(mark_of) - {"W"})
        frame, marks = program.run(ops, self.model_joints(q2), marks=needed)
        n_conf = q2.shape[0]
        # Snapshot k: columns x, y, z, origin, each (3, N); 'W' is the world axes at the base origin.
        world = np.zeros((4, 3, n_conf))
        world[0, 0] = world[1, 1] = world[2, 2] = 1.0
        world[3] = self.base[:3, 3, None]
        stack = np.array([world] + [[marks[m].x, marks[m].y, marks[m].z, marks[m].t] for m in needed])
        index = {m: k + 1 for k, m in enumerate(needed)}
        index["W"] = 0
        which = np.array([index[m] for m in mark_of])
        out = np.zeros((len(names), 6, n_conf))
        # POE axis parameters act at two marks; everything else at one, written directly.
        place = np.add.at if len(set(column.tolist())) < len(column) else _assign
        rot = np.flatnonzero(rotational)
        if rot.size:
            axes = stack[which[rot], axis_of[rot]] * coef[rot, None, None]
            lever = frame.t[None] - stack[which[rot], 3]
            place(out, (column[rot], slice(0, 3)), _cross_rows(axes, lever))
            place(out, (column[rot], slice(3, 6)), axes)
        trans = np.flatnonzero(~rotational)
        if trans.size:
            place(out, (column[trans], slice(0, 3)), stack[which[trans], axis_of[trans]] * coef[trans, None, None])
        return np.transpose(out, (2, 1, 0))

    def _with_gain_columns(self, q2, names, gains):
        """Gain k moves the TCP as joint k's zero offset does, times the model joint value."""
        joints = [self.parameters[names[j]].joint - 1 for j in gains]
        others = [j for j in range(len(names)) if j not in gains]
        offsets = [self.offset_parameter(k) for k in joints]
        jac = self.identification_jacobian(q2, [names[j] for j in others] + offsets)
        out = np.empty(jac.shape[:2] + (len(names),))
        out[:, :, others] = jac[:, :, :len(others)]
        out[:, :, gains] = jac[:, :, len(others):] * self.model_joints(q2)[:, None, joints]
        return out

    def offset_parameter(self, k):
        """Name of the parameter added to model joint k's variable (0-based k)."""
        prismatic = self.joint_types[k] == "prismatic" and self.convention != "poe"
        return f"{'d' if prismatic else 'theta'}{k + 1}"

    def _groups(self):
        return ("links", "base", "tool", "home") if self.convention == "poe" else ("links", "base", "tool")

    def perturbed(self, names, deviations=None):
        """A new chain with parameter deviations applied.

        ``names`` is a list with ``deviations`` the matching values (rad, mm), or a dict.
        Link parameters add; base rotations turn about world axes through the base origin;
        tool and POE home deviations act in their own frame; POE axis deviations move the
        joint frame F_i by Trans(ux, uy, 0) · Rot([wx, wy, 0]).
        """
        if deviations is None:
            items = dict(names)
        else:
            deviations = np.asarray(deviations, dtype=float).reshape(-1)
            if len(names) != deviations.size:
                raise InputError(f"{len(names)} parameter names but {deviations.size} deviations")
            items = dict(zip(names, deviations))
        bad = [name for name, value in items.items() if not np.isfinite(value)]
        if bad:
            raise InputError(f"the deviation of {bad[0]!r} is {items[bad[0]]}: deviations must be finite numbers "
                             "(rad, mm)")
        link = {k: np.array(getattr(self, k), dtype=float) for k in ("theta", "d", "a", "alpha", "beta")
                if getattr(self, k) is not None}
        frame_dev = {"base": np.zeros(6), "tool": np.zeros(6), "home": np.zeros(6)}
        poe_dev = np.zeros((self.n_joints, 4))
        joint_map = self.joint_map.copy()
        for name, value in items.items():
            p = self.parameters.get(name)
            if p is None:
                raise InputError(f"parameter {name!r} does not exist in a {self.convention} model")
            if p.group == "gains":
                joint_map[p.joint - 1] *= np.exp(value)
            elif p.joint is None:
                frame_dev[p.group][FRAME_KINDS.index(p.kind)] += value
            elif p.kind in link:
                link[p.kind][p.joint - 1] += value
            else:
                poe_dev[p.joint - 1, LINK_KINDS["poe"].index(p.kind) - 1] += value
        changes = dict(link)
        if not np.array_equal(joint_map, self.joint_map):
            changes["joint_map"] = joint_map
        dev = frame_dev["base"]
        if np.any(dev):
            base = self.base.copy()
            base[:3, :3] = so3_exp(dev[3:]) @ base[:3, :3]
            base[:3, 3] += dev[:3]
            changes["base"] = base
        for group in ("tool", "home"):
            dev = frame_dev[group]
            if np.any(dev):
                changes[group] = getattr(self, group) @ make_transform(so3_exp(dev[3:]), dev[:3])
        if np.any(poe_dev):
            frames = self.poe_frames()
            moved = frames @ make_transform(
                so3_exp(np.column_stack([poe_dev[:, 2:], np.zeros(self.n_joints)])),
                np.column_stack([poe_dev[:, :2], np.zeros(self.n_joints)]),
            )
            changes["axes"] = moved[:, :3, 2]
            changes["points"] = moved[:, :3, 3]
        if self.convention == "poe":
            for key in ("d", "a", "alpha", "beta"):
                changes.pop(key, None)
        return self.replace(**changes)

    # ----------------------------------------------------------------- Jacobian
    def jacobian(self, q):
        """Geometric Jacobian of the TCP, world frame, w.r.t. controller joints: (N, 6, n)."""
        return self.fk_jacobian(q)[1]

    def fk_jacobian(self, q):
        """TCP pose and geometric Jacobian in one pass: ((N, 4, 4), (N, 6, n))."""
        q2, single = self._check_q(q)
        q_model = self.model_joints(q2)
        n_conf, n = q2.shape
        tcp = np.empty((n_conf, 4, 4))
        jac = np.empty((n_conf, 6, n))
        names = [f"J{k}" for k in range(1, n + 1)]
        for start in range(0, n_conf, program.CHUNK):
            stop = min(start + program.CHUNK, n_conf)
            frame, marks = program.run(self._compiled[0], q_model[start:stop], marks=names)
            tcp[start:stop] = _frame_to_matrix(frame)
            block = jac[start:stop]
            for i, name in enumerate(names):
                z, origin = marks[name].z, marks[name].t
                if self.joint_types[i] == "revolute":
                    block[:, :3, i] = _cross_rows(z, frame.t - origin).T
                    block[:, 3:, i] = z.T
                else:
                    block[:, :3, i] = z.T
                    block[:, 3:, i] = 0.0
        if not np.array_equal(self.joint_map, np.eye(n)):
            # One 2-D product (BLAS) rather than N tiny batched ones.
            jac = (jac.reshape(-1, n) @ self.joint_map).reshape(jac.shape)
        if single:
            return tcp[0], jac[0]
        return tcp, jac

def _assign(array, index, values):
    array[index] = values


def _frame_to_matrix(frame):
    """Frame of (3, N) columns -> (N, 4, 4)."""
    out = np.zeros((frame.t.shape[1], 4, 4))
    out[:, :3, 0], out[:, :3, 1], out[:, :3, 2] = frame.x.T, frame.y.T, frame.z.T
    out[:, :3, 3] = frame.t.T
    out[:, 3, 3] = 1.0
    return out


def _cross_rows(u, v):
    """Cross product of vectors stored along axis -2 (rows x, y, z), any leading/trailing axes."""
    ux, uy, uz = u[..., 0, :], u[..., 1, :], u[..., 2, :]
    vx, vy, vz = v[..., 0, :], v[..., 1, :], v[..., 2, :]
    return np.stack([uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx], axis=-2)
