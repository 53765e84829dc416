"""``robocal filter``: robot programs in, compensated robot programs out.

Each Cartesian target of a program is handed to the model's compensator exactly as
``robocal compensate`` hands a row of a targets file (``Compensator.commands``, with the
posture the program names as the hint), and the corrected target it returns — the nominal
controller's forward kinematics of the compensated joints — is written back into the program
in the program's own base and tool frames.  Everything else in the files stays byte for byte;
one comment line says that robocal wrote them.

Frames.  The controller's world is the frame of the nominal robot's forward kinematics (the
robot base).  A target P in the program's base B (world -> base) with the controller's tool
Tc (flange -> TCP) puts the controller's flange at B·P·Tc⁻¹; the target given to the
compensator is the robot-file tool's pose there, B·P·Tc⁻¹·T₀ (T₀ the robot file's tool),
and a corrected target C (robot-file tool, world) goes back as B⁻¹·C·T₀⁻¹·Tc.  Without
frames (no KRL --config, RAPID's tool0 and wobj0, URScript) B = I and Tc = T₀: the target is
the model's TCP, as in a targets file.  The world is the frame of the model's data, as for
``compensate``'s targets: the robot's base when the measurements were registered to it
(a calibration in a tracker's frame cannot tell the robot's base apart from its first link,
so robocal does not guess a transform between the two).

Postures.  Among the nominal robot's inverse kinematics branches of a target (and the 2 pi
turns of its joints), the one whose posture matches what the program names (KRL S and T for
PTP, RAPID confdata) is the hint; a target the robot arrives at with the posture it has (KRL
LIN/CIRC/SPL, URScript) takes the branch nearest the previous motion's joints.  A program
whose first motion names no posture (URScript's movel or movej to a pose, a KRL point
without S and T) is reached in the branch of wherever the robot stands when it starts, which
no file says: refused, naming the line and what to add.

Units.  The targets of a file in mm (KRL, RAPID) meet the length test of typed positions
(:func:`robocal.io.units.check_robot_lengths`: metres are a thousandth of a length about
the robot); unreachable targets that all lie beyond the robot's reach are named so, with the
unit that would bring them within it (URScript in mm).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FileFormatError, InputError
from ..io.csv_writing import csv_text
from ..io.atomic import check_outputs, write_text_atomic
from ..io.reading import check_regular_file
from ..io.units import LENGTH_UNITS, SMALLEST_REACH_SHARE, check_robot_lengths, reach_mm
from ..io.programs import LANGUAGES, krl, language_of, postures
from ..io.programs.core import (
    ENCODING,
    check_joint_targets,
    comment_text,
    is_filtered,
    model_digest,
    rewrite,
)
from ..kinematics.ik.solve import ik_all
from ..spatial.transforms import invert
from .jobs import NO_DOMAIN, load_fitted
from .results import Filtered

SUMMARY = "filter-summary.csv"
# RAPID's tool0: the flange itself.
FLANGE = np.eye(4)
FLANGE.flags.writeable = False
SUMMARY_COLUMNS = ("file", "line", "name", "status", "moved_mm", "turned_deg", "in_domain", "bound_mm")


@dataclass
class Prepared:
    """A program read and its targets made ready for the compensator: ``programs``
    ([ProgramFile]), ``targets`` ([Target]), ``poses`` (N, 4, 4) the compensator's targets
    (measurement frame), ``hints`` (N, n) rad, ``frames`` [(B, Tc)] per target; ``unknown``
    the indices of the targets whose arm branch nothing fixes (a program's first motion
    naming no posture)."""

    programs: list
    targets: list
    poses: np.ndarray
    hints: np.ndarray
    frames: list
    unknown: list = field(default_factory=list)


def read_programs(paths, language=None):
    """[ProgramFile] of the given program files (a KRL .src brings its .dat)."""
    if not paths:
        raise InputError("give at least one program file")
    by_language = {}
    for path in paths:
        check_regular_file(path, "program file")
        module = language_of(path, language)
        by_language.setdefault(module, []).append(path)
    programs, seen = [], set()
    for module, files in by_language.items():
        grouped = []
        for path in module.group(files):
            key = Path(path).resolve()
            if key not in seen:
                seen.add(key)
                grouped.append(path)
        try:
            parsed = module.parse(grouped)
        except (ValueError, IndexError, KeyError) as error:
            if isinstance(error, InputError):
                raise
            raise FileFormatError(f"cannot read {', '.join(map(str, grouped))} as {module.NAME}: {error}") from None
        for program in parsed:
            program.module = module
            programs.append(program)
    names = [Path(p.path).name for p in programs]
    twice = {n for n in names if names.count(n) > 1}
    if twice:
        raise InputError(f"two programs are named {min(twice)}: they would be written to the same file in --out")
    return programs


def _frames_of(target, program, config):
    """(B, Tc) of a target: the program's base and the controller's tool, or None for the
    defaults."""
    if program.module is krl:
        if config is None:
            return None, None
        base = np.eye(4) if not target.base else _config_frame(config, "BASE", target.base, target)
        tool = np.eye(4) if not target.tool else _config_frame(config, "TOOL", target.tool, target)
        return base, tool
    if program.module is LANGUAGES["rapid"]:
        tool = None if target.tool in (None, "TOOL0") else _module_frame(program, "tool", target.tool, target)
        base = None if target.base in (None, "WOBJ0") else _module_frame(program, "wobj", target.base, target)
        return base, (FLANGE if tool is None and target.tool == "TOOL0" else tool)
    return None, None


def _config_frame(config, kind, number, target):
    frame = config.get((kind, number))
    if frame is None:
        raise InputError(f"{target.file} line {target.line}: {kind}_DATA[{number}] is not in the --config file")
    return frame


def _module_frame(program, kind, name, target):
    frame = program.frames.get((kind, name))
    if frame is None:
        raise InputError(f"{target.file} line {target.line}: {'tooldata' if kind == 'tool' else 'wobjdata'} "
                         f"{name.lower()} is not declared in the module with a literal value; declare it there")
    return frame


def prepare(programs, model, *, config=None) -> Prepared:
    """The compensator's targets and posture hints for every Cartesian target of ``programs``
    (model: the :class:`~robocal.io.model_file.ModelFile`)."""
    nominal = model.nominal
    targets, frames = [], []
    identity = np.eye(4)
    for program in programs:
        for target in program.targets:
            base, tool = _frames_of(target, program, config)
            targets.append(target)
            frames.append((identity if base is None else base, nominal.tool if tool is None else tool))
    if not targets:
        return Prepared(programs, [], np.zeros((0, 4, 4)), np.zeros((0, nominal.n_joints)), [])
    bases, tools = (np.array(f) for f in zip(*frames))
    controller_poses = bases @ np.array([t.pose for t in targets]) @ np.linalg.inv(tools) @ nominal.tool
    hints, unknown = _hints(programs, targets, controller_poses, nominal)
    return Prepared(programs, targets, controller_poses, hints, frames, unknown)


def _turned(nominal, q, wanted):
    """Branches q (..., n) with each joint whose range exceeds a turn taken 2 pi further
    where ``wanted(joint, values, turned values)`` (bool arrays) prefers the turned value and
    the limits allow it."""
    q = q.copy()
    for j in np.flatnonzero(nominal.upper - nominal.lower > 2 * np.pi):
        values = q[..., j]
        other = values - 2 * np.pi * np.sign(values)
        allowed = (other >= nominal.lower[j] - 1e-9) & (other <= nominal.upper[j] + 1e-9)
        q[..., j] = np.where(allowed & wanted(j, values, other), other, values)
    return q


def _named_turns(language, nominal, q, targets):
    """Branches q (N, 8, n) turned to the turns each target names (KRL T: the sign of each
    axis; RAPID cf1, cf4, cf6: the quadrants of axes 1, 4 and 6)."""
    if language == krl.NAME:
        turn = np.array([t.posture[1] if t.posture and t.posture[1] is not None else -1 for t in targets])

        def wanted(j, values, other):
            negative = (turn[:, None] >> j) & 1
            return (turn[:, None] >= 0) & ((other < 0) == negative) & ((values < 0) != negative)
        return _turned(nominal, q, wanted)
    if language == LANGUAGES["rapid"].NAME and q.shape[2] == 6:
        conf = np.array([t.posture if t.posture else (-99,) * 4 for t in targets])
        column = {0: 0, 3: 1, 5: 2}

        def wanted(j, values, other):
            if j not in column:
                return np.zeros(values.shape, dtype=bool)
            named = conf[:, None, column[j]]
            return (np.floor(np.degrees(other) / 90) == named) & (np.floor(np.degrees(values) / 90) != named)
        return _turned(nominal, q, wanted)
    return q


def _branch_postures(language, nominal, q):
    """The part of the posture a branch fixes (KRL status, RAPID cfx) for q (M, 6): (M,)."""
    ok = np.isfinite(q).all(axis=1)
    out = np.full(len(q), -1)
    if ok.any() and q.shape[1] == 6:
        if language == krl.NAME:
            out[ok] = postures.kuka(nominal, q[ok])[0]
        elif language == LANGUAGES["rapid"].NAME:
            out[ok] = postures.abb(nominal, q[ok])[:, 3]
    return out


def _scores(targets, language, code, candidates):
    """(N, 8) how well each branch matches the posture its target names: 2 for the branch's
    part (status, cfx), 1 for each turn or quadrant that matches; 0 without one."""
    degrees = np.degrees(candidates)
    named = np.array([t.posture is not None for t in targets])
    scores = np.zeros(candidates.shape[:2])
    if language == krl.NAME:
        status = np.array([t.posture[0] if t.posture else -1 for t in targets])
        turn = np.array([t.posture[1] if t.posture and t.posture[1] is not None else -1 for t in targets])
        candidate_turn = ((degrees < 0) * (1 << np.arange(candidates.shape[2]))).sum(axis=2)
        scores = 2.0 * (code == status[:, None]) + ((candidate_turn == turn[:, None]) & (turn[:, None] >= 0))
    elif language == LANGUAGES["rapid"].NAME and candidates.shape[2] == 6:
        conf = np.array([t.posture if t.posture else (-99,) * 4 for t in targets])
        quadrants = np.floor(degrees[..., [0, 3, 5]] / 90.0)
        scores = 2.0 * (code == conf[:, None, 3]) + (quadrants == conf[:, None, :3]).sum(axis=2)
    return np.where(named[:, None], scores, 0.0)


def _hints(programs, targets, poses, nominal):
    """((N, n) rad, [index]): the nominal robot's joints for each target in the posture it is
    reached with, taken in program order so that a motion that keeps the posture follows the
    one before; and the targets whose posture nothing fixes: a motion that names none with no
    motion before it in its program (their hint is the branch nearest zero joints, a guess)."""
    q, valid = ik_all(nominal, poses)
    base = np.where(valid[..., None], q, np.nan)
    named = base.copy()
    scores = np.zeros(valid.shape)
    for language in {t.language for t in targets}:
        rows = np.array([i for i, t in enumerate(targets) if t.language == language])
        chosen = [targets[i] for i in rows]
        if any(t.posture is not None for t in chosen):
            named[rows] = _named_turns(language, nominal, base[rows], chosen)
            code = _branch_postures(language, nominal, base[rows].reshape(-1, nominal.n_joints)).reshape(len(rows), -1)
            scores[rows] = _scores(chosen, language, code, named[rows])
    scores = np.where(valid, scores, -1.0)
    # The branches a named posture allows (those that match it best).
    matching = valid & (scores == scores.max(axis=1, keepdims=True))
    named_posture = np.array([t.posture is not None for t in targets])
    unique, first = named_posture & (matching.sum(axis=1) == 1), np.argmax(matching, axis=1)
    base, named = np.nan_to_num(base, nan=1e3), np.nan_to_num(named, nan=1e3)
    periodic = np.flatnonzero(nominal.upper - nominal.lower > 2 * np.pi)
    hints = np.zeros((len(targets), nominal.n_joints))
    events = [(t.order, 1, i, t.file) for i, t in enumerate(targets)]
    for program in programs:
        events += [(j.order, 0, j, j.file) for j in program.joint_targets]
    previous, zero, started, unknown = {}, np.zeros(nominal.n_joints), set(), []
    for order, kind, item, file in sorted(events, key=lambda e: (_program_key(e[3]), e[0], e[1])):
        group = _program_key(file)
        if kind == 0:
            joints = np.asarray(item.joints, dtype=float)
            if joints.shape == (nominal.n_joints,) and np.isfinite(joints).all():
                previous[group] = nominal.joints_from_file(joints[None])[0]
                started.add(group)
            continue
        i, target = item, targets[item]
        opens = np.isfinite(order) and group not in started  # the program's first motion
        if np.isfinite(order):
            started.add(group)
        if not valid[i].any():
            hints[i] = np.nan  # refused as unreachable, whatever its posture
            continue
        if opens and target.posture is None:
            unknown.append(i)
        if unique[i] and not (target.follows and group in previous):
            hints[i] = named[i, first[i]]  # the one branch that matches the named posture
            if np.isfinite(order):
                previous[group] = hints[i]
            continue
        reference = previous.get(group, zero)
        if target.posture is not None and not (target.follows and group in previous):
            allowed, candidates = matching[i], named[i]
        else:  # the posture the robot has: the branch, and the turns, nearest the joints before
            allowed, candidates = valid[i], base[i].copy()
            if len(periodic):
                turned = candidates[:, periodic]
                turned += 2 * np.pi * np.round((reference[periodic] - turned) / (2 * np.pi))
                inside = (turned >= nominal.lower[periodic]) & (turned <= nominal.upper[periodic])
                candidates[:, periodic] = np.where(inside, turned, candidates[:, periodic])
        distance = ((candidates - reference) ** 2).sum(axis=1)
        hints[i] = candidates[int(np.argmin(np.where(allowed, distance, np.inf)))]
        if np.isfinite(order):
            previous[group] = hints[i]
    return hints, unknown


@functools.cache
def _program_key(path):
    """Files of one program share their motions' order (a KRL .src and its .dat)."""
    return str(Path(path).with_suffix("")).lower()


