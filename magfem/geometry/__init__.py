"""Geometry: robot shapes and field sources as gmsh models, distributed to dolfinx.

Only this package imports gmsh (:mod:`magfem.geometry.gmshio`). Robot
shapes live in :mod:`magfem.geometry.shapes`, one module each.
"""
