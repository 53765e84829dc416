"""What ``robocal design`` does with files: read the robot, the candidates, the poses measured
before and the targets; draw candidates when none are given; design; write the poses CSV.

The poses CSV is the joint part of a measurement file: ``pose`` (the order to measure in),
``q1`` … ``qN`` in the controller's degrees (mm for prismatic joints) and ``x_nominal,
y_nominal, z_nominal``, where the nominal model puts the TCP (mm, robot base frame; a check
for the operator, which ``calibrate`` ignores).  Add the measured ``x, y, z`` and it is a
measurement file.

Ball-in-socket designs (:func:`socket_job`) write ``pose, q1 … qN, x_nominal, y_nominal,
z_nominal, fixture, socket``: the ``fixture`` column names the placement and ``socket`` the
fixture file's socket id, as a constraint measurement file holds them, so the file measured
as it stands (the ball seated where each row says) is the constraint calibration's input.
Candidate placements come from a placements CSV: ``x, y, z, rx, ry, rz``, the fixture frame
in the robot base frame (mm; deg, roll-pitch-yaw as every robocal pose), and optionally a
``fixture`` column naming each placement (default P1, P2, …); or from a region (a box of the
base frame, mm) where the fixture may stand level.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from ..io.atomic import check_outputs
from ..io.library import load_robot
from ..io.observations import check_robot_in_mm, read_observations, read_target_poses
from ..io.poses import joint_table, read_joints, read_placements, write_poses
from ..io.units import check_robot_lengths, check_typed_units
from ..kinematics.ik import solve_ik
from ..spatial import compose_pose, rpy_to_matrix
from .candidates import DEFAULT_COUNT, MARGIN_DEG, box_candidates, joint_candidates
from .criteria import DEFAULT_CRITERION, VarianceKernel
from .design import Design, design_poses
from .workspace import WorkingVolume

if TYPE_CHECKING:  # imported by socket_job, when a ball-in-socket design is asked for
    from .sockets import SocketDesign

# An existing measurement file fitted for its residual needs this many times as many
# equations as parameters.
NOISE_FIT_RATIO = 1.5


@dataclass(frozen=True)
class Designed:
    """What ``design`` chose and wrote: its command's result, in the manner of
    :mod:`robocal.interfaces.results` (here, in the layer of the job that returns it).

    Attributes
    ----------
    robot, out : str
        The robot's name, and the poses CSV written.
    candidates_from, noise_from : str
        Where the candidates came from (drawn, or a file), and the reading noise assumed.
    working_volume : str
        The volume drawn candidates keep to (:class:`~.workspace.WorkingVolume`).
    targets : str
        Where the robot will work, the design's targets.
    design : Design
        The chosen poses and what they predict (:class:`~.design.Design`: mm, deg).
    """

    robot: str
    out: str
    candidates_from: str
    noise_from: str
    working_volume: str
    targets: str
    design: Design

    def to_dict(self):
        return {"robot": self.robot, "out": self.out, "candidates_from": self.candidates_from,
                "noise_from": self.noise_from, "working_volume": self.working_volume, "targets": self.targets,
                **self.design.to_dict()}


@dataclass(frozen=True)
class SocketsDesigned:
    """What ``design --fixture`` chose and wrote: a ball-in-socket campaign.

    Attributes
    ----------
    robot, out : str
        The robot's name, and the poses CSV written (with fixture and socket columns).
    fixture : str
        The fixture's name.
    placements_from : str
        Where the candidate placements came from (a file, or drawn in a region).
    reachable_placements : int
        How many candidate placements the robot reaches.
    placement_poses : dict
        {placement id: {"xyz_mm": [x, y, z]}}: where each chosen placement stands (mm, robot
        base frame).
    noise_from : str
        The reading noise assumed.
    design : SocketDesign
        The chosen placements and configurations and what they predict
        (:class:`~.sockets.SocketDesign`, mm).
    """

    robot: str
    out: str
    fixture: str
    placements_from: str
    reachable_placements: int
    placement_poses: dict
    noise_from: str
    design: SocketDesign

    def to_dict(self):
        return {"robot": self.robot, "out": self.out, "fixture": self.fixture, "placements_from": self.placements_from,
                "reachable_placements": self.reachable_placements, "placement_poses": self.placement_poses,
                "noise_from": self.noise_from, **self.design.to_dict()}


def _targets(path, chain, volume):
    """Target configurations (rad): a file's q columns, or its x, y, z, rx, ry, rz targets
    solved by the nominal IK (q columns as posture hints), the unreachable ones dropped;
    refused when one puts the arm outside ``volume`` (a WorkingVolume)."""
    header = joint_table(path, chain).header
    if "x" not in header and "q1" in header:
        q = read_joints(path, chain, "targets")[0]
        volume.check_given(chain, q, np.arange(2, len(q) + 2), path, "targets")
        return q
    targets = read_target_poses(path, chain)
    result = solve_ik(chain, targets.poses, targets.hints)
    if not result.success.any():
        raise InputError(f"none of the targets of {path} can be reached by robot '{chain.name}': are they in the robot "
                         "base frame, in mm and degrees?")
    volume.check_given(chain, result.q[result.success], targets.rows[result.success], path, "targets")
    return result.q[result.success]


def _check_existing(path, chain):
    """Measured poses given to a design (``--existing``) with positions meet the data check
    every calibration meets (:func:`robocal.estimation.plausibility.check_robot_data`): another
    robot's measurements, or positions that are the nominal robot's own, are refused."""
    from ..estimation.plausibility import check_measured, check_robot_data

    header = joint_table(path, chain).header
    if {"x", "y", "z"} <= set(header):
        observations = read_observations(path, chain)
        check_robot_data(chain, observations, fitting=False)
        check_measured(chain, observations, fitting=False)


def _noise_from(path, chain, parameters, payload):
    """The per-coordinate standard deviation (mm) a calibration of the measured poses of
    ``path`` leaves, with its degrees of freedom (3N - P); None when the file has no
    positions or too few poses."""
    from ..estimation.calibration import KinematicCalibration

    header = joint_table(path, chain).header
    if not {"x", "y", "z"} <= set(header):
        return None
    observations = read_observations(path, chain)
    fit = KinematicCalibration(parameters, payload=payload)
    try:
        fit.fit(chain, observations.joints, observations.positions, sigmas=observations.sigmas)
    except InputError:
        return None
    count = len(fit.names_)
    equations = 3 * observations.n_poses
    if equations < NOISE_FIT_RATIO * count:
        return None
    residual = observations.positions - fit.predict(observations.joints)
    return float(np.sqrt(np.sum(residual ** 2) / (equations - count)))


def _variance_kernel(path, chain, parameters, payload):
    """The variance criterion's prior fitted to the poses measured before (``path`` with x, y,
    z): a ``sincos`` joint-space Kriging of the residual a calibration of ``parameters``
    leaves, as the residual models fit it; None (the fixed prior) when the file has no
    positions or too few poses to fit."""
    from ..estimation.calibration import KinematicCalibration
    from ..estimation.joint_kriging import JointKriging
    from ..estimation.kriging import Kriging

    header = joint_table(path, chain).header
    if not {"x", "y", "z"} <= set(header):
        return None
    observations = read_observations(path, chain)
    try:
        fit = KinematicCalibration(parameters, payload=payload).fit(
            chain, observations.joints, observations.positions, sigmas=observations.sigmas)
        errors = observations.positions - fit.predict(observations.joints)
        model = JointKriging("sincos", Kriging(nugget="estimate", random_state=0)).fit(
            fit.chain_, observations.joints, errors)
    except InputError:
        return None
    return VarianceKernel.of_kriging(model, f"a sincos Kriging of the residual of a calibration of {path}")


def design_job(robot, out, *, n, seed=0, criterion=DEFAULT_CRITERION, parameters="full", candidates=None,
               pool=DEFAULT_COUNT, sampling="uniform", box=None, rpy=None, hint=None, tool=None,
               margin=MARGIN_DEG, existing=None, targets=None, noise=None, tracker=None, payload=None,
               order="tour", root=None, tip=None, joint_noise_deg=0.0, sag_deg=0.0, volume=None, progress=None):
    """Design ``n`` poses for ``robot`` and write them to ``out`` (module notes); returns a
    :class:`Designed`: the design and where the candidates, the noise and the poses came from
    and went.  ``volume``: the
    :class:`~robocal.planning.workspace.WorkingVolume` drawn candidates keep to (default:
    above the mounting plane); the candidates and targets a user gives are held to it too.  ``progress``:
    called as ``progress(stage=...)`` as each stage begins."""
    progress = (lambda **info: None) if progress is None else progress
    check_outputs([out], [robot, candidates, existing, targets])
    chain = load_robot(robot, root=root, tip=tip)
    volume = WorkingVolume() if volume is None else volume
    progress(stage="drawing candidates")
    check_typed_units(chain, box=box, rpy=rpy, hint=hint, tool=tool, tracker=tracker, walls=volume.walls_mm)
    if tool is not None:
        chain = chain.replace(tool=compose_pose(np.asarray(tool, dtype=float), np.zeros(3)))
    check_robot_in_mm(chain)
    if candidates is not None:
        given = {"--pool": pool != DEFAULT_COUNT or None, "--sampling": sampling != "uniform" or None, "--box": box,
                 "--rpy": rpy, "--hint": hint}
        unused = [name for name, value in given.items() if value]
        if unused:
            raise InputError(f"{', '.join(unused)} draw candidates, but --candidates gives them: leave "
                             f"{'it' if len(unused) == 1 else 'them'} out")
        q = read_joints(candidates, chain, "candidates")[0]
        volume.check_given(chain, q, np.arange(2, len(q) + 2), candidates, "candidates")
        source = str(candidates)
    elif box is not None:
        rotation = rpy_to_matrix(np.radians(rpy if rpy is not None else [180.0, 0.0, 0.0]))
        hint_rad = None if hint is None else chain.joints_from_file(np.asarray(hint, dtype=float))
        q = box_candidates(chain, pool, np.asarray(box[0::2], float), np.asarray(box[1::2], float), rotation, seed,
                           hint=hint_rad, margin_deg=margin, volume=volume)
        source = f"{len(q)} reachable of {pool} Latin-hypercube points in the box"
    else:
        if rpy is not None or hint is not None:
            raise InputError("--rpy and --hint set the TCP orientation in a --box: give --box too, or leave them out")
        q = joint_candidates(chain, pool, seed, sampling=sampling, margin_deg=margin, volume=volume)
        source = f"{len(q)} {sampling} joint configurations {margin:g} deg inside the limits"
    if n > len(q):
        raise InputError(f"--n {n} poses asked for but there are {len(q)} candidates: ask for "
                         f"at most {len(q)}, or give "
                         "more candidates")
    before = None
    noise_note = "as stated (--noise)" if noise is not None else "the default tracker noise"
    if existing is not None:
        before = read_joints(existing, chain, "measured poses")[0]
        _check_existing(existing, chain)
        if noise is None:
            fitted = _noise_from(existing, chain, parameters, payload)
            if fitted is not None:
                noise, noise_note = fitted, f"the residual of a calibration of {existing}"
    target_q = None if targets is None else _targets(targets, chain, volume)
    kernel = None
    if criterion == "variance" and existing is not None:
        kernel = _variance_kernel(existing, chain, parameters, payload)
    design = design_poses(chain, n, q, criterion=criterion, parameters=parameters,
                          noise=0.02 if noise is None else noise, tracker=tracker, targets=target_q,
                          existing=before, payload=payload, seed=seed, order=order, kernel=kernel,
                          joint_noise_deg=joint_noise_deg, sag_deg=sag_deg, progress=progress)
    write_poses(out, chain, design.joints)
    return Designed(chain.name, str(out), source, noise_note, volume.describe(),
                    "the candidates" if targets is None else f"{len(target_q)} configurations of {targets}", design)


def _refuse_below_mounting_plane(rig, poses, where):
    """When no placement was reachable: InputError naming the mounting plane if every socket of
    every placement ``poses`` (P, 4, 4) lies below it (z < 0 of the robot base frame, the plane
    a table- or floor-mounted robot stands on), the cause a user can fix."""
    sockets = np.array([rig.sockets[s] for s in rig.ids], dtype=float)
    z = np.einsum("pj,sj->ps", poses[:, 2, :3], sockets) + poses[:, 2, 3][:, None]
    if len(z) and z.max() < 0.0:
        raise InputError(f"{where} puts every socket below the robot's mounting plane (highest socket z = "
                         f"{z.max():.0f} mm, robot base frame; z = 0 is the plane a table- or floor-mounted robot "
                         "stands on), where the arm does not reach: place the fixture above it, z >= 0 mm")


def socket_job(robot, out, *, fixture, n, placements=None, region=None, per_socket=None, criterion="prediction",
               seed=0, tool=None, noise=None, margin=MARGIN_DEG, max_tilt=None, root=None, tip=None):
    """Design a ball-in-socket campaign of ``n`` configurations in all for ``robot`` (its
    tool: the ball centre) and ``fixture`` (a fixture TOML file), from candidate
    ``placements`` (a placements CSV) or a ``region`` (xmin, xmax, ymin, ymax, zmin, zmax mm);
    ``per_socket`` configurations per socket (default: spread over every candidate placement
    reached).  Writes the poses CSV with fixture and socket columns to ``out`` and returns a
    :class:`SocketsDesigned`."""
    from ..io.fixtures import read_fixture
    from .sockets import MAX_TILT_DEG, design_sockets, region_placements, socket_candidates

    check_outputs([out], [robot, fixture, placements])
    if (placements is None) == (region is None):
        raise InputError("a ball-in-socket design needs where the fixture may go: give --placements FILE.csv or "
                         "--region xmin,xmax,ymin,ymax,zmin,zmax (mm), one of them")
    chain = load_robot(robot, root=root, tip=tip)
    check_typed_units(chain, tool=tool, region=region)
    if tool is not None:
        chain = chain.replace(tool=compose_pose(np.asarray(tool, dtype=float), np.zeros(3)))
    check_robot_in_mm(chain)
    rig = read_fixture(fixture)
    if placements is not None:
        poses, names = read_placements(placements)
        check_robot_lengths(chain, poses[:, :3, 3], f"the x, y, z of {placements}")
        source = f"{len(poses)} placements of {placements}"
    else:
        poses, names = region_placements(rig, region[0::2], region[1::2], seed=seed), None
        source = f"{len(poses)} level placements drawn in the region"
    try:
        candidates = socket_candidates(chain, rig, poses, names, seed=seed, margin_deg=margin,
                                       max_tilt_deg=MAX_TILT_DEG if max_tilt is None else max_tilt)
    except InputError:
        _refuse_below_mounting_plane(rig, poses, placements if placements is not None else "--region")
        raise
    sockets = len(rig.ids)
    places = len(candidates.poses)
    per_socket_given = per_socket
    if per_socket is None:
        per_socket = n // (sockets * places)
        if per_socket < 2:
            raise InputError(f"--n {n} configurations over {places} reachable placements x {sockets} sockets leave "
                             f"fewer than 2 per socket: ask for at least {2 * sockets * places}, or give --per-socket "
                             "to use fewer placements")
        count = places
    else:
        count = n // (sockets * per_socket)
    if count * sockets * per_socket != n and per_socket_given is None:
        # Every reachable placement is used: what --n leaves free is the number per socket.
        fewer, more = per_socket * sockets * places, (per_socket + 1) * sockets * places
        raise InputError(f"--n {n} over {places} reachable placements x {sockets} sockets is not a whole number per "
                         f"socket: ask for {fewer} or {more} ({per_socket} or {per_socket + 1} per socket), or give "
                         "--per-socket to use fewer placements")
    if count * sockets * per_socket != n:
        whole = max(count, 1) * sockets * per_socket
        raise InputError(f"--n {n} is not a whole number of placements x {sockets} sockets x {per_socket} per socket: "
                         f"ask for {whole}" + (f" or {whole + sockets * per_socket}" if count >= 1 else ""))
    design = design_sockets(chain, candidates, per_socket, count, criterion=criterion,
                            noise=0.02 if noise is None else noise, seed=seed)
    write_poses(out, chain, design.joints, {"fixture": list(design.placement), "socket": list(design.socket)})
    return SocketsDesigned(chain.name, str(out), rig.name, source, places,
                           {k: {"xyz_mm": [round(float(v), 3) for v in pose[:3, 3]]}
                            for k, pose in design.poses.items()},
                           "as stated (--noise)" if noise is not None else "the default 0.02 mm", design)
