"""Robot files (TOML, mm and degrees) <-> :class:`~robocal.kinematics.Chain`.

Keys beyond the basic format (docs/ARCHITECTURE.md, "File formats"), all optional:

* per joint: ``type = "revolute" | "prismatic"``, ``sign = -1`` (the controller's axis turns
  the other way from the model's), ``beta`` (Hayati rotation about y, deg);
* POE joints (``convention = "poe"``): ``axis = [x, y, z]`` (direction, normalised on load) and
  ``point = [x, y, z]`` (mm, any point on the axis), both in the robot base frame at the zero
  configuration, with ``theta`` the joint zero offset; ``[home]`` ``xyz``/``rpy`` is the
  flange pose at the zero configuration;
* ``[flange]`` ``xyz``/``rpy``: last joint frame -> mechanical flange (DH/MDH);
* ``joint_map = [[...], ...]``: a full n x n matrix with q_model = joint_map @ q_controller,
  for coupled axes such as FANUC's J2/J3 (``sign`` is its diagonal special case; give one or
  the other).  Joint zero offsets of the model live in ``theta``.
"""
import sys

import numpy as np

from ..errors import FileFormatError, InputError
from ..kinematics import Chain
from ..spatial import compose_pose, pose_to_xyz_rpy
from .atomic import write_text_atomic
from . import schema
from .reading import load_toml
from .units import check_angles

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

_LINK_KEYS = {"dh": ("a", "alpha", "d", "theta"), "mdh": ("a", "alpha", "d", "theta"),
              "poe": ("axis", "point", "theta")}
# beta (Hayati) belongs to DH/MDH joints only: a POE axis already takes any direction.
_OPTIONAL_JOINT_KEYS = ("min", "max", "type", "sign", "name", "mass")
_TOP_KEYS = ("name", "convention", "description", "joints", "tool", "base", "flange", "home",
             "joint_map", "notes", "tolerances")


def _fail(path, message):
    raise FileFormatError(f"{path}: {message}")


def _number(path, where, value):
    return schema.number(value, f"{path}: {where}")


def _vector(path, where, value):
    return np.array(schema.numbers(value, f"{path}: {where}", count=3))


def _frame(path, table, key):
    """An optional [key] table with xyz (mm) and rpy (deg) -> 4x4 (mm, rad)."""
    if key not in table:
        return np.eye(4)
    sub = schema.table(table[key], f"{path}: [{key}]", "a table with xyz and rpy")
    unknown = set(sub) - {"xyz", "rpy"}
    if unknown:
        _fail(path, f"[{key}] has unknown key {sorted(unknown)[0]!r}: use xyz = [...] (mm) and rpy = [...] (deg)")
    xyz = _vector(path, f"[{key}] xyz", sub.get("xyz", [0.0, 0.0, 0.0]))
    rpy = _vector(path, f"[{key}] rpy", sub.get("rpy", [0.0, 0.0, 0.0]))
    return compose_pose(xyz, np.radians(rpy))


def _tolerances(path, doc):
    """The [tolerances] table over the defaults (:mod:`robocal.kinematics.tolerances`), or None."""
    if "tolerances" not in doc:
        return None
    from ..kinematics.tolerances import Tolerances

    # Read against placeholders; the defaults depend on the whole chain and fill the rest later.
    table = doc["tolerances"]
    try:
        keys = {name for name, (key, _) in Tolerances.FILE_KEYS.items() if isinstance(table, dict) and key in table}
        placeholder = Tolerances(*([1.0] * len(Tolerances.FILE_KEYS)))
        given = placeholder.with_file_values(table)
    except InputError as exc:
        _fail(path, str(exc))
    return {name: getattr(given, name) for name in keys}


def _check_keys(path, where, keys, allowed):
    schema.keys(keys, f"{path}: {where}", allowed)


