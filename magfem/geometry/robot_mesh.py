"""Mesh a robot: gmsh on rank 0 (outline → extrusion → physical groups), distributed to dolfinx.

Pipeline (:func:`create_robot_mesh`):

1. The planar outline of :func:`magfem.geometry.robots.outline_of` is built
   with the OCC kernel on z = 0 and its pieces fragmented into one conforming
   partition (clamp patch and tip zones are separate pieces).
2. ``solid``: the pieces are meshed (``hex``: recombined into quadrilaterals,
   checked to contain no triangle; ``wedge``: triangles) and extruded to the
   thickness with ``layers`` structured element layers, giving hexahedra or
   prisms. ``surface``: the pieces themselves, lifted to the mid-plane
   z = thickness/2. ``strip``: the side view (x, z) of a uniform-width arm,
   a line along x extruded through the thickness (quadrilaterals or
   triangles), as a gdim = 2 mesh whose second coordinate is z.
   ``size_across`` (arms along x only): the outline is stretched in y by
   size/size_across before meshing and the nodes are scaled back after, so
   the elements are ``size`` long and ``size_across`` wide.
3. Physical groups by name (see :class:`RobotMesh`), optional second-order
   geometry, element quality, then :func:`magfem.geometry.gmshio.build_mesh`
   distributes the mesh with its tags.
4. ``position`` translates the mesh nodes (strip: (x, z) += (px, pz)).

Group names. Cells: one group per arm/petal/fin (``arm``; ``arm_left``,
``arm_right``; ``arm_1``..; ``petal_1``..; ``fin_left``, ``fin_right``),
plus ``hub`` or ``body``; every cell is in exactly one. Facets (faces of the
solid, edges of the strip and surface): ``bottom`` (z = 0 minus the clamp),
``clamp`` (the bonded bottom patch; absent for free robots), ``top``,
``tip`` / ``tip_<arm>``. dolfinx keeps one tag per facet, so ``bottom`` and
``clamp`` are disjoint: the whole ground-facing face is ``("bottom",
"clamp")`` (use :func:`group_tags` for ``ds``). In the surface model there
is no ``bottom``/``top``; ``clamp`` holds every edge inside the bonded patch
less :data:`SHELL_CLAMP_INSET` thicknesses at its free edges
(computed geometrically after distribution, so Dirichlet conditions on it
fix every node of the patch).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from magfem.config import CaseError
from magfem.geometry.gmshio import build_mesh
from magfem.geometry.robots import BeamOutline, Outline, outline_of
from magfem.geometry.spec import MeshSpec, RobotSpec, check_mesh_for_robot

__all__ = [
    "SHELL_CLAMP_INSET",
    "Arm",
    "MeshQualityError",
    "RobotMesh",
    "create_robot_mesh",
    "group_tags",
    "locate",
]

QUALITY_METRIC = "minSJ"
"""gmsh element quality used: minimum scaled Jacobian (1 for undistorted
boxes of any aspect ratio, <= 0 for inverted elements)."""

MIN_QUALITY = 0.1
"""Meshes whose worst element has a smaller scaled Jacobian are rejected."""

SHELL_CLAMP_INSET = 0.41
"""Clamp inset of the shell model, in thicknesses.

