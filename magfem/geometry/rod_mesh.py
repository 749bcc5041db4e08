"""The rod model's mesh: a 1D mesh in 3D along the midline of every arm, with its section widths.

``[mesh] model = "rod"`` describes the robot by the midlines of its arms
(:mod:`magfem.mechanics.models.rod`). The midline network comes from the
robot's outline:

* beam-like outlines (:class:`~magfem.geometry.beam.BeamOutline`: one arm,
  two arms meeting at x = 0, bow tie): one straight branch per arm from its
  root along ±x; two arms share their root node, so a two-arm strip is one
  continuous rod;
* radial outlines (:class:`~magfem.geometry.radial.RadialOutline`: star,
  flower): one branch per arm from the hub circle outwards, and one *hub
  spoke* per arm from the centre to that arm's root. The spokes meet at the
  centre node; they carry the hub's mass (a spoke of width π r/n, n spokes of
  length r hold the disk's area π r²) and are :data:`HUB_STIFFENING` times
  stiffer than an arm of that section: a rigid hub. Where the hub's bottom
  is bonded (a clamp disk), its spokes are clamped: a bonded hub.

Each branch knows its width as a function of the arc length from its start
(:class:`RodBranch`): linear for trapezoid, rectangle and triangle arms (exact),
the half-disk end of a flower petal sampled where the rod's quadrature asks.

The bonded patch (``clamp``) is a vertex group: every midline vertex over the
patch shrunk by :data:`~magfem.geometry.robot_mesh.SHELL_CLAMP_INSET`
thicknesses at its free edges (``[mesh] root = "bonded"``, the default:
the root compliance of a bonded membrane, as the shell), or over the patch
itself (``"rigid"``: the rod's rigid clamp at the patch edge). A mesh vertex
lies on each end of the clamped stretch, on every arm root and every tip.
Groups: cells ``arm``/``arm_<i>``/``petal_<i>``/... and ``hub``; vertices
``clamp`` and the tips (``tip``, ``tip_<arm>``).

Every cell lives on rank 0 (a rod is too small to split); other ranks take
part in the collective calls with no cells.

Other outlines (manta, membrane, disk, slim triangle fins...) have no rod
model (:class:`~magfem.config.CaseError`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import basix.ufl
import meshio
import numpy as np
import numpy.typing as npt
from dolfinx import graph
from dolfinx import mesh as dmesh
from mpi4py import MPI

from magfem.config import CaseError
from magfem.geometry.beam import BeamArm, BeamOutline
from magfem.geometry.outline import Outline
from magfem.geometry.radial import RadialOutline
from magfem.geometry.spec import MeshSpec, RobotSpec

__all__ = [
    "HUB_STIFFENING",
    "RodBranch",
    "RodGeometry",
    "RodLayout",
    "build_rod_mesh",
    "rod_layout",
]

HUB_STIFFENING = 1.0e3
"""Stiffness of a hub spoke relative to an arm of the same section (a rigid hub)."""

Width = Callable[[npt.NDArray[np.float64]], npt.NDArray[np.float64]]
"""Section width (m) at arc lengths s (m) from a branch's start, vectorised."""


class RodBranch(NamedTuple):
    """A straight piece of the midline network, in the robot frame (m).

    Attributes:
        group: its cell group (an arm's name, or ``hub``).
        start: (2,) start point in the robot's plane.
        direction: (2,) unit vector along the branch.
        length: its length.
        width: section width against arc length from ``start``.
        rigid: a hub spoke (stiffened by :data:`HUB_STIFFENING`).
    """

    group: str
    start: tuple[float, float]
    direction: tuple[float, float]
    length: float
    width: Width
    rigid: bool = False

    def point(self, s: Any) -> npt.NDArray[np.float64]:
        """Points (..., 2) at arc lengths s from the start."""
        s = np.asarray(s, dtype=float)[..., None]
        return np.asarray(self.start) + s * np.asarray(self.direction)


@dataclass(frozen=True)
class RodLayout:
    """The midline network of an outline (robot frame) and where it is held.

    Attributes:
        branches: the branches, arms first.
        in_clamp: vectorised (x, y) -> bool: the clamped points (the bonded
            patch, inset for ``root = "bonded"``).
        tips: arm tip group -> tip point (2,).
    """

    branches: tuple[RodBranch, ...]
    in_clamp: Callable[[Any, Any], Any]
    tips: dict[str, tuple[float, float]]


