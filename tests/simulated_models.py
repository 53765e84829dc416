"""Simulated robots and models several test files start from, built one way."""
import numpy as np

from robocal.io.library import load_robot
from robocal.methods import make_method
from robocal.methods.fallback import wrap
from robocal.simulation import make_true_robot, uniform_joints


def with_deviations(truth, changes):
    """The same true robot with some parameters changed further (file units: mm, deg), as a
    new set-up or a changed robot would have them."""
    import dataclasses

    deviations = dict(truth.deviations)
    for name, value in changes.items():
        deviations[name] = deviations.get(name, 0.0) + value
    return dataclasses.replace(truth, deviations=deviations)


def ur5_auto_model(seed=5):
    """A UR5 with the typical errors measured with q1 in the lower half of its range (90 poses)
    and an auto-like model fitted there: full+gains inside its domain, full+compliance
    outside.  Returns (chain, truth, rng, train, model, fallback); ``rng`` is the generator
    the poses were drawn with, for the caller's further draws."""
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=seed)
    rng = np.random.default_rng(seed)
    q = uniform_joints(chain, 200, rng)
    train = truth.observations(q[q[:, 0] < 0.0][:90], rng)
    fallback = make_method("kinematic", parameters="full+compliance").fit(chain, train)
    model = wrap(make_method("kinematic", parameters="full+gains").fit(chain, train), fallback,
                 "kinematic full+compliance")
    return chain, truth, rng, train, model, fallback
