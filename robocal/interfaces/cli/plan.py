"""Commands that plan and simulate measurements: simulate, design."""
import typer

from ...errors import InputError
from ...estimation.calibration import PARAMETER_SETS
from ...settings import Choice, Number, Numbers
from ...simulation.presets import PRESETS
from ..jobs import SAMPLINGS, simulate_job
from .app import verb
from .options import FIXTURE, JSON, LARGEST_NOISE_MM, MOST_SIMULATED_POSES, ROBOT, ROOT, SEED, TIP, Output, out_option, parsed
from .rendering import print_design, print_json, print_result, print_socket_design

# Where the poses are drawn (simulate --sampling lhs) or the candidates lie (design --box).
BOX = typer.Option(None, help="A Cartesian box of the robot base frame, xmin,xmax,ymin,ymax,zmin,zmax in mm: where "
                   "simulate --sampling lhs draws the poses, where design's candidates lie.", **parsed(Numbers(count=6)))
RPY = typer.Option(None, help="With --box: the TCP orientation rx,ry,rz in deg (default 180,0,0).",
                   **parsed(Numbers(count=3)))
HINT = typer.Option(None, help="With --box: a posture q1,...,qn in deg whose IK branch every pose takes.",
                    **parsed(Numbers()))


@verb()
def simulate(
    robot: str = ROBOT,
    out_file: str = out_option("Measurement CSV to write.", ".csv"),
    n: int = typer.Option(None, "--n", help="Number of poses (default 200; liu2022: 150).", **parsed(Number(whole=True, at_least=1, at_most=MOST_SIMULATED_POSES))),
    sampling: str = typer.Option("joint", help="joint (uniform in the limits), lhs (Latin hypercube in --box), grid (n^(1/3) per axis in --box) or sockets (ball in the sockets of --fixture, joint angles only).", **parsed(Choice(SAMPLINGS))),
    errors: str = typer.Option("typical", **parsed(Choice(PRESETS, or_file=".json")), help="none, typical, liu2022 (KR150-2 only), or a truth file (JSON, as --truth writes it) whose deviations you edit, e.g. joint gains in ppm."),
    noise: float = typer.Option(None, help="Measurement noise sigma in mm (overrides the preset); sockets: the ball's seating error.", **parsed(Number(at_least=0, at_most=LARGEST_NOISE_MM))),
    seed: int = SEED,
    truth: str = typer.Option(None, help="Also write the hidden truth (JSON) here.", **parsed(Output(".json"))),
    orientation: bool = typer.Option(False, "--orientation", help="Also write measured rx, ry, rz."),
    box: str = BOX,
    rpy: str = RPY,
    hint: str = HINT,
    fixture: str = FIXTURE,
    placements: int = typer.Option(None, help="sockets: number of fixture placements (default 4).", **parsed(Number(whole=True, at_least=1))),
    per_socket: int = typer.Option(None, "--per-socket", help="sockets: configurations per socket and placement (default 10).", **parsed(Number(whole=True, at_least=2))),
    joint_noise: float = typer.Option(None, "--joint-noise", help="sockets: noise of the joint readings (deg, default 0).", **parsed(Number(at_least=0))),
    tip: str = TIP,
    root: str = ROOT,
    as_json: bool = JSON,
):
    """Measure a simulated robot with known errors and write a measurement CSV.

    Example: robocal simulate kr150-2 --errors liu2022 --sampling lhs --out meas.csv

    Ball in sockets: robocal simulate kr150-2 --sampling sockets --fixture fix.toml --placements 6 --per-socket 20 --out sockets.csv
    """
    result = simulate_job(robot, out_file, n=n, sampling=sampling, errors=errors, noise=noise, seed=seed,
                          truth=truth, orientation=orientation, box=box, rpy=rpy, hint=hint, root=root, tip=tip,
                          fixture=fixture, placements=placements, per_socket=per_socket, joint_noise=joint_noise)
    print_result(result, as_json, f"simulated {result['poses']} poses -> {out_file}")