A membrane whose bottom face is bonded to the substrate is not clamped
rigidly where it leaves the bond: the material near that edge shears and
lifts (a corner of the plane-strain side view, a region ~t in size), and the
free part bends as if it were longer. A shell cannot resolve that region;
it holds u and θ on the bonded patch shrunk by this many thicknesses at the
edges where the free membrane leaves it (:func:`magfem.geometry.robots.
outline_of`, ``clamp_inset``). Measured on the static hard-magnetic
cantilever: the resolved strip (K = 100 μ, bonded patch) bends like the
elastica of the free length + α t with one α at every load (0.1–0.4 mT),
α = 0.396, 0.407, 0.412 (plane strain) and 0.395, 0.409, 0.415 (plane
stress) with 4, 8, 16 P2 layers through the thickness, converging to
0.41–0.42 (``benchmarks/clamp_compliance.py``, docs/verification.md §1)."""


class MeshQualityError(RuntimeError):
    """gmsh produced a mesh dolfinx cannot use (mixed cell types) or of too poor quality."""


class Arm(NamedTuple):
    """One arm of the robot, in mesh coordinates (m).

    Attributes:
        name: its cell group.
        root: (3,) point on the arm's midline where its cell group begins,
            at mid-thickness: (x, y, t/2) + position for ``solid`` and
            ``surface``; (x, t/2, 0) + (px, pz, 0) for ``strip`` (mesh
            coordinates (x, z), third component 0 as in dolfinx geometry).
        direction: (3,) unit vector from root to tip in the resting plane
            (strip: (±1, 0, 0)).
        length: root-to-tip length along ``direction`` (m).
        tip: name of its tip facet group.
    """

    name: str
    root: npt.NDArray[np.float64]
    direction: npt.NDArray[np.float64]
    length: float
    tip: str


class RobotMesh(NamedTuple):
    """A distributed robot mesh with named groups.

    Attributes:
        mesh: dolfinx mesh (tdim 3 solid; tdim 2 strip (gdim 2) and surface (gdim 3)).
        cell_tags, facet_tags: dolfinx ``MeshTags``.
        groups: name -> (dim, tag); see the module docstring for the names.
        arms: the robot's arms (see :class:`Arm`).
        model: ``"solid"``, ``"strip"`` or ``"surface"``.
        thickness: membrane thickness (m).
        min_quality: worst element scaled Jacobian (gmsh ``minSJ``).
        num_cells: global cell count as generated by gmsh.
        area: exact area of the outline (m²; strip: length × thickness).
    """

    mesh: Any
    cell_tags: Any
    facet_tags: Any
    groups: dict[str, tuple[int, int]]
    arms: tuple[Arm, ...]
    model: str
    thickness: float
    min_quality: float
    num_cells: int
    area: float


def locate(robot_mesh: RobotMesh, name: str) -> tuple[int, npt.NDArray[np.int32]]:
    """Local (owned + ghost) entity indices of a named group.

    ``name = "robot"`` means every cell. Returns ``(dim, indices)``.

    Raises:
        KeyError: unknown group (message lists the groups).
    """
    topology = robot_mesh.mesh.topology
    tdim = topology.dim
    if name == "robot":
        imap = topology.index_map(tdim)
        return tdim, np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    if name not in robot_mesh.groups:
        raise KeyError(f"no group '{name}'; groups are " + ", ".join(sorted(robot_mesh.groups)))
    dim, tag = robot_mesh.groups[name]
    tags = robot_mesh.cell_tags if dim == tdim else robot_mesh.facet_tags
    return dim, tags.find(tag).astype(np.int32)


def group_tags(robot_mesh: RobotMesh, *names: str) -> tuple[int, ...]:
    """Integer tags of the named groups that exist.

    Example: the whole ground-facing face is ``ds(group_tags(rm, "bottom", "clamp"))``.
    """
    return tuple(robot_mesh.groups[n][1] for n in names if n in robot_mesh.groups)


# --- gmsh side (rank 0) ------------------------------------------------------------------------


class _Plan(NamedTuple):
    """What a geometry builder hands to the meshing step (gmsh entity tags)."""

    tdim: int
    cells: dict[str, list[int]]  # cell group -> entities of dim tdim
    facets: dict[str, list[int]]  # facet group -> entities of dim tdim - 1
    recombine: list[int]  # surfaces to recombine into quadrilaterals
    tip_dim: int  # dimension of the tip entities below (0 points, 1 curves)
    tips: list[int]  # entities the tip refinement is measured from
    curves: list[int]  # curves of the meshed outline (before extrusion)


class _StretchedOutline(Outline):
    """``outline`` with its y axis scaled by ``stretch`` (gmsh side of ``mesh.size_across``).

    gmsh meshes the stretched outline with isotropic elements of size
    ``mesh.size`` and the mesh nodes are scaled back afterwards, which leaves
    elements of length ``size`` along x and ``size / stretch`` along y. The
    queries (``cell_group``, ``tip_group``, ``in_clamp``) take stretched
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
    """Uniform size ``spec.size``, refined linearly to ``tip_size`` at the tip entities.

    The size grows from ``tip_size`` at the tips to ``size`` at a distance of a
    quarter of the shortest arm.
    """
    gmsh.option.setNumber("Mesh.MeshSizeMax", spec.size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    if spec.tip_size is None or not plan.tips:
        return
    field = gmsh.model.mesh.field
    dist = field.add("Distance")
    field.setNumbers(dist, "PointsList" if plan.tip_dim == 0 else "CurvesList", plan.tips)
    field.setNumber(dist, "Sampling", 100)
    thr = field.add("Threshold")
    field.setNumber(thr, "InField", dist)
    field.setNumber(thr, "SizeMin", spec.tip_size)
    field.setNumber(thr, "SizeMax", spec.size)
    field.setNumber(thr, "DistMin", 0.0)
    field.setNumber(thr, "DistMax", 0.25 * min(a.length for a in outline.arms))
    field.setAsBackgroundMesh(thr)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)


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
    return _Plan(3, _cell_groups(gmsh, outline, 3), facets, surfaces, 1, tips, curves)