class RodGeometry(NamedTuple):
    """What the rod model reads besides the mesh: the branches and which cells are whose.

    Attributes:
        branches: the :class:`RodBranch` list, in mesh coordinates (robot
            frame + ``position``; the midline at mid-thickness).
        branch_of_cell: (local cells,) index of each local cell's branch.
        origin: (3,) the mesh position of the robot frame's origin at mid-thickness.
        bending: out-of-plane bending law of the section (``[mesh] rod_bending``).
    """

    branches: tuple[RodBranch, ...]
    branch_of_cell: npt.NDArray[np.int32]
    origin: npt.NDArray[np.float64]
    bending: str = "anticlastic"


def _linear(w0: float, w1: float, length: float) -> Width:
    return lambda s: w0 + (w1 - w0) * np.asarray(s, dtype=float) / length


def _beam_branches(outline: BeamOutline) -> list[RodBranch]:
    out = []
    for b in outline.beams:
        b: BeamArm  # type: ignore[no-redef]
        out.append(
            RodBranch(
                b.name,
                (b.x_root, 0.0),
                (float(b.sign), 0.0),
                b.length,
                _linear(b.root_width, b.tip_width, b.length),
            )
        )
    return out


def _petal(half: float, end: float) -> Width:
    """Width of a petal: 2 × ``half`` up to ``end``, then its half-disk end."""

    def width(s: Any) -> Any:
        s = np.asarray(s, dtype=float)
        cap = 2.0 * np.sqrt(np.clip(half * half - (s - end) ** 2, 0.0, None))
        return np.where(s <= end, 2.0 * half, cap)

    return width


def _constant(value: float) -> Width:
    return lambda s: np.full(np.shape(s), value)


def _radial_branches(outline: RadialOutline) -> list[RodBranch]:
    r, n = outline.hub_radius, outline.n
    arms, spokes = [], []
    spoke_width = math.pi * r / n
    for arm in outline.arms:
        d = arm.direction
        if outline.rounded:
            half = 0.5 * outline.root_width
            width = _petal(half, outline.reach - half - r)
        else:
            w0 = 2.0 * outline._half_width(r)
            width = _linear(w0, outline.tip_width, outline.reach - r)
        arms.append(RodBranch(arm.name, arm.root, d, arm.length, width))
        spokes.append(RodBranch(outline.hub, (0.0, 0.0), d, r, _constant(spoke_width), True))
    return arms + spokes


def rod_layout(outline: Outline, robot: RobotSpec, *, root: str, inset: float) -> RodLayout:
    """The midline network of ``outline`` and its clamped points.

    Args:
        outline: the robot's outline (robot frame).
        robot: the ``[robot]`` table (for messages).
        root: ``"bonded"`` (patch less ``inset``) or ``"rigid"`` (the patch).
        inset: the clamp inset (m) of a bonded patch.

    Raises:
        CaseError: an outline without a rod model, or a bonded patch shorter
            than the inset (key ``mesh.model``).
    """
    if isinstance(outline, BeamOutline):
        branches = _beam_branches(outline)
    elif isinstance(outline, RadialOutline) and outline.n > 0:
        branches = _radial_branches(outline)
    else:
        raise CaseError(
            "mesh.model",
            "rod",
            f"'{robot.shape}' has no rod model (arms along x, stars and flowers have one); "
            "use 'surface' or 'solid'",
        )
    held = outline
    if root == "bonded" and outline.clamped:
        try:
            held = outline.inset_clamp(inset)
        except ValueError as err:
            raise CaseError(
                "mesh.root",
                root,
                f"the bonded patch is held less {inset:g} m at its free edges, and {err}: "
                "use root = 'rigid' or a longer bonded patch",
            ) from None
    tips = {}
    for arm in outline.arms:
        end = np.asarray(arm.root) + arm.length * np.asarray(arm.direction)
        tips[arm.tip] = (float(end[0]), float(end[1]))
    return RodLayout(tuple(branches), held.in_clamp, tips)


