"""robocal: calibration and error compensation for industrial robots.

Layers (each depends only on those above it): ``spatial`` (rigid-body math), ``kinematics``
(chains, Jacobians, IK, conversions), ``io`` (robot, measurement, model and dataset files;
units converted here), ``simulation``, ``estimation`` (calibration and error models),
``compensation``, ``methods`` (one class per method, and the registry) and ``interfaces``
(command line, reports).  docs/ARCHITECTURE.md is the map.
"""
__version__ = "0.1.0"