def _angles(a, b):
    """Angles (deg) between the rotations of (N, 4, 4) poses a and b."""
    cosine = (np.einsum("nij,nij->n", a[:, :3, :3], b[:, :3, :3]) - 1) / 2
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def filter_job(model_path, paths, out_dir, *, language=None, config=None, allow_unfiltered=False,
               accept_extrapolation=False, iterate=False):
    """Write the filtered programs and filter-summary.csv into ``out_dir``.

    Refuses (InputError, nothing written) a program robocal filtered already, run-time
    motions without ``allow_unfiltered``, positions in another unit than the language's, a
    first motion whose posture nothing fixes, targets the model cannot reach, and targets
    outside its domain of validity without ``accept_extrapolation`` (and, as it reads them,
    a KRL .src without its .dat and a RAPID quaternion that is not unit).  Returns a
    :class:`.results.Filtered`.
    """
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise InputError(f"--out {out_dir} is not a directory: create it first")
    programs = read_programs(paths, language)
    if not any(p.targets or p.joint_targets or p.run_time for p in programs):
        # Nothing to filter: an empty file, or not a program of this language at all.
        raise InputError(f"no motion found in {', '.join(str(p.path) for p in programs)}: is it a "
                         f"{programs[0].language if programs else 'robot'} program? (robocal filter reads KRL .src/"
                         ".dat, RAPID .mod/.prg and URScript .script)")
    for program in programs:
        if is_filtered(program.text, program.module.COMMENT):
            raise InputError(f"{program.path} was written by robocal filter already (it carries robocal's comment "
                             "line): filter the original program instead")
    outputs = [out_dir / Path(p.path).name for p in programs] + [out_dir / SUMMARY]
    check_outputs(outputs, [model_path, config, *[p.path for p in programs]])
    run_time = [r for p in programs for r in p.run_time]
    if run_time and not allow_unfiltered:
        lines = "; ".join(f"{r.file} line {r.line}: {r.what}" for r in run_time)
        raise InputError(f"{len(run_time)} motion(s) are computed at run time and cannot be filtered ({lines}); "
                         "nothing was written; give --allow-unfiltered to write the program with them as they are")
    model, fitted = load_fitted(model_path)
    check_joint_targets(programs, model.nominal)
    frames = None if config is None else krl.read_config(config)
    prepared = prepare(programs, model, config=frames)
    targets = prepared.targets
    # Each target in the robot's base, B·P, in one batched product (as prepare's poses).
    bases = np.array([base for base, _ in prepared.frames]).reshape(-1, 4, 4)
    placed = (bases @ np.array([t.pose for t in targets]).reshape(-1, 4, 4))[:, :3, 3]
    _check_lengths(prepared, placed, model.nominal)
    if prepared.unknown:
        target = targets[prepared.unknown[0]]
        raise InputError(f"{target.file} line {target.line} ({target.name}): no joint position comes before this "
                         "motion, so the controller reaches it in the arm branch of wherever the robot stands when "
                         f"the program starts, which robocal cannot know; {_module_of(prepared, target).POSTURE_ADVICE}"
                         "; nothing was written")
    corrected, inside = np.zeros((0, 4, 4)), np.zeros(0, dtype=bool)
    domain_summary = NO_DOMAIN if fitted.domain_ is None else "no targets"
    if targets:
        reachable = np.isfinite(prepared.hints).all(axis=1)
        result = fitted.compensator_.commands(prepared.poses, hint=np.nan_to_num(prepared.hints), iterate=iterate)
        reached = result.success & reachable
        if not reached.all():
            bad = [f"{t.file} line {t.line} ({t.name})" for t, ok in zip(targets, reached) if not ok]
            why = _beyond_reach(prepared, placed, reached, model.nominal)
            raise InputError(f"{len(bad)} target(s) cannot be reached by the calibrated robot: {', '.join(bad[:10])}"
                             f"{' ...' if len(bad) > 10 else ''}{why}; nothing was written")
        inside = np.ones(len(targets), dtype=bool)
        if fitted.domain_ is not None:
            check = fitted.domain_.check(result.q, prepared.poses[:, :3, 3])
            inside = np.asarray(check.inside, dtype=bool)
            domain_summary = check.summary
            if not inside.all() and not accept_extrapolation:
                bad = [f"{t.file} line {t.line} ({t.name}): {why}"
                       for t, ok, why in zip(targets, inside, check.reasons) if not ok]
                raise InputError(f"{len(bad)} target(s) lie outside the model's domain of validity: "
                                 f"{'; '.join(bad[:5])}{' ...' if len(bad) > 5 else ''}; nothing was written; "
                                 "give --accept-extrapolation to filter them anyway")
        bases, tools = (np.array(f) for f in zip(*prepared.frames))
        corrected = np.linalg.inv(bases) @ result.corrected @ invert(model.nominal.tool) @ tools
    comment_words = comment_text(Path(model_path).name, model_digest(model_path))
    edits = {p.path: [] for p in programs}
    rows = []
    for name in {t.language for t in targets}:
        chosen = [k for k, t in enumerate(targets) if t.language == name]
        module = LANGUAGES[_key_of(name)]
        chosen_targets = [targets[k] for k in chosen]
        files = [t.file for t in chosen_targets for _ in t.numbers]
        for file, pair in zip(files, module.new_numbers(chosen_targets, corrected[chosen])):
            edits[file].append(pair)
    originals = np.array([t.pose for t in targets]) if targets else np.zeros((0, 4, 4))
    moved = np.linalg.norm(corrected[:, :3, 3] - originals[:, :3, 3], axis=1)
    turned = _angles(corrected, originals)
    names = {p.path: Path(p.path).name for p in programs}
    for target, distance, angle, ok in zip(targets, moved.tolist(), turned.tolist(), inside):
        rows.append([names[target.file], target.line, target.name, "filtered", f"{distance:.4f}",
                     f"{angle:.4f}", "" if fitted.domain_ is None else ("1" if ok else "0"), ""])
    for r in run_time:
        rows.append([Path(r.file).name, r.line, r.what, "unfiltered (run time)", "", "", "", ""])
    texts = []
    for program, target_path in zip(programs, outputs):
        comment = f"{program.module.COMMENT} {comment_words}"
        text = rewrite(program, edits[program.path], program.module.comment_offset(program.text), comment)
        texts.append((target_path, text))
    _write_all(texts + [(outputs[-1], _summary(rows))])
    return Filtered(files=[str(p) for p, _ in texts], summary=str(outputs[-1]), targets=len(targets),
                    unfiltered=[f"{r.file} line {r.line}: {r.what}" for r in run_time],
                    outside_domain=int((~inside).sum()), domain_summary=domain_summary,
                    max_moved_mm=float(moved.max()) if len(moved) else 0.0)


