"""Geometry: gmsh builders for robots and field sources, distributed to dolfinx.

Only this package imports gmsh.
"""