def chain_from_dict(doc, path="<robot>"):
    """Build a Chain from a parsed robot document (file units).

    The checks run in a fixed order (top-level keys, convention, each joint, masses, joint
    map, name, frames), so a document with several faults always reports the same one.
    """
    if not doc:
        _fail(path, "the robot file is empty: give its name, convention and one [[joints]] table per joint")
    _check_keys(path, "the robot file", doc, _TOP_KEYS)
    convention = doc.get("convention")
    if convention is None:
        _fail(path, "no convention line: add convention = \"dh\", \"mdh\" or \"poe\"")
    schema.text(convention, f"{path}: convention", tuple(_LINK_KEYS))
    joints = doc.get("joints")
    if not joints:
        _fail(path, "no [[joints]] tables: list one per joint, base to tip")
    schema.tables(joints, f"{path}: joints", "[[joints]] tables, one per joint, base to tip")
    columns, types, signs = _read_joints(path, joints, convention)
    _check_angle_units(path, convention, columns, types)
    joint_map = _joint_map(path, doc, signs)
    name = doc.get("name")
    if not isinstance(name, str) or not name:
        _fail(path, "name = \"...\" is missing")
    fields = dict(
        name=name, convention=convention, joint_types=tuple(types),
        theta=columns["theta"], joint_map=joint_map, lower=columns["min"], upper=columns["max"],
        base=_frame(path, doc, "base"), tool=_frame(path, doc, "tool"),
        masses=columns["mass"] or None,
        tolerances=_tolerances(path, doc),
        joint_names=tuple(columns["name"]) or None,
    )
    fields.update(_convention_fields(path, doc, convention, columns))
    try:
        return Chain(**fields)
    except InputError as exc:
        _fail(path, str(exc))


def _read_joints(path, joints, convention):
    """The [[joints]] tables as columns in model units.

    Returns ``columns`` (a dict of lists, one entry per joint: theta, d, a, alpha, beta in mm
    and rad for DH/MDH; axis (3,), point (3,) mm and theta for POE; min and max in rad or mm,
    infinite where absent; mass in kg, for every joint or none), the joint types and the
    per-joint signs (+-1.0).
    """
    required = _LINK_KEYS[convention]
    allowed = required + _OPTIONAL_JOINT_KEYS + (() if convention == "poe" else ("beta",))
    columns = {k: [] for k in ("theta", "d", "a", "alpha", "beta", "axis", "point", "min", "max", "mass", "name")}
    types, signs = [], []
    for j, joint in enumerate(joints, start=1):
        where = f"joint {j}"
        if convention == "poe" and "beta" in joint:
            _fail(path, f"{where} has beta, the Hayati angle of DH/MDH joints: a POE joint's axis already takes "
                        "any direction; remove beta or tilt the axis")
        _check_keys(path, where, joint, allowed)
        missing = [k for k in required if k not in joint]
        if missing:
            _fail(path, f"{where} is missing {', '.join(missing)} (a {convention} joint needs {', '.join(required)})")
        kind = schema.text(joint.get("type", "revolute"), f"{path}: {where} type", ("revolute", "prismatic"))
        types.append(kind)
        sign = _number(path, f"{where} sign", joint.get("sign", 1.0))
        if sign not in (1.0, -1.0):
            _fail(path, f"{where}: sign must be 1 or -1, got {sign}")
        signs.append(sign)
        # Joint values (theta of POE joints, limits) are degrees for revolute joints and mm
        # for prismatic ones; DH/MDH theta is always an angle (a prismatic joint's variable
        # is d there).
        angle = np.radians if kind == "revolute" else (lambda v: v)
        _read_link(path, where, joint, convention, angle, columns)
        lo, hi = _joint_limits(path, where, joint, angle)
        columns["min"].append(lo)
        columns["max"].append(hi)
        if "mass" in joint:
            columns["mass"].append(_number(path, f"{where} mass", joint["mass"]))
        if "name" in joint:
            if not isinstance(joint["name"], str) or not joint["name"].strip():
                _fail(path, f"{where}: name must be text (the joint's name, e.g. \"shoulder_pan_joint\")")
            columns["name"].append(joint["name"].strip())
    n = len(joints)
    if columns["name"] and len(columns["name"]) != n:
        _fail(path, f"name is given for {len(columns['name'])} of {n} joints: give it for every joint or none")
    if len(set(columns["name"])) != len(columns["name"]):
        _fail(path, "two joints have the same name: every joint needs its own")
    if columns["mass"] and len(columns["mass"]) != n:
        _fail(path, f"mass (kg) is given for {len(columns['mass'])} of {n} joints: give it for every joint or none")
    return columns, types, signs


