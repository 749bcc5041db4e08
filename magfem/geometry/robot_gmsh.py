"""The gmsh side of robot meshing (rank 0): outline → pieces → extrusion → named groups.

:func:`robot_builder` returns the builder that
:func:`magfem.geometry.gmshio.build_mesh` runs on rank 0:

1. The planar outline is built with the OCC kernel on z = 0 and its pieces
   fragmented into one conforming partition (clamp patch and tip zones are
   separate pieces).
2. ``solid``: the pieces are meshed (``hex``: recombined into quadrilaterals
   by blossom full-quad; ``wedge``: triangles) and extruded to the thickness
   with ``layers`` structured element layers, giving hexahedra or prisms.
   ``surface``: the pieces themselves, lifted to the mid-plane
   z = thickness/2. ``strip``: the side view (x, z) of a uniform-width
   beam outline, a line along x extruded through the thickness, in gmsh's
   (x, y).
3. Physical groups by name from the outline's ``cell_group``, ``tip_group``
   and ``in_clamp``, optional second-order geometry, then ``position`` and
   the ``size_across`` stretch are applied to the mesh nodes, and the cell
   type and element quality are checked.

Full-quad recombination (gmsh's blossom full-quad, Remacle et al., Int. J.
Numer. Meth. Eng. 89, 1102 (2012)) meshes each surface at twice the size,
recombines, splits every quadrilateral into four and every triangle into
three, and moves the new nodes of curved curves back onto the curve. Where
a curve is resolved by few segments (a circle of 10 segments is a pentagon
on the coarse mesh) next to a band narrower than the coarse elements (the
0.5 mm ring between a star's bonded disk and its hub), that move inverts
elements, and gmsh splits the inverted quadrilaterals into triangles. When
the first mesh keeps triangles, the mesh is made again with every curved
outline curve given at least :data:`ARC_SEGMENTS` segments per full turn
(even counts). The recombination also halves each curve's 1D mesh, and a
curve with an odd count (one segment on a short curve far from a
``tip_size`` refinement) leaves its surfaces without elements, which gmsh
reports only in its log: such meshes are made again with those counts one
higher, and a piece without elements is refused. Meshes the first recipe
makes are left as they are.

``size_across``: :class:`StretchedOutline` scales the outline's y axis by
size/size_across before meshing; the nodes are scaled back afterwards, so
the elements are ``size`` long and ``size_across`` wide.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from magfem.config import CaseError
from magfem.geometry.beam import BeamOutline
from magfem.geometry.outline import Outline
from magfem.geometry.spec import MeshSpec, RobotSpec

__all__ = [
    "ARC_SEGMENTS",
    "MIN_QUALITY",
    "QUALITY_METRIC",
    "MeshQualityError",
    "StretchedOutline",
    "robot_builder",
]

QUALITY_METRIC = "minSJ"
"""gmsh element quality used: minimum scaled Jacobian (1 for undistorted
boxes of any aspect ratio, <= 0 for inverted elements)."""

MIN_QUALITY = 0.1
"""Meshes whose worst element has a smaller scaled Jacobian are rejected."""


ARC_SEGMENTS = 16
"""Segments per full turn of a curved outline curve when the first mesh keeps triangles:
the coarse mesh of the full-quad recombination then has 8 chords per turn, whose
sagitta is 8 % of the radius (every robot of the cases meshes into quadrilaterals
with 16, 20 and 24, not with 12: ``benchmarks/hex_meshing.py --cases --arc-segments``)."""


class MeshQualityError(RuntimeError):
    """gmsh produced a mesh dolfinx cannot use (mixed cell types) or of too poor quality."""


class _Plan(NamedTuple):
    """What a geometry builder hands to the meshing step (gmsh entity tags)."""

    tdim: int
    cells: dict[str, list[int]]  # cell group -> entities of dim tdim
    facets: dict[str, list[int]]  # facet group -> entities of dim tdim - 1
    recombine: list[int]  # surfaces to recombine into quadrilaterals
    tip_dim: int  # dimension of the tip and root entities below (0 points, 1 curves)
    tips: list[int]  # entities the tip refinement is measured from
    curves: list[int]  # curves of the meshed outline (before extrusion)
    roots: list[int]  # where the membrane leaves the clamp patch (root refinement)


class StretchedOutline(Outline):
    """``outline`` with its y axis scaled by ``stretch`` (gmsh side of ``mesh.size_across``).

    The queries (``cell_group``, ``tip_group``, ``in_clamp``) take stretched
    coordinates and answer for the true outline.
    """

    def __init__(self, outline: Outline, stretch: float):
        self.outline = outline
        self.stretch = stretch
        self.arms = outline.arms
        self.area = outline.area
        self.curved = outline.curved
        self.clamped = outline.clamped
        self.scale = outline.scale

    def build(self, occ: Any) -> None:
        before = set(occ.getEntities(2))
        self.outline.build(occ)
        added = [e for e in occ.getEntities(2) if e not in before]
        occ.dilate(added, 0.0, 0.0, 0.0, 1.0, self.stretch, 1.0)

    def cell_group(self, x: float, y: float) -> str:
        return self.outline.cell_group(x, y / self.stretch)

    def tip_group(self, x: float, y: float) -> str | None:
        return self.outline.tip_group(x, y / self.stretch)

    def in_clamp(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Any:
        return self.outline.in_clamp(x, np.asarray(y) / self.stretch)


def _size_field(gmsh: Any, spec: MeshSpec, outline: Outline, plan: _Plan) -> None:
    """Uniform size ``spec.size``, refined linearly to ``tip_size`` at the tip entities and
    to ``root_size`` where the membrane leaves the clamp patch.

    Each refinement grows to ``size`` at a distance of a quarter of the
    shortest arm; where both reach, the smaller size wins.
    """
    gmsh.option.setNumber("Mesh.MeshSizeMax", spec.size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    field = gmsh.model.mesh.field
    refined = []
    for size, entities in ((spec.tip_size, plan.tips), (spec.root_size, plan.roots)):
        if size is None or not entities:
            continue
        dist = field.add("Distance")
        field.setNumbers(dist, "PointsList" if plan.tip_dim == 0 else "CurvesList", entities)
        field.setNumber(dist, "Sampling", 100)
        thr = field.add("Threshold")
        field.setNumber(thr, "InField", dist)
        field.setNumber(thr, "SizeMin", size)
        field.setNumber(thr, "SizeMax", spec.size)
        field.setNumber(thr, "DistMin", 0.0)
        field.setNumber(thr, "DistMax", 0.25 * min(a.length for a in outline.arms))
        refined.append(thr)
    if not refined:
        return
    background = refined[0]
    if len(refined) > 1:
        background = field.add("Min")
        field.setNumbers(background, "FieldsList", refined)
    field.setAsBackgroundMesh(background)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)


def _root_curves(gmsh: Any, outline: Outline, surfaces: list[int]) -> list[int]:
    """The curves between a piece of the clamp patch and a free piece (planar outline)."""
    if not outline.clamped:
        return []
    bonded = {}
    for s in surfaces:
        x, y, _ = _com(gmsh, 2, s)
        bonded[s] = bool(np.all(outline.in_clamp(np.array([x]), np.array([y]))))
    roots = []
    for _, c in gmsh.model.getEntities(1):
        up = [s for s in gmsh.model.getAdjacencies(1, c)[0] if s in bonded]
        if len({bonded[s] for s in up}) == 2:
            roots.append(c)
    return roots


def _vertices(gmsh: Any, dim: int, tag: int) -> npt.NDArray[np.float64]:
    """(n, 3) coordinates of the geometric vertices bounding entity (dim, tag)."""
    points = gmsh.model.getBoundary([(dim, tag)], combined=False, recursive=True)
    return np.array([gmsh.model.getValue(0, abs(p), []) for _, p in points]).reshape(-1, 3)


def _com(gmsh: Any, dim: int, tag: int) -> tuple[float, float, float]:
    x, y, z = gmsh.model.occ.getCenterOfMass(dim, tag)
    return float(x), float(y), float(z)


def _planar_outline(gmsh: Any, outline: Outline) -> list[int]:
    """Build and fragment the outline pieces; returns the surface tags (z = 0)."""
    occ = gmsh.model.occ
    outline.build(occ)
    surfaces = occ.getEntities(2)
    if len(surfaces) > 1:
        occ.fragment(surfaces[:1], surfaces[1:])
    occ.synchronize()
    return [t for _, t in gmsh.model.getEntities(2)]


def _tip_curves(gmsh: Any, outline: Outline) -> dict[str, list[int]]:
    out: dict[str, list[int]] = {}
    for _, c in gmsh.model.getEntities(1):
        name = outline.tip_group(*_com(gmsh, 1, c)[:2])
        if name is not None:
            out.setdefault(name, []).append(c)
    return out


def _cell_groups(gmsh: Any, outline: Outline, dim: int) -> dict[str, list[int]]:
    cells: dict[str, list[int]] = {}
    for _, e in gmsh.model.getEntities(dim):
        x, y, _ = _com(gmsh, dim, e)
        cells.setdefault(outline.cell_group(x, y), []).append(e)
    return cells


def _facet_groups(gmsh: Any, outline: Outline, dim: int, thickness: float) -> dict[str, list[int]]:
    """Named boundary facets (entities of dimension ``dim``) of the extruded robot.

    The thickness (m) runs along gmsh axis ``dim``: z for the solid (facets
    are surfaces, dim 2), y for the strip's side view (facets are lines,
    dim 1, whose in-plane y is 0). A facet wholly below mid-thickness is the
    bonded ``clamp`` (inside the outline's clamp patch) or ``bottom``, wholly
    above ``top``; one across the thickness is a side face, named by the
    outline's tip group at its centre of mass (other sides are left out).
    """
    half = 0.5 * thickness
    facets: dict[str, list[int]] = {}
    for _, f in gmsh.model.getEntities(dim):
        p = _vertices(gmsh, dim, f)
        x, y = p[:, 0], (p[:, 1] if dim == 2 else 0 * p[:, 0])
        if np.all(p[:, dim] < half):
            name = "clamp" if np.all(outline.in_clamp(x, y)) else "bottom"
        elif np.all(p[:, dim] > half):
            name = "top"
        else:
            cx, cy, _ = _com(gmsh, dim, f)
            name = outline.tip_group(cx, cy if dim == 2 else 0.0) or ""
        if name:
            facets.setdefault(name, []).append(f)
    return facets


def _build_solid(gmsh: Any, outline: Outline, robot: RobotSpec, spec: MeshSpec) -> _Plan:
    occ = gmsh.model.occ
    surfaces = _planar_outline(gmsh, outline)
    curves = [c for _, c in gmsh.model.getEntities(1)]
    tips = [c for cs in _tip_curves(gmsh, outline).values() for c in cs]
    roots = _root_curves(gmsh, outline, surfaces)
    occ.extrude(
        [(2, s) for s in surfaces],
        0.0,
        0.0,
        robot.thickness,
        numElements=[spec.layers],
        recombine=True,  # quads -> hexahedra, triangles -> prisms (False would give tetrahedra)
    )
    occ.synchronize()
    facets = _facet_groups(gmsh, outline, 2, robot.thickness)
    return _Plan(3, _cell_groups(gmsh, outline, 3), facets, surfaces, 1, tips, curves, roots)


def _build_surface(gmsh: Any, outline: Outline, robot: RobotSpec, spec: MeshSpec) -> _Plan:
    surfaces = _planar_outline(gmsh, outline)
    tips = _tip_curves(gmsh, outline)
    cells = _cell_groups(gmsh, outline, 2)
    curves = [c for _, c in gmsh.model.getEntities(1)]
    roots = _root_curves(gmsh, outline, surfaces)
    gmsh.model.occ.translate(gmsh.model.occ.getEntities(), 0.0, 0.0, 0.5 * robot.thickness)
    flat = [c for cs in tips.values() for c in cs]
    return _Plan(2, cells, tips, surfaces, 1, flat, curves, roots)


def _build_strip(gmsh: Any, outline: Outline, robot: RobotSpec, spec: MeshSpec) -> _Plan:
    """Side view in gmsh's (x, y) = magfem's (x, z): a line along x extruded through t."""
    if not isinstance(outline, BeamOutline):  # check_mesh_for_robot prevents this
        raise CaseError("mesh.model", spec.model, f"no strip model for shape '{robot.shape}'")
    occ = gmsh.model.occ
    xs = outline.strip_breaks()
    pts = [occ.addPoint(x, 0.0, 0.0) for x in xs]
    lines = [occ.addLine(a, b) for a, b in itertools.pairwise(pts)]
    tip_pts = [p for p, x in zip(pts, xs, strict=True) if outline.tip_group(x, 0.0)]
    held = outline.in_clamp(0.5 * (np.array(xs[:-1]) + np.array(xs[1:])), np.zeros(len(xs) - 1))
    root_pts = [pts[i + 1] for i in range(len(xs) - 2) if held[i] != held[i + 1]]
    occ.extrude(
        [(1, ln) for ln in lines],
        0.0,
        robot.thickness,
        0.0,
        numElements=[spec.layers],
        recombine=spec.element == "hex",
    )
    occ.synchronize()
    facets = _facet_groups(gmsh, outline, 1, robot.thickness)
    return _Plan(2, _cell_groups(gmsh, outline, 2), facets, [], 0, tip_pts, [], root_pts)


_BUILDERS = {"solid": _build_solid, "surface": _build_surface, "strip": _build_strip}

_EXPECTED_TYPES = {  # (model, element) -> gmsh element name of the cells
    ("solid", "hex"): "Hexahedron",
    ("solid", "wedge"): "Prism",
    ("surface", "hex"): "Quadrilateral",
    ("surface", "wedge"): "Triangle",
    ("strip", "hex"): "Quadrilateral",
    ("strip", "wedge"): "Triangle",
}


def _add_groups(gmsh: Any, plan: _Plan) -> None:
    """Physical groups by name (only after the last OCC synchronize, which may drop them)."""
    for dim, named in ((plan.tdim, plan.cells), (plan.tdim - 1, plan.facets)):
        for name, tags in sorted(named.items()):
            gmsh.model.addPhysicalGroup(dim, sorted(tags), name=name)


def _mesh_options(gmsh: Any, spec: MeshSpec, plan: _Plan) -> None:
    """Meshing algorithm and, for ``hex``, quadrilateral recombination of the outline."""
    hex_ = spec.element == "hex"
    gmsh.option.setNumber("Mesh.Algorithm", 8 if hex_ else 6)  # frontal-Delaunay (quads)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)  # blossom full-quad
    if not hex_:
        return
    for s in plan.recombine:
        gmsh.model.mesh.setRecombine(2, s)
    # full-quad recombination fails on curves meshed with one element
    # (short hub arcs, the cut at a triangle's tip zone): give them two
    h = min(x for x in (spec.size, spec.tip_size, spec.root_size) if x is not None)
    for c in plan.curves:
        if gmsh.model.occ.getMass(1, c) < 2 * h:
            gmsh.model.mesh.setTransfiniteCurve(c, 3)


def _with_triangles(gmsh: Any, surfaces: list[int]) -> list[int]:
    """The surfaces among ``surfaces`` whose mesh has triangles."""
    out = []
    for s in surfaces:
        types, _, _ = gmsh.model.mesh.getElements(2, s)
        names = [gmsh.model.mesh.getElementProperties(t)[0] for t in types]
        if any(n.startswith("Triangle") for n in names):
            out.append(s)
    return out


def _resolve_arcs(gmsh: Any, curves: list[int], counts: dict[int, int]) -> None:
    """At least :data:`ARC_SEGMENTS` segments per full turn on every curved curve.

    ``counts`` are the curves' segment counts of the first mesh; a curve keeps
    its count where that is enough, and the new counts are even (the full-quad
    recombination halves them).
    """
    for c in curves:
        lo, hi = gmsh.model.getParametrizationBounds(1, c)
        kappa = gmsh.model.getCurvature(1, c, np.linspace(lo[0], hi[0], 5))
        turn = gmsh.model.occ.getMass(1, c) * float(np.max(np.abs(kappa)))  # rad (arcs)
        n = max(counts[c], math.ceil(turn * ARC_SEGMENTS / (2 * math.pi) - 1e-9))
        n += n % 2
        if n > counts[c]:
            gmsh.model.mesh.setTransfiniteCurve(c, n + 1)


def _segments(gmsh: Any, curves: list[int]) -> dict[int, int]:
    """Segment count of each curve's 1D mesh."""
    return {c: len(gmsh.model.mesh.getElements(1, c)[1][0]) for c in curves}


def _even_curves(gmsh: Any, curves: list[int]) -> None:
    """Clear the mesh, mesh the curves anew and give those with an odd segment count one more.

    Full-quad recombination halves every boundary curve's 1D mesh and fails
    on an odd count: a curve shorter than two elements far from a
    ``tip_size`` refinement (:func:`_mesh_options` measures curves against
    ``tip_size``) is meshed with one. The counts are taken from a fresh 1D
    mesh: the failed recombination leaves the halved one behind.
    """
    gmsh.model.mesh.clear()
    gmsh.model.mesh.generate(1)
    counts = _segments(gmsh, curves)
    gmsh.model.mesh.clear()
    for c, n in counts.items():
        if n % 2:
            gmsh.model.mesh.setTransfiniteCurve(c, n + 2)


def _generate(gmsh: Any, spec: MeshSpec, plan: _Plan, info: dict[str, Any]) -> None:
    """Mesh; for ``hex``, again if gmsh could not (odd curve counts made even) or left
    triangles (curved curves resolved). Meshes the first try makes are kept as they are.

    Sets ``info["recipe"]`` to how the mesh kept was made.
    """
    hex_ = spec.element == "hex"
    recipe = ["full-quad" if hex_ else "triangles"]
    try:
        gmsh.model.mesh.generate(plan.tdim)
    except Exception as err:  # raised only when gmsh's verbosity shows errors
        if not hex_ or "cannot be divided by 2" not in str(err):
            raise
    # an odd count leaves the curve's surfaces without elements (an error in gmsh's log,
    # but no exception, at the verbosity build_mesh sets): remesh with even counts
    odd = any(n % 2 for n in _segments(gmsh, plan.curves).values())
    if hex_ and (odd or not all(_has_elements(gmsh, 2, s) for s in plan.recombine)):
        _even_curves(gmsh, plan.curves)
        gmsh.model.mesh.generate(plan.tdim)
        recipe.append("odd curve counts made even")
    if hex_ and _with_triangles(gmsh, plan.recombine):
        counts = _segments(gmsh, plan.curves)
        gmsh.model.mesh.clear()
        _resolve_arcs(gmsh, plan.curves, counts)
        gmsh.model.mesh.generate(plan.tdim)
        recipe.append(f"arcs >= {ARC_SEGMENTS} segments per turn")
    info["recipe"] = ", ".join(recipe)


def _place_nodes(gmsh: Any, robot: RobotSpec, spec: MeshSpec, outline: Outline) -> None:
    """Add ``position`` (strip: (x, z) += (px, pz)) and undo the ``size_across`` stretch.

    The mesh nodes move, not the geometry: an OCC translation would drop the
    structured-extrusion constraints.
    """
    px, py, pz = robot.position
    sx, sy, sz = (px, pz, 0.0) if spec.model == "strip" else (px, py, pz)
    syy = 1.0 / outline.stretch if isinstance(outline, StretchedOutline) else 1.0
    if sx or sy or sz or syy != 1.0:
        gmsh.model.mesh.affineTransform([1, 0, 0, sx, 0, syy, 0, sy, 0, 0, 1, sz])


def _has_elements(gmsh: Any, dim: int, tag: int) -> bool:
    return any(len(t) for t in gmsh.model.mesh.getElements(dim, tag)[1])


def _check_cells(gmsh: Any, spec: MeshSpec, tdim: int, info: dict[str, Any]) -> None:
    """Every piece meshed, one cell type as expected and worst quality >= MIN_QUALITY;
    fills ``info``."""
    empty = [e for _, e in gmsh.model.getEntities(tdim) if not _has_elements(gmsh, tdim, e)]
    if empty:
        raise MeshQualityError(
            f"gmsh left {len(empty)} of the robot's {len(gmsh.model.getEntities(tdim))} "
            "pieces without elements at this size; try a slightly smaller or larger mesh.size"
        )
    types = gmsh.model.mesh.getElementTypes(dim=tdim)
    names = [gmsh.model.mesh.getElementProperties(t)[0] for t in types]
    want = _EXPECTED_TYPES[(spec.model, spec.element)]
    if len(types) != 1 or not names[0].startswith(want):
        raise MeshQualityError(
            f"gmsh made {names} cells where only {want} are meshed (its recombination left "
            f"other cells at this size, also with curved curves at >= {ARC_SEGMENTS} segments "
            "per turn); try a slightly smaller or larger mesh.size"
        )
    _, tags, _ = gmsh.model.mesh.getElements(dim=tdim)
    quality = gmsh.model.mesh.getElementQualities(tags[0], QUALITY_METRIC)
    info["num_cells"] = len(tags[0])
    info["min_quality"] = float(np.min(quality))
    if info["min_quality"] < MIN_QUALITY:
        advice = (
            "use mesh.order = 1 or a smaller mesh.size (order-2 elements follow the curved "
            "outline and can come out nearly inverted at its corners)"
            if spec.order == 2
            else "use a smaller mesh.size"
        )
        raise MeshQualityError(
            f"worst element {QUALITY_METRIC} = {info['min_quality']:.3g} < {MIN_QUALITY}; {advice}"
        )


def robot_builder(
    robot: RobotSpec, spec: MeshSpec, outline: Outline, info: dict[str, Any]
) -> Callable[[Any], None]:
    """The gmsh builder of ``outline`` meshed as ``spec`` says (run on rank 0).

    It fills ``info`` with ``num_cells``, ``min_quality`` (gmsh's
    :data:`QUALITY_METRIC`) and ``recipe`` (how the quadrilaterals were
    made), and raises :class:`MeshQualityError` on mixed cell types or
    elements worse than :data:`MIN_QUALITY`.
    """

    def builder(gmsh: Any) -> None:
        plan = _BUILDERS[spec.model](gmsh, outline, robot, spec)
        gmsh.model.occ.synchronize()
        _add_groups(gmsh, plan)
        _mesh_options(gmsh, spec, plan)
        _size_field(gmsh, spec, outline, plan)
        _generate(gmsh, spec, plan, info)
        if spec.order == 2:
            gmsh.model.mesh.setOrder(2)
        _place_nodes(gmsh, robot, spec, outline)
        _check_cells(gmsh, spec, plan.tdim, info)

    return builder
