"""URDF in and out: serial chains from ROS robot descriptions, and calibrated chains back.

URDF itself is in metres and radians (as its specification says); robocal works in mm and
radians inside, so lengths are converted at this edge only.

Reading walks the link tree from a root link to a tip link and turns the joints on that
path into a product-of-exponentials :class:`~robocal.kinematics.Chain`: every movable joint
becomes an axis and a point in the root-link frame at zero joint values, fixed joints fold
into the constant transforms around them, and the tip-link pose at zero becomes ``home``.

Writing lays a chain out as links ``world``, ``base_link``, ``link_1`` … ``link_n``,
``flange`` and ``tcp``.  Each joint's origin is the constant transform between consecutive
joint frames, with the joint's zero offset folded in, so that a URDF joint value equals the
controller's joint value and forward kinematics of the file reproduces ``chain.fk`` to
rounding.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.errors import FileFormatError, InputError
from robocal.io.atomic import write_text_atomic
from robocal.io.file_kinds import check
from robocal.io.reading import check_line_lengths, read_bytes
from robocal.kinematics import Chain
from robocal.spatial import compose_pose, make_transform, matrix_to_rpy, rot_x, rot_y, rot_z, translation

MM_PER_M = 1000.0
_MOVABLE = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic"}
_UNSUPPORTED = {"floating", "planar"}
_XACRO_NAMESPACE = "{http://www.ros.org/wiki/xacro}"
# Round-off residue such as cos(90 deg) = 6e-17 is written as 0 so the file reads like the
# robot's drawing; below 1e-15 (m or rad) this moves the TCP by far less than 1e-9 mm.
_WRITE_AS_ZERO = 1e-15
# Longest list of link names quoted in an error message.
_MAX_LISTED = 25


# ------------------------------------------------------------------------------ reading
def read_urdf(path, *, root: str | None = None, tip: str | None = None, name: str | None = None) -> Chain:
    """Read the serial chain from link ``root`` to link ``tip`` of a URDF file.

    Args:
        path: the URDF file (plain URDF; run xacro on ``.xacro`` files first).
        root: the link whose frame becomes the robot base frame; default the root of the
            link tree.
        tip: the link whose frame becomes the flange; default the only leaf below ``root``
            (an :class:`InputError` lists the leaves when there are several).
        name: the chain's name; default the ``<robot name>`` of the file.

    Returns:
        A POE chain in mm and radians: revolute and continuous joints are revolute,
        prismatic joints prismatic (limits converted to mm), continuous joints unlimited.
        ``base`` and ``tool`` are identities; ``home`` is the tip pose at zero.

    A missing ``<origin>`` is the identity and a missing ``<axis>`` is (1, 0, 0), as the
    URDF specification says.  A missing ``lower`` or ``upper`` limit is read as unbounded
    (the specification's default of 0 would lock the joint; robocal omits bounds it does
    not have when writing).  Mimic, floating and planar joints on the path are refused.
    """
    path = Path(path)
    robot = _parse(path)
    tree = _LinkTree(robot, path)
    root = tree.default_root() if root is None else tree.check_link(root, "root")
    tip = tree.default_tip(root) if tip is None else tree.check_link(tip, "tip")
    walk = _walk(tree, tree.path(root, tip), path)
    if not walk.joint_types:
        raise InputError(
            f"{path}: no movable joint between links {root!r} and {tip!r}: choose a tip link "
            "further from the root (or a root closer to the base)"
        )
    return Chain(
        name=name if name is not None else robot.get("name") or path.stem,
        convention="poe",
        joint_types=tuple(walk.joint_types),
        theta=np.zeros(len(walk.joint_types)),
        axes=np.array(walk.axes),
        points=np.array(walk.points),
        home=walk.pose,
        lower=np.array(walk.lower),
        upper=np.array(walk.upper),
        # Link masses only when every link a joint moves declares one.
        masses=None if any(np.isnan(walk.masses)) else np.array(walk.masses),
        # The URDF's joint names, which ROS data name their columns by (unnamed joints: none).
        joint_names=tuple(walk.names) if "<unnamed>" not in walk.names and len(set(walk.names)) == len(walk.names)
        else None,
    )


@dataclass
class _Walk:
    """The movable joints met walking from the root link to the tip, in the root-link frame
    at zero joint values: robocal joint types, unit axes (3,), points (3,) mm on the axes,
    limits (rad or mm), masses (kg, NaN where undeclared) of the links each joint moves;
    ``pose`` (4x4, mm) of the current link, the tip's once the walk is over."""

    joint_types: list[str] = field(default_factory=list)
    axes: list[np.ndarray] = field(default_factory=list)
    points: list[np.ndarray] = field(default_factory=list)
    lower: list[float] = field(default_factory=list)
    upper: list[float] = field(default_factory=list)
    masses: list[float] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))


