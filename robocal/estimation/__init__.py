"""Layer 5: estimation — parametric calibration and error models with a fit/predict interface."""
from .calibration import KinematicCalibration
from .kriging import Kriging

__all__ = ["KinematicCalibration", "Kriging"]
