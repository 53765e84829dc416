"""Layer 2: kinematic chains (DH, MDH, POE), forward kinematics, Jacobians, conversions, IK."""
from .chain import Chain
from .conversions import to_dh, to_mdh, to_poe

__all__ = ["Chain", "to_dh", "to_mdh", "to_poe"]
