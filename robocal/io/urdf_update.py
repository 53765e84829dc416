"""A calibrated robot written into its own URDF: the original file with only what the
calibration changed rewritten, so that joint and link names, meshes, limits, inertias,
other branches (grippers, sensors) and comments stay as they were.

The chain is found in the original file as the links whose forward kinematics is the
model's nominal robot (to 1e-6 mm, joint names equal when the robot has them).  Every link
frame keeps its place relative to its joint's axis as far as the calibration allows: the
frame of movable joint i at zero is the original one turned by the smallest rotation that
carries its axis onto the calibrated axis (so ``<axis>`` stays as written) and, for a
revolute joint, moved onto the calibrated axis line.  With every joint frame on the
calibrated axis, the forward kinematics of the links is the calibrated product of
exponentials, whatever the turn of a frame about its axis; each movable joint's
``<origin>`` is rewritten to put its frame there, and the first fixed joint after the last
movable one takes the calibrated flange.  The calibration's base (measurement frame ->
robot base) and tool (flange -> measured point) are added as a new root link and a new tip
link, when they are not identities.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..spatial import chained, invert, so3_exp
from .atomic import write_text_atomic
from .reading import read_bytes
from .urdf import MM_PER_M, _axis, _joint_origins, _joint_type, _LinkTree, _name, _numbers, _origin, _parse, read_urdf

# The original robot's chain must reproduce the model's nominal robot to this (mm).
NOMINAL_MATCH_MM = 1e-6
# Names of the links (and their joints) added for the calibration's base and tool.
MEASUREMENT_FRAME = "measurement_frame"
CALIBRATED_TCP = "calibrated_tcp"
# A change below this (m, rad) is rounding, not a calibration: the origin is left as written.
_UNCHANGED = 1e-12


def write_calibrated_urdf(original, nominal, calibrated, out):
    """Write ``calibrated`` (a rigid :class:`~robocal.kinematics.Chain`, controller joint
    values) into a copy of the URDF ``original`` whose chain is ``nominal`` (the model's
    nominal robot), atomically at ``out``.  Returns a JSON-ready account: the root and tip
    links, the joints whose origins changed, and the links added.

    Raises:
        InputError: no chain of ``original`` is the nominal robot; a joint map that scales
            or couples joints (calibrated gains: URDF cannot hold them); a calibrated axis
            pointing against the original's; a tip link right after the last movable joint
            with a flange its joint frame cannot take.
    """
    original = Path(original)
    diagonal = np.diag(calibrated.joint_map)
    if np.any(calibrated.joint_map != np.diag(diagonal)) or np.any(np.abs(diagonal) != 1.0):
        raise InputError("the calibrated robot scales or couples joints (calibrated joint gains), which a URDF cannot "
                         "hold: calibrate without gains to export into the original URDF, or export a robot file")
    robot = _parse_keeping_comments(original)
    tree = _LinkTree(robot, original)
    root, tip = _nominal_path(tree, original, nominal)
    joints = tree.path(root, tip)
    origins, last = _joint_origins(calibrated)
    frames = chained(origins)
    flange = frames[-1] @ last @ calibrated.flange
    changed = _rewrite_origins(joints, frames, diagonal, flange, original)
    added = []
    if not _is_identity(calibrated.base):
        added.append(_add_base(robot, tree, root, calibrated.base, original))
    if not _is_identity(calibrated.tool):
        added.append(_add_tool(robot, tree, tip, calibrated.tool))
    robot.insert(0, ET.Comment(
        f" Calibrated by robocal: the origins of {', '.join(changed) or 'no joint'} rewritten for the calibrated "
        f"{calibrated.name!r}; {', '.join(added) or 'no link'} added. Everything else is the original file. "))
    robot[0].tail = "\n  "
    write_text_atomic(out, '<?xml version="1.0"?>\n' + _prolog(original) + ET.tostring(robot, encoding="unicode")
                      + "\n")
    return {"original": str(original), "root": root, "tip": tip, "changed_joints": changed, "added_links": added}


def _parse_keeping_comments(path):
    """The ``<robot>`` element with the file's comments (after :func:`urdf._parse`'s checks)."""
    _parse(path)
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    parser.feed(read_bytes(path, "URDF file", "settings"))
    return parser.close()


def _prolog(path):
    """The comments before the ``<robot>`` element (a xacro banner), as written."""
    text = read_bytes(path, "URDF file", "settings").decode("utf-8", errors="replace")
    start = text.find("<robot")
    head = text[:max(start, 0)]
    if head.lstrip().startswith("<?xml"):
        head = head[head.find("?>") + 2:]
    return head.lstrip("\n")


def _is_identity(transform):
    return bool(np.abs(transform[:3, :3] - np.eye(3)).max() < _UNCHANGED
                and np.abs(transform[:3, 3]).max() < _UNCHANGED * MM_PER_M)


def _nominal_path(tree, path, nominal):
    """(root, tip) links of the original whose chain is ``nominal`` (module notes)."""
    bare = nominal.replace(base=np.eye(4), tool=np.eye(4))
    q = bare.random_configurations(16, np.random.default_rng(0))
    expected = bare.fk(q)
    for tip in sorted(tree.links):
        link, ancestors = tip, [tip]
        while link in tree.parent_joint:
            link = tree.parent_joint[link].find("parent").get("link")
            ancestors.append(link)
        for root in ancestors[1:]:
            joints = tree.path(root, tip)
            movable = [j for j in joints if _joint_type(j, path) != "fixed"]
            if len(movable) != nominal.n_joints or (
                    nominal.joint_names is not None and [_name(j) for j in movable] != list(nominal.joint_names)):
                continue
            chain = read_urdf(path, root=root, tip=tip)
            found = chain.fk(q)
            if np.abs(found - expected).max() < NOMINAL_MATCH_MM:
                return root, tip
    raise InputError(f"{path} holds no chain of links whose forward kinematics is the model's nominal robot "
                     f"{nominal.name!r} ({nominal.n_joints} joints): give the URDF the robot was calibrated from")


def _rewrite_origins(joints, frames, signs, flange, path):
    """Rewrite the ``<origin>`` of each movable joint on the path and of the first fixed
    joint after the last one (module notes); the names of the joints whose origins changed."""
    movable = [k for k, joint in enumerate(joints) if _joint_type(joint, path) != "fixed"]
    pose, new_pose, changed = np.eye(4), np.eye(4), []
    tail = movable[-1] + 1
    for k, joint in enumerate(joints):
        origin = _origin(joint, path)
        pose = pose @ origin
        if k in movable:
            i = movable.index(k)
            target = _on_calibrated_axis(pose, _axis(joint, path), frames[i], signs[i], joint, path)
        elif k == tail:
            rest = np.eye(4)
            for later in joints[k + 1:]:
                rest = rest @ _origin(later, path)
            target = flange @ invert(rest)
        else:
            new_pose = new_pose @ origin
            continue
        new_origin = invert(new_pose) @ target
        if np.abs(new_origin - origin).max() > _UNCHANGED:
            _set_origin(joint, new_origin)
            changed.append(_name(joint))
        new_pose = target
    if tail == len(joints):
        # The tip is the last movable joint's link: its frame must be the flange itself.
        if np.abs(new_pose - flange).max() > NOMINAL_MATCH_MM:
            raise InputError(f"{path}: the tip link follows joint {_name(joints[-1])!r} with no fixed joint between, "
                             "so it cannot take the calibrated flange: add a fixed joint and a flange link to the "
                             "original URDF, or export without the original")
    return changed


def _on_calibrated_axis(frame, axis, calibrated, sign, joint, path):
    """The joint frame (4x4, mm) nearest to the original ``frame`` whose ``axis`` (in the
    frame) is the calibrated one: ``sign`` times the z axis of ``calibrated``, through its
    origin for a revolute joint."""
    direction = frame[:3, :3] @ axis
    target = sign * calibrated[:3, 2]
    cross = np.cross(direction, target)
    if np.dot(direction, target) <= 0:
        raise InputError(f"{path}: the calibrated axis of joint {_name(joint)!r} points against the original's: "
                         "this URDF is not the one the robot was calibrated from")
    angle = np.arctan2(np.linalg.norm(cross), np.dot(direction, target))
    turn = np.eye(3) if angle < _UNCHANGED else so3_exp(cross / np.linalg.norm(cross) * angle)
    out = np.eye(4)
    out[:3, :3] = turn @ frame[:3, :3]
    point = frame[:3, 3]
    if joint.get("type") in ("revolute", "continuous"):
        on_axis = calibrated[:3, 3]
        point = on_axis + np.dot(point - on_axis, target) * target
    out[:3, 3] = point
    return out


def _set_origin(joint, transform):
    """Write ``transform`` (4x4, mm) as the joint's ``<origin>`` (m, rad), creating it."""
    from ..spatial import matrix_to_rpy

    element = joint.find("origin")
    if element is None:
        element = ET.Element("origin")
        joint.insert(0, element)
    element.set("xyz", _numbers(transform[:3, 3] / MM_PER_M))
    element.set("rpy", _numbers(matrix_to_rpy(transform[:3, :3])))