def _build_surface(gmsh: Any, outline: Outline, robot: RobotSpec, spec: MeshSpec) -> _Plan:
    surfaces = _planar_outline(gmsh, outline)
    tips = _tip_curves(gmsh, outline)
    cells = _cell_groups(gmsh, outline, 2)
    curves = [c for _, c in gmsh.model.getEntities(1)]
    gmsh.model.occ.translate(gmsh.model.occ.getEntities(), 0.0, 0.0, 0.5 * robot.thickness)
    flat = [c for cs in tips.values() for c in cs]
    return _Plan(2, cells, tips, surfaces, 1, flat, curves)


def _build_strip(gmsh: Any, outline: Outline, robot: RobotSpec, spec: MeshSpec) -> _Plan:
    """Side view in gmsh's (x, y) = magfem's (x, z): a line along x extruded through t."""
    if not isinstance(outline, BeamOutline):  # check_mesh_for_robot prevents this
        raise CaseError("mesh.model", spec.model, f"no strip model for shape '{robot.shape}'")
    occ = gmsh.model.occ
    xs = outline.strip_breaks()
    pts = [occ.addPoint(x, 0.0, 0.0) for x in xs]
    lines = [occ.addLine(a, b) for a, b in itertools.pairwise(pts)]
    tip_pts = [p for p, x in zip(pts, xs, strict=True) if outline.tip_group(x, 0.0)]
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
    return _Plan(2, _cell_groups(gmsh, outline, 2), facets, [], 0, tip_pts, [])


_EXPECTED_TYPES = {  # (model, element) -> gmsh element name of the cells
    ("solid", "hex"): "Hexahedron",
    ("solid", "wedge"): "Prism",
    ("surface", "hex"): "Quadrilateral",
    ("surface", "wedge"): "Triangle",
    ("strip", "hex"): "Quadrilateral",
    ("strip", "wedge"): "Triangle",
}


def _make_builder(robot: RobotSpec, spec: MeshSpec, outline: Outline, info: dict[str, Any]) -> Any:
    """The gmsh builder (rank 0); fills ``info`` with the cell count and worst quality."""

    def builder(gmsh: Any) -> None:
        build = {"solid": _build_solid, "surface": _build_surface, "strip": _build_strip}
        plan = build[spec.model](gmsh, outline, robot, spec)
        gmsh.model.occ.synchronize()
        # mesh constraints and groups only now: an OCC synchronize may drop them
        for dim, named in ((plan.tdim, plan.cells), (plan.tdim - 1, plan.facets)):
            for name, tags in sorted(named.items()):
                gmsh.model.addPhysicalGroup(dim, sorted(tags), name=name)
        hex_ = spec.element == "hex"
        gmsh.option.setNumber("Mesh.Algorithm", 8 if hex_ else 6)  # frontal-Delaunay (quads)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 3)  # blossom full-quad
        if hex_:
            for s in plan.recombine:
                gmsh.model.mesh.setRecombine(2, s)
            # full-quad recombination fails on curves meshed with one element
            # (short hub arcs, the cut at a triangle's tip zone): give them two
            h = spec.size if spec.tip_size is None else spec.tip_size
            for c in plan.curves:
                if gmsh.model.occ.getMass(1, c) < 2 * h:
                    gmsh.model.mesh.setTransfiniteCurve(c, 3)
        _size_field(gmsh, spec, outline, plan)
        gmsh.model.mesh.generate(plan.tdim)
        if spec.order == 2:
            gmsh.model.mesh.setOrder(2)
        # ``position``: move the mesh nodes, not the geometry (an OCC translation
        # would drop the structured-extrusion constraints)
        px, py, pz = robot.position
        sx, sy, sz = (px, pz, 0.0) if spec.model == "strip" else (px, py, pz)
        syy = 1.0 / outline.stretch if isinstance(outline, _StretchedOutline) else 1.0
        if sx or sy or sz or syy != 1.0:
            gmsh.model.mesh.affineTransform([1, 0, 0, sx, 0, syy, 0, sy, 0, 0, 1, sz])
        types = gmsh.model.mesh.getElementTypes(dim=plan.tdim)
        names = [gmsh.model.mesh.getElementProperties(t)[0] for t in types]
        want = _EXPECTED_TYPES[(spec.model, spec.element)]
        if len(types) != 1 or not names[0].startswith(want):
            raise MeshQualityError(f"expected only {want} cells, gmsh made {names}")
        _, tags, _ = gmsh.model.mesh.getElements(dim=plan.tdim)
        quality = gmsh.model.mesh.getElementQualities(tags[0], QUALITY_METRIC)
        info["num_cells"] = len(tags[0])
        info["min_quality"] = float(np.min(quality))
        if info["min_quality"] < MIN_QUALITY:
            raise MeshQualityError(
                f"worst element {QUALITY_METRIC} = {info['min_quality']:.3g} < {MIN_QUALITY}; "
                "use a smaller mesh.size (curved outlines with order 2 need several "
                "elements per radius)"
            )

    return builder