def _walk(tree: _LinkTree, joints: list[ET.Element], path: Path) -> _Walk:
    """Compose the joints from root to tip (as :meth:`_LinkTree.path` lists them): fixed
    joints fold into the running pose; each movable one becomes a POE joint, its axis turned
    into the root-link frame and its point the origin of its joint frame."""
    walk = _Walk()
    for joint in joints:
        kind = _joint_type(joint, path)
        walk.pose = walk.pose @ _origin(joint, path)
        child = joint.find("child").get("link")
        if kind == "fixed":
            if walk.masses:  # a link fixed to the one the last joint moves moves with it (a
                # bare frame, with no <inertial>, weighs nothing)
                walk.masses[-1] += np.nan_to_num(tree.mass(child))
            continue
        walk.masses.append(tree.mass(child))
        _check_not_mimic(joint, path)
        robocal_type = _MOVABLE[kind]
        walk.joint_types.append(robocal_type)
        walk.names.append(_name(joint))
        walk.axes.append(walk.pose[:3, :3] @ _axis(joint, path))
        walk.points.append(walk.pose[:3, 3].copy())
        low, high = _limits(joint, kind, path)
        scale = MM_PER_M if robocal_type == "prismatic" else 1.0
        walk.lower.append(low * scale)
        walk.upper.append(high * scale)
    return walk


def _check_not_mimic(joint: ET.Element, path: Path) -> None:
    """Refuse a mimic joint: its value follows another joint's, which a Chain cannot hold."""
    if joint.find("mimic") is not None:
        raise InputError(
            f"{path}: joint {_name(joint)!r} mimics another joint, which robocal does not "
            "support: choose a tip link whose path has no mimic joints, or replace the mimic "
            "joint by a fixed one"
        )


def _parse(path: Path) -> ET.Element:
    """The ``<robot>`` element of a URDF file, or a one-line error naming the file."""
    raw = read_bytes(path, "URDF file", "settings")
    check_line_lengths(raw, path, "URDF file")
    check(path, "urdf", text=raw[:65536].decode("utf-8", errors="replace"))  # robocal's other files, named
    try:
        robot = ET.fromstring(raw)
    except ET.ParseError as error:
        raise FileFormatError(
            f"{path} is not well-formed XML ({error}): fix the file or export the URDF again"
        ) from None
    if any(element.tag.startswith(_XACRO_NAMESPACE) for element in robot.iter()):
        raise FileFormatError(
            f"{path} is a xacro file: expand it first, e.g. `xacro {path.name} > robot.urdf`"
        )
    if robot.tag != "robot":
        raise FileFormatError(
            f"{path}: the top XML element is <{robot.tag}>, not <robot>: this is not a URDF file"
        )
    return robot


def _name(joint: ET.Element) -> str:
    return joint.get("name", "<unnamed>")


def _listing(names) -> str:
    names = sorted(names)
    shown = ", ".join(names[:_MAX_LISTED])
    return shown + (f", … ({len(names)} in all)" if len(names) > _MAX_LISTED else "")


