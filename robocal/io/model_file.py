"""Model files: one versioned JSON document per calibrated model.

Layout (schema 1; schema 2 when it has ``outside_domain``)::

    {"schema": "robocal.model", "schema_version": 1, "software_version": "...",
     "created": "2026-11-22T04:30:00Z", "method": "kriging",
     "robot": {"name": ..., "hash": ..., "model": {robot document}},     # the nominal robot
     "kinematics": {robot document},        # the chain compensation uses (registered/calibrated)
     "joint_compliance": {...} or absent,   # full+compliance: masses (kg), compliances (urad/(N*m))
     "reference": {robot document},         # nominal geometry in the measurement frame
     "error_model": {...} or null,          # e.g. Kriging.to_dict()
     "training": {...}, "options": {...},
     "domain": {...} or absent,             # the training data's domain of validity (deg, mm)
     "outside_domain": {...} or absent,     # schema 2: what answers beyond the domain
     "bound": {...} or absent,              # the 95 % bound on the position error
     "checksum": "sha256 of everything above"}

``outside_domain`` (``calibrate --method auto``, :mod:`robocal.methods.fallback`) holds a
parametric calibration — ``label``, ``kinematics``, ``reference`` and ``joint_compliance``
as above — that answers for configurations outside the domain, and optionally, in the same
form, its ``alternative``: the other parametric model auto chose between, which a
re-registration may take instead.  A file that has it is
written as schema 2, so that a robocal that would ignore it refuses the file instead.

Robot documents are the robot-TOML structure (mm, deg) as JSON.  Loading validates all of it
and refuses, with a message, a file of another robot, a newer schema, or one that was edited
or truncated (checksum, missing keys, arrays of the wrong shape), and, since an editor can
recompute the checksum, one whose entries have the wrong types (:mod:`.model_schema`, in one
line naming the entry).  Nothing is ever unpickled.
"""
import datetime as _dt
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

from .. import __version__
from ..errors import FileFormatError, InputError
from .atomic import write_text_atomic
from .file_kinds import check
from .reading import read_text
from .robot_file import chain_from_dict, chain_to_dict, robot_to_toml
from ..kinematics.chain import Chain
from ..kinematics.compliant import CompliantChain
from .model_schema import check_document


SCHEMA = "robocal.model"
SCHEMA_VERSION = 2
# Files without an outside_domain entry are written as schema 1, readable by older robocal.
PLAIN_SCHEMA_VERSION = 1


def robot_hash(chain):
    """A short fingerprint of a robot's nominal geometry, frames and joint map."""
    # Names (the robot's, its joints') are not geometry: renaming changes no model.
    text = robot_to_toml(chain.replace(name="robot", joint_names=None))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _canonical(document):
    return json.dumps(document, sort_keys=True, separators=(",", ":"), allow_nan=False)