# --- dolfinx side (collective) -----------------------------------------------------------------


def _surface_clamp(data: Any, outline: Outline, robot: RobotSpec) -> tuple[Any, int | None]:
    """Facet tags of the surface model plus a ``clamp`` tag on all edges inside the patch."""
    from dolfinx import mesh as dmesh

    msh, ft = data.mesh, data.facet_tags
    if not outline.clamped:
        return ft, None
    px, py, _ = robot.position
    msh.topology.create_entities(1)
    edges = dmesh.locate_entities(
        msh, 1, lambda x: np.asarray(outline.in_clamp(x[0] - px, x[1] - py), dtype=bool)
    )
    tag = max((pg.tag for pg in data.physical_groups.values()), default=0) + 1
    old_i = ft.indices if ft is not None else np.empty(0, np.int32)
    old_v = ft.values if ft is not None else np.empty(0, np.int32)
    keep = ~np.isin(old_i, edges)
    idx = np.concatenate([old_i[keep], edges]).astype(np.int32)
    val = np.concatenate([old_v[keep], np.full(len(edges), tag, np.int32)]).astype(np.int32)
    order = np.argsort(idx)
    return dmesh.meshtags(msh, 1, idx[order], val[order]), tag


def create_robot_mesh(
    robot: RobotSpec, mesh: MeshSpec, comm: MPI.Comm, *, msh_path: Path | str | None = None
) -> RobotMesh:
    """Mesh ``robot`` as ``mesh`` says and distribute it over ``comm`` (collective).

    Args:
        robot: validated ``[robot]`` table.
        mesh: validated ``[mesh]`` table.
        comm: communicator of the dolfinx mesh.
        msh_path: if given, rank 0 also writes the gmsh ``.msh`` file.

    Raises:
        CaseError: ``mesh`` incompatible with ``robot`` (size, strip model, a bonded
            patch too short for the shell's clamp inset).
        GmshError: gmsh failed, made mixed cell types or elements of
            quality below :data:`MIN_QUALITY` (message from rank 0).
    """
    check_mesh_for_robot(robot, mesh)
    outline = outline_of(robot)
    meshed = outline  # the outline the mesh resolves (the shell: its clamp patch inset)
    if mesh.model == "surface":
        try:
            meshed = outline_of(robot, clamp_inset=SHELL_CLAMP_INSET * robot.thickness)
        except ValueError as err:
            raise CaseError(
                "mesh.model",
                mesh.model,
                f"the shell clamps the bonded patch less {SHELL_CLAMP_INSET:g} thicknesses at its "
                f"free edges, and {err}: use mesh.model = 'solid' or a longer bonded patch",
            ) from None
    gmsh_outline = meshed
    if mesh.size_across is not None and mesh.size_across != mesh.size:
        if not isinstance(outline, BeamOutline):
            raise CaseError(
                "mesh.size_across",
                mesh.size_across,
                f"needs arms along the x axis (rectangle, trapezoid, triangle, two-arm, bow-tie "
                f"shapes); '{robot.shape}' has arms in other directions: leave it out",
            )
        gmsh_outline = _StretchedOutline(meshed, mesh.size / mesh.size_across)
    info: dict[str, Any] = {}
    gdim = 2 if mesh.model == "strip" else 3
    data = build_mesh(
        _make_builder(robot, mesh, gmsh_outline, info),
        comm,
        gdim=gdim,
        name=f"robot_{robot.shape}",
        msh_path=msh_path,
    )
    info = comm.bcast(info, root=0)
    groups = {name: (int(pg.dim), int(pg.tag)) for name, pg in data.physical_groups.items()}
    facet_tags = data.facet_tags
    if mesh.model == "surface":
        facet_tags, clamp_tag = _surface_clamp(data, meshed, robot)
        if clamp_tag is not None:
            groups["clamp"] = (1, clamp_tag)
    t = robot.thickness
    px, py, pz = robot.position
    arms = []
    for a in outline.arms:
        if mesh.model == "strip":
            root = (a.root[0] + px, 0.5 * t + pz, 0.0)
        else:
            root = (a.root[0] + px, a.root[1] + py, 0.5 * t + pz)
        d = np.array([a.direction[0], a.direction[1], 0.0])
        arms.append(Arm(a.name, np.array(root), d / math.hypot(*d), a.length, a.tip))
    area = outline.area
    if mesh.model == "strip":
        area = sum(a.length for a in outline.arms) * t
    return RobotMesh(
        mesh=data.mesh,
        cell_tags=data.cell_tags,
        facet_tags=facet_tags,
        groups=groups,
        arms=tuple(arms),
        model=mesh.model,
        thickness=t,
        min_quality=float(info["min_quality"]),
        num_cells=int(info["num_cells"]),
        area=float(area),
    )