class _LinkTree:
    """Links and joints of a URDF file, indexed to walk between a root and a tip."""

    def __init__(self, robot: ET.Element, path: Path):
        self.file = path
        self.elements = {link.get("name"): link for link in robot.findall("link") if link.get("name")}
        self.links = set(self.elements)
        if not self.links:
            raise FileFormatError(f"{path} has no <link> elements: this is not a robot description")
        self.parent_joint = {}  # child link -> the joint that carries it
        self.child_joints = {}  # parent link -> the joints hanging from it
        for joint in robot.findall("joint"):
            parent, child = (self._joint_link(joint, role) for role in ("parent", "child"))
            if parent == child:
                raise FileFormatError(
                    f"{path}: joint {_name(joint)!r} has link {child!r} as both its parent and its child: "
                    "a joint connects two different links; fix its <parent> or <child>"
                )
            if child in self.parent_joint:
                raise FileFormatError(
                    f"{path}: link {child!r} is the child of two joints "
                    f"({_name(self.parent_joint[child])!r} and {_name(joint)!r}): a URDF must be "
                    "a tree; remove one of them"
                )
            self.parent_joint[child] = joint
            self.child_joints.setdefault(parent, []).append(joint)
        self._check_no_loop()

    def _check_no_loop(self) -> None:
        """FileFormatError naming the links of the first loop of joints (each link has one
        parent here, so going up from any link either ends at a root or comes round)."""
        done = set()  # links known to lead up to a root
        for start in sorted(self.parent_joint):
            seen, link = [], start
            while link in self.parent_joint and link not in done:
                if link in seen:
                    loop = seen[seen.index(link):]
                    joints = [_name(self.parent_joint[item]) for item in loop]
                    raise FileFormatError(
                        f"{self.file}: the joints {_listing(map(repr, joints))} form a loop through the links "
                        f"{_listing(map(repr, loop))}: a URDF must be a tree; remove one of those joints"
                    )
                seen.append(link)
                link = self.parent_joint[link].find("parent").get("link")
            done.update(seen)

    def _joint_link(self, joint: ET.Element, role: str) -> str:
        element = joint.find(role)
        link = None if element is None else element.get("link")
        if link is None:
            raise FileFormatError(
                f"{self.file}: joint {_name(joint)!r} has no <{role} link=\"…\"/>: add it"
            )
        if link not in self.links:
            raise FileFormatError(
                f"{self.file}: joint {_name(joint)!r} names {role} link {link!r}, which has no "
                "<link> element: declare the link or fix the name"
            )
        return link

    def mass(self, link: str) -> float:
        """The ``<inertial><mass value>`` of a link in kg, NaN when it declares none."""
        element = self.elements[link].find("inertial/mass")
        try:
            return float(element.get("value")) if element is not None else float("nan")
        except (TypeError, ValueError):
            raise FileFormatError(f"{self.file}: link {link!r} has a <mass> without a numeric value") from None

    def check_link(self, link: str, role: str) -> str:
        if link not in self.links:
            raise InputError(
                f"{self.file} has no link {link!r} to use as the {role}: choose one of "
                f"{_listing(self.links)}"
            )
        return link

    def default_root(self) -> str:
        roots = self.links - set(self.parent_joint)
        # Not empty: without a loop (refused when the tree was read) some link has no parent.
        if len(roots) == 1:
            return roots.pop()
        raise InputError(
            f"{self.file} describes {len(roots)} separate link trees (roots: {_listing(roots)}): "
            "choose the root link with --root (root= in Python)"
        )

    def default_tip(self, root: str) -> str:
        leaves, stack, seen = [], [root], {root}
        while stack:
            link = stack.pop()
            children = [joint.find("child").get("link") for joint in self.child_joints.get(link, [])]
            if not children:
                leaves.append(link)
            for child in children:
                if child not in seen:
                    seen.add(child)
                    stack.append(child)
        if len(leaves) == 1:
            return leaves[0]
        raise InputError(
            f"{self.file}: the tree below link {root!r} branches into {len(leaves)} leaf links "
            f"({_listing(leaves)}): choose the tip link (the flange or tool frame to calibrate, "
            "a leaf or any link before one) with --tip (tip= in Python)"
        )

    def path(self, root: str, tip: str) -> list[ET.Element]:
        """The joints from ``root`` down to ``tip``, in that order."""
        joints, link = [], tip
        while link != root:
            joint = self.parent_joint.get(link)
            if joint is None or len(joints) > len(self.parent_joint):
                raise InputError(
                    f"{self.file}: no path from link {root!r} down to link {tip!r} (the links "
                    f"above {tip!r} end at {link!r}): choose a root link that the tip hangs from"
                )
            joints.append(joint)
            link = joint.find("parent").get("link")
        return joints[::-1]


