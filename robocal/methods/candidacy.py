"""How a method says whether and how it is compared (``robocal compare``, ``calibrate
--method auto``): its classmethod ``candidates(chain, observations, training, forced)``
returns (a list of :class:`Candidate`, notes), so that a new method is compared with no edit
to :mod:`robocal.methods.selection`.

``training`` is how many poses a fit of the comparison sees at the least (for what a method
offers at all: the network below 500, Kriging above 1,500); a candidate whose fit needs more
than its fits see (``minimum_poses``) is left out by the selection, with a note that says
how many poses to measure.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# The kinematic parameter sets compared, the default calibration first (the model every
# other must beat), then simplest to richest.
PARAMETER_SETS = ("full", "offsets", "full+gains", "full+compliance", "full+compliance+gains")
# How far each set models the robot, for ranking models the held-out errors cannot tell apart.
RICHNESS = ("offsets", "full", "full+gains", "full+compliance", "full+compliance+gains")


@dataclass(frozen=True)
class Candidate:
    """One model compared: its ``label`` in tables, the registered ``method`` and its
    ``settings``, the ``base`` label a residual model must beat (None for the others),
    ``minimum_poses``: the fewest training poses its fit takes, and ``linear``: whether it is
    a linearised least-squares fit whose held-out errors on a small campaign come from its
    fit on every pose (:mod:`robocal.methods.scoring`)."""

    label: str
    method: str
    settings: dict
    base: str | None = None
    minimum_poses: int = 0
    linear: bool = False

    def richness(self):
        """What the candidate models, for ranking those the held-out errors cannot tell apart:
        a residual on a kinematic model above the kinematic model, then the parameter set."""
        parameters = self.settings.get("parameters")
        return (self.base is not None, RICHNESS.index(parameters) if parameters in RICHNESS else -1)


def parameter_count(chain, observations, parameters):
    """How many parameters a calibration of ``parameters`` identifies at most from
    ``observations`` of ``chain`` (with the compliances of the joints they load)."""
    from ..estimation.calibration import candidate_parameters, parameter_terms
    from ..kinematics.compliant import with_compliance

    rotations = getattr(observations, "rotations", None) is not None
    count = len(candidate_parameters(chain, parameters, tool_orientation=rotations))
    if "compliance" in parameter_terms(parameters):
        count += len(with_compliance(chain, observations.joints)[1])
    return count


def kinematic_candidates(name, chain, observations, sets=PARAMETER_SETS, linear=False):
    """The candidates of a parametric calibration called ``name``, one per parameter set in
    ``sets``, each needing as many equations as parameters (3 a pose, 6 with orientations), as
    its calibration asks; ``linear``: scored by deletion on small campaigns."""
    rows = 6 if getattr(observations, "rotations", None) is not None else 3
    return [Candidate(f"{name} {parameters}", name, {"parameters": parameters},
                      minimum_poses=int(np.ceil(parameter_count(chain, observations, parameters) / rows)),
                      linear=linear) for parameters in sets]


# Error models of a residual are compared over the joints' sines and cosines (what holds on
# another arm branch) and, for Kriging alone, over the TCP position (the paper's form).
RESIDUAL_INPUTS = "sincos"
# Kriging keeps per input dimension an n x n matrix of squared differences while it searches
# its hyperparameters (216 MB at 1,500 poses over the 12 sines and cosines of a 6-axis arm):
# beyond this many training poses the Kriging-based models are left out of a comparison.
KRIGING_MAX_POSES = 1500


def kriging_too_many(training):
    """The note that leaves Kriging-based models out beyond KRIGING_MAX_POSES training poses,
    or None."""
    if training <= KRIGING_MAX_POSES:
        return None
    return (f"hybrid and kriging left out: the training folds hold {training} poses, more than the "
            f"{KRIGING_MAX_POSES} Kriging is fitted on here (compare a random subset of the file to see them)")


# Kriging's hyperparameters (one length scale per input) are learnt from the data: a Gaussian
# process needs about ten points per input dimension for them (Loeppky, Sacks & Welch 2009,
# "Choosing the sample size of a computer experiment"): 30 over the TCP position; over the
# joints, or their sines and cosines (two coordinates of one angle), ten per joint (60 for a
# 6-axis arm).
POINTS_PER_DIMENSION = 10


def kriging_minimum(chain, inputs):
    """The fewest training poses a Kriging over ``inputs`` is compared with."""
    return POINTS_PER_DIMENSION * (3 if inputs == "position" else chain.n_joints)
