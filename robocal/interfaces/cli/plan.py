"""Commands that plan and simulate measurements: simulate, design.

Their many options are declared as :class:`~robocal.settings.Setting` tables below (option,
default, help, constraint), and each keyword-only parameter of the command takes its
option from the setting of its name (:func:`.options.declared`).
"""
from ...errors import InputError
from ...methods.base import PARAMETERS, PAYLOAD
from ...settings import ANGLE_SIGMA, LENGTH_SIGMA, Choice, Either, Flag, Number, Numbers, Plausible, Setting
from ..jobs import SAMPLINGS, simulate_job
from .app import verb
from .options import FIXTURE, JSON, ROBOT, ROOT, SEED, TIP, Output, declared, out_option
from .rendering import print_design, print_json, print_result, print_socket_design, progress

# simulate --n: beyond this a file is no measurement series anyone makes, and the run would
# take minutes and gigabytes.
MOST_SIMULATED_POSES = 1_000_000
# Fixture placements and configurations per socket: a real ball-in-socket campaign has a few
# dozen placements (MUKCa: 3 to 9) and tens of configurations per socket, each seated by hand.
MOST_PLACEMENTS = 1000
MOST_PER_SOCKET = 10_000
# design --pool: memory grows by some 7 kB a candidate (UR5: 200 MB for 10,000, 410 MB for
# 40,000), so a million would need 7 GB; 200,000 (1.4 GB) is twenty times the default.
MOST_POOL = 200_000
# --noise: an instrument this noisy (a metre) measures nothing about a robot.
LARGEST_NOISE_MM = 1000
# design --max-tilt: 0 (the tool axis on the fixture normal) or at least this; the whole range of
# tilts typed in radians (30 deg as 0.5236) lies between.
TILT = Plausible(2.0, "deg")
# design's choices, as robocal.planning names them (CRITERIA, SOCKET_CRITERIA, ORDERS and the
# candidates' SAMPLINGS), spelled here because importing robocal.planning loads scipy.stats:
# seconds at the start of every command on a busy machine.  design_job refuses any other.
CRITERIA = ("prediction", "d-optimal", "space-filling", "variance")
SOCKET_CRITERIA = ("prediction", "d-optimal")
ORDERS = ("tour", "random")
CANDIDATE_SAMPLINGS = ("uniform", "lhs")
# simulate --errors: robocal.simulation.presets.PRESETS (that package loads scipy.stats too).
PRESETS = ("none", "typical", "liu2022")

# Where the poses are drawn (simulate --sampling lhs) or the candidates lie (design --box).
BOX = Setting("box", None, "--box", "A Cartesian box of the robot base frame, xmin, xmax, ymin, ymax, zmin, zmax in "
              "mm: where simulate --sampling lhs draws the poses, where design's candidates lie.", Numbers(count=6))
RPY = Setting("rpy", None, "--rpy", "With --box: the TCP orientation rx,ry,rz in deg (default 180,0,0).",
              Numbers(count=3))
HINT = Setting("hint", None, "--hint", "With --box: a posture q1,...,qn in deg whose IK branch every pose takes.",
               Numbers())