@dataclass(frozen=True)
class ModelFile:
    """The content of a model file, with the chains rebuilt.  Frozen: a changed copy is
    ``dataclasses.replace(model, bound=...)``.

    Attributes
    ----------
    method : str
        The method's registry name (:mod:`robocal.methods`).
    nominal : Chain
        The robot the file belongs to, as its robot file describes it.
    kinematics : Chain or CompliantChain
        The chain compensation uses (registered or calibrated).
    error_model : dict or None
        The method's error-model document (e.g. ``Kriging.to_dict``), or None.
    reference : Chain or None
        The nominal geometry in the measurement frame ("before"); None: ``kinematics``.
    training, options : dict
        What the fit did and on which data (``FitRecord.to_dict`` and the data's file, poses,
        kind); the method's settings by keyword.
    domain : dict or None
        The domain of validity (``Domain.to_dict``: deg, mm); None in files written before
        robocal recorded it.
    outside : (str, Chain, Chain) or None
        What answers beyond the domain: its label, kinematics and reference.
    outside_alternative : (str, Chain, Chain) or None
        The other parametric model auto could have answered with there (the same form),
        which a re-registration's new poses may prefer (robocal.methods.reregistration).
    bound : dict or None
        The 95 % bound on the position error (``PositionBound.to_dict``; for ball-in-socket
        data, on the socket consistency); None in files written before robocal computed one.
    created, software_version : str
        When and by which robocal the file was written ("" for created: now, at saving).
    """

    method: str
    nominal: Chain
    kinematics: Chain
    error_model: dict | None = None
    reference: Chain | None = None
    training: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    domain: dict | None = None
    outside: tuple[str, Chain, Chain] | None = None
    outside_alternative: tuple[str, Chain, Chain] | None = None
    bound: dict | None = None
    created: str = ""
    software_version: str = __version__

    def to_document(self):
        doc = {
            "schema": SCHEMA,
            "schema_version": PLAIN_SCHEMA_VERSION if self.outside is None else SCHEMA_VERSION,
            "software_version": self.software_version,
            "created": self.created or _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "method": self.method,
            "robot": {"name": self.nominal.name, "hash": robot_hash(self.nominal),
                      "model": chain_to_dict(self.nominal)},
            "kinematics": chain_to_dict(self.kinematics),
            "reference": chain_to_dict(self.reference if self.reference is not None else self.kinematics),
            "error_model": self.error_model,
            "training": self.training,
            "options": self.options,
        }
        if isinstance(self.kinematics, CompliantChain):
            doc["joint_compliance"] = self.kinematics.compliance_document()
        if self.domain is not None:
            doc["domain"] = self.domain
        if self.bound is not None:
            doc["bound"] = self.bound
        if self.outside is not None:
            doc["outside_domain"] = _parametric_document(*self.outside)
            if self.outside_alternative is not None:
                doc["outside_domain"]["alternative"] = _parametric_document(*self.outside_alternative)
        doc["checksum"] = hashlib.sha256(_canonical(doc).encode()).hexdigest()
        return doc


def _parametric_document(label, chain, reference):
    """The ``outside_domain`` entry (or its ``alternative``) of a parametric model."""
    document = {"label": label, "kinematics": chain_to_dict(chain), "reference": chain_to_dict(reference)}
    if isinstance(chain, CompliantChain):
        document["joint_compliance"] = chain.compliance_document()
    return document


def save_model(model: ModelFile, path):
    """Write a model file atomically."""
    try:
        text = json.dumps(model.to_document(), indent=1, allow_nan=False)
    except ValueError as exc:
        raise InputError(f"the model contains NaN or infinite values and cannot be saved ({exc})") from None
    write_text_atomic(path, text + "\n")


def _require(doc, key, kind, path, where="the model file"):
    if key not in doc:
        raise FileFormatError(f"{path}: {where} has no '{key}': the file is truncated or was edited; "
                              "regenerate it with 'robocal calibrate'")
    if not isinstance(doc[key], kind):
        raise FileFormatError(f"{path}: '{key}' in {where} has the wrong type; regenerate the file")
    return doc[key]