def _read_link(path, where, joint, convention, angle, columns):
    """Append one joint's link parameters to ``columns``: axis, point (mm) and theta (through
    ``angle``: deg -> rad, or mm as it is) for POE; theta, alpha, beta (deg -> rad), d and
    a (mm) for DH/MDH."""
    if convention == "poe":
        columns["axis"].append(_vector(path, f"{where} axis", joint["axis"]))
        columns["point"].append(_vector(path, f"{where} point", joint["point"]))
        columns["theta"].append(angle(_number(path, f"{where} theta", joint["theta"])))
    else:
        columns["theta"].append(np.radians(_number(path, f"{where} theta", joint["theta"])))
        for key in ("d", "a"):
            columns[key].append(_number(path, f"{where} {key}", joint[key]))
        for key in ("alpha", "beta"):
            columns[key].append(np.radians(_number(path, f"{where} {key}", joint.get(key, 0.0))))


def _check_angle_units(path, convention, columns, types):
    """InputError when the angles of the [[joints]] look like radians, by the one test of typed
    angles (robocal.io.units.check_angles): the twists alpha (a table of 1.5708 and 0 is
    radians; degrees write 90 and 0), the link angles alpha, theta, beta together, and the
    revolute joints' limits (within one turn)."""
    fix = "a robot file is in mm and degrees: convert them with numpy.degrees()"
    if convention != "poe":
        alpha = np.degrees(columns["alpha"])
        check_angles(alpha, f"{path}: the alpha of the [[joints]]", fix=fix)
        link = np.concatenate([alpha, np.degrees(columns["theta"]), np.degrees(columns["beta"])])
        check_angles(link, f"{path}: the alpha, theta and beta of the [[joints]]", fix=fix)
    revolute = np.array([kind == "revolute" for kind in types])
    limits = np.degrees(np.concatenate([np.asarray(columns["min"])[revolute], np.asarray(columns["max"])[revolute]]))
    limits = limits[np.isfinite(limits)]
    if len(limits) == 2 * revolute.sum():  # every revolute limit given: a robot's range, judged whole
        check_angles(limits, f"{path}: the min and max of the revolute [[joints]]", joints=True, fix=fix)


def _joint_limits(path, where, joint, angle):
    """(min, max) of one joint in rad or mm (``angle`` converts from file units); an absent
    bound is infinite."""
    lo = angle(_number(path, f"{where} min", joint.get("min", -np.inf))) if "min" in joint else -np.inf
    hi = angle(_number(path, f"{where} max", joint.get("max", np.inf))) if "max" in joint else np.inf
    if lo > hi:
        _fail(path, f"{where}: min {joint['min']} is above max {joint['max']}")
    return lo, hi


def _joint_map(path, doc, signs):
    """The (n, n) joint map: the document's ``joint_map`` (checked: shape, not singular, and
    no per-joint sign besides it), else the diagonal of the per-joint ``signs``."""
    if "joint_map" not in doc:
        return np.diag(signs)
    n = len(signs)
    if any(s != 1.0 for s in signs):
        _fail(path, "give either per-joint sign or a joint_map, not both")
    try:
        joint_map = np.array(doc["joint_map"], dtype=float)
    except (TypeError, ValueError):
        _fail(path, "joint_map must be a list of lists of numbers")
    if joint_map.shape != (n, n):
        _fail(path, f"joint_map must be {n}x{n} for {n} joints, got shape {joint_map.shape}")
    if abs(np.linalg.det(joint_map)) < 1e-9:
        _fail(path, "joint_map is singular: every controller axis must drive the model")
    return joint_map


def _convention_fields(path, doc, convention, columns):
    """The Chain arguments that depend on the convention: axes, points and [home] (4x4, mm)
    for POE; d, a, alpha, beta and [flange] (4x4, mm) for DH/MDH.  Each convention refuses
    the other's frame table."""
    if convention == "poe":
        if "flange" in doc:
            _fail(path, "a POE robot has no [flange]: the flange pose is [home]")
        return dict(axes=columns["axis"], points=columns["point"], home=_frame(path, doc, "home"))
    if "home" in doc:
        _fail(path, "[home] belongs to POE robots; a DH/MDH robot may have a [flange]")
    return dict(d=columns["d"], a=columns["a"], alpha=columns["alpha"], beta=columns["beta"],
                flange=_frame(path, doc, "flange"))


