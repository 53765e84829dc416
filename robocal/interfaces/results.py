"""What the commands' jobs return: one frozen result type per command, in the manner of
SciPy's ``OptimizeResult`` (every field documented, set once at the job's single exit), and
its ``to_dict()``: the JSON object ``--json`` prints, key for key and in the same order as
before the types existed.  Rendering them is :mod:`robocal.interfaces.cli.rendering`'s (the
demo's tables, :mod:`robocal.interfaces.demo`'s).

``compare`` returns its :class:`~robocal.methods.selection.Comparison`; ``design`` a
:class:`~robocal.planning.job.Designed` (``--fixture``: a
:class:`~robocal.planning.job.SocketsDesigned`), defined beside its job in the planning layer,
which may not import this one; ``demo`` a :class:`~robocal.interfaces.demo.Demonstrated`,
beside its experiment (the one module of ``interfaces/`` that names a method).  Still
JSON-ready dicts: ``import``'s and ``iso9283 plan``'s.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..acceptance.iso9283 import Iso9283Result
from ..estimation.metrics import ErrorStats


@dataclass(frozen=True)
class Calibrated:
    """What ``calibrate`` (and re-registration) did.

    Attributes
    ----------
    method, robot, out : str
        The method's name, the robot's name, the model file written.
    data : dict
        The training data: ``file``, ``n_poses``, ``kind``, ``fixture_file``, ``comparison``
        with --method auto, ``fingerprint`` (left out of :meth:`to_dict`).
    record : FitRecord
        The fit's record (:class:`robocal.methods.FitRecord`).
    kinematics : Chain or None
        The fitted method's chain.
    """

    method: str
    robot: str
    out: str
    data: dict
    record: object  # robocal.methods.FitRecord: interfaces may not name a method's types here
    kinematics: object = None

    def to_dict(self):
        # The training rows' fingerprint is for robocal to read back, not for people.
        data = {key: value for key, value in self.data.items() if key != "fingerprint"}
        return {"method": self.method, "robot": self.robot, "out": self.out, **data, **self.record.to_dict()}


@dataclass(frozen=True)
class Compensated:
    """What ``compensate`` wrote.

    Attributes
    ----------
    targets, reachable : int
        How many targets the file holds, and how many the calibrated robot reaches.
    unreachable_rows : list of int
        The file lines of the targets it cannot reach.
    out : str
        The commands file written.
    predicted_error : ErrorStats
        The model's predicted correction over the reachable targets (mm).
    outside_domain : int or None
        Reachable targets outside the model's domain of validity (None: the file records no
        domain).
    domain_summary : str
        The domain check in one line.
    bound95_median_mm : float or None
        The median 95 % bound over the reachable targets (None when the file stores no bound,
        and ``bound_note`` says so).
    bound_note : str or None
        Why there is no bound, or what the bound bounds when it is not the position error.
    """

    targets: int
    reachable: int
    unreachable_rows: list
    out: str
    predicted_error: ErrorStats
    outside_domain: int | None
    domain_summary: str
    bound95_median_mm: float | None = None
    bound_note: str | None = None

    def to_dict(self):
        out = {"targets": self.targets, "reachable": self.reachable, "unreachable_rows": list(self.unreachable_rows),
               "out": self.out, "predicted_error": self.predicted_error.to_dict(),
               "outside_domain": self.outside_domain, "domain_summary": self.domain_summary}
        if self.bound95_median_mm is not None:
            out["bound95_median_mm"] = self.bound95_median_mm
        if self.bound_note is not None:
            # No bound, or what a ball-in-socket model's bound bounds (the socket consistency).
            out["bound_note"] = self.bound_note
        return out


@dataclass(frozen=True)
class Exported:
    """What ``export`` wrote.

    Attributes
    ----------
    model, format, out : str
        The model file read, ``toml`` or ``urdf``, the file written.
    robot, convention : str
        The exported robot's name and its convention (dh, mdh, poe).
    left_out : list of str
        What the robot file cannot hold (the compliance, an error model, a joint map).
    into_original : dict
        Written into the robot's own URDF (``--urdf``): what changed in it
        (:func:`robocal.io.urdf_update.write_calibrated_urdf`); empty otherwise.
    """

    model: str
    format: str
    out: str
    robot: str
    convention: str
    left_out: list
    into_original: dict = field(default_factory=dict)

    def to_dict(self):
        return {"model": self.model, "format": self.format, "out": self.out, "robot": self.robot,
                "convention": self.convention, "left_out": list(self.left_out), **self.into_original}


@dataclass(frozen=True)
class Evaluated:
    """What ``evaluate`` measured.

    Attributes
    ----------
    model, method, file : str
        The model file, its method, the measurement file.
    training_poses : int or None
        How many of the poses the model was trained on, by content (None: the file keeps no
        fingerprint): a score of them is not held out.
    scores : dict
        The method's statistics, JSON-ready: on position data :class:`ErrorStats` keys (mm),
        the orientation's ``rot_*_deg`` with 6-D data, and the nominal robot's under
        ``nominal``; on ball-in-socket data the socket consistency and distances.
    outside_domain : int or None
        Poses outside the model's domain of validity (None: the file records no domain).
    domain_summary : str
        The domain check in one line.
    in_domain, out_of_domain : ErrorStats or None
        Position data with a domain: the statistics of each part.
    bound95 : dict or None
        Position data: the share of poses within their 95 % bound (``poses``,
        ``within_share``, ``median_bound_mm``, ``median_error_mm``, ``inside``, ``outside``);
        None with ``bound_note`` saying why for a file that stores no bound.
    bound_note : str or None
    per_pose : str or None
        The per-pose CSV written (``--per-pose``).
    """

    model: str
    method: str
    file: str
    training_poses: int | None
    scores: dict
    outside_domain: int | None
    domain_summary: str
    in_domain: ErrorStats | None = None
    out_of_domain: ErrorStats | None = None
    bound95: dict | None = None
    bound_note: str | None = None
    per_pose: str | None = None

    @property
    def on_positions(self):
        """Whether the data were positions (else ball-in-socket joint readings)."""
        return self.bound95 is not None or self.bound_note is not None

    def to_dict(self):
        out = {"model": self.model, "method": self.method, "file": self.file, "training_poses": self.training_poses,
               **self.scores, "outside_domain": self.outside_domain, "domain_summary": self.domain_summary}
        if self.in_domain is not None:
            out.update(in_domain=self.in_domain.to_dict(), out_of_domain=self.out_of_domain.to_dict())
        if self.on_positions:
            out["bound95"] = self.bound95
            if self.bound_note is not None:
                out["bound_note"] = self.bound_note
        if self.per_pose is not None:
            out["per_pose"] = self.per_pose
        return out


@dataclass(frozen=True)
class Validated:
    """What ``validate`` measured (:func:`robocal.methods.validation.cross_validate`).

    Attributes
    ----------
    robot, method, file : str
        The robot's name (the report checks a validation against its model's robot by it),
        the method, the measurement file.
    poses, folds : int
        How many poses; how many folds (placements, on ball-in-socket data).
    cross_validation, nominal_cross_validation : dict
        The method's and the registered nominal's held-out figures: ``k``, ``folds`` (per
        fold ``fold``, ``n_train``, ``held_out``: ErrorStats keys, mm), ``pooled``.
    metric : str or None
        On ball-in-socket data, what the figures measure.
    learning_curve : list of dict or None
        With ``--sizes``: per training size ``n_train``, ``n_test``, ``repeats``, ``held_out``,
        ``per_repeat``.
    """

    robot: str
    method: str
    file: str
    poses: int
    folds: int
    cross_validation: dict
    nominal_cross_validation: dict
    metric: str | None = None
    learning_curve: list | None = None

    @classmethod
    def of(cls, robot, result):
        """From the robot's name and :func:`~robocal.methods.validation.cross_validate`'s dict."""
        return cls(robot=robot, **result)

    def to_dict(self):
        out = {"robot": self.robot, "method": self.method, "file": self.file, "poses": self.poses,
               "folds": self.folds}
        if self.metric is not None:
            out["metric"] = self.metric
        out.update(cross_validation=self.cross_validation, nominal_cross_validation=self.nominal_cross_validation)
        if self.learning_curve is not None:
            out["learning_curve"] = self.learning_curve
        return out


@dataclass(frozen=True)
class DatasetWritten:
    """What ``dataset`` wrote.

    Attributes
    ----------
    dataset : str
        The dataset's name; ``poses`` its size; ``source`` the file (or folder) it was read from.
    robot : str
        The robot file written (PREFIX.toml); ``fixture`` the fixture file of ball-in-socket
        data (None for the others).
    measurements : str or None
        The one measurement file, without a split.
    train, test : str or None
        With a split: the two measurement files, ``train_poses`` and ``test_poses`` their
        sizes and, on ball-in-socket data, ``train_placements`` the placements trained on.
    """

    dataset: str
    poses: int
    source: str
    robot: str
    fixture: str | None = None
    measurements: str | None = None
    train: str | None = None
    test: str | None = None
    train_poses: int | None = None
    test_poses: int | None = None
    train_placements: list | None = None
    # ipa-ur10-d: the ISO 9283 campaign written beside it, and how well its tracker frame
    # registered to the commanded poses (robocal.io.ipa_iso).
    iso_campaign: str | None = None
    registration_rms_mm: float | None = None
    probe_mm: list | None = None

    def to_dict(self):
        out = {"dataset": self.dataset, "poses": self.poses, "source": self.source, "robot": self.robot}
        if self.fixture is not None:
            out["fixture"] = self.fixture
        if self.iso_campaign is not None:
            out.update(iso_campaign=self.iso_campaign, registration_rms_mm=self.registration_rms_mm,
                       probe_mm=self.probe_mm)
        if self.train is None:
            out["measurements"] = self.measurements
            return out
        if self.train_placements is not None:
            out["train_placements"] = self.train_placements
        out.update(train=self.train, test=self.test, train_poses=self.train_poses, test_poses=self.test_poses)
        return out


@dataclass(frozen=True)
class Simulated:
    """What ``simulate`` wrote.

    Attributes
    ----------
    robot, sampling, errors, out : str
        The robot's name, the sampling plan (joint, lhs, grid, sockets), the error preset or
        truth file the true robot came from, the measurement file written.
    truth : str or None
        The truth file written (``--truth``).
    poses : int
        How many poses (ball-in-socket: configurations) were measured.
    true_error : ErrorStats or None
        The true robot's position error from the nominal's at the poses (mm); None with
        ``--sampling sockets``, which records joint angles only.
    placements, per_socket : int or None
        ``--sampling sockets``: the fixture placements, and the configurations per socket.
    nominal_socket_consistency : dict or None
        ``--sampling sockets``: the nominal robot's socket consistency on the readings
        (ErrorStats keys and ``socket_distance``, mm).
    """

    robot: str
    sampling: str
    errors: str
    out: str
    truth: str | None
    poses: int
    true_error: ErrorStats | None = None
    placements: int | None = None
    per_socket: int | None = None
    nominal_socket_consistency: dict | None = None

    def to_dict(self):
        if self.true_error is None:
            return {"robot": self.robot, "sampling": self.sampling, "errors": self.errors, "out": self.out,
                    "truth": self.truth, "poses": self.poses, "placements": self.placements,
                    "per_socket": self.per_socket, "nominal_socket_consistency": self.nominal_socket_consistency}
        return {"robot": self.robot, "poses": self.poses, "sampling": self.sampling, "errors": self.errors,
                "out": self.out, "truth": self.truth, "true_error": self.true_error.to_dict()}


@dataclass(frozen=True)
class Filtered:
    """What ``filter`` wrote.

    Attributes
    ----------
    files : list of str
        The filtered programs written (same names as the originals).
    summary : str
        filter-summary.csv, a line per motion.
    targets : int
        How many Cartesian targets were compensated.
    unfiltered : list of str
        The motions computed at run time and left as they were (``file line N: what``).
    outside_domain : int
        Targets outside the model's domain of validity.
    domain_summary : str
        The domain check in one line.
    max_moved_mm : float
        The largest distance a target moved (mm; 0 without targets).
    """

    files: list
    summary: str
    targets: int
    unfiltered: list
    outside_domain: int
    domain_summary: str
    max_moved_mm: float

    def to_dict(self):
        return {"files": list(self.files), "summary": self.summary, "targets": self.targets,
                "unfiltered": list(self.unfiltered), "outside_domain": self.outside_domain,
                "domain_summary": self.domain_summary, "max_moved_mm": self.max_moved_mm}


@dataclass(frozen=True)
class Reported:
    """What ``report`` wrote, and the numbers it shows.

    Attributes
    ----------
    out : str
        The HTML report; ``pdf`` the PDF (None without ``--pdf``).
    figures : list of str
        The figures' titles, in the report's order.
    held_out : bool
        Whether no pose scored is one the model was fitted to.
    model, method, file : str
        The model file, its method, the measurement file scored.
    scores : dict
        The statistics as ``evaluate --json`` prints them (:class:`Evaluated`'s ``scores``,
        mm): the nominal robot's under ``nominal``; on ball-in-socket data the socket
        consistency, with ``metric`` saying so.
    iso9283 : dict or None
        Position data: the ISO 9283-style AP and RP of the ``nominal`` and the
        ``calibrated`` model (mm, :func:`robocal.estimation.metrics.iso9283_position`).
    """

    out: str
    pdf: str | None
    figures: list
    held_out: bool
    model: str
    method: str
    file: str
    scores: dict
    iso9283: dict | None = None

    def to_dict(self):
        extra = {} if self.iso9283 is None else {"iso9283": self.iso9283}
        return {"out": self.out, "pdf": self.pdf, "figures": list(self.figures), "held_out": self.held_out, **extra,
                "model": self.model, "method": self.method, "file": self.file, **self.scores}


@dataclass(frozen=True)
class FleetRun:
    """What ``fleet`` did (:mod:`robocal.interfaces.fleet`).

    Attributes
    ----------
    fleet, out : str
        The fleet file, and the folder written.
    ran_on : str
        Where the robots ran (a local cluster, a scheduler's, or in this process); on
        ``workers`` workers.
    workers : int
    robots : list of dict
        A summary row per robot, in the fleet file's order: the columns of summary.csv
        (``name``, ``status``, ``method``, ``n_train``, ``n_test``, ``mean_mm``, ``max_mm``,
        ``message``) and ``seconds``.
    ok, failed : int
        How many robots succeeded, and failed.
    summary_csv, summary_html : str
        The summary files written.
    """

    fleet: str
    out: str
    ran_on: str
    workers: int
    robots: list
    ok: int
    failed: int
    summary_csv: str
    summary_html: str

    def to_dict(self):
        return {"fleet": self.fleet, "out": self.out, "ran_on": self.ran_on, "workers": self.workers,
                "robots": list(self.robots), "ok": self.ok, "failed": self.failed, "summary_csv": self.summary_csv,
                "summary_html": self.summary_html}


@dataclass(frozen=True)
class CompensatedFigures:
    """The ISO 9283 figures the robot compensated by a model is predicted to reach on a
    campaign (``iso9283 --model``; :mod:`robocal.interfaces.metrology_jobs`).

    Attributes
    ----------
    model, method : str
        The model file and its method.
    note : str
        What the figures mean: predicted from the model's systematic error, not measured.
    figures : Iso9283Result
        The predicted figures (:class:`robocal.acceptance.iso9283.Iso9283Result`; mm, deg).
    """

    model: str
    method: str
    note: str
    figures: Iso9283Result

    def to_dict(self):
        return {"predicted": True, "model": self.model, "method": self.method, "note": self.note,
                **{key: value for key, value in self.figures.to_dict().items() if key != "file"}}


@dataclass(frozen=True)
class Iso9283Figures:
    """What ``iso9283 CAMPAIGN.csv`` measured.

    Attributes
    ----------
    figures : Iso9283Result
        The campaign's measured figures (:class:`robocal.acceptance.iso9283.Iso9283Result`:
        AP, RP per pose, AD, RD; mm, deg).
    compensated : CompensatedFigures or None
        With ``--model``: the compensated robot's predicted figures.
    report : str or None
        With ``--report``: the ISO page written.
    """

    figures: Iso9283Result
    compensated: CompensatedFigures | None = None
    report: str | None = None

    def to_dict(self):
        out = self.figures.to_dict()
        if self.compensated is not None:
            out["compensated"] = self.compensated.to_dict()
        if self.report is not None:
            out["report"] = self.report
        return out
