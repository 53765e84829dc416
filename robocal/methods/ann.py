"""A neural network of the position error over the joint vector, trained by a genetic
algorithm (then L-BFGS unless told otherwise), compensated in joint space."""
from ..compensation import Compensator
from ..estimation.metrics import error_stats
from ..estimation.network import NetworkErrorModel
from ..errors import InputError
from ..settings import Choice, Number, Numbers, Setting
from .base import LOSS, PARAMETERS, PAYLOAD, RANDOM_STATE, Method, require_distinct, require_positions
from .candidacy import Candidate
from .records import FitRecord, ReportFigure
from .frames import measurement_frame
from .kinematic import KinematicMethod

BASE_MODELS = ("nominal", "kinematic")
TRAINERS = ("ga", "lbfgs")
REFINERS = ("lbfgs", "none")
DOCUMENT_TYPE = "network"
# The network's 16-16 hidden layers have 435 weights; with fewer training poses than this
# (each gives three equations) it fits noise rather than the robot's error.
NETWORK_MIN_POSES = 500
# The network's genetic algorithm runs this many generations in a comparison (its default is
# 300): held out on the UR5's 1,000 poses, 5 random folds, two seeds, 150 generations gave
# 0.0957 / 0.0932 mm against 0.0963 / 0.0974 with 300, in 10 s of CPU instead of 17.  What
# compare scores is what auto fits: the candidate's settings.
NETWORK_GENERATIONS = 150

HIDDEN = Setting("hidden", (16, 16), "--hidden", "hidden layer widths, at least two",
                 Numbers(whole=True, at_least=1, at_least_count=2, example="16,16", at_most=256, at_most_count=8))
GENERATIONS = Setting("generations", 300, "--generations", "generation limit of the genetic algorithm",
                      Number(whole=True, at_least=0, at_most=10_000,
                             advice="300 take about 3.5 s on 1,000 poses and the L-BFGS refinement does what more "
                                    "would; for a longer search run several --seed values"))
TRAINER = Setting("trainer", "ga", "--trainer", "ga (genetic algorithm) or lbfgs (gradient from random starts)",
                  Choice(TRAINERS))
REFINE = Setting("refine", "lbfgs", "--refine", "refine the GA's best network by lbfgs, or none", Choice(REFINERS))
BASE_MODEL = Setting("base_model", "nominal", "--base-model",
                     "the network learns the error of the nominal robot or of the kinematic calibration",
                     Choice(BASE_MODELS))


class NetworkMethod(Method):
    """The GA-trained network of :class:`~robocal.estimation.network.NetworkErrorModel`.

    base_model: 'nominal' (registered in the measurement frame when needed: the method as
    specified) or 'kinematic' (the parametric calibration first, with its settings; the
    network learns what it leaves).  ``fit``'s ``progress(best=fitness)`` is called once per
    generation.
    """

    name = "ann"
    description = "network of the error over the joints, trained by a genetic algorithm, joint-space compensation"
    settings = KinematicMethod.settings + (BASE_MODEL, HIDDEN, GENERATIONS, TRAINER, REFINE, RANDOM_STATE)

    @classmethod
    def candidates(cls, chain, observations, training, forced=None):
        """Position data with NETWORK_MIN_POSES training poses or more (``forced`` {'ann':
        True/False} forces it in or out), trained for NETWORK_GENERATIONS generations."""
        wanted = (forced or {}).get(cls.name)
        if observations.positions is None:
            return [], []
        if wanted if wanted is not None else training >= NETWORK_MIN_POSES:
            return [Candidate(cls.name, cls.name, {"generations": NETWORK_GENERATIONS})], []
        if wanted is None:
            return [], [f"ann left out: the training folds hold {training} poses, fewer than the {NETWORK_MIN_POSES} "
                        "its 435 weights need (--network includes it)"]
        return [], []

    @property
    def progress_label(self):
        return "genetic algorithm, generation" if self.trainer == "ga" else "fitting the network"

    def progress_total(self):
        return self.generations if self.trainer == "ga" else None

    def network(self):
        """The unfitted :class:`NetworkErrorModel` these settings ask for."""
        return NetworkErrorModel(hidden=tuple(int(w) for w in self.hidden), trainer=self.trainer,
                                 refine=None if self.refine == "none" else self.refine,
                                 generations=self.generations, random_state=self.random_state)

    def _fit(self, chain, observations, progress):
        obs = require_distinct(require_positions(observations, self.name), self.name)
        unused = [s.option for s in (PARAMETERS, LOSS, PAYLOAD) if getattr(self, s.name) != s.default]
        if self.base_model == "nominal" and unused:
            raise InputError(f"{', '.join(unused)} set the network's kinematic base model: add --base-model kinematic")
        network = self.network()
        if self.base_model == "kinematic":
            base = KinematicMethod(**{s.name: getattr(self, s.name) for s in KinematicMethod.settings})
            base.fit(chain, obs)
            model_chain, reference, record = base.compensator_.chain, base.reference_, base.record_.to_dict()
        else:
            model_chain, record = measurement_frame(chain, obs.joints, obs.positions, self.register)
            reference = model_chain
        errors = obs.positions - model_chain.fk_positions(obs.joints)
        callback = None if progress is None else (lambda generation, fitness: progress(best=fitness))
        network.fit(obs.joints, errors, progress=callback)
        record.update(base_model=self.base_model, network=network.training_,
                      residual_after_training=error_stats(errors - network.predict(obs.joints)).to_dict())
        record.setdefault("residual_before", error_stats(errors).to_dict())
        self.compensator_ = Compensator(model_chain, network, nominal=chain, error_input="joints", controller=chain,
                                        reference=reference)
        self.reference_ = reference
        self.record_ = FitRecord.from_dict(record)
        return self

    def error_model_document(self):
        return {"type": DOCUMENT_TYPE, "input": "joints", "parameters": self.compensator_.error_model.to_dict()}

    @classmethod
    def error_model_from_document(cls, document, path):
        if not isinstance(document, dict) or document.get("type") != DOCUMENT_TYPE:
            raise ValueError(f"expected a {DOCUMENT_TYPE} error model")
        return NetworkErrorModel.from_dict(document["parameters"]), "joints"

    def report_figures(self, joints):
        history = getattr(self.compensator_.error_model, "history_", None)
        if not history:
            return []
        return [ReportFigure("fitness_history", "Genetic algorithm", "Best fitness per generation.",
                             {"history": history})]