def read_robot(path) -> Chain:
    """Read a robot TOML file."""
    doc = load_toml(path, "robot file", "fix the file or regenerate it with 'robocal export'", reader="robot")
    return chain_from_dict(doc, str(path))


def _fmt(value):
    return repr(float(value)) if np.isfinite(value) else None


def _frame_lines(key, transform):
    xyz, rpy = pose_to_xyz_rpy(transform)
    if np.allclose(transform, np.eye(4), rtol=0, atol=0):
        return []
    return [f"[{key}]", f"xyz = [{', '.join(_fmt(v) for v in xyz)}]",
            f"rpy = [{', '.join(_fmt(v) for v in np.degrees(rpy))}]", ""]


def robot_to_toml(chain: Chain, description=None) -> str:
    """Serialise a chain as a robot TOML document (mm, degrees, shortest exact floats)."""
    lines = [f"name = {_toml_string(chain.name)}", f"convention = \"{chain.convention}\""]
    if description:
        lines.append(f"description = {_toml_string(description)}")
    diag = np.diag(np.diag(chain.joint_map))
    coupled = not np.array_equal(chain.joint_map, diag) or not np.all(np.isin(np.diag(chain.joint_map), (1.0, -1.0)))
    if coupled:
        rows = ", ".join("[" + ", ".join(_fmt(v) for v in row) + "]" for row in chain.joint_map)
        lines.append(f"joint_map = [{rows}]")
    lines.append("")
    for i, kind in enumerate(chain.joint_types):
        revolute = kind == "revolute"
        angle = np.degrees if revolute else (lambda v: v)
        lines.append("[[joints]]")
        if chain.joint_names is not None:
            lines.append(f"name = {_toml_string(chain.joint_names[i])}")
        if not revolute:
            lines.append('type = "prismatic"')
        if chain.convention == "poe":
            lines.append(f"axis = [{', '.join(_fmt(v) for v in chain.axes[i])}]")
            lines.append(f"point = [{', '.join(_fmt(v) for v in chain.points[i])}]")
            lines.append(f"theta = {_fmt(angle(chain.theta[i]))}")
        else:
            lines += [f"a = {_fmt(chain.a[i])}", f"alpha = {_fmt(np.degrees(chain.alpha[i]))}",
                      f"d = {_fmt(chain.d[i])}", f"theta = {_fmt(np.degrees(chain.theta[i]))}"]
            if chain.beta[i] != 0.0:
                lines.append(f"beta = {_fmt(np.degrees(chain.beta[i]))}")
        if not coupled and chain.joint_map[i, i] == -1.0:
            lines.append("sign = -1")
        for key, value in (("min", chain.lower[i]), ("max", chain.upper[i])):
            if np.isfinite(value):
                lines.append(f"{key} = {_fmt(angle(value))}")
        if chain.masses is not None:
            lines.append(f"mass = {_fmt(chain.masses[i])}")
        lines.append("")
    if chain.convention == "poe":
        lines += _frame_lines("home", chain.home) or ["[home]", "xyz = [0.0, 0.0, 0.0]", ""]
    else:
        lines += _frame_lines("flange", chain.flange)
    lines += _frame_lines("tool", chain.tool)
    lines += _frame_lines("base", chain.base)
    if chain.tolerances:
        from ..kinematics.tolerances import Tolerances

        keys = Tolerances.FILE_KEYS
        lines += ["[tolerances]"] + [f"{keys[name][0]} = {_fmt(value * keys[name][1])}"
                                     for name, value in chain.tolerances.items()] + [""]
    return "\n".join(lines).rstrip() + "\n"


def _toml_string(text):
    return '"' + str(text).replace("\\", "\\\\").replace('"', '\\"') + '"'


def write_robot(chain: Chain, path, description=None):
    """Write a robot TOML file atomically."""
    write_text_atomic(path, robot_to_toml(chain, description))


def chain_to_dict(chain: Chain) -> dict:
    """The rigid geometry of ``chain`` as the robot-file structure (mm, deg), JSON-ready: what
    :func:`chain_from_dict` reads back (model files keep their chains this way)."""
    return tomllib.loads(robot_to_toml(chain.rigid))
