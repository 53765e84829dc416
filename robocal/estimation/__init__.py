"""Layer 5: estimation — parametric calibration (from a measuring instrument or from
ball-in-socket constraints) and error models with a fit/predict interface."""
from .calibration import KinematicCalibration
from .constraint import ConstraintCalibration
from .kriging import Kriging
from .network import NetworkErrorModel

__all__ = ["ConstraintCalibration", "KinematicCalibration", "Kriging", "NetworkErrorModel"]