def _joint_type(joint: ET.Element, path: Path) -> str:
    kind = joint.get("type")
    if kind in _UNSUPPORTED:
        raise InputError(
            f"{path}: joint {_name(joint)!r} is {kind}, which a serial robot model cannot hold: "
            "choose root and tip links so that only revolute, continuous, prismatic and fixed "
            "joints lie between them"
        )
    if kind != "fixed" and kind not in _MOVABLE:
        raise FileFormatError(
            f"{path}: joint {_name(joint)!r} has type {kind!r}: URDF joint types are revolute, "
            "continuous, prismatic, fixed, floating and planar"
        )
    return kind


def _vector(element: ET.Element | None, attribute: str, default, joint: ET.Element, path: Path):
    """Three finite numbers from an attribute such as xyz="0 0 0.333"."""
    text = None if element is None else element.get(attribute)
    if text is None:
        return np.array(default, dtype=float)
    try:
        values = np.array([float(word) for word in text.split()], dtype=float)
    except ValueError:
        values = np.array([])
    if values.shape != (3,) or not np.all(np.isfinite(values)):
        raise FileFormatError(
            f"{path}: joint {_name(joint)!r}: {attribute}=\"{text}\" is not three numbers"
        )
    return values


def _origin(joint: ET.Element, path: Path) -> np.ndarray:
    """The joint origin (parent link -> joint frame) in mm; no <origin> is the identity."""
    origin = joint.find("origin")
    xyz = _vector(origin, "xyz", (0.0, 0.0, 0.0), joint, path) * MM_PER_M
    rpy = _vector(origin, "rpy", (0.0, 0.0, 0.0), joint, path)
    return compose_pose(xyz, rpy)


def _axis(joint: ET.Element, path: Path) -> np.ndarray:
    """Unit joint axis in the joint frame; (1, 0, 0) when absent, as URDF specifies."""
    axis = _vector(joint.find("axis"), "xyz", (1.0, 0.0, 0.0), joint, path)
    norm = np.linalg.norm(axis)
    if norm < 1e-12:
        raise FileFormatError(f"{path}: joint {_name(joint)!r} has a zero-length axis: fix its <axis xyz>")
    return axis / norm


def _limits(joint: ET.Element, kind: str, path: Path) -> tuple[float, float]:
    """(lower, upper) in URDF units; continuous joints and missing bounds are unbounded."""
    limit = joint.find("limit")
    if kind == "continuous" or limit is None:
        return -np.inf, np.inf
    bounds = []
    for attribute, unbounded in (("lower", -np.inf), ("upper", np.inf)):
        text = limit.get(attribute)
        try:
            value = unbounded if text is None else float(text)
        except ValueError:
            value = np.nan
        if np.isnan(value):
            raise FileFormatError(f"{path}: joint {_name(joint)!r}: {attribute}=\"{text}\" is not a number")
        bounds.append(value)
    if bounds[0] > bounds[1]:
        raise FileFormatError(
            f"{path}: joint {_name(joint)!r} has lower limit {bounds[0]} above upper limit "
            f"{bounds[1]}: swap them"
        )
    return bounds[0], bounds[1]


# ------------------------------------------------------------------------------ writing
def write_urdf(chain: Chain, path, *, robot_name: str | None = None, allow_coupled: bool = False) -> Path:
    """Write ``chain`` as a URDF file (atomically) and return its path.

    See :func:`chain_to_urdf` for the layout and for ``allow_coupled``.
    """
    text = chain_to_urdf(chain, robot_name=robot_name, allow_coupled=allow_coupled)
    return write_text_atomic(path, text)


