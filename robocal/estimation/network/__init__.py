"""Neural-network error model trained by a genetic algorithm (docs/ARCHITECTURE.md; the ann method).

:class:`NetworkErrorModel` maps joint vectors to position errors; :mod:`.genetic` holds the
GA (binary encoding, adaptive crossover and mutation, elitism), :mod:`.mlp` the batched
network with switchable hidden neurons.  Joint-space compensation with such a model is
:func:`robocal.compensation.joint_space.correct_joints`.
"""
from .genetic import Encoding, Fitness, GeneticAlgorithm, adaptive_probability
from .mlp import Layout
from .model import NetworkErrorModel

__all__ = ["Encoding", "Fitness", "GeneticAlgorithm", "Layout", "NetworkErrorModel",
           "adaptive_probability"]
