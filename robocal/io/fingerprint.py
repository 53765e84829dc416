"""Which poses a model has seen, decided by their content, not by a file name.

A pose is its joint configuration.  Two rows are the same pose when every joint value agrees
within :data:`TOLERANCE` (deg; mm on prismatic joints), revolute joints modulo 360°: a copy, a
re-ordering, a re-export rounded to 0.1°, a joint written one turn off (q6 − 360° on a wrist
that turns ±360°), or the same configuration measured again with other x, y, z, is not a new
pose.  Distinct poses differ by more: the closest distinct poses of the shipped datasets
(ipa-ur10-d's ISO cube, 0.8 mm apart) differ by 0.084° on some joint; calibration poses by
degrees.

A model file keeps the training rows' joint configurations, rounded to :data:`RESOLUTION`,
in ``training.fingerprint`` (not their measured positions: the model file does not carry the
data it was fitted to); :func:`seen` finds, in a k-d tree over the joints (periodic on the
revolute ones), the rows within TOLERANCE of a training row.  A model re-registered on a new
set-up (``calibrate MODEL.json --method frames``) was fitted to those poses too: its base and
tool come from them, and it keeps theirs, made by the same function, in
``training.reregistration_fingerprint`` (:data:`ENTRIES`).  Whatever says "held out",
"validated" or "scored on new poses" (``evaluate``, ``report``) asks
:func:`seen_by_model` which of its rows the model was fitted to, every entry at once.

Model files written before this rule keep 64-bit digests of joints and positions rounded to
1e-3 on two grids (``"grids"``); they are read as they were written: a row is seen when its
digest matches.
"""
from __future__ import annotations

import base64
import hashlib

import numpy as np

from ..errors import FileFormatError

# Rows whose every joint agrees within this (deg; mm on prismatic joints) are the same pose:
# a reading rounded to 0.1° (0.05° off at most) is; the closest distinct poses robocal ships
# (0.084° apart) are not.
TOLERANCE = 0.06
# The stored joint values' step (deg; mm), far below TOLERANCE.
RESOLUTION = 1e-3
# Prismatic joints are placed in a box this large (mm), so that only revolute joints wrap.
_FLAT_BOX = 1e7

# The entries of a model file's training record that fingerprint poses the model was fitted
# to: those it was calibrated on, and those a re-registration identified its frames from.
ENTRIES = ("fingerprint", "reregistration_fingerprint")

# The fingerprint of model files written before joints alone decided.
LEGACY_RESOLUTION = 1e-3
_LEGACY_GRIDS = (0.0, 0.5)


def _mix(values):
    """splitmix64's finaliser on a uint64 array (wrapping arithmetic): every input bit
    reaches every output bit."""
    with np.errstate(over="ignore"):
        z = values + np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def fingerprint(joints, revolute=None):
    """The model file's ``fingerprint`` entry of the training rows ``joints`` (N, n) in file
    units (deg; mm on prismatic joints): {"resolution", "tolerance", "n_joints", "joints":
    base64 text of the joint values in steps of RESOLUTION, little-endian int32, row by row}.
    ``revolute`` is not stored: :func:`seen` is told it by the robot."""
    joints = np.asarray(joints, dtype=float).reshape(len(joints), -1)
    steps = np.round(joints / RESOLUTION).astype("<i4")
    return {"resolution": RESOLUTION, "tolerance": TOLERANCE, "n_joints": int(joints.shape[1]),
            "joints": base64.b64encode(steps.tobytes()).decode("ascii")}


