"""Which poses a model has seen, decided by their content, not by a file name.

A model file keeps a fingerprint of its training rows: per pose, 64-bit digests of its joint
values and measured position (or socket) rounded to :data:`RESOLUTION` (deg, mm) on two
grids half a cell apart, so that a copy, a re-export with fewer digits or a re-ordering of
the same rows is recognised (a row is seen when either grid's digest matches: rounding a
value across a cell boundary on one grid leaves it inside a cell on the other) and a
genuinely new measurement, which differs by a tracker's noise (0.01 mm) or more, is not.
Whatever says "held out", "validated" or "scored on new poses"
(``evaluate``, ``report``) asks :func:`seen` which of its rows the model was trained on.
Digests, not rows, are stored: a model file does not carry its training data.
"""
from __future__ import annotations

import base64
import hashlib

import numpy as np

from ..errors import FileFormatError

# Rows equal to this resolution (deg, mm in the file's units) are the same pose.
RESOLUTION = 1e-3
# The two grids' offsets, in cells.
GRIDS = (0.0, 0.5)


def _mix(values):
    """splitmix64's finaliser on a uint64 array (wrapping arithmetic): every input bit
    reaches every output bit."""
    z = values + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def digests(joints, positions=None, labels=None, grid=0):
    """(N,) uint64 digests of the rows on grid ``grid`` (an index of GRIDS): ``joints``
    (N, n) and ``positions`` (N, 3) in file units, ``labels`` (N,) text (fixture/socket of
    ball-in-socket rows) where there are no positions.  Vectorised."""
    parts = [np.asarray(joints, dtype=float)]
    if positions is not None:
        parts.append(np.asarray(positions, dtype=float))
    columns = np.floor(np.hstack(parts) / RESOLUTION + GRIDS[grid]).astype(np.int64).view(np.uint64)
    value = np.full(len(columns), np.uint64(columns.shape[1]), dtype=np.uint64)
    if labels is not None:
        names, index = np.unique(np.asarray(labels).astype(str), return_inverse=True)
        label_digest = np.array([np.frombuffer(hashlib.blake2b(n.encode(), digest_size=8).digest(), np.uint64)[0]
                                 for n in names], dtype=np.uint64)
        value = _mix(value ^ label_digest[index])
    with np.errstate(over="ignore"):
        for column in columns.T:
            value = _mix(value ^ _mix(column))
    return value


def fingerprint(joints, positions=None, labels=None):
    """The model file's ``fingerprint`` entry of the training rows: {"resolution": ...,
    "grids": [base64 text per grid]} (sorted unique little-endian uint64 digests)."""
    return {"resolution": RESOLUTION,
            "grids": [_encode(digests(joints, positions, labels, grid)) for grid in range(len(GRIDS))]}


def _encode(values):
    return base64.b64encode(np.unique(np.asarray(values, dtype=np.uint64)).astype("<u8").tobytes()).decode("ascii")


def _decode(text, where):
    try:
        raw = base64.b64decode(str(text), validate=True)
    except ValueError:
        raise FileFormatError(f"{where}: the training fingerprint is not base64 text; the file was edited") from None
    if len(raw) % 8:
        raise FileFormatError(f"{where}: the training fingerprint has a partial digest; the file was edited")
    return np.frombuffer(raw, dtype="<u8").astype(np.uint64)


def seen(entry, joints, positions=None, labels=None, where="the model file"):
    """(N,) bool: the rows (file units, as :func:`digests`) a model with the fingerprint
    ``entry`` (:func:`fingerprint`) was trained on.

    Raises:
        FileFormatError: ``entry`` is not a fingerprint of this resolution and grids.
    """
    if not isinstance(entry, dict) or entry.get("resolution") != RESOLUTION or \
            not isinstance(entry.get("grids"), list) or len(entry["grids"]) != len(GRIDS):
        raise FileFormatError(f"{where}: the training fingerprint is not one this robocal writes; the file was edited")
    out = np.zeros(len(joints), dtype=bool)
    for grid, text in enumerate(entry["grids"]):
        out |= np.isin(digests(joints, positions, labels, grid), _decode(text, where))
    return out


def of_observations(chain, observations):
    """:func:`fingerprint` of :class:`~robocal.io.observations.Observations` of ``chain``
    (their rows in file units: degrees and mm)."""
    joints = chain.joints_to_file(observations.joints)
    if observations.positions is not None:
        return fingerprint(joints, observations.positions)
    return fingerprint(joints, labels=_socket_labels(observations))


def seen_observations(entry, chain, observations, where="the model file"):
    """:func:`seen` for :class:`~robocal.io.observations.Observations` of ``chain``."""
    joints = chain.joints_to_file(observations.joints)
    if observations.positions is not None:
        return seen(entry, joints, observations.positions, where=where)
    return seen(entry, joints, labels=_socket_labels(observations), where=where)


def _socket_labels(observations):
    return np.char.add(np.char.add(np.asarray(observations.placement).astype(str), "/"),
                       np.asarray(observations.socket).astype(str))
