"""Ready-made true robots: ``none``, ``typical`` and ``liu2022``.

``typical`` is an industrial arm as it leaves the factory without calibration:

* every link parameter off by a few tenths of a mm (sigma 0.2 mm) or a few hundredths of a
  degree (sigma 0.02 deg); base and tool frames off by a few mm (sigma 2 mm) and a few tenths
  of a degree (sigma 0.2 deg), all drawn from a normal distribution with ``seed``;
* joint compliance of a 150 kg-class arm (a KUKA KR 150-2: 3.46 m of links, about 1000 kg of
  moving structure, 150 kg rated payload, joints of 1e8 N·m/rad — stiff because the second
  axis of such arms is counterbalanced).  The moving mass is spread over the links in
  proportion to their length; another robot gets the same design scaled to its size s
  (its total link length over 3.46 m): masses and payload by s³ and stiffness by s⁴, so
  every joint deflects by the same angle under its own rated load (prismatic joints stay
  rigid).  The KR 150-2 itself,
  stretched out horizontally with its payload, deflects 0.4 mm at the TCP;
* backlash of 0.005 deg at every joint and laser-tracker noise of 0.02 mm (0.01 deg on
  orientations, as a 6-DoF probe gives).

``liu2022`` is the published KR 150-2 experiment (:mod:`robocal.simulation.liu2022`).
"""
import numpy as np

from ..errors import InputError
from ..kinematics.gravity import scaled_mass_model, size_factor
from . import liu2022
from .joint_effects import Compliance
from .true_robot import TrueRobot

PRESETS = ("none", "typical", "liu2022")

LINK_LENGTH_SIGMA = 0.2  # mm
LINK_ANGLE_SIGMA = 0.02  # deg
FRAME_LENGTH_SIGMA = 2.0  # mm, base and tool
FRAME_ANGLE_SIGMA = 0.2  # deg, base and tool
REFERENCE_STIFFNESS = 1e8  # N·m/rad
BACKLASH = 0.005  # deg, half-width
NOISE = 0.02  # mm
NOISE_ORIENTATION = 0.01  # deg


def make_true_robot(chain, preset, seed=0):
    """A :class:`TrueRobot` for ``chain`` (the nominal model) from a named preset.

    preset: ``none`` (the nominal robot itself, exact), ``typical`` or ``liu2022`` (only
    for the KUKA KR 150-2).  seed: draws the ``typical`` deviations.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be a whole number >= 0, got {seed!r}")
    if preset == "none":
        return TrueRobot(nominal=chain, preset="none")
    if preset == "typical":
        return TrueRobot(
            nominal=chain,
            deviations=_typical_deviations(chain, np.random.default_rng(seed)),
            compliance=_typical_compliance(chain),
            backlash=np.where(chain.revolute, BACKLASH, 0.0),
            noise=NOISE,
            noise_orientation=NOISE_ORIENTATION,
            seed=seed,
            preset="typical",
        )
    if preset == "liu2022":
        liu2022.require_kr150(chain, "the liu2022 preset")
        return TrueRobot(nominal=chain, deviations=liu2022.deviations(), preset="liu2022")
    raise InputError(f"unknown error preset {preset!r}: use one of {', '.join(PRESETS)}")


def _typical_deviations(chain, rng):
    """Normal deviations of every parameter, in file units (mm, deg)."""
    groups = ("links", "base", "tool") + (("home",) if chain.convention == "poe" else ())
    names = chain.parameter_names(groups)
    frame = np.array([name.startswith(("base_", "tool_")) for name in names])
    angular = np.array([chain.is_angular(name) for name in names])
    sigma = np.where(frame, np.where(angular, FRAME_ANGLE_SIGMA, FRAME_LENGTH_SIGMA),
                     np.where(angular, LINK_ANGLE_SIGMA, LINK_LENGTH_SIGMA))
    return dict(zip(names, rng.normal(scale=sigma).tolist()))


def _typical_compliance(chain):
    """The 150 kg-class compliance scaled to ``chain``'s size (see the module docstring)."""
    mass = scaled_mass_model(chain)
    return Compliance(
        # Prismatic joints (rare on such arms) are left rigid.
        stiffness=np.where(chain.revolute, REFERENCE_STIFFNESS * size_factor(chain)**4, np.inf),
        link_masses=mass.link_masses,
        payload=mass.payload,
    )