SIMULATE = (
    BOX, RPY, HINT,
    Setting("n", None, "--n", "Number of poses (default 200; liu2022: 150).",
            Number(whole=True, at_least=1, at_most=MOST_SIMULATED_POSES,
                   advice="a million take minutes and gigabytes; simulate several files for more")),
    Setting("sampling", "joint", "--sampling", "joint (uniform in the limits), lhs (Latin hypercube in --box), grid "
            "(n^(1/3) per axis in --box) or sockets (ball in the sockets of --fixture, joint angles only).",
            Choice(SAMPLINGS)),
    Setting("errors", "typical", "--errors", "none, typical, liu2022 (KR150-2 only), or a truth file (JSON, as --truth "
            "writes it) whose deviations you edit, e.g. joint gains in ppm.", Choice(PRESETS, or_file=".json")),
    Setting("noise", None, "--noise", "Measurement noise sigma in mm (overrides the preset); sockets: the ball's "
            "seating error.", Number(at_least=0, at_most=LARGEST_NOISE_MM, plausible=LENGTH_SIGMA)),
    Setting("truth", None, "--truth", "Also write the hidden truth (JSON) here.", Output(".json")),
    Setting("orientation", False, "--orientation", "Also write measured rx, ry, rz.", Flag()),
    Setting("placements", None, "--placements", "sockets: number of fixture placements (default 4).",
            Number(whole=True, at_least=1, at_most=MOST_PLACEMENTS,
                   advice="a real campaign places a fixture a few dozen times")),
    Setting("per_socket", None, "--per-socket", "sockets: configurations per socket and placement (default 10).",
            Number(whole=True, at_least=2, at_most=MOST_PER_SOCKET,
                   advice="a real campaign seats the ball tens of times per socket")),
    Setting("joint_noise", None, "--joint-noise", "sockets: noise of the joint readings (deg, default 0).",
            Number(at_least=0, plausible=ANGLE_SIGMA)),
)

DESIGN = (
    BOX, RPY, HINT,
    Setting("n", ..., "--n", "Number of poses to measure.",
            Number(whole=True, at_least=1, at_most=100_000,
                   advice="real campaigns measure tens to a few thousand poses")),
    Setting("criterion", "prediction", "--criterion", "prediction (default: the mean squared error of the calibrated "
            "TCP over the targets; what a calibration is for), d-optimal (log det of the parameters' information), "
            "space-filling (spread over configuration space) or variance (one pose at a time where a "
            "Gaussian-process prior over the joints' sines and cosines is least certain; hyperparameters from "
            "--existing measurements when given); the last two for the kriging, hybrid and ann residual models. "
            "With --fixture: prediction or d-optimal.", Choice(CRITERIA)),
    Setting("parameters", PARAMETERS.default, "--parameters", "The parameter set the calibration will identify (as "
            "calibrate --parameters).", PARAMETERS.constraint),
    Setting("candidates", None, "--candidates", "CSV of your own candidate configurations (q1..qN, deg): reachable "
            "poses of an offline program, or an earlier campaign's."),
    Setting("pool", 10_000, "--pool", "Candidate configurations to draw (without --candidates).",
            Number(whole=True, at_least=10, at_most=MOST_POOL,
                   advice="10,000, the default, take about 4 s and 200 MB for a UR5; memory grows with the pool")),
    Setting("sampling", "uniform", "--sampling", "How candidates are drawn in joint space: uniform or lhs (Latin "
            "hypercube).", Choice(CANDIDATE_SAMPLINGS)),
    Setting("tool", None, "--tool", "The TCP x,y,z in mm in the flange frame, in place of the robot file's tool.",
            Numbers(count=3)),
    Setting("margin", 5.0, "--margin", "Degrees the candidates keep from joint limits and singularities.",
            Number(at_least=0, at_most=45)),
    Setting("floor", None, "--floor", "The lowest z (mm, robot base frame) the arm's joints and TCP may take in a "
            "drawn candidate. Default 0: above the mounting plane (a table- or floor-mounted robot); none for a wall "
            "or ceiling mount.", Either(Choice(("none",)), Number(at_least=-1e6, at_most=1e6))),
    Setting("walls", None, "--walls", "Keep the arm's joints and TCP within xmin, xmax, ymin, ymax (mm, robot base "
            "frame).", Numbers(count=4)),
    Setting("existing", None, "--existing", "Measurement (or poses) CSV of poses measured before: design the --n "
            "poses that best complement them; with x, y, z their calibration's residual sets the noise unless --noise "
            "is given."),
    Setting("targets", None, "--targets", "Where the robot will work: a CSV of configurations (q1..qN, deg) or of "
            "targets (x, y, z, rx, ry, rz; mm, deg, robot base frame). Default: the candidates."),
    Setting("noise", None, "--noise", "Standard deviation of a reading per coordinate in mm (default 0.02): the "
            "tracker's noise, plus what the calibration will not explain if you know it (an earlier calibration's "
            "residual RMS / 1.73).", Number(between=(0, LARGEST_NOISE_MM), plausible=LENGTH_SIGMA)),
    Setting("tracker", None, "--tracker", "The laser tracker's position x,y,z in mm (robot base frame): its noise then "
            "grows with distance.", Numbers(count=3)),
    Setting("joint_noise", 0.0, "--joint-noise", "Standard deviation in deg of an error at every joint that the "
            "calibration does not model (gear backlash or play, e.g. the half-width of the gears' backlash): a pose "
            "then reads noisier the further the arm reaches, and the design and its predicted held-out error count "
            "it. Default 0: none.", Number(at_least=0, at_most=1, plausible=ANGLE_SIGMA)),
    Setting("sag", 0.0, "--sag", "How far gravity bends the most loaded joint, in deg, when --parameters has no "
            "compliance (e.g. 0.01 for a counterbalanced 150 kg arm, 0.08 for a UR5): the design then also chooses "
            "poses whose sag the geometry absorbs as the targets' would be, and the predicted error counts what it "
            "leaves. Default 0: none.", Number(at_least=0, at_most=1)),
    Setting("order", "tour", "--order", "The order to measure in: tour (short motions) or random (averages out gear "
            "backlash, which a tour approaches from one side).", Choice(ORDERS)),
    Setting("payload", None, "--payload", "With a compliance parameter set: the mass at the TCP in kg (as calibrate "
            "--payload).", PAYLOAD.constraint),
    Setting("fixture", None, "--fixture", "Ball in sockets: the fixture TOML file; the design then chooses placements "
            "and, per socket, configurations for the constraint calibration (the robot's tool is the ball centre), and "
            "--n counts configurations in all."),
    Setting("placements", None, "--placements", "With --fixture: CSV of candidate fixture placements, x,y,z (mm), "
            "rx,ry,rz (deg) of the fixture frame in the robot base frame, and optionally a fixture column naming "
            "them."),
    Setting("region", None, "--region", "With --fixture, instead of --placements: where the fixture may stand level, "
            "xmin, xmax, ymin, ymax, zmin, zmax in mm (robot base frame).", Numbers(count=6)),
    Setting("per_socket", None, "--per-socket", "With --fixture: configurations per socket (default: --n spread over "
            "every reachable placement); fewer placements are then chosen.",
            Number(whole=True, at_least=2, at_most=MOST_PER_SOCKET,
                   advice="a real campaign seats the ball tens of times per socket")),
    Setting("max_tilt", None, "--max-tilt", "With --fixture: the largest angle between the tool axis and the fixture "
            "normal, deg (default 30).", Number(at_least=0, at_most=89, plausible=TILT)),
)


