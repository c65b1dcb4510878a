"""Terrain: height fields (`iguana_ros.terrain.heightfield.HeightField`), plane and residual fitting."""
