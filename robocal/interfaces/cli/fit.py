"""Commands that fit models to measurements: calibrate, compare, validate.

Their method options are generated from the registry's settings (:func:`.options.method_options`):
a setting declared in ``robocal/methods/<method>.py`` is an option of calibrate and validate
with nothing to add here.
"""
import typer

from ... import parallel
from ...errors import InputError
from ...methods import DEFAULT_METHOD, FRAMES, get_method, make_method, method_names
from ...methods.base import option_of
from ...methods.reregistration import PARAMETER_CHOICES as FRAME_PARAMETERS
from ...settings import Choice, Number, Numbers
from ..jobs import AUTO, calibrate_job, compare_job, reregister_job, validate_job
from .app import verb
from .options import (ACCEPT_EXTRAPOLATION, BEYOND_LIMITS, FIXTURE, JOBS, JSON, MEASUREMENTS, METHOD_HELP, ROBOT,
                      ROOT, SCHEDULER, SEED, TIP, method_options, options_named, out_option, parsed)
from .rendering import (print_calibrated, print_comparison, print_json, print_reregistration, print_validation,
                        progress)


@verb()
@method_options(frames=True)
def calibrate(
    robot: str = typer.Argument(..., help="Built-in name, robot .toml or .urdf file (--method frames: a model file)."),
    measurements: str = MEASUREMENTS,
    out_file: str = out_option("Model file (JSON) to write.", ".json"),
    method: str = typer.Option(DEFAULT_METHOD, help=METHOD_HELP + " auto: the model 'robocal compare' recommends, with "
                               "the comparison kept in the model file. frames: ROBOT is a model file, re-registered on "
                               "a new set-up (base and tool; --parameters frames+offsets adds the joint offsets).",
                               **parsed(Choice(method_names() + (AUTO, FRAMES)))),
    settings: dict = None,
    folds: int = typer.Option(None, help="auto: folds of the comparison (default 5; on a campaign too small for 5 "
                              "folds of 30 training poses, leave-one-out, or with --folds K, K folds repeated 5 "
                              "times).", **parsed(Number(whole=True, at_least=2, at_most=1000))),
    fixture: str = FIXTURE,
    tip: str = TIP,
    root: str = ROOT,
    beyond_limits: bool = BEYOND_LIMITS,
    accept_extrapolation: bool = ACCEPT_EXTRAPOLATION,
    jobs: int = JOBS,
    scheduler: str = SCHEDULER,
    as_json: bool = JSON,
):
    """Fit a calibration / error model to measurements and save it as a model file.

    Options that do not apply to the chosen method are refused ('robocal methods' lists
    which method takes which).

    Example: robocal calibrate ur5 meas.csv --method kinematic --out model.json
    """
    if folds is not None and method != AUTO:
        raise InputError(f"--folds sets the folds of --method auto's comparison: leave it out for --method {method} "
                         "(robocal validate --folds cross-validates one method)")
    if method == FRAMES:
        return _reregister(robot, measurements, out_file, settings, beyond_limits, as_json, root=root, tip=tip,
                           fixture=fixture, accept_extrapolation=accept_extrapolation)
    if settings.get("parameters") in FRAME_PARAMETERS:
        raise InputError(f"--parameters {settings['parameters']} re-registers a model file: give --method frames and "
                         "the model file in place of the robot")
    if (jobs is not None or scheduler is not None) and method != AUTO and not get_method(method).spreads_work:
        given = "--jobs" if jobs is not None else "--scheduler"
        raise InputError(f"{given} spreads Kriging's likelihood searches and auto's comparison over workers: the "
                         f"{method} method has none; leave {given} out")
    if method == AUTO:
        fitter, label, total = AUTO, "comparing the methods, fit", None
    else:
        fitter = make_method(method, **settings)
        label = fitter.progress_label if fitter.progress_total() else f"fitting the {method} model"
        total = fitter.progress_total()
    with parallel.executor(jobs=jobs, scheduler=scheduler), progress(label, total, enabled=not as_json) as advance:
        result = calibrate_job(robot, measurements, out_file, method=fitter,
                               settings=settings if method == AUTO else None,
                               fixture=fixture, progress=advance, beyond_limits=beyond_limits, root=root, tip=tip,
                               accept_extrapolation=accept_extrapolation, folds=folds)
    print_calibrated(result, out_file, as_json, comparison=method == AUTO)


