"""gmsh geometry of field sources in their air region: axisymmetric (r, z) and 3D.

Builders return a function ``builder(gmsh)`` for
:func:`magfem.geometry.gmshio.build_mesh`; they run on rank 0 only.

Axisymmetric: the half-disk {r ≥ 0, r² + z² ≤ R_air²} of the (r, z) plane
(gdim = 2, x = r, y = z) containing the windings / magnets as rectangles
(physical groups by name, e.g. ``coil_1``, ``coil_2``, ``magnet``) and
``air``. 3D: a ball of radius R_air with box magnets (``magnet``) in ``air``.

Element size: ``h_source`` in and near the sources, ``h_workspace`` in the
robot's workspace box, growing linearly with the distance from the sources
up to ``R_air / 8`` at the outer boundary, so large air regions cost few
elements (the truncation error of the open boundary is measured in
docs/field.md).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["BoxRegion", "RectRegion", "axisymmetric_builder", "solid_builder"]


@dataclass(frozen=True)
class RectRegion:
    """A rectangle [r0, r1] × [z0, z1] (m) of the (r, z) half-plane, physical group ``name``."""

    name: str
    r0: float
    r1: float
    z0: float
    z1: float


@dataclass(frozen=True)
class BoxRegion:
    """A box of edges ``size`` (3,) centred at ``center`` with orientation ``rotation``.

    ``rotation`` (3, 3): columns are the box's local x, y, z axes (m).
    """

    name: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]
    rotation: tuple[tuple[float, ...], ...]


def _name_pieces(
    gmsh: Any, dim: int, names: Sequence[str], pieces: Sequence[Sequence[tuple[int, int]]]
) -> list[int]:
    """Physical groups after ``occ.fragment``: each source's pieces under its name, the rest "air".

    Args:
        dim: dimension of the regions (2: axisymmetric, 3: solid).
        names: group name of each source (sources may share a name).
        pieces: per source, the (dim, tag) pairs it became in the fragment
            (``mapping[1:]`` of ``occ.fragment`` with the air region first).

    Returns:
        The sorted tags of all source pieces.
    """
    named: dict[str, list[int]] = {}
    used: set[int] = set()
    for name, piece in zip(names, pieces, strict=True):
        tags = [t for d, t in piece if d == dim]
        named.setdefault(name, []).extend(tags)
        used.update(tags)
    air = [t for d, t in gmsh.model.getEntities(dim) if t not in used]
    for name, tags in named.items():
        gmsh.model.addPhysicalGroup(dim, tags, name=name)
    gmsh.model.addPhysicalGroup(dim, air, name="air")
    return sorted(used)


def _size_fields(
    gmsh: Any,
    dim: int,
    source_entities: list[int],
    h_source: float,
    r_air: float,
    box: np.ndarray | None,
    h_workspace: float | None,
) -> None:
    """Background size: fine at the sources, graded with distance, refined in the workspace box."""
    f = gmsh.model.mesh.field
    dist = f.add("Distance")
    if dim == 2:
        curves = gmsh.model.getBoundary([(2, s) for s in source_entities], oriented=False)
        f.setNumbers(dist, "CurvesList", [abs(c[1]) for c in curves])
    else:
        f.setNumbers(dist, "SurfacesList", source_entities)
    f.setNumber(dist, "Sampling", 40)
    thr = f.add("Threshold")
    f.setNumber(thr, "InField", dist)
    f.setNumber(thr, "SizeMin", h_source)
    f.setNumber(thr, "SizeMax", r_air / 8)
    f.setNumber(thr, "DistMin", h_source)
    f.setNumber(thr, "DistMax", r_air)
    fields = [thr]
    if dim == 3:  # field singular (log) at a magnet's edges: refine them further
        edges = gmsh.model.getBoundary(
            [(2, s) for s in source_entities], combined=False, oriented=False
        )
        dist_e = f.add("Distance")
        f.setNumbers(dist_e, "CurvesList", sorted({abs(e[1]) for e in edges}))
        f.setNumber(dist_e, "Sampling", 40)
        thr_e = f.add("Threshold")
        f.setNumber(thr_e, "InField", dist_e)
        f.setNumber(thr_e, "SizeMin", h_source / 3)
        f.setNumber(thr_e, "SizeMax", r_air / 8)
        f.setNumber(thr_e, "DistMin", h_source / 3)
        f.setNumber(thr_e, "DistMax", r_air)
        fields.append(thr_e)
    if box is not None and h_workspace is not None:
        b = f.add("Box")
        f.setNumber(b, "VIn", h_workspace)
        f.setNumber(b, "VOut", r_air)
        lo, hi = box
        for k, ax in enumerate("XYZ"[:3]):
            lo_k = lo[k] if k < dim else -1.0
            hi_k = hi[k] if k < dim else 1.0
            f.setNumber(b, f"{ax}Min", float(lo_k))
            f.setNumber(b, f"{ax}Max", float(hi_k))
        f.setNumber(b, "Thickness", float(np.max(hi - lo)))
        fields.append(b)
    mn = f.add("Min")
    f.setNumbers(mn, "FieldsList", fields)
    f.setAsBackgroundMesh(mn)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


def axisymmetric_builder(
    regions: Sequence[RectRegion],
    r_air: float,
    *,
    h_source: float,
    workspace: np.ndarray | None = None,
    h_workspace: float | None = None,
) -> Callable[[Any], None]:
    """Builder of the (r, z) half-disk of radius ``r_air`` (m) containing ``regions``.

    Args:
        regions: source rectangles (must lie inside the half-disk, r0 >= 0).
        r_air: radius of the air region, m.
        h_source: element size in/near the sources, m.
        workspace: optional (2, 2) box [[r_min, z_min], [r_max, z_max]] refined to ``h_workspace``.
        h_workspace: element size in ``workspace``, m.
    """
    regions = list(regions)
    for reg in regions:
        corners = np.array([[reg.r1, reg.z0], [reg.r1, reg.z1]])
        if reg.r0 < 0 or not reg.r1 > reg.r0 or not reg.z1 > reg.z0:
            raise ValueError(f"region {reg.name}: empty or crosses the axis")
        if np.any(np.linalg.norm(corners, axis=1) >= r_air):
            raise ValueError(f"region {reg.name} reaches the outer boundary r_air = {r_air:g} m")

    def build(gmsh: Any) -> None:
        occ = gmsh.model.occ
        disk = occ.addDisk(0, 0, 0, r_air, r_air)
        left = occ.addRectangle(-r_air, -r_air, 0, r_air, 2 * r_air)
        half, _ = occ.cut([(2, disk)], [(2, left)])
        rects = [occ.addRectangle(g.r0, g.z0, 0, g.r1 - g.r0, g.z1 - g.z0) for g in regions]
        _, mapping = occ.fragment(half, [(2, t) for t in rects])
        occ.synchronize()
        used = _name_pieces(gmsh, 2, [g.name for g in regions], mapping[1:])
        _size_fields(gmsh, 2, used, h_source, r_air, workspace, h_workspace)
        gmsh.model.mesh.generate(2)

    return build


def solid_builder(
    boxes: Sequence[BoxRegion],
    r_air: float,
    *,
    center: Sequence[float] = (0.0, 0.0, 0.0),
    h_source: float,
    workspace: np.ndarray | None = None,
    h_workspace: float | None = None,
) -> Callable[[Any], None]:
    """Builder of a ball of radius ``r_air`` (m) about ``center`` containing box magnets.

    Args:
        boxes: magnets (group ``name`` each; all must lie inside the ball).
        r_air: radius of the air ball, m.
        h_source: element size at the magnets, m.
        workspace: optional (2, 3) box [min, max] refined to ``h_workspace``.
    """
    boxes = list(boxes)
    c0 = np.asarray(center, dtype=float)
    for b in boxes:
        reach = np.linalg.norm(np.asarray(b.center) - c0) + 0.5 * np.linalg.norm(b.size)
        if reach >= r_air:
            raise ValueError(f"magnet {b.name} reaches the outer boundary r_air = {r_air:g} m")

    def build(gmsh: Any) -> None:
        occ = gmsh.model.occ
        ball = occ.addSphere(*c0, r_air)
        tags = []
        for b in boxes:
            sx, sy, sz = b.size
            t = occ.addBox(-sx / 2, -sy / 2, -sz / 2, sx, sy, sz)
            R = np.asarray(b.rotation)
            affine = np.zeros(12)
            affine[[0, 1, 2, 4, 5, 6, 8, 9, 10]] = R.ravel()
            affine[[3, 7, 11]] = b.center
            occ.affineTransform([(3, t)], list(affine))
            tags.append(t)
        _, mapping = occ.fragment([(3, ball)], [(3, t) for t in tags])
        occ.synchronize()
        used = _name_pieces(gmsh, 3, [b.name for b in boxes], mapping[1:])
        surfaces = gmsh.model.getBoundary([(3, t) for t in used], oriented=False)
        _size_fields(
            gmsh, 3, [abs(s[1]) for s in surfaces], h_source, r_air, workspace, h_workspace
        )
        gmsh.model.mesh.generate(3)

    return build