@verb()
@declared(SIMULATE)
def simulate(robot: str = ROBOT, out_file: str = out_option("Measurement CSV to write.", ".csv"), *,
             n: int, sampling: str, errors: str, noise: float, seed: int = SEED, truth: str, orientation: bool,
             box: str, rpy: str, hint: str, fixture: str = FIXTURE, placements: int, per_socket: int,
             joint_noise: float, tip: str = TIP, root: str = ROOT, as_json: bool = JSON):
    """Measure a simulated robot with known errors and write a measurement CSV.

    Example: robocal simulate kr150-2 --errors liu2022 --sampling lhs --out meas.csv

    Ball in sockets: robocal simulate kr150-2 --sampling sockets --fixture fix.toml --placements 6
    --per-socket 20 --out sockets.csv
    """
    if box is not None and sampling in ("lhs", "grid") and fixture is None:  # where --box, --rpy, --hint apply
        from ...io.library import load_robot
        from ...io.units import check_typed_units

        check_typed_units(load_robot(robot, root=root, tip=tip), box=box, rpy=rpy, hint=hint)
    result = simulate_job(robot, out_file, n=n, sampling=sampling, errors=errors, noise=noise, seed=seed,
                          truth=truth, orientation=orientation, box=box, rpy=rpy, hint=hint, root=root, tip=tip,
                          fixture=fixture, placements=placements, per_socket=per_socket, joint_noise=joint_noise)
    print_result(result.to_dict(), as_json, f"simulated {result.poses} poses -> {out_file}")


