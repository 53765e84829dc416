"""Exact conversions between DH, modified DH and POE chains.

Each conversion regroups the same product of elementary transforms, so forward kinematics
of the result equals the original to rounding.  DH -> MDH moves the last link's Tx(a) Rx(alpha)
Ry(beta) into the flange; MDH -> DH moves the first link's Rx(alpha) Tx(a) Ry(beta) into the
base.  POE -> MDH finds the common normals of consecutive axes (defined when every joint is
revolute; parallel axes take the common normal through the previous frame's origin).
"""
import numpy as np

from ..errors import InputError
from ..spatial import invert, make_transform, rot_x, rot_y, rot_z, translation
from .chain import Chain


def _rx(angle):
    return make_transform(rot_x(angle))


def _ry(angle):
    return make_transform(rot_y(angle))


def _rz(angle):
    return make_transform(rot_z(angle))


def to_mdh(chain: Chain) -> Chain:
    """The same robot in Craig's modified DH form."""
    if chain.convention == "mdh":
        return chain
    if chain.convention == "poe":
        return _poe_to_mdh(chain)
    n = chain.n_joints
    shift = lambda v: np.concatenate([[0.0], v[:-1]])  # noqa: E731 (tiny local helper)
    tail = translation(chain.a[-1]) @ _rx(chain.alpha[-1]) @ _ry(chain.beta[-1])
    return chain.replace(
        convention="mdh",
        a=shift(chain.a), alpha=shift(chain.alpha), beta=shift(chain.beta),
        flange=tail @ chain.flange,
    ) if n else chain


def to_dh(chain: Chain) -> Chain:
    """The same robot in standard DH form."""
    if chain.convention == "dh":
        return chain
    mdh = to_mdh(chain) if chain.convention == "poe" else chain
    head = _rx(mdh.alpha[0]) @ translation(mdh.a[0]) @ _ry(mdh.beta[0])
    unshift = lambda v: np.concatenate([v[1:], [0.0]])  # noqa: E731
    return mdh.replace(
        convention="dh",
        a=unshift(mdh.a), alpha=unshift(mdh.alpha), beta=unshift(mdh.beta),
        base=mdh.base @ head,
    )


def to_poe(chain: Chain) -> Chain:
    """The same robot as a product of exponentials (axes in the base frame at q = 0)."""
    if chain.convention == "poe":
        return chain
    # A chain is frozen: its POE form is made once (a calibration asks for it several times).
    cached = chain.__dict__.get("_poe_form")
    if cached is not None:
        return cached
    chain.__dict__["_poe_form"] = poe = _to_poe(chain)
    return poe


def _to_poe(chain: Chain) -> Chain:
    # Frames right before each joint's motion with every link variable at zero: evaluate
    # the chain at the configuration that cancels the offsets, on a copy with no base/tool.
    bare = chain.replace(base=np.eye(4), tool=np.eye(4), theta=np.zeros(chain.n_joints),
                         joint_map=np.eye(chain.n_joints))
    q0 = np.zeros((1, chain.n_joints))
    q0[0, ~chain.revolute] = -chain.d[~chain.revolute]
    rot, origins, flange_pose = bare.joint_frames(q0)
    theta = chain.theta.copy()
    theta[~chain.revolute] = chain.d[~chain.revolute]
    return Chain(
        name=chain.name, convention="poe", joint_types=chain.joint_types, theta=theta,
        axes=rot[0, :, :, 2], points=origins[0], home=flange_pose[0],
        joint_map=chain.joint_map, lower=chain.lower, upper=chain.upper,
        base=chain.base, tool=chain.tool, masses=chain.masses,
    )