def _clamp_edge(branch: RodBranch, in_clamp: Callable[[Any, Any], Any]) -> float | None:
    """Arc length where the clamped stretch starting at the branch's start ends, if inside it."""
    s = np.linspace(0.0, branch.length, 2001)
    p = branch.point(s)
    inside = np.asarray(in_clamp(p[:, 0], p[:, 1]), dtype=bool)
    if not inside[0] or inside.all():
        return None
    k = int(np.argmin(inside))
    lo, hi = float(s[k - 1]), float(s[k])
    while hi - lo > 1e-12 * branch.length:
        mid = 0.5 * (lo + hi)
        p = branch.point(mid)
        lo, hi = (mid, hi) if in_clamp(np.array([p[0]]), np.array([p[1]]))[0] else (lo, mid)
    return lo  # a clamped point: the vertex placed there belongs to the clamp


def _branch_nodes(branch: RodBranch, size: float, in_clamp: Callable[[Any, Any], Any]) -> Any:
    """Arc lengths of the branch's vertices: every piece between breaks split at ``size``."""
    breaks = [0.0, branch.length]
    edge = _clamp_edge(branch, in_clamp)
    if edge is not None and 1e-9 * branch.length < edge < branch.length * (1 - 1e-9):
        breaks.insert(1, edge)
    nodes = [0.0]
    for a, b in itertools.pairwise(breaks):
        n = max(1, math.ceil((b - a) / size - 1e-9))
        nodes += list(np.linspace(a, b, n + 1)[1:])
    return np.array(nodes)


def _mesh_arrays(layout: RodLayout, size: float) -> tuple[Any, Any, Any]:
    """(vertices (N, 2), cells (M, 2), branch index per cell) with shared vertices merged."""
    points: list[Any] = []
    cells: list[tuple[int, int]] = []
    owner: list[int] = []
    index: dict[tuple[int, int], int] = {}
    scale = max(b.length for b in layout.branches)

    def vertex(p: Any) -> int:
        key = (round(p[0] / (1e-9 * scale)), round(p[1] / (1e-9 * scale)))
        if key not in index:
            index[key] = len(points)
            points.append(p)
        return index[key]

    for i, branch in enumerate(layout.branches):
        ids = [vertex(p) for p in branch.point(_branch_nodes(branch, size, layout.in_clamp))]
        cells += list(itertools.pairwise(ids))
        owner += [i] * (len(ids) - 1)
    return np.array(points), np.array(cells, dtype=np.int64), np.array(owner, dtype=np.int32)


def _vertex_tags(msh: Any, layout: RodLayout, origin: Any, groups: dict[str, int]) -> Any:
    """Vertex meshtags: ``clamp`` and the tips (robot frame + origin offset)."""
    scale = max(b.length for b in layout.branches)
    found: list[tuple[Any, int]] = []
    clamp = dmesh.locate_entities(
        msh,
        0,
        lambda x: np.asarray(layout.in_clamp(x[0] - origin[0], x[1] - origin[1]), dtype=bool),
    )
    if "clamp" in groups:
        found.append((clamp, groups["clamp"]))
    for name, tip in layout.tips.items():
        at = dmesh.locate_entities(
            msh,
            0,
            lambda x, tip=tip: (
                np.hypot(x[0] - origin[0] - tip[0], x[1] - origin[1] - tip[1]) < 1e-9 * scale
            ),
        )
        found.append((at, groups[name]))
    idx = np.concatenate([f[0] for f in found]) if found else np.zeros(0, np.int32)
    val = np.concatenate([np.full(len(f[0]), f[1], np.int32) for f in found]) if found else idx
    idx, first = np.unique(idx, return_index=True)  # a clamped tip keeps its tip tag
    return dmesh.meshtags(msh, 0, idx.astype(np.int32), val[first].astype(np.int32))


def _on_first_rank(comm: Any, nparts: int, cell_types: Any, cells: Any) -> Any:
    """Cell partitioner that keeps every cell on rank 0.

    A rod has tens to a few hundred cells: split over ranks, each assembly
    and solve would trade a few microseconds of work for a message exchange.
    The other ranks hold no cells and take part in the collective calls.
    """
    n_local = len(cells[0]) // 2
    return graph.adjacencylist(np.zeros(n_local, dtype=np.int32))._cpp_object