def _unique(tree, name):
    while name in tree.links:
        name += "_robocal"
    return name


def _add_base(robot, tree, root, base, path):
    """A new root link, the measurement frame, fixed to the tree's root so that the chain's
    root link stands at ``base`` (4x4, mm) in it; its name."""
    top, above = root, np.eye(4)
    while top in tree.parent_joint:
        joint = tree.parent_joint[top]
        if _joint_type(joint, path) != "fixed":
            raise InputError(f"{path}: the root link {root!r} hangs from movable joint {_name(joint)!r}: the "
                             "calibrated base cannot be placed above it")
        above = _origin(joint, path) @ above
        top = joint.find("parent").get("link")
    name = _unique(tree, MEASUREMENT_FRAME)
    link = ET.Element("link", name=name)
    link.tail = "\n  "
    joint = ET.Element("joint", name=f"{name}_joint", type="fixed")
    _set_origin(joint, base @ invert(above))
    ET.SubElement(joint, "parent", link=name)
    ET.SubElement(joint, "child", link=top)
    joint.tail = "\n  "
    robot.insert(0, joint)
    robot.insert(0, link)
    return name


def _add_tool(robot, tree, tip, tool):
    """A new link fixed to the tip at ``tool`` (4x4, mm): the calibrated TCP; its name."""
    name = _unique(tree, CALIBRATED_TCP)
    link = ET.SubElement(robot, "link", name=name)
    joint = ET.SubElement(robot, "joint", name=f"{name}_joint", type="fixed")
    _set_origin(joint, tool)
    ET.SubElement(joint, "parent", link=tip)
    ET.SubElement(joint, "child", link=name)
    link.tail = joint.tail = "\n"
    return name