def load_model(path, robot=None) -> ModelFile:
    """Read and validate a model file; ``robot`` (a Chain) must be the robot it belongs to."""
    path = Path(path)
    try:
        text = read_text(path, "model file", "model", lines=False)
    except FileFormatError as exc:
        if not path.is_file():  # missing, a directory, a device: said as for every file
            raise
        raise FileFormatError(f"{path}: not a robocal model file ({str(exc).replace(str(path), 'it')})") from None
    check(path, "model", text=text)
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{path}: not a robocal model file (not JSON: {exc})") from None
    except RecursionError:
        raise FileFormatError(f"{path}: not a robocal model file (its JSON nests thousands of levels deep)") from None
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
        raise FileFormatError(f"{path}: not a robocal model file (no \"schema\": \"{SCHEMA}\")")
    version = _require(doc, "schema_version", int, path)
    if version > SCHEMA_VERSION:
        raise FileFormatError(
            f"{path}: schema version {version} is newer than this robocal understands ({SCHEMA_VERSION}); "
            "upgrade robocal"
        )
    checksum = _require(doc, "checksum", str, path)
    body = {k: v for k, v in doc.items() if k != "checksum"}
    try:
        canonical = _canonical(body)
    except ValueError:  # NaN or infinity: robocal never writes them
        raise FileFormatError(f"{path}: the file holds NaN or infinite numbers, which robocal never writes: it was "
                              "modified; regenerate it with 'robocal calibrate'") from None
    if hashlib.sha256(canonical.encode()).hexdigest() != checksum:
        raise FileFormatError(f"{path}: the checksum does not match: the file was modified after robocal "
                              "wrote it; regenerate it with 'robocal calibrate'")
    # A matching checksum proves nothing of the entries' types (an editor may recompute it).
    check_document(doc, path)
    # Which methods exist is the methods registry's to say (robocal.methods.load_fitted).
    method = _require(doc, "method", str, path)
    robot_doc = _require(doc, "robot", dict, path)
    nominal = chain_from_dict(_require(robot_doc, "model", dict, path, "'robot'"), f"{path} (robot)")
    kinematics = chain_from_dict(_require(doc, "kinematics", dict, path), f"{path} (kinematics)")
    reference = (chain_from_dict(doc["reference"], f"{path} (reference)") if isinstance(doc.get("reference"), dict)
                 else kinematics)
    if "joint_compliance" in doc:
        kinematics = CompliantChain.from_document(kinematics, _require(doc, "joint_compliance", dict, path), path)
    if kinematics.n_joints != nominal.n_joints:
        raise FileFormatError(f"{path}: the calibrated kinematics and the robot have different joint counts")
    if robot is not None and robot_hash(robot) != robot_doc.get("hash"):
        raise InputError(
            f"{path} belongs to robot '{robot_doc.get('name')}' (hash {robot_doc.get('hash')}), "
            f"not to '{robot.name}' (hash {robot_hash(robot)}): use the model calibrated for this robot"
        )
    error_model = doc.get("error_model")
    if error_model is not None and not isinstance(error_model, dict):
        raise FileFormatError(f"{path}: 'error_model' has the wrong type; regenerate the file")
    domain = doc.get("domain")
    if domain is not None and not isinstance(domain, dict):
        raise FileFormatError(f"{path}: 'domain' has the wrong type; regenerate the file")
    bound = doc.get("bound")
    if bound is not None and not isinstance(bound, dict):
        raise FileFormatError(f"{path}: 'bound' has the wrong type; regenerate the file")
    outside = alternative = None
    if "outside_domain" in doc:
        entry = _require(doc, "outside_domain", dict, path)
        outside = _parametric_entry(entry, "'outside_domain'", nominal, path)
        if "alternative" in entry:
            alternative = _parametric_entry(_require(entry, "alternative", dict, path, "'outside_domain'"),
                                            "'outside_domain.alternative'", nominal, path)
    return ModelFile(
        method=method, nominal=nominal, kinematics=kinematics, error_model=error_model, reference=reference,
        training=doc.get("training") or {}, options=doc.get("options") or {}, domain=domain, outside=outside,
        outside_alternative=alternative, bound=bound, created=doc.get("created", ""),
        software_version=doc.get("software_version", ""),
    )


def _parametric_entry(entry, where, nominal, path):
    """(label, kinematics Chain, reference Chain) of a parametric model stored in ``entry``
    (``outside_domain`` and its ``alternative``)."""
    label = _require(entry, "label", str, path, where)
    chain = chain_from_dict(_require(entry, "kinematics", dict, path, where), f"{path} ({where})")
    reference = chain_from_dict(_require(entry, "reference", dict, path, where), f"{path} ({where} reference)")
    if "joint_compliance" in entry:
        chain = CompliantChain.from_document(chain, _require(entry, "joint_compliance", dict, path, where), path)
    if chain.n_joints != nominal.n_joints:
        raise FileFormatError(f"{path}: the kinematics of {where} and the robot have different joint counts")
    return label, chain, reference