def chain_to_urdf(chain: Chain, *, robot_name: str | None = None, allow_coupled: bool = False) -> str:
    """The URDF text of ``chain`` (any convention, with base, flange and tool).

    Links ``world`` -> ``base_link`` (fixed, ``chain.base``) -> ``link_1`` … ``link_n`` (one
    joint per robot joint, named as the chain's joints when it has names, else ``joint_1`` …)
    -> ``flange`` (fixed) -> ``tcp`` (fixed, ``chain.tool``).  A URDF
    joint value is the controller's joint value: the joint's zero offset is folded into its
    origin and its sign in ``chain.joint_map`` gives the axis (0, 0, ±1).  Joint limits are
    ``chain.lower`` / ``chain.upper``; a revolute joint without limits is ``continuous``.

    A joint map that couples joints (FANUC's J2/J3) cannot be written without mimic joints;
    it raises :class:`InputError` unless ``allow_coupled`` is true, in which case the URDF
    joints are the model variables ``joint_map @ q`` (an XML comment says so).
    """
    coupled = _is_coupled(chain.joint_map)
    if coupled and not allow_coupled:
        raise InputError(
            f"robot {chain.name!r}: its joint_map couples joints (e.g. FANUC's J2/J3) or scales them "
            "(calibrated joint gains), which URDF cannot express: pass allow_coupled=True to write "
            "the model variables joint_map·q as the URDF joints instead, or export a robot file"
        )
    origins, last_to_flange = _joint_origins(chain)
    robot = _robot_element(chain, robot_name, coupled)
    links = _add_links(robot, chain)
    _fixed_joint(robot, "world_to_base", "world", "base_link", chain.base)
    _add_movable_joints(robot, chain, links, origins, coupled)
    _fixed_joint(robot, "flange_joint", links[-3], "flange", last_to_flange @ chain.flange)
    _fixed_joint(robot, "tcp_joint", "flange", "tcp", chain.tool)
    ET.indent(robot, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def _robot_element(chain: Chain, robot_name: str | None, coupled: bool) -> ET.Element:
    """The ``<robot>`` element with the comments that say where the file came from, and,
    for a ``coupled`` joint map, what its joint values mean."""
    robot = ET.Element("robot", name=robot_name if robot_name is not None else chain.name)
    robot.append(ET.Comment(
        f" Written by robocal from the {chain.convention} model {chain.name!r}. Metres and radians. "
        "Kinematics only: effort and velocity limits are placeholders (0) required by the URDF "
        "format; set them before using this file with a controller. "
    ))
    if coupled:
        robot.append(ET.Comment(
            " The joint_map of this robot couples or scales controller joints. The URDF joint values below "
            "are the model variables q_model = joint_map . q, not the controller's joint values; "
            "their limits are the bounds of q_model over the controller's joint-limit box. "
        ))
    return robot


def _add_links(robot: ET.Element, chain: Chain) -> list[str]:
    """Append the ``<link>`` elements (with the chain's masses, kg, on the links the joints
    move) and return their names, base to TCP: world, base_link, link_1 … link_n, flange, tcp."""
    links = ["world", "base_link"] + [f"link_{k}" for k in range(1, chain.n_joints + 1)] + ["flange", "tcp"]
    for k, link in enumerate(links):
        element = ET.SubElement(robot, "link", name=link)
        joint_index = k - 2  # link_1 .. link_n are moved by joints 1 .. n
        if chain.masses is not None and 0 <= joint_index < chain.n_joints:
            inertial = ET.SubElement(element, "inertial")
            ET.SubElement(inertial, "mass", value=_numbers([chain.masses[joint_index]]))
    return links


def _add_movable_joints(robot: ET.Element, chain: Chain, links: list[str], origins, coupled: bool) -> None:
    """Append one ``<joint>`` per robot joint, link_{i} -> link_{i+1}, at the (4x4, mm)
    ``origins``.  Controller joints: axis (0, 0, sign) from the joint map's diagonal, limits
    ``chain.lower`` / ``chain.upper``.  With a ``coupled`` joint map the URDF joints are the
    model variables instead: axis (0, 0, 1) and the bounds of joint_map @ q over the limit box.
    A revolute joint without limits is ``continuous``."""
    if coupled:
        signs = np.ones(chain.n_joints)
        lower, upper = _mapped_bounds(chain.joint_map, chain.lower, chain.upper)
    else:
        signs = np.diag(chain.joint_map)
        lower, upper = chain.lower, chain.upper
    for i, origin in enumerate(origins):
        joint_type = chain.joint_types[i]
        unlimited = not (np.isfinite(lower[i]) or np.isfinite(upper[i]))
        if joint_type == "revolute" and unlimited:
            joint_type = "continuous"
        name = chain.joint_names[i] if chain.joint_names is not None else f"joint_{i + 1}"
        joint = ET.SubElement(robot, "joint", name=name, type=joint_type)
        _origin_element(joint, origin)
        ET.SubElement(joint, "parent", link=links[i + 1])
        ET.SubElement(joint, "child", link=links[i + 2])
        ET.SubElement(joint, "axis", xyz=_numbers([0.0, 0.0, signs[i]]))
        if joint_type != "continuous":
            _limit_element(joint, chain.joint_types[i], lower[i], upper[i])


def _is_coupled(joint_map: np.ndarray) -> bool:
    """True unless the joint map is diagonal with entries ±1 (a per-joint sign)."""
    diagonal = np.diag(joint_map)
    return bool(np.any(joint_map != np.diag(diagonal)) or np.any(np.abs(diagonal) != 1.0))


def _mapped_bounds(joint_map, lower, upper):
    """Bounds of joint_map @ q for q in the box [lower, upper] (interval arithmetic)."""
    # A zero coefficient contributes nothing even when its joint is unlimited (0 * inf).
    with np.errstate(invalid="ignore"):
        ends = np.stack([joint_map * lower, joint_map * upper])
    ends = np.where(joint_map == 0.0, 0.0, ends)
    return ends.min(axis=0).sum(axis=1), ends.max(axis=0).sum(axis=1)


def _joint_origins(chain: Chain):
    """Constant transforms (mm) between consecutive joint frames, offsets folded in.

    Returns the n joint origins (frame after joint i-1's motion -> frame of joint i's
    motion; the first from the robot base) and the transform from the last joint frame to
    the flange, excluding ``chain.flange``.  It walks the chain's own factor program, so the
    regrouping is exact for DH, MDH and POE alike.
    """
    bare = chain.replace(base=np.eye(4), flange=np.eye(4), tool=np.eye(4))
    origins, current = [], np.eye(4)
    for op in bare._compiled[0]:
        if op.kind == "joint":
            # The offset acts exactly like the joint variable, so it goes before the motion.
            offset = make_transform(rot_z(op.value)) if op.revolute else translation(z=op.value)
            origins.append(current @ offset)
            current = np.eye(4)
        elif op.kind != "mark":
            current = current @ _factor(op)
    return origins, current


def _factor(op) -> np.ndarray:
    """The 4x4 matrix of one constant factor of the program."""
    if op.kind == "const":
        return op.matrix
    rotations = {"rx": rot_x, "ry": rot_y, "rz": rot_z}
    if op.kind in rotations:
        return make_transform(rotations[op.kind](op.value))
    return translation(**{op.kind[1]: op.value})


def _fixed_joint(robot: ET.Element, name: str, parent: str, child: str, transform: np.ndarray) -> None:
    joint = ET.SubElement(robot, "joint", name=name, type="fixed")
    _origin_element(joint, transform)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)


def _origin_element(joint: ET.Element, transform: np.ndarray) -> None:
    ET.SubElement(
        joint, "origin",
        xyz=_numbers(transform[:3, 3] / MM_PER_M),
        rpy=_numbers(matrix_to_rpy(transform[:3, :3])),
    )


def _limit_element(joint: ET.Element, joint_type: str, lower: float, upper: float) -> None:
    """<limit> in URDF units; a bound robocal does not have is left out."""
    scale = 1.0 / MM_PER_M if joint_type == "prismatic" else 1.0
    bounds = {key: _numbers([value * scale]) for key, value in (("lower", lower), ("upper", upper))
              if np.isfinite(value)}
    ET.SubElement(joint, "limit", effort="0", velocity="0", **bounds)


def _numbers(values) -> str:
    """Space-separated numbers with round-trip (repr) precision."""
    return " ".join(repr(0.0 if abs(v) < _WRITE_AS_ZERO else float(v)) for v in values)