def _reregister(model, measurements, out_file, settings, beyond_limits, as_json, accept_extrapolation=False,
                **robot_options):
    """calibrate --method frames: the model file re-registered on the poses of a new set-up."""
    given = [option for option, value in robot_options.items() if value is not None]
    others = sorted(set(settings) - {"parameters"})
    if given or others:
        options = [option_of(name) for name in others] + ["--" + name for name in given]
        raise InputError(f"--method frames keeps everything the model file holds and re-identifies its frames: "
                         f"leave out {', '.join(options)} (--parameters frames or frames+offsets is its one option)")
    result = reregister_job(model, measurements, out_file, parameters=settings.get("parameters"),
                            beyond_limits=beyond_limits, accept_extrapolation=accept_extrapolation)
    print_reregistration(result, measurements, out_file, as_json)


@verb()
def compare(
    robot: str = ROBOT,
    measurements: str = MEASUREMENTS,
    folds: int = typer.Option(None, help="Folds of each split (random folds, and regions of joint space; default 5). "
                              "A campaign too small for 5 folds of 30 training poses is split leave-one-out, or with "
                              "--folds K into K folds repeated 5 times.",
                              **parsed(Number(whole=True, at_least=2, at_most=1000))),
    seed: int = SEED,
    network: bool = typer.Option(None, "--network/--no-network", help="Include the ann method (default: when the "
                                 "training folds hold 500 poses or more)."),
    fixture: str = FIXTURE,
    tip: str = TIP,
    root: str = ROOT,
    beyond_limits: bool = BEYOND_LIMITS,
    jobs: int = JOBS,
    scheduler: str = SCHEDULER,
    as_json: bool = JSON,
):
    """Which model to trust: every method and parameter set scored on poses it never saw.

    Two kinds of split: random folds, and regions of configuration space left out whole
    (clusters of joint configurations; one side of an arm branch when both were measured;
    the last 20 % in time when the file has a timestamp column; one fixture placement for
    ball-in-socket data).  The recommendation: the simplest model, unless a richer one is
    better on the random folds by more than its fold-to-fold spread and not worse on the
    held-out regions by more than theirs.  'calibrate --method auto' fits it, answering with
    the kinematic calibration outside its training domain.

    Example: robocal compare ur5 meas.csv
    """
    with parallel.executor(jobs=jobs, scheduler=scheduler), \
            progress("comparing the methods, fit", None, enabled=not as_json) as advance:
        comparison = compare_job(robot, measurements, folds=folds, seed=seed, fixture=fixture, network=network,
                                 root=root, tip=tip, on_fit=advance, beyond_limits=beyond_limits)
    result = comparison.to_dict()
    if as_json:
        print_json(result)
    else:
        print_comparison(result)


@verb()
@method_options(skip=("--seed",))
def validate(
    robot: str = ROBOT,
    measurements: str = MEASUREMENTS,
    method: str = typer.Option(DEFAULT_METHOD, help=METHOD_HELP + " Ball-in-socket data (constraint) are validated one "
                               "fixture placement left out at a time.", **parsed(Choice(method_names()))),
    folds: int = typer.Option(5, help="Number of cross-validation folds.", **parsed(Number(whole=True, at_least=2))),
    sizes: str = typer.Option(None, help="Learning curve: training sizes, e.g. 20,50,100,200.",
                              **parsed(Numbers(whole=True, at_least=1, example="20,50,100,200"))),
    seed: int = SEED,
    settings: dict = None,
    fixture: str = FIXTURE,
    beyond_limits: bool = BEYOND_LIMITS,
    jobs: int = JOBS,
    scheduler: str = SCHEDULER,
    as_json: bool = JSON,
):
    """Held-out accuracy of a method: k-fold cross-validation and an optional learning curve.

    Every pose is predicted by a model that did not see it; the nominal robot, registered on
    the same folds, is the baseline.  --seed also seeds the method's random search where it
    has one.

    Example: robocal validate ur5 meas.csv --method kinematic --folds 5 --sizes 20,50,100,200
    """
    if any(s.name == "random_state" for s in get_method(method).settings):
        settings = {**settings, "random_state": seed}
    by_placement = get_method(method).data_kind == "sockets"
    # Each fold fits the method and the registered nominal; each size of the curve 3 times.
    fits = None if by_placement else 2 * folds + 3 * len(sizes or [])
    with parallel.executor(jobs=jobs, scheduler=scheduler), progress("fitting", fits, enabled=not as_json) as advance, \
            options_named({"k": "--folds"}):
        result = validate_job(robot, measurements, method=method, settings=settings, folds=folds, sizes=sizes,
                              beyond_limits=beyond_limits, seed=seed, fixture=fixture, on_fit=advance)
    print_validation(result, method, by_placement, as_json)
