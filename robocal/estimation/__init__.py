"""Layer 5: estimation — parametric calibration and error models with a fit/predict interface."""
from .kriging import Kriging  # noqa: F401