def _write_msh(path: Path, x: Any, cells: Any, cell_tags: Any, groups: dict, vertices: Any) -> None:
    """A gmsh file of the rod (lines and tagged vertices) for ``magfem mesh`` (rank 0)."""
    blocks = [("line", cells)] + [("vertex", v[:, None]) for v, _ in vertices]
    tags = [cell_tags] + [np.full(len(v), tag, np.int32) for v, tag in vertices]
    mesh = meshio.Mesh(
        x,
        blocks,
        cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
        field_data={name: np.array([tag, dim]) for name, (dim, tag) in groups.items()},
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    meshio.write(path, mesh, file_format="gmsh22", binary=False)


def build_rod_mesh(
    robot: RobotSpec,
    mesh: MeshSpec,
    comm: MPI.Comm,
    layout: RodLayout,
    msh_path: Path | str | None = None,
) -> tuple[Any, Any, Any, dict[str, tuple[int, int]], RodGeometry]:
    """The distributed rod mesh of ``layout`` (collective); rank 0 writes ``msh_path`` if given.

    Returns:
        (mesh, cell tags, vertex tags, groups name -> (dim, tag), rod geometry).
    """
    px, py, pz = robot.position
    origin = np.array([px, py, pz + 0.5 * robot.thickness])
    data = None
    if comm.rank == 0:
        pts, cells, owner = _mesh_arrays(layout, mesh.size)
        data = (pts, cells, owner)
    pts, cells, owner = comm.bcast(data, root=0)
    x = np.zeros((len(pts), 3))
    x[:, :2] = pts
    x += origin
    degree = int(np.bincount(cells.ravel()).max())
    element: Any = basix.ufl.element("Lagrange", "interval", 1, shape=(3,))
    mine = slice(None) if comm.rank == 0 else slice(0, 0)
    msh = dmesh.create_mesh(
        comm,
        cells[mine],
        element,
        x[mine],
        partitioner=_on_first_rank if comm.size > 1 else None,
        max_facet_to_cell_links=max(2, degree),
    )
    names = list(dict.fromkeys(b.group for b in layout.branches))
    groups = {name: (1, i + 1) for i, name in enumerate(names)}
    vertex_names = (["clamp"] if np.any(layout.in_clamp(pts[:, 0], pts[:, 1])) else []) + list(
        layout.tips
    )
    groups |= {name: (0, len(names) + i + 1) for i, name in enumerate(vertex_names)}
    original = np.asarray(msh.topology.original_cell_index, dtype=np.int64)
    local_branch = owner[original]
    cell_values = np.array([groups[layout.branches[b].group][1] for b in local_branch], np.int32)
    tdim = 1
    n_local = msh.topology.index_map(tdim).size_local + msh.topology.index_map(tdim).num_ghosts
    cell_tags = dmesh.meshtags(msh, tdim, np.arange(n_local, dtype=np.int32), cell_values)
    vertex_tags = _vertex_tags(msh, layout, origin, {k: v[1] for k, v in groups.items()})
    if msh_path is not None and comm.rank == 0:
        all_tags = np.array([groups[layout.branches[b].group][1] for b in owner], np.int32)
        held = np.flatnonzero(layout.in_clamp(pts[:, 0], pts[:, 1]))
        tips = [
            np.flatnonzero(np.hypot(pts[:, 0] - p[0], pts[:, 1] - p[1]) < 1e-12 + 1e-9 * mesh.size)
            for p in layout.tips.values()
        ]
        vertices = ([(held, groups["clamp"][1])] if held.size else []) + [
            (v, groups[name][1]) for v, name in zip(tips, layout.tips, strict=True)
        ]
        _write_msh(Path(msh_path), x, cells, all_tags, groups, vertices)
    shifted = tuple(b._replace(start=(b.start[0] + px, b.start[1] + py)) for b in layout.branches)
    return (
        msh,
        cell_tags,
        vertex_tags,
        groups,
        RodGeometry(shifted, local_branch, origin, mesh.rod_bending),
    )


def arm_widths(layout: RodLayout) -> dict[str, tuple[float, float]]:
    """Arm group -> (root width, tip width) (m): what ``magfem check`` reports."""
    out = {}
    for b in layout.branches:
        if not b.rigid:
            w = b.width(np.array([0.0, b.length]))
            out[b.group] = (float(w[0]), float(w[1]))
    return out


def shortest_arm(branches: Sequence[RodBranch]) -> float:
    """Length (m) of the shortest arm branch."""
    return min(b.length for b in branches if not b.rigid)