def _poe_to_mdh(chain: Chain) -> Chain:
    """Common-normal construction of MDH parameters from POE axes (revolute joints)."""
    if not np.all(chain.revolute):
        raise InputError("POE -> DH/MDH conversion is implemented for revolute joints only")
    n = chain.n_joints
    alpha, a, beta, d, theta = (np.zeros(n) for _ in range(5))
    frame = np.eye(4)  # frame i-1 in the robot base frame
    for i in range(n):
        w, p = chain.axes[i], chain.points[i]
        o_prev = frame[:3, 3]
        # Express the axis line in frame i-1.
        w_loc = frame[:3, :3].T @ w
        p_loc = frame[:3, :3].T @ (p - o_prev)
        # MDH: Rx(alpha) Tx(a) Ry(beta) then z_i.  Choose alpha so the axis lies in a plane
        # parallel to x-z after Rx(alpha) wherever possible; beta takes what is left.
        alpha[i] = np.arctan2(-w_loc[1], w_loc[2])
        w1 = rot_x(-alpha[i]) @ w_loc
        p1 = rot_x(-alpha[i]) @ p_loc
        beta[i] = np.arctan2(w1[0], w1[2])
        # The axis passes through the x axis of the rotated frame at x = a when beta = 0;
        # in general take the point of the line closest to that x axis.
        if abs(w1[0]) < 1e-12 and abs(w1[1]) < 1e-12:
            a[i] = p1[0]
            y_off = p1[1]
        else:
            # solve p1 + s w1 has y = 0 in the x-z plane if possible
            s = -p1[1] / w1[1] if abs(w1[1]) > 1e-12 else 0.0
            pt = p1 + s * w1
            # move along the line to the point with z = 0 in frame rotated by beta
            a[i] = pt[0] - pt[2] * np.tan(beta[i]) if abs(np.cos(beta[i])) > 1e-12 else pt[0]
            y_off = pt[1]
        if abs(y_off) > 1e-6:
            raise InputError(
                f"joint {i + 1}'s axis does not meet the common normal of a DH form; "
                "export this model as POE or URDF instead"
            )
        pre = frame @ _rx(alpha[i]) @ translation(a[i]) @ _ry(beta[i])
        # theta / d: place frame i's x along the common normal to the next axis.
        if i + 1 < n:
            x_dir, d[i] = _normal_to_next(pre, chain.axes[i + 1], chain.points[i + 1])
        else:
            home_loc = invert(pre) @ chain.home
            x_dir = home_loc[:3, 0]
            d[i] = home_loc[2, 3]
        theta[i] = np.arctan2(x_dir[1], x_dir[0])
        frame = pre @ _rz(theta[i]) @ translation(z=d[i])
    flange = invert(frame) @ chain.home
    return Chain(
        name=chain.name, convention="mdh", joint_types=chain.joint_types,
        theta=theta + chain.theta, d=d, a=a, alpha=alpha, beta=beta,
        joint_map=chain.joint_map, lower=chain.lower, upper=chain.upper,
        base=chain.base, flange=flange, tool=chain.tool, masses=chain.masses,
    )


# Below this sine of the angle between consecutive axes they are treated as parallel
# (Hayati): about 3 degrees, where a common normal would already lie metres away.
_NEAR_PARALLEL = 0.05


def _normal_to_next(frame, w_next, p_next):
    """Direction (in ``frame`` coordinates, z = current axis) and height d of the common
    normal from the current axis to the next one."""
    w = frame[:3, :3].T @ w_next
    p = frame[:3, :3].T @ (p_next - frame[:3, 3])
    z = np.array([0.0, 0.0, 1.0])
    cross = np.cross(z, w)
    if np.linalg.norm(cross) < _NEAR_PARALLEL:
        # (Nearly) parallel axes: the common normal is far away or anywhere.  Point x at
        # where the next axis pierces this frame's x-y plane; its beta takes up the tilt.
        pierce = p - w * (p[2] / w[2])
        direction = pierce
        height = 0.0
    else:
        # Closest points between z-axis (t z) and next line (p + s w).
        mat = np.array([[1.0, -z @ w], [z @ w, -1.0]])
        rhs = np.array([z @ p, w @ p])
        t, s = np.linalg.solve(mat, rhs)
        direction = (p + s * w) - t * z
        height = t
    norm = np.linalg.norm(direction[:2])
    if norm < 1e-9:
        return np.array([1.0, 0.0, 0.0]), height
    return direction / norm, height