@verb()
@declared(DESIGN)
def design(robot: str = ROBOT, *, n: int,
           out_file: str = out_option("Poses CSV to write: pose, q1..qN (deg, the joint columns of a measurement "
                                      "file), x_nominal, y_nominal, z_nominal.", ".csv"),
           seed: int = SEED, criterion: str, parameters: str, candidates: str, pool: int, sampling: str, box: str,
           rpy: str, hint: str, tool: str, margin: float, floor: str, walls: str, existing: str, targets: str,
           noise: float, tracker: str,
           joint_noise: float, sag: float, order: str, payload: float, tip: str = TIP, root: str = ROOT,
           fixture: str, placements: str, region: str, per_socket: int, max_tilt: float, as_json: bool = JSON):
    """Choose which poses to measure for a calibration, and predict what they will give.

    From 10,000 candidate configurations (or --candidates), greedy selection and exchange
    choose --n poses for the criterion, ordered as a short tour in joint space; the summary
    gives the predicted standard error of every identifiable parameter and the predicted
    held-out position error, beside random poses of the same number.

    Example: robocal design kr150-2 --n 30 --out poses.csv

    Augment a campaign: robocal design ur5 --n 10 --existing measured.csv --out next.csv

    Ball in sockets: robocal design panda --fixture plate.toml --placements where.csv --n 72
    --per-socket 8 --out plan.csv
    """
    from ...planning.job import design_job, socket_job
    from ...planning.workspace import WorkingVolume, parse_floor

    socket_options = {"--placements": placements, "--region": region, "--per-socket": per_socket,
                      "--max-tilt": max_tilt}
    if fixture is None and any(v is not None for v in socket_options.values()):
        given = [k for k, v in socket_options.items() if v is not None]
        raise InputError(f"{', '.join(given)} plan a ball-in-socket campaign: give --fixture too, or leave "
                         f"{'it' if len(given) == 1 else 'them'} out")
    if fixture is not None:
        pose_options = {"--candidates": candidates, "--box": box, "--rpy": rpy, "--hint": hint, "--existing": existing,
                        "--floor": floor, "--walls": walls,
                        "--targets": targets, "--tracker": tracker, "--payload": payload,
                        "--joint-noise": joint_noise or None, "--sag": sag or None,
                        "--parameters": parameters if parameters != "full" else None,
                        "--order": order if order != "tour" else None}
        given = [k for k, v in pose_options.items() if v is not None]
        if given:
            raise InputError(f"{', '.join(given)} do not apply to a ball-in-socket design (--fixture): leave "
                             f"{'it' if len(given) == 1 else 'them'} out")
        if criterion not in SOCKET_CRITERIA:
            raise InputError(f"--criterion {criterion} is for residual models over poses; a ball-in-socket design "
                             "takes prediction or d-optimal")
        with progress("design", None, enabled=not as_json):  # a heartbeat: its stages are not reported
            result = socket_job(robot, out_file, fixture=fixture, n=n, placements=placements, region=region,
                                per_socket=per_socket, criterion=criterion, seed=seed, tool=tool, noise=noise,
                                margin=margin, max_tilt=max_tilt, root=root, tip=tip)
    else:
        with progress("design", None, enabled=not as_json) as advance:
            result = design_job(robot, out_file, n=n, seed=seed, criterion=criterion, parameters=parameters,
                                candidates=candidates, pool=pool, sampling=sampling, box=box, rpy=rpy, hint=hint,
                                tool=tool, margin=margin, existing=existing, targets=targets, noise=noise,
                                tracker=tracker, payload=payload, order=order, root=root, tip=tip,
                                joint_noise_deg=joint_noise, sag_deg=sag,
                                volume=WorkingVolume(parse_floor(floor), walls),
                                progress=lambda **info: advance(steps=0, **info))
    if as_json:
        print_json(result.to_dict())
    elif fixture is not None:
        print_socket_design(result, out_file)
    else:
        print_design(result, out_file)
