"""Commands that use a model file: evaluate, compensate, filter, serve, report, export."""
from pathlib import Path

import typer

from ...errors import InputError
from ...kinematics.chain import CONVENTIONS
from ...settings import Choice
from ..filter import filter_job
from ..jobs import EXPORT_FORMATS, compensate_job, evaluate_job, export_job
from .app import verb
from .options import (ACCEPT_EXTRAPOLATION, BEYOND_LIMITS, FIXTURE, ITERATE, JSON, MODEL, OUTPUT_KINDS, Output,
                      out_option, parsed)
from ..serve import FORMATS as LINE_FORMATS
from .rendering import print_compensated, print_evaluated, print_exported, print_filtered, print_result


@verb()
def evaluate(
    model: str = MODEL,
    measurements: str = typer.Argument(..., help="Measurement CSV (use poses the model was not trained on)."),
    fixture: str = FIXTURE,
    beyond_limits: bool = BEYOND_LIMITS,
    per_pose: str = typer.Option(None, "--per-pose", help="Write one CSV line per pose: row, measured and model "
                                 "x, y, z, error_mm, bound95_mm (the model's 95 % bound) and in_domain.",
                                 **parsed(Output(".csv"))),
    as_json: bool = JSON,
):
    """Residual of a model on measured data, beside the nominal robot's.

    On ball-in-socket data: the socket consistency (distance of each ball centre from the
    mean of its socket group) and the socket-distance error.  On position data, bound95
    says which share of the poses lie within the model's 95 % bound.

    Example: robocal evaluate model.json test.csv --json --per-pose poses.csv
    """
    result = evaluate_job(model, measurements, fixture=fixture, beyond_limits=beyond_limits, per_pose=per_pose)
    print_evaluated(result, measurements, as_json)


@verb()
def compensate(
    model: str = MODEL,
    targets: str = typer.Argument(..., help="Targets CSV: x, y, z, rx, ry, rz (+ optional q1..qN hint)."),
    out_file: str = out_option("Commands CSV to write.", ".csv"),
    iterate: bool = ITERATE,
    as_json: bool = JSON,
):
    """Joint commands and corrected Cartesian targets that make the real robot hit the targets.

    Targets are in the measurement frame (the frame of the data the model was fitted to).
    In the commands file, q1..qN are the joint commands; x, y, z, rx, ry, rz are the target
    to send instead to a controller that keeps its nominal model: its forward kinematics of
    those joints, in the robot's base frame with the tool of the robot file (a base and tool
    registered to the data are part of the calibrated model, not of these columns).

    Example: robocal compensate model.json targets.csv --out commands.csv
    """
    print_compensated(compensate_job(model, targets, out_file, iterate=iterate), out_file, as_json)


@verb(name="filter")
def filter_programs(
    model: str = MODEL,
    programs: list[str] = typer.Argument(..., help="Robot programs: KRL .src (its .dat comes along), RAPID "
                                                   ".mod/.modx/.prg, URScript .script."),
    out_dir: str = out_option("Directory to write the filtered programs (same names) and filter-summary.csv into."),
    language: str = typer.Option(None, "--language", help="krl, rapid or urscript (default: by extension)."),
    config: str = typer.Option(None, "--config", help="KRL: the robot's $config.dat, for TOOL_DATA and BASE_DATA "
                                                      "(default: the robot's base and the model's tool)."),
    allow_unfiltered: bool = typer.Option(False, "--allow-unfiltered",
                                          help="Write the program even if some motions are computed at run time "
                                               "(they stay as they are and are listed)."),
    accept_extrapolation: bool = ACCEPT_EXTRAPOLATION,
    iterate: bool = ITERATE,
    as_json: bool = JSON,
):
    """Robot programs in, compensated robot programs out.

    Every Cartesian target of the programs becomes what 'robocal compensate' gives for it, in
    the program's own base and tool frames and for the posture the point names; every other
    byte stays as it was, and one comment line naming robocal and the model is added.

    Example: robocal filter model.json pallet_cell.src --out filtered/
    """
    result = filter_job(model, programs, out_dir, language=language, config=config,
                        allow_unfiltered=allow_unfiltered, accept_extrapolation=accept_extrapolation, iterate=iterate)
    print_filtered(result, out_dir, as_json)


