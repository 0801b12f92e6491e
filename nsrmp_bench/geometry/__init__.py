"""Geometry: camera projection, 3D object boxes, and 2D box arithmetic (numpy only)."""
