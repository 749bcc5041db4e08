"""gmsh geometry of magnetizable (iron) bodies in their air region: 3D and axisymmetric (r, z).

The fields of coils and magnets are closed forms, so only iron bodies and the
air around them are meshed. A body is a named union of primitives:

* 3D (:class:`IronBody`): :class:`Ball`, :class:`Frustum` (cylinder or
  truncated cone), :class:`Box`, :class:`RuledSolid` (two parallel
  quadrilaterals joined by ruled faces, e.g. a tapered tweezers prong);
* (r, z) half-plane (:class:`IronProfile`): :class:`HalfDisk` (a sphere's
  meridian section) and :class:`Polygon` (rods, needles, cones).

Builders return a function ``builder(gmsh)`` for
:func:`magfem.geometry.gmshio.build_mesh`; they run on rank 0 only. Physical
groups: each body under its name, the rest ``air`` (a ball, or a half-disk
of the (r, z) plane, of radius ``r_air``). Element size: ``h_iron`` on the
iron surfaces, growing by ``grading`` per unit distance from them up to
``r_air / 8``, and at most ``h_workspace`` inside the ``workspace`` box.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "Ball",
    "Box",
    "Frustum",
    "HalfDisk",
    "IronBody",
    "IronProfile",
    "IronSizing",
    "Polygon",
    "RuledSolid",
    "axisymmetric_builder",
    "solid_builder",
]


@dataclass(frozen=True)
class Ball:
    """Sphere of ``radius`` (m) about ``center`` (3,)."""

    center: tuple[float, ...]
    radius: float


@dataclass(frozen=True)
class Frustum:
    """Truncated cone from ``base`` (3,) along ``vector`` (3,; length = height), radii r0 → r1."""

    base: tuple[float, ...]
    vector: tuple[float, ...]
    r0: float
    r1: float


@dataclass(frozen=True)
class Box:
    """Box of edges ``size`` (3,) about ``center``; ``rotation`` (3, 3): columns = local axes."""

    center: tuple[float, ...]
    size: tuple[float, ...]
    rotation: tuple[tuple[float, ...], ...]


@dataclass(frozen=True)
class RuledSolid:
    """Solid between the quadrilaterals ``corners[:4]`` and ``corners[4:]`` ((8, 3), m)."""

    corners: tuple[tuple[float, ...], ...]


@dataclass(frozen=True)
class IronBody:
    """A named 3D iron body: the union of ``parts``."""

    name: str
    parts: tuple[Ball | Frustum | Box | RuledSolid, ...]


@dataclass(frozen=True)
class HalfDisk:
    """The half-disk r ≥ 0 of ``radius`` (m) about (0, ``z``) in the (r, z) plane."""

    z: float
    radius: float


@dataclass(frozen=True)
class Polygon:
    """A polygon of (r, z) ``points`` (m), r ≥ 0."""

    points: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class IronProfile:
    """A named meridian section of an axisymmetric iron body: the union of ``parts``."""

    name: str
    parts: tuple[HalfDisk | Polygon, ...]


def _add_solid(occ: Any, part: Ball | Frustum | Box | RuledSolid) -> int:
    """Add one 3D primitive to the OCC model; returns its volume tag."""
    if isinstance(part, Ball):
        return int(occ.addSphere(*part.center, part.radius))
    if isinstance(part, Frustum):
        return int(occ.addCone(*part.base, *part.vector, part.r0, part.r1))
    if isinstance(part, Box):
        sx, sy, sz = part.size
        tag = occ.addBox(-sx / 2, -sy / 2, -sz / 2, sx, sy, sz)
        affine = np.zeros(12)
        affine[[0, 1, 2, 4, 5, 6, 8, 9, 10]] = np.asarray(part.rotation).ravel()
        affine[[3, 7, 11]] = part.center
        occ.affineTransform([(3, tag)], list(affine))
        return int(tag)
    loops = []
    for quad in (part.corners[:4], part.corners[4:]):
        pts = [occ.addPoint(*c) for c in quad]
        lines = [occ.addLine(pts[i], pts[(i + 1) % 4]) for i in range(4)]
        loops.append(occ.addCurveLoop(lines))
    out = occ.addThruSections(loops, makeSolid=True, makeRuled=True)
    return int(next(t for d, t in out if d == 3))


def _add_profile(occ: Any, part: HalfDisk | Polygon, r_air: float) -> int:
    """Add one (r, z) primitive to the OCC model (z = 0 plane, x = r, y = z); surface tag."""
    if isinstance(part, HalfDisk):
        disk = occ.addDisk(0, part.z, 0, part.radius, part.radius)
        left = occ.addRectangle(
            -2 * part.radius, part.z - 2 * part.radius, 0, 2 * part.radius, 4 * part.radius
        )
        out, _ = occ.cut([(2, disk)], [(2, left)])
        return int(out[0][1])
    pts = [occ.addPoint(r, z, 0) for r, z in part.points]
    lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    return int(occ.addPlaneSurface([occ.addCurveLoop(lines)]))


def _union(occ: Any, dim: int, tags: list[int]) -> list[int]:
    """Fuse the entities ``tags`` of dimension ``dim`` (one body); returns the resulting tags."""
    if len(tags) == 1:
        return tags
    out, _ = occ.fuse([(dim, tags[0])], [(dim, t) for t in tags[1:]])
    return [t for d, t in out if d == dim]


def _fragment_iron(
    gmsh: Any, dim: int, container: int, body_tags: list[list[int]], names: Sequence[str]
) -> list[int]:
    """Fragment the ``container`` entity with the bodies' pieces and name the groups.

    ``body_tags``: per body, its ``dim``-entity tags. Returns the iron tags
    (:func:`_name_groups`).
    """
    occ = gmsh.model.occ
    tools = [(dim, t) for tags in body_tags for t in tags]
    _, mapping = occ.fragment([(dim, container)], tools)
    occ.synchronize()
    per_body, k = [], 1
    for tags in body_tags:
        per_body.append([pair for m in mapping[k : k + len(tags)] for pair in m])
        k += len(tags)
    return _name_groups(gmsh, dim, names, per_body)


def _generate(gmsh: Any, dim: int, order: int) -> None:
    """Mesh in ``dim`` dimensions; elevate to geometric ``order`` (curved) when > 1."""
    gmsh.model.mesh.generate(dim)
    if order > 1:
        gmsh.model.mesh.setOrder(order)


def _name_groups(gmsh: Any, dim: int, names: Sequence[str], mapping: list[Any]) -> list[int]:
    """Physical groups after ``occ.fragment``: each body's pieces under its name, the rest air.

    ``mapping``: per body, the (dim, tag) pairs it became (``mapping[1:]`` of
    ``occ.fragment`` with the air region first). Returns the sorted iron tags.
    """
    named: dict[str, list[int]] = {}
    used: set[int] = set()
    for name, piece in zip(names, mapping, strict=True):
        tags = [t for d, t in piece if d == dim and t not in used]
        named.setdefault(name, []).extend(tags)
        used.update(tags)
    air = [t for d, t in gmsh.model.getEntities(dim) if t not in used]
    for name, tags in named.items():
        gmsh.model.addPhysicalGroup(dim, tags, name=name)
    gmsh.model.addPhysicalGroup(dim, air, name="air")
    return sorted(used)


@dataclass(frozen=True)
class IronSizing:
    """Element sizes of an iron mesh.

    Attributes:
        h_iron: element size on the iron surfaces, m.
        grading: growth of the element size per unit distance from the iron.
        workspace: optional box (2, dim) [min, max] meshed at most at ``h_workspace``.
        h_workspace: the size in the workspace box, m.
        order: geometric order of the elements (1 or 2: curved).
    """

    h_iron: float
    grading: float = 0.3
    workspace: np.ndarray | None = None
    h_workspace: float | None = None
    order: int = 1


def _size_fields(gmsh: Any, dim: int, iron: list[int], sizing: IronSizing, r_air: float) -> None:
    """Background size: h_iron at the iron + grading × distance; ≤ h_workspace in the box."""
    h_iron, grading = sizing.h_iron, sizing.grading
    box, h_workspace = sizing.workspace, sizing.h_workspace
    f = gmsh.model.mesh.field
    boundary = gmsh.model.getBoundary([(dim, t) for t in iron], combined=False, oriented=False)
    dist = f.add("Distance")
    f.setNumbers(
        dist, "CurvesList" if dim == 2 else "SurfacesList", sorted({abs(t) for _, t in boundary})
    )
    f.setNumber(dist, "Sampling", 60)
    h_max = max(r_air / 8, h_iron)
    thr = f.add("Threshold")
    f.setNumber(thr, "InField", dist)
    f.setNumber(thr, "SizeMin", h_iron)
    f.setNumber(thr, "SizeMax", h_max)
    f.setNumber(thr, "DistMin", 0.0)
    f.setNumber(thr, "DistMax", (h_max - h_iron) / grading)
    fields = [thr]
    if box is not None and h_workspace is not None:
        b = f.add("Box")
        f.setNumber(b, "VIn", h_workspace)
        f.setNumber(b, "VOut", h_max)
        lo, hi = box
        for k, ax in enumerate("XYZ"):
            f.setNumber(b, f"{ax}Min", float(lo[k]) if k < dim else -1.0)
            f.setNumber(b, f"{ax}Max", float(hi[k]) if k < dim else 1.0)
        f.setNumber(b, "Thickness", float(np.max(hi[:dim] - lo[:dim])))
        fields.append(b)
    mn = f.add("Min")
    f.setNumbers(mn, "FieldsList", fields)
    f.setAsBackgroundMesh(mn)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


def solid_builder(
    bodies: Sequence[IronBody],
    r_air: float,
    *,
    center: Sequence[float],
    sizing: IronSizing,
) -> Callable[[Any], None]:
    """Builder of a ball of radius ``r_air`` (m) about ``center`` containing the iron ``bodies``.

    Args:
        bodies: iron bodies (group ``name`` each), inside the ball.
        r_air: radius of the air ball, m.
        center: its centre (3,), m.
        sizing: element sizes and order.
    """
    bodies = list(bodies)

    def build(gmsh: Any) -> None:
        occ = gmsh.model.occ
        ball = occ.addSphere(*center, r_air)
        body_tags = [_union(occ, 3, [_add_solid(occ, p) for p in b.parts]) for b in bodies]
        names = [b.name for b in bodies]
        iron = _fragment_iron(gmsh, 3, ball, body_tags, names)
        _size_fields(gmsh, 3, iron, sizing, r_air)
        _generate(gmsh, 3, sizing.order)

    return build


def axisymmetric_builder(
    profiles: Sequence[IronProfile],
    r_air: float,
    *,
    z_center: float,
    sizing: IronSizing,
) -> Callable[[Any], None]:
    """Builder of the (r, z) half-disk of radius ``r_air`` about (0, ``z_center``), with iron.

    The mesh lies in the plane z = 0 with x = r, y = z (gdim = 2); the sizing's
    workspace is a box [[r_min, z_min], [r_max, z_max]].
    """
    profiles = list(profiles)

    def build(gmsh: Any) -> None:
        occ = gmsh.model.occ
        air = _add_profile(occ, HalfDisk(z_center, r_air), r_air)
        body_tags = [
            _union(occ, 2, [_add_profile(occ, p, r_air) for p in b.parts]) for b in profiles
        ]
        names = [b.name for b in profiles]
        iron = _fragment_iron(gmsh, 2, air, body_tags, names)
        _size_fields(gmsh, 2, iron, sizing, r_air)
        _generate(gmsh, 2, sizing.order)

    return build
