"""Layer 3: the edge — robot, URDF, measurement, target, command, fixture and model files, the
packaged real datasets, and observations converted once into internal units (mm, rad)."""
