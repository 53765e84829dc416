"""robocal filter on large programs (issue 27): a 10,000-point program in each language,
timed beside robocal compensate on the same points.

    python bench/filter.py             # KRL, RAPID and URScript, 10,000 points each
    python bench/filter.py krl 20000   # one language, another size

The robots are simulated with geometric errors of their links (about 1 mm at the TCP) and
calibrated (kinematic, full) on 300 exact full-pose measurements; the program's points are
the nominal forward kinematics of random configurations inside the training range, each with
the posture its configuration has (KRL S and T on PTP motions; RAPID confdata), so the
filter chooses branches as it would on a taught program.  (URScript's movel keeps the
posture it has: from one random point to the next, the nearest branch.)  Times are of the whole job (reading,
posture search, compensation, writing), wall-clock and the process's CPU time (which a loaded
machine inflates less), one BLAS thread as the command line runs it.
"""
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from filter_support import compensate_targets, model_of, true_robot

from robocal.interfaces.filter import filter_job, prepare, read_programs
from robocal.io.model_file import load_model
from robocal.io.programs import postures
from robocal.kinematics.ik import solve_ik
from robocal.methods.domain import arm_branches
from robocal.spatial.rotations import matrix_to_rpy

ROBOTS = {"krl": "kr150-2", "rapid": "irb120", "urscript": "ur5"}


def configurations(chain, calibrated, n, rng):
    """n random configurations away from the joint limits and from the singularities between
    arm branches, whose poses the calibrated robot reaches (a point taught with a stretched
    elbow may lie beyond the true robot's reach: the filter refuses it, rightly)."""
    low, high = np.maximum(chain.lower, -np.pi), np.minimum(chain.upper, np.pi)
    kept = np.zeros((0, chain.n_joints))
    while len(kept) < n:
        q = rng.uniform(low + 0.15 * (high - low), high - 0.15 * (high - low), (2 * n, chain.n_joints))
        _, sides = arm_branches(chain, q)
        q = q[np.all([side >= 0 for side in sides.values()], axis=0)]
        reached = solve_ik(calibrated, chain.fk(q), hint=q, nominal=chain).success
        kept = np.concatenate([kept, q[reached]])
    return kept[:n]


def krl_program(chain, q, folder):
    poses = chain.fk(q)
    status, turn = postures.kuka(chain, q)
    a = np.degrees(matrix_to_rpy(poses[:, :3, :3]))
    src = ["&ACCESS RVP", "DEF bench( )", "PTP {A1 0,A2 -90,A3 90,A4 0,A5 45,A6 0}"]
    dat = ["&ACCESS RVP", "DEFDAT bench"]
    for k, (pose, s, t, rpy) in enumerate(zip(poses, status, turn, a)):
        src.append(f"PTP XP{k} C_PTP")
        x, y, z = pose[:3, 3]
        dat.append(f"DECL E6POS XP{k}={{X {x:.3f},Y {y:.3f},Z {z:.3f},A {rpy[2]:.3f},B {rpy[1]:.3f},"
                   f"C {rpy[0]:.3f},S {s},T {t},E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}")
    (folder / "bench.src").write_bytes(("\r\n".join(src + ["END", ""])).encode("latin-1"))
    (folder / "bench.dat").write_bytes(("\r\n".join(dat + ["ENDDAT", ""])).encode("latin-1"))
    return folder / "bench.src"


def rapid_program(chain, q, folder):
    poses = chain.fk(q)
    conf = postures.abb(chain, q)
    lines = ["MODULE Bench"]
    moves = []
    for k, (pose, c) in enumerate(zip(poses, conf)):
        x, y, z, w = Rotation.from_matrix(pose[:3, :3]).as_quat()
        lines.append(f"    CONST robtarget p{k}:=[[{pose[0, 3]:.2f},{pose[1, 3]:.2f},{pose[2, 3]:.2f}],"
                     f"[{w:.6f},{x:.6f},{y:.6f},{z:.6f}],[{c[0]},{c[1]},{c[2]},{c[3]}],"
                     "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];")
        moves.append(f"        MoveL p{k}, v500, z10, tool0;")
    lines += ["    PROC main()", *moves, "    ENDPROC", "ENDMODULE", ""]
    (folder / "Bench.mod").write_bytes("\r\n".join(lines).encode("latin-1"))
    return folder / "Bench.mod"


def urscript_program(chain, q, folder):
    poses = chain.fk(q)
    lines = ["def bench():", f"  movej([{', '.join(f'{v:.4f}' for v in q[0])}], a=1.4, v=1.05)"]
    for pose in poses:
        r = Rotation.from_matrix(pose[:3, :3]).as_rotvec()
        x, y, z = pose[:3, 3] / 1000
        lines.append(f"  movel(p[{x:.5f}, {y:.5f}, {z:.5f}, {r[0]:.4f}, {r[1]:.4f}, {r[2]:.4f}], a=1.2, v=0.25)")
    lines += ["end", ""]
    (folder / "bench.script").write_text("\n".join(lines))
    return folder / "bench.script"


WRITERS = {"krl": krl_program, "rapid": rapid_program, "urscript": urscript_program}


def run(language, n):
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        robot = true_robot(ROBOTS[language])
        model = model_of(robot, folder)
        loaded = load_model(model)
        rng = np.random.default_rng(1)
        program = WRITERS[language](robot.nominal, configurations(robot.nominal, loaded.kinematics, n, rng), folder)
        out = folder / "out"
        out.mkdir()
        wall, cpu = time.perf_counter(), time.process_time()
        result = filter_job(model, [program], out, accept_extrapolation=True)
        filter_wall, filter_cpu = time.perf_counter() - wall, time.process_time() - cpu
        prepared = prepare(read_programs([program]), loaded)
        wall, cpu = time.perf_counter(), time.process_time()
        compensate_targets(model, prepared.poses, prepared.hints, folder)
        compensate_wall, compensate_cpu = time.perf_counter() - wall, time.process_time() - cpu
        print(f"{language:9s} {result.targets:6d} points: filter {filter_wall:.2f} s ({filter_cpu:.2f} s CPU), "
              f"compensate on the same points {compensate_wall:.2f} s ({compensate_cpu:.2f} s CPU); "
              f"{result.outside_domain} outside the domain; largest move {result.max_moved_mm:.3f} mm")


def main(argv):
    languages = [a for a in argv if a in WRITERS] or list(WRITERS)
    sizes = [int(a) for a in argv if a.isdigit()] or [10_000]
    with threadpool_limits(limits=1, user_api="blas"):
        for language in languages:
            for n in sizes:
                run(language, n)


if __name__ == "__main__":
    main(sys.argv[1:])
