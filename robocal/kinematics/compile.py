"""Compiling a chain into its program of elementary motions.

Whatever the convention (DH, MDH, POE), a :class:`~robocal.kinematics.chain.Chain` is
evaluated as one program of factors (:mod:`robocal.kinematics.program`): constant frames,
rotations and translations about one axis, the joints' motions, and marks (snapshots of the
frame so far).  Every kinematic parameter is tagged with the mark and axis where it acts,
which is what the analytic identification Jacobian reads: a parameter rotating about an
axis of a mark moves the TCP by that axis crossed with the lever arm from the mark.
"""
import numpy as np

from ..spatial import invert, make_transform, translation
from .parameters import FRAME_KINDS
from .program import Op


def compile_chain(chain):
    """(ops, tags): ``chain``'s factor program and, per parameter, where it acts.

    A tag is (mark, 'rot' | 'trans', axis 0/1/2, coefficient): the parameter rotates
    about / translates along that axis of the frame snapshot ``mark``.
    """
    ops, tags = [], {}

    identity = np.eye(4)

    def emit(kind, value=0.0, **kw):
        # Factors that do nothing (zero angles and offsets, identity frames) are left out.
        if kind == "const":
            if not np.array_equal(kw["matrix"], identity):
                ops.append(Op(kind, value, **kw))
        elif kind in ("mark", "joint") or value != 0.0:
            ops.append(Op(kind, value, **kw))

    def tag(name, mark, motion, axis, coef=1.0):
        tags.setdefault(name, []).append((mark, motion, axis, coef))

    # Base: translation then rotation, with a mark between them so base rotations act
    # about world axes through the base origin.
    emit("const", matrix=translation(*chain.base[:3, 3]))
    emit("mark", name="W")
    emit("const", matrix=make_transform(chain.base[:3, :3]))
    for k, s in enumerate(FRAME_KINDS):
        tag(f"base_{s}", "W", "trans" if k < 3 else "rot", k % 3)

    if chain.convention == "poe":
        _compile_poe(chain, emit, tag)
    else:
        for i in range(chain.n_joints):
            (_compile_dh_joint if chain.convention == "dh" else _compile_mdh_joint)(chain, i, emit, tag)
    emit("const", matrix=chain.flange)
    emit("const", matrix=chain.tool)
    emit("mark", name="T")
    for k, s in enumerate(FRAME_KINDS):
        tag(f"tool_{s}", "T", "trans" if k < 3 else "rot", k % 3)
    return tuple(ops), tags

def _joint_op(chain, i, emit, offset_if_revolute, offset_if_prismatic):
    revolute = chain.joint_types[i] == "revolute"
    if revolute:
        emit("joint", offset_if_revolute, index=i, revolute=True)
    else:
        emit("rz", offset_if_revolute)
        emit("joint", offset_if_prismatic, index=i, revolute=False)

def _compile_dh_joint(chain, i, emit, tag):
    k = i + 1
    revolute = chain.joint_types[i] == "revolute"
    _joint_op(chain, i, emit, chain.theta[i], chain.d[i])
    emit("mark", name=f"J{k}")
    if revolute:
        emit("tz", chain.d[i])
    emit("tx", chain.a[i])
    emit("mark", name=f"A{k}")
    emit("rx", chain.alpha[i])
    emit("mark", name=f"B{k}")
    emit("ry", chain.beta[i])
    tag(f"theta{k}", f"J{k}", "rot", 2)
    tag(f"d{k}", f"J{k}", "trans", 2)
    tag(f"a{k}", f"J{k}", "trans", 0)
    tag(f"alpha{k}", f"A{k}", "rot", 0)
    tag(f"beta{k}", f"B{k}", "rot", 1)

def _compile_mdh_joint(chain, i, emit, tag):
    k = i + 1
    revolute = chain.joint_types[i] == "revolute"
    emit("mark", name=f"P{k}")
    emit("rx", chain.alpha[i])
    emit("tx", chain.a[i])
    emit("mark", name=f"A{k}")
    emit("ry", chain.beta[i])
    _joint_op(chain, i, emit, chain.theta[i], chain.d[i])
    emit("mark", name=f"J{k}")
    if revolute:
        emit("tz", chain.d[i])
    tag(f"alpha{k}", f"P{k}", "rot", 0)
    tag(f"a{k}", f"P{k}", "trans", 0)
    tag(f"beta{k}", f"A{k}", "rot", 1)
    tag(f"theta{k}", f"J{k}", "rot", 2)
    tag(f"d{k}", f"J{k}", "trans", 2)

def _compile_poe(chain, emit, tag):
    frames = chain.poe_frames()
    previous_inv = np.eye(4)
    for i in range(chain.n_joints):
        k = i + 1
        emit("const", matrix=previous_inv @ frames[i])
        emit("mark", name=f"P{k}")
        revolute = chain.joint_types[i] == "revolute"
        emit("joint", chain.theta[i], index=i, revolute=revolute)
        emit("mark", name=f"J{k}")
        previous_inv = invert(frames[i])
        tag(f"theta{k}", f"J{k}", "rot" if revolute else "trans", 2)
        # Moving the axis moves F_i on both sides of the joint: F E Rz(q) E^-1 F^-1.
        for name, motion, axis in (("ux", "trans", 0), ("uy", "trans", 1),
                                   ("wx", "rot", 0), ("wy", "rot", 1)):
            tag(f"{name}{k}", f"P{k}", motion, axis, 1.0)
            tag(f"{name}{k}", f"J{k}", motion, axis, -1.0)
    emit("const", matrix=previous_inv @ chain.home)
    emit("mark", name="H")
    for k, s in enumerate(FRAME_KINDS):
        tag(f"home_{s}", "H", "trans" if k < 3 else "rot", k % 3)