@verb(hold_warnings=False)  # it answers until stopped: its warnings are shown as they come
def serve(
    model: str = MODEL,
    port: int = typer.Option(8765, "--port", min=0, max=65535, help="TCP port (0: any free port, printed)."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address to listen on."),
    line_format: str = typer.Option("json", "--format", help="Request and answer lines: json or csv.",
                                    **parsed(Choice(LINE_FORMATS))),
):
    """Answer a controller point by point over TCP: one target per line in, one command out.

    A request is one line, {"x","y","z","rx","ry","rz","q":[hint]} (mm, deg, the units and
    frames of a targets file); the answer is one line, {"q":[...],"x","y","z","rx","ry","rz",
    "in_domain","bound95_mm"}, what 'robocal compensate' writes for that target.  With
    --format csv: x,y,z,rx,ry,rz[,q1..qN] in, q1..qN,x,y,z,rx,ry,rz,in_domain,bound95_mm out.
    A bad request gets one {"error": "..."} line.  SIGTERM or Ctrl-C stops it (exit 0).

    Example: robocal serve model.json --port 8765
    """
    from ..serve import serve as run_server

    run_server(model, host=host, port=port, fmt=line_format)


@verb()
def report(
    model: str = MODEL,
    measurements: str = typer.Argument(..., help="Measurement CSV to score (held-out poses, ideally)."),
    out_file: str = out_option("HTML report to write (one self-contained file).", ".html"),
    pdf: str = typer.Option(None, "--pdf", help="Also write the tables and figures as a PDF.",
                            **parsed(Output(".pdf"))),
    validation: str = typer.Option(None, "--validation",
                                   help="JSON of 'robocal validate --json': adds cross-validation and the "
                                        "learning curve."),
    iso: str = typer.Option(None, "--iso", help="An ISO 9283 campaign CSV: adds its ISO page (measured and, "
                                                "predicted, compensated by this model)."),
    beyond_limits: bool = BEYOND_LIMITS,
    as_json: bool = JSON,
):
    """Accuracy report in one HTML file that opens offline: data, parameters, errors, plots.

    For a customer or a file: the data summary, the identified parameters with their standard
    errors and what could not be identified, the error before and after (mean, RMS, max, 95 %,
    per axis, ISO 9283-style AP/RP), and plots of where the error is.

    Example: robocal report model.json test.csv --out report.html
    """
    from ..report import report_job

    result = report_job(model, measurements, out_file, validation=validation, pdf=pdf, beyond_limits=beyond_limits,
                        iso=iso)
    print_result(result.to_dict(), as_json, f"report -> {out_file}")


@verb()
def export(
    model: str = MODEL,
    fmt: str = typer.Option(None, "--format", help="toml (robot file), urdf, or ur-yaml (UR's ROS 2 kinematics file) "
                                                   "(default: as --out ends, else toml).",
                            **parsed(Choice(EXPORT_FORMATS))),
    out_file: str = out_option("Robot file to write (.toml or .urdf)."),
    convention: str = typer.Option(None, help="Convert first, exactly (default: as calibrated).",
                                   **parsed(Choice(CONVENTIONS))),
    original: str = typer.Option(None, "--urdf", help="With --format urdf: the robot's own URDF (the one calibrated "
                                                      "from); only what the calibration changed is rewritten."),
    as_json: bool = JSON,
):
    """Calibrated kinematics as a robot TOML or URDF (direct compensation, or ROS).

    For a controller that accepts new parameters, or a simulator; the base is the measurement
    frame -> robot base the calibration found.

    Example: robocal export model.json --format urdf --out calibrated.urdf
    """
    suffix = Path(out_file).suffix.lower().lstrip(".")
    if fmt is None and "." + suffix in OUTPUT_KINDS and suffix not in EXPORT_FORMATS:
        raise InputError(f"export writes a robot TOML or a URDF, but --out {out_file} names a "
                         f"{OUTPUT_KINDS['.' + suffix]} file: name it {Path(out_file).with_suffix('.toml')} or "
                         f"{Path(out_file).with_suffix('.urdf')}")
    if fmt is None:
        fmt = "ur-yaml" if suffix in ("yaml", "yml") else suffix if suffix in EXPORT_FORMATS else "toml"
    elif "." + suffix in OUTPUT_KINDS and suffix != fmt:
        wanted = ".yaml" if fmt == "ur-yaml" else "." + fmt
        raise InputError(f"--format {fmt} writes a {OUTPUT_KINDS.get(wanted, 'UR kinematics YAML')} file, but --out "
                         f"{out_file} names a {OUTPUT_KINDS['.' + suffix]} file: name it "
                         f"{Path(out_file).with_suffix(wanted)} or drop --format")
    if original is not None and (fmt != "urdf" or convention is not None):
        raise InputError("--urdf rewrites the robot's own URDF: give --format urdf (or an --out ending in .urdf) "
                         "and no --convention")
    print_exported(export_job(model, out_file, fmt=fmt, convention=convention, original=original), out_file,
                   as_json)
