"""robocal: calibration and error compensation for industrial robots.

Layers (each depends only on those above it): ``spatial`` (rigid-body math), ``kinematics``
(chains, Jacobians, IK, conversions), ``io`` (robot, measurement and dataset files),
``simulation``, ``estimation`` (calibration and error models), ``compensation``, and
``interfaces`` (command line, reports, model files).
"""
__version__ = "0.1.0"