@verb()
def design(
    robot: str = ROBOT,
    n: int = typer.Option(..., "--n", help="Number of poses to measure.", **parsed(Number(whole=True, at_least=1, at_most=100_000))),
    out_file: str = out_option("Poses CSV to write: pose, q1..qN (deg, the joint columns of a measurement file), "
                               "x_nominal, y_nominal, z_nominal.", ".csv"),
    seed: int = SEED,
    criterion: str = typer.Option("prediction", help="prediction (default: the mean squared error of the calibrated TCP over the targets; what a calibration is for), d-optimal (log det of the parameters' information), space-filling (spread over configuration space) or variance (one pose at a time where a Gaussian-process prior over the joints' sines and cosines is least certain; hyperparameters from --existing measurements when given); the last two for the kriging, hybrid and ann residual models. With --fixture: prediction or d-optimal.", **parsed(Choice(("prediction", "d-optimal", "space-filling", "variance")))),
    parameters: str = typer.Option("full", help="The parameter set the calibration will identify (as calibrate --parameters).", **parsed(Choice(PARAMETER_SETS))),
    candidates: str = typer.Option(None, help="CSV of your own candidate configurations (q1..qN, deg): reachable poses of an offline program, or an earlier campaign's."),
    pool: int = typer.Option(10_000, help="Candidate configurations to draw (without --candidates).", **parsed(Number(whole=True, at_least=10, at_most=1_000_000))),
    sampling: str = typer.Option("uniform", help="How candidates are drawn in joint space: uniform or lhs (Latin hypercube).", **parsed(Choice(("uniform", "lhs")))),
    box: str = BOX,
    rpy: str = RPY,
    hint: str = HINT,
    tool: str = typer.Option(None, help="The TCP x,y,z in mm in the flange frame, in place of the robot file's tool.", **parsed(Numbers(count=3))),
    margin: float = typer.Option(5.0, help="Degrees the candidates keep from joint limits and singularities.", **parsed(Number(at_least=0, at_most=45))),
    existing: str = typer.Option(None, help="Measurement (or poses) CSV of poses measured before: design the --n poses that best complement them; with x, y, z their calibration's residual sets the noise unless --noise is given."),
    targets: str = typer.Option(None, help="Where the robot will work: a CSV of configurations (q1..qN, deg) or of targets (x, y, z, rx, ry, rz; mm, deg, robot base frame). Default: the candidates."),
    noise: float = typer.Option(None, help="Standard deviation of a reading per coordinate in mm (default 0.02): the tracker's noise, plus what the calibration will not explain if you know it (an earlier calibration's residual RMS / 1.73).", **parsed(Number(at_least=0, at_most=LARGEST_NOISE_MM))),
    tracker: str = typer.Option(None, help="The laser tracker's position x,y,z in mm (robot base frame): its noise then grows with distance.", **parsed(Numbers(count=3))),
    joint_noise: float = typer.Option(0.0, "--joint-noise", help="Standard deviation in deg of an error at every joint that the calibration does not model (gear backlash or play, e.g. the half-width of the gears' backlash): a pose then reads noisier the further the arm reaches, and the design and its predicted held-out error count it. Default 0: none.", **parsed(Number(at_least=0, at_most=1))),
    sag: float = typer.Option(0.0, "--sag", help="How far gravity bends the most loaded joint, in deg, when --parameters has no compliance (e.g. 0.01 for a counterbalanced 150 kg arm, 0.08 for a UR5): the design then also chooses poses whose sag the geometry absorbs as the targets' would be, and the predicted error counts what it leaves. Default 0: none.", **parsed(Number(at_least=0, at_most=1))),
    order: str = typer.Option("tour", help="The order to measure in: tour (short motions) or random (averages out gear backlash, which a tour approaches from one side).", **parsed(Choice(("tour", "random")))),
    payload: float = typer.Option(None, help="full+compliance: mass at the TCP in kg (as calibrate --payload).", **parsed(Number(at_least=0))),
    tip: str = TIP,
    root: str = ROOT,
    fixture: str = typer.Option(None, help="Ball in sockets: the fixture TOML file; the design then chooses placements and, per socket, configurations for the constraint calibration (the robot's tool is the ball centre), and --n counts configurations in all."),
    placements: str = typer.Option(None, help="With --fixture: CSV of candidate fixture placements, x,y,z (mm), rx,ry,rz (deg) of the fixture frame in the robot base frame, and optionally a fixture column naming them."),
    region: str = typer.Option(None, help="With --fixture, instead of --placements: where the fixture may stand level, xmin,xmax,ymin,ymax,zmin,zmax in mm (robot base frame).", **parsed(Numbers(count=6))),
    per_socket: int = typer.Option(None, "--per-socket", help="With --fixture: configurations per socket (default: --n spread over every reachable placement); fewer placements are then chosen.", **parsed(Number(whole=True, at_least=2))),
    max_tilt: float = typer.Option(None, "--max-tilt", help="With --fixture: the largest angle between the tool axis and the fixture normal, deg (default 30).", **parsed(Number(at_least=0, at_most=89))),
    as_json: bool = JSON,
):
    """Choose which poses to measure for a calibration, and predict what they will give.

    From 10,000 candidate configurations (or --candidates), greedy selection and exchange
    choose --n poses for the criterion, ordered as a short tour in joint space; the summary
    gives the predicted standard error of every identifiable parameter and the predicted
    held-out position error, beside random poses of the same number.

    Example: robocal design kr150-2 --n 30 --out poses.csv

    Augment a campaign: robocal design ur5 --n 10 --existing measured.csv --out next.csv

    Ball in sockets: robocal design panda --fixture plate.toml --placements where.csv --n 72 --per-socket 8 --out plan.csv
    """
    from ...planning.job import design_job, socket_job

    if noise is not None and noise <= 0:
        raise InputError(f"--noise is a standard deviation and must be > 0 mm, got {noise}")
    socket_options = {"--placements": placements, "--region": region, "--per-socket": per_socket, "--max-tilt": max_tilt}
    if fixture is None and any(v is not None for v in socket_options.values()):
        given = [k for k, v in socket_options.items() if v is not None]
        raise InputError(f"{', '.join(given)} plan a ball-in-socket campaign: give --fixture too, or leave "
                         f"{'it' if len(given) == 1 else 'them'} out")
    if fixture is not None:
        pose_options = {"--candidates": candidates, "--box": box, "--rpy": rpy, "--hint": hint, "--existing": existing,
                        "--targets": targets, "--tracker": tracker, "--payload": payload,
                        "--joint-noise": joint_noise or None, "--sag": sag or None,
                        "--parameters": parameters if parameters != "full" else None,
                        "--order": order if order != "tour" else None}
        given = [k for k, v in pose_options.items() if v is not None]
        if given:
            raise InputError(f"{', '.join(given)} do not apply to a ball-in-socket design (--fixture): leave "
                             f"{'it' if len(given) == 1 else 'them'} out")
        if criterion not in ("prediction", "d-optimal"):
            raise InputError(f"--criterion {criterion} is for residual models over poses; a ball-in-socket design "
                             "takes prediction or d-optimal")
        result = socket_job(robot, out_file, fixture=fixture, n=n, placements=placements, region=region,
                            per_socket=per_socket, criterion=criterion, seed=seed, tool=tool, noise=noise,
                            margin=margin, max_tilt=max_tilt, root=root, tip=tip)
    else:
        result = design_job(robot, out_file, n=n, seed=seed, criterion=criterion, parameters=parameters,
                            candidates=candidates, pool=pool, sampling=sampling, box=box, rpy=rpy, hint=hint,
                            tool=tool, margin=margin, existing=existing, targets=targets, noise=noise,
                            tracker=tracker, payload=payload, order=order, root=root, tip=tip,
                            joint_noise=joint_noise, sag=sag)
    if as_json:
        print_json(result)
    elif fixture is not None:
        print_socket_design(result, out_file)
    else:
        print_design(result, out_file)
