"""What the ``robocal filter`` tests of every language share: simulated robots and their
models, the comparison with ``robocal compensate`` and the byte-for-byte checks."""
import csv
from pathlib import Path
from unittest import mock

import numpy as np

from robocal.interfaces.filter import read_programs
from robocal.interfaces.jobs import calibrate_job, compensate_job
from robocal.io.library import load_robot
from robocal.io.programs.core import ENCODING, MARK
from robocal.io.tables import write_measurements
from robocal.simulation import TrueRobot, uniform_joints
from robocal.simulation.presets import _typical_deviations
from robocal.spatial.rotations import matrix_to_rpy

PROGRAMS = Path(__file__).parent / "data" / "programs"
# Each link parameter of the simulated robots is off by this many times robocal's "typical"
# spread: about 1 mm at the TCP.
LINK_SCALE = 0.6


def true_robot(name, *, errors=True, seed=3):
    """A simulated robot with geometric errors of its links (base and tool exact, so that the
    measurement frame is the robot's base), or the nominal robot itself."""
    chain = load_robot(name)
    if not errors:
        return TrueRobot(nominal=chain, preset="none")
    deviations = {k: LINK_SCALE * v for k, v in _typical_deviations(chain, np.random.default_rng(seed)).items()
                  if not k.startswith(("base_", "tool_"))}
    return TrueRobot(nominal=chain, deviations=deviations)


def true_and_nominal_models(name, tmp_path_factory):
    """{"true": the model of ``name`` with geometric errors, "nominal": of the nominal robot},
    each calibrated by :func:`model_of` in a folder of its own."""
    return {kind: model_of(true_robot(name, errors=errors), tmp_path_factory.mktemp(f"{name}-{kind}"))
            for kind, errors in (("true", True), ("nominal", False))}


def model_of(robot, folder, *, n=300, seed=0, first_joint=None):
    """Calibrate (kinematic, full) on ``n`` exact full-pose measurements of ``robot`` spread
    over the joint ranges (joint 1 within ``first_joint`` (low, high) deg when given); the
    model file's path."""
    folder = Path(folder)
    q = uniform_joints(robot.nominal, n, np.random.default_rng(seed))
    if first_joint is not None:
        q[:, 0] = np.radians(np.random.default_rng(seed + 1).uniform(*first_joint, n))
    measurements = folder / "measurements.csv"
    write_measurements(measurements, robot.measurements(q, np.random.default_rng(seed), orientation=True))
    model = folder / "model.json"
    # The nominal robot measured exactly is the one reference a filter must reproduce byte for
    # byte; the data check refuses such positions from a user (computed, not measured), so
    # this reference model is made past it.
    with mock.patch("robocal.estimation.plausibility.check_measured", lambda chain, observations: None):
        calibrate_job(_robot_key(robot), measurements, model, method="kinematic")
    return model


def _robot_key(robot):
    return {"KUKA KR 150-2": "kr150-2", "ABB IRB 120": "irb120"}.get(robot.nominal.name, "ur5")


def targets_of(paths):
    """[Target] of program files, in the filter's order."""
    return [t for p in read_programs(paths) for t in p.targets]


def compensate_targets(model, poses, hints, folder):
    """What ``robocal compensate`` writes for (N, 4, 4) target poses (measurement frame) with
    posture hints (N, n) controller rad: (corrected (N, 4, 4), q (N, n) controller deg)."""
    from robocal.spatial.rotations import rpy_to_matrix

    folder = Path(folder)
    targets, commands = folder / "targets.csv", folder / "commands.csv"
    xyz, rpy = poses[:, :3, 3], np.degrees(matrix_to_rpy(poses[:, :3, :3]))
    n = hints.shape[1]
    with open(targets, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["x", "y", "z", "rx", "ry", "rz", *[f"q{k}" for k in range(1, n + 1)]])
        for row in np.column_stack([xyz, rpy, np.degrees(hints)]):
            writer.writerow([repr(float(v)) for v in row])
    compensate_job(model, targets, commands)
    with open(commands, newline="") as stream:
        rows = list(csv.DictReader(stream))
    corrected = np.tile(np.eye(4), (len(rows), 1, 1))
    for pose, row in zip(corrected, rows):
        pose[:3, 3] = [float(row[k]) for k in ("x", "y", "z")]
        pose[:3, :3] = rpy_to_matrix(np.radians([float(row[k]) for k in ("rx", "ry", "rz")]))
    q = np.array([[float(row[f"q{k}"]) for k in range(1, n + 1)] for row in rows])
    return corrected, q