def seen(entry, joints, positions=None, labels=None, where="the model file", revolute=None):
    """(N,) bool: the rows ``joints`` (N, n) file units a model with the fingerprint ``entry``
    was trained on (:func:`fingerprint`): within TOLERANCE of a training row on every joint,
    the ``revolute`` (n,) bool ones modulo 360°.  ``positions`` (N, 3) and ``labels`` (N,) are
    read only by fingerprints written before joints alone decided.

    Raises:
        FileFormatError: ``entry`` is not a fingerprint robocal writes or wrote.
    """
    edited = f"{where}: the training fingerprint is not one this robocal writes; the file was edited"
    if not isinstance(entry, dict):
        raise FileFormatError(edited)
    if "joints" not in entry:
        if entry.get("resolution") != LEGACY_RESOLUTION or not isinstance(entry.get("grids"), list) \
                or len(entry["grids"]) != len(_LEGACY_GRIDS):
            raise FileFormatError(edited)
        return _legacy_seen(entry, joints, positions, labels, where)
    joints = np.asarray(joints, dtype=float).reshape(len(joints), -1)
    count = joints.shape[1]
    if entry.get("resolution") != RESOLUTION or entry.get("tolerance") != TOLERANCE or entry.get("n_joints") != count:
        raise FileFormatError(edited)
    training = _decode(entry["joints"], where, "<i4", 4 * count).reshape(-1, count) * RESOLUTION
    if not len(training) or not len(joints):
        return np.zeros(len(joints), dtype=bool)
    from scipy.spatial import cKDTree

    wraps = np.zeros(count, dtype=bool) if revolute is None else np.asarray(revolute, dtype=bool)
    box = np.where(wraps, 360.0, _FLAT_BOX)

    def placed(values):
        return np.where(wraps, np.mod(values, 360.0), values + _FLAT_BOX / 2) % box

    tree = cKDTree(placed(training), boxsize=box)
    # The tolerance plus the stored values' rounding.
    distance, _ = tree.query(placed(joints), k=1, p=np.inf, distance_upper_bound=TOLERANCE + RESOLUTION)
    return np.isfinite(distance)


def _legacy_digests(joints, positions, labels, grid):
    parts = [np.asarray(joints, dtype=float)]
    if positions is not None:
        parts.append(np.asarray(positions, dtype=float))
    columns = np.floor(np.hstack(parts) / LEGACY_RESOLUTION + _LEGACY_GRIDS[grid]).astype(np.int64).view(np.uint64)
    value = np.full(len(columns), np.uint64(columns.shape[1]), dtype=np.uint64)
    if labels is not None:
        names, index = np.unique(np.asarray(labels).astype(str), return_inverse=True)
        label_digest = np.array([np.frombuffer(hashlib.blake2b(n.encode(), digest_size=8).digest(), np.uint64)[0]
                                 for n in names], dtype=np.uint64)
        value = _mix(value ^ label_digest[index])
    for column in columns.T:
        value = _mix(value ^ _mix(column))
    return value


def _legacy_seen(entry, joints, positions, labels, where):
    out = np.zeros(len(joints), dtype=bool)
    for grid, text in enumerate(entry["grids"]):
        out |= np.isin(_legacy_digests(joints, positions, labels, grid), _decode(text, where, "<u8", 8))
    return out


def _encode(values):
    return base64.b64encode(np.unique(np.asarray(values, dtype=np.uint64)).astype("<u8").tobytes()).decode("ascii")


def _decode(text, where, dtype, size):
    """The base64 ``text`` as an array of ``dtype`` whose records are ``size`` bytes long."""
    try:
        raw = base64.b64decode(str(text), validate=True)
    except ValueError:
        raise FileFormatError(f"{where}: the training fingerprint is not base64 text; the file was edited") from None
    if len(raw) % size:
        raise FileFormatError(f"{where}: the training fingerprint has a partial row; the file was edited")
    values = np.frombuffer(raw, dtype=dtype)
    return values.astype(np.uint64) if dtype == "<u8" else values.astype(float)


def of_observations(chain, observations):
    """:func:`fingerprint` of :class:`~robocal.io.observations.Observations` of ``chain``
    (their joints in file units: degrees, mm on prismatic joints)."""
    return fingerprint(chain.joints_to_file(observations.joints), chain.revolute)


def seen_observations(entry, chain, observations, where="the model file"):
    """:func:`seen` for :class:`~robocal.io.observations.Observations` of ``chain``."""
    joints = chain.joints_to_file(observations.joints)
    labels = None if observations.positions is not None else _socket_labels(observations)
    return seen(entry, joints, observations.positions, labels, where=where, revolute=chain.revolute)


def _socket_labels(observations):
    return np.char.add(np.char.add(np.asarray(observations.placement).astype(str), "/"),
                       np.asarray(observations.socket).astype(str))


def seen_by_model(training, chain, observations, where="the model file"):
    """(N,) bool: the rows of :class:`~robocal.io.observations.Observations` of ``chain`` that
    the model whose training record is ``training`` was fitted to, by any fingerprint of
    :data:`ENTRIES` (:func:`seen_observations`).  None when the record keeps no fingerprint of
    the poses it was calibrated on (a model file written before it did): which rows are
    training rows cannot be told then, even where a re-registration's poses are known."""
    if training.get(ENTRIES[0]) is None:
        return None
    out = np.zeros(observations.n_poses, dtype=bool)
    for entry in ENTRIES:
        if training.get(entry) is not None:
            out |= seen_observations(training[entry], chain, observations, where=where)
    return out