def _module_of(prepared, target):
    return next(p.module for p in prepared.programs if p.path == target.file)


def _by_file(prepared):
    """{file: (its language module, indices of its targets)}, in the order the targets come."""
    files = {}
    for k, target in enumerate(prepared.targets):
        files.setdefault(target.file, (_module_of(prepared, target), []))[1].append(k)
    return files


def _check_lengths(prepared, positions, nominal):
    """InputError when the targets of a file in mm (KRL, RAPID) are no lengths about the robot
    in mm: ``positions`` (N, 3) where each target's frame is in the robot's base (B·P), its
    largest coordinate a thousandth of what it should be (metres), by robocal.io.units, as the
    positions of a targets file."""
    for file, (module, rows) in _by_file(prepared).items():
        if module.LENGTH_UNIT == "mm":
            check_robot_lengths(nominal, positions[rows], f"the target positions of {file} (in the robot's base)")


def _beyond_reach(prepared, positions, reached, nominal):
    """What to add to the refusal of unreachable targets for each file whose every target
    lies beyond the robot's reach (''): how far, and the length unit that would bring them
    all within it (robocal.io.units.LENGTH_UNITS), or the file's units as a question."""
    reach, origin = reach_mm(nominal), np.asarray(nominal.base, dtype=float)[:3, 3]
    notes = []
    for file, (module, rows) in _by_file(prepared).items():
        if reached[rows].any():
            continue
        # The TCP reaches as far as the flange plus the tool.
        limit = reach + np.array([np.linalg.norm(prepared.frames[k][1][:3, 3]) for k in rows])
        distance = np.linalg.norm(positions[rows] - origin, axis=1)
        if not (distance > limit).all():
            notes.append(f"none of the targets of {file} can be reached: are they in {module.UNITS}, in the "
                         "robot's base?")
            continue
        stated = LENGTH_UNITS[module.LENGTH_UNIT]
        fits = [unit for unit, factor in LENGTH_UNITS.items()
                if unit != module.LENGTH_UNIT and (distance * factor / stated <= limit).all()
                and (distance * factor / stated).max() >= reach * SMALLEST_REACH_SHARE]
        where = (f"every target of {file} lies beyond the robot's reach ({reach:.0f} mm), {distance.min():.0f} to "
                 f"{distance.max():.0f} mm from its base")
        if fits:
            unit = max(fits, key=LENGTH_UNITS.get)  # the nearest to the stated unit that brings them within
            ratio = LENGTH_UNITS[unit] / stated
            fix = f"divide them by {1 / ratio:.4g}" if ratio < 1 else f"multiply them by {ratio:.4g}"
            notes.append(f"{where}: {module.NAME} positions are in {module.LENGTH_UNIT}, these look like {unit} "
                         f"({fix})")
        else:
            notes.append(f"{where}: are they in {module.UNITS}?")
    return "".join(f"; {note}" for note in notes)


def _write_all(files):
    """Write [(path, text)] each atomically; if one fails, the ones this call created are
    removed again, so that a failure leaves no new file behind."""
    created = []
    try:
        for path, text in files:
            existed = Path(path).exists()
            write_text_atomic(path, text, encoding=ENCODING)
            if not existed:
                created.append(Path(path))
    except BaseException:
        for path in created:
            path.unlink(missing_ok=True)
        raise


def _key_of(language_name):
    return next(k for k, m in LANGUAGES.items() if m.NAME == language_name)


def _summary(rows):
    return csv_text(SUMMARY_COLUMNS, rows, "filter-summary")