def angle_deg(a, b):
    """Angle (deg) between the rotations of poses a and b (..., 4, 4)."""
    cosine = (np.einsum("...ij,...ij->...", a[..., :3, :3], b[..., :3, :3]) - 1) / 2
    return np.degrees(np.arccos(np.clip(cosine, -1, 1)))


def without_comment(data: bytes, sign: str):
    """(bytes without robocal's one line, how many such lines there were)."""
    lines = data.decode(ENCODING).splitlines(keepends=True)
    mine = [k for k, line in enumerate(lines) if line.lstrip().startswith(f"{sign} {MARK}")]
    kept = [line for k, line in enumerate(lines) if k not in mine]
    return "".join(kept).encode(ENCODING), len(mine)


def masked(path):
    """The file's bytes with every number of every Cartesian target replaced by '#' (a KRL
    .src is read with the .dat beside it, whose targets it uses)."""
    text = Path(path).read_bytes().decode(ENCODING)
    spans = sorted((n.start, n.end) for t in targets_of([path]) if Path(t.file) == Path(path) for n in t.numbers)
    out, position = [], 0
    for start, end in spans:
        out += [text[position:start], "#"]
        position = end
    return "".join(out + [text[position:]]).encode(ENCODING)


def filter_and_compensate(model, program, out_dir, folder, *, frames=None, config=None, **options):
    """Filter ``program`` with ``model`` into ``out_dir``, and give every one of its targets to
    ``robocal compensate`` as a targets file would: ``frames(target)`` is the (B, Tc) the
    test expects the program to use (None: the robot's base and the model's tool).

    Returns (targets before, targets after, their poses as compensate makes them, the
    compensated joints (N, n) deg, the filter's result)."""
    from robocal.interfaces.filter import filter_job, prepare
    from robocal.io.model_file import load_model
    from robocal.io.programs.krl import read_config

    result = filter_job(model, [program], out_dir, config=config, allow_unfiltered=True, **options)
    loaded = load_model(model)
    t0 = loaded.nominal.tool
    before = targets_of([program])
    after = targets_of([Path(out_dir) / Path(program).name])
    assert [(Path(t.file).name, t.name) for t in after] == [(Path(t.file).name, t.name) for t in before]
    pairs = [frames(t) if frames else (np.eye(4), t0) for t in before]
    goal = np.array([b @ t.pose @ np.linalg.inv(tc) @ t0 for t, (b, tc) in zip(before, pairs)])
    hints = prepare(read_programs([program]), loaded, config=None if config is None else read_config(config)).hints
    corrected, q = compensate_targets(model, goal, hints, folder)
    expected = np.array([np.linalg.inv(b) @ c @ np.linalg.inv(t0) @ tc for c, (b, tc) in zip(corrected, pairs)])
    return before, after, expected, q, result


def assert_same_poses(after, expected, mm=1e-3, deg=1e-3):
    poses = np.array([t.pose for t in after])
    assert np.abs(poses[:, :3, 3] - expected[:, :3, 3]).max() <= mm
    assert angle_deg(poses, expected).max() <= deg


def assert_only_targets_changed(original, written, sign):
    """The written file is the original but for its targets' numbers and robocal's one line
    (line endings included)."""
    data, count = without_comment(Path(written).read_bytes(), sign)
    assert count == 1
    assert without_comment(masked(written), sign)[0] == masked(original)
    assert data.count(b"\r\n") == Path(original).read_bytes().count(b"\r\n")


def assert_filter_refused(model, files, programs, says, folder, monkeypatch):
    """Write ``files`` ({name: text}, Latin-1) into ``folder`` and run ``robocal filter MODEL
    PROGRAMS --out fo`` there: refused with a non-zero exit in one error line holding ``says``,
    no traceback, nothing written into fo and no input rewritten."""
    from refusals import assert_refused

    for name, text in files.items():
        (folder / name).write_bytes(text.encode(ENCODING))
    (folder / "fo").mkdir()
    monkeypatch.chdir(folder)
    before = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    assert_refused(["filter", str(model), *programs, "--out", "fo"], says, folder, before)
    assert not list((folder / "fo").iterdir())
