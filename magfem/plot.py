"""Off-screen pyvista pictures of robot meshes (and anything else drawn next to them).

Parallel use: every function is called on all ranks. :func:`robot_grid`
gathers the owned cells of a distributed mesh to rank 0 (collective); the
picture is drawn and written on rank 0 only, other ranks get ``None``.

Regenerate the robot gallery of docs/geometry.md with::

    .venv/bin/python -m magfem.plot docs/figures

which writes ``robots_<shape>.png`` (800 × 600) for every shape with its
default dimensions, and ``scene_coil_pair.png``: the coil pair of the
experiments with the default one-arm trapezoid at its centre.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyvista
from dolfinx import plot
from mpi4py import MPI

from magfem.case import parse_case
from magfem.config import from_table
from magfem.geometry.robot_mesh import RobotMesh, create_robot_mesh
from magfem.geometry.spec import SHAPES, MeshSpec, RobotSpec
from magfem.mechanics.pose import initial_motion
from magfem.scene_grids import MeshItem, Region, contact_items, source_grids, source_items

__all__ = ["MeshItem", "plot_mesh_groups", "plot_robot", "plot_scene", "robot_grid", "source_grids"]

WINDOW = (800, 600)
_PALETTE = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
    "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
]  # fmt: skip


def robot_grid(robot_mesh: RobotMesh, comm: MPI.Comm | None = None) -> Any:
    """The robot mesh as one pyvista grid on rank 0 (``None`` elsewhere); collective.

    Cell data ``"group"`` holds the index of each cell's group in
    ``grid.field_data["groups"]`` (sorted cell-group names). Strip meshes
    (gdim 2, coordinates (x, z)) are drawn in the x–z plane.
    """
    comm = robot_mesh.mesh.comm if comm is None else comm
    msh = robot_mesh.mesh
    tdim = msh.topology.dim
    n_owned = msh.topology.index_map(tdim).size_local
    cells = np.arange(n_owned, dtype=np.int32)
    topology, cell_types, x = plot.vtk_mesh(msh, tdim, cells)
    names = sorted(n for n, (d, _) in robot_mesh.groups.items() if d == tdim)
    tag_to_index = {robot_mesh.groups[n][1]: i for i, n in enumerate(names)}
    group = np.full(n_owned, -1, dtype=np.int32)
    tags = robot_mesh.cell_tags
    local = tags.indices < n_owned
    group[tags.indices[local]] = [tag_to_index.get(int(v), -1) for v in tags.values[local]]
    if msh.geometry.dim == 2 or x.shape[1] == 2:
        x = np.column_stack([x[:, 0], np.zeros(len(x)), x[:, 1]])  # (x, z) -> x-z plane
    gathered = comm.gather((topology, cell_types, x, group), root=0)
    if comm.rank != 0:
        return None
    topo_all, types_all, x_all, group_all = [], [], [], []
    offset = 0
    for topo, ctypes, xs, grp in gathered or []:
        if len(ctypes):
            per = len(topo) // len(ctypes)  # one cell type per mesh: [n, i_0..i_n-1] rows
            rows = np.asarray(topo).reshape(-1, per).copy()
            rows[:, 1:] += offset
            topo_all.append(rows.ravel())
            types_all.append(ctypes)
            group_all.append(grp)
        x_all.append(xs)
        offset += len(xs)
    grid = pyvista.UnstructuredGrid(
        np.concatenate(topo_all), np.concatenate(types_all), np.concatenate(x_all)
    )
    grid.cell_data["group"] = np.concatenate(group_all)
    grid.field_data["groups"] = np.array(names)
    return grid


def plot_mesh_groups(
    path: Path | str,
    items: Sequence[MeshItem],
    *,
    title: str | None = None,
    view: str = "iso",
    window_size: tuple[int, int] = WINDOW,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Path | None:
    """Draw ``items`` off screen into the PNG ``path`` (rank 0 writes; returns the path there).

    ``view``: ``"iso"`` (3D), ``"xy"`` (top) or ``"xz"`` (side). Items whose
    grid is ``None`` (non-root ranks of :func:`robot_grid`) are skipped.
    """
    if comm.rank != 0:
        return None
    pyvista.OFF_SCREEN = True
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    plotter: Any = pyvista.Plotter(off_screen=True, window_size=list(window_size))
    plotter.background_color = "white"
    legend = False
    for item in items:
        if item.grid is None:
            continue
        style: dict[str, Any] = {
            "opacity": item.opacity,
            "show_edges": item.show_edges,
            "edge_color": "#333333",
            "line_width": 0.5,
        }
        if item.scalars is None:
            plotter.add_mesh(
                item.grid, color=item.color or "lightgray", label=item.label or None, **style
            )
            legend = legend or bool(item.label)
            continue
        # one colour per category, named in the legend
        names = [str(n) for n in item.grid.field_data.get("groups", [])]
        values = np.asarray(item.grid.cell_data[item.scalars])
        for i in np.unique(values):
            part = item.grid.extract_cells(np.flatnonzero(values == i))
            name = names[i] if 0 <= i < len(names) else str(i)
            plotter.add_mesh(part, color=_PALETTE[int(i) % len(_PALETTE)], label=name, **style)
            legend = True
    if legend:
        plotter.add_legend(bcolor="white", face="rectangle", size=(0.2, 0.3))
    if title:
        plotter.add_text(title, font_size=12, color="black")
    views = {"iso": "view_isometric", "xy": "view_xy", "xz": "view_xz"}
    getattr(plotter, views[view])()
    plotter.screenshot(str(path))
    plotter.close()
    return path


def plot_robot(
    robot: RobotMesh | RobotSpec,
    path: Path | str,
    *,
    title: str | None = None,
    view: str = "iso",
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Path | None:
    """PNG of a robot coloured by cell group; call on all ranks, rank 0 writes.

    Args:
        robot: a :class:`~magfem.geometry.robot_mesh.RobotMesh` (gathered
            collectively over its communicator) or a
            :class:`~magfem.geometry.spec.RobotSpec` (meshed on rank 0 alone
            with element size min_feature/4).
        path: PNG file to write.
        title: text in the top-left corner (default: the shape or model).
        view: ``"iso"``, ``"xy"`` or ``"xz"``.
    """
    if isinstance(robot, RobotSpec):
        grid = None
        if comm.rank == 0:
            rm = create_robot_mesh(robot, MeshSpec(size=robot.min_feature / 4), MPI.COMM_SELF)
            grid = robot_grid(rm, MPI.COMM_SELF)
        title = robot.shape if title is None else title
    else:
        grid = robot_grid(robot, robot.mesh.comm)
        title = robot.model if title is None else title
    return plot_mesh_groups(
        path, [MeshItem(grid, label="group", scalars="group")], title=title, view=view, comm=comm
    )


def plot_scene(
    case: Any,
    path: Path | str,
    *,
    robot: RobotMesh | None = None,
    title: str | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Path | None:
    """PNG of a case's scene: robot, field sources, iron parts, obstacles, cargo; rank 0 writes.

    Everything is drawn at t = 0 (the robot in its ``[initial]`` placement),
    and each body that moves also faintly where its path takes it farthest
    (:mod:`magfem.scene_grids`). ``robot``: the case's distributed robot mesh
    (gathered, collective); default: the case's robot meshed on rank 0 alone
    with its ``[mesh]``. A case without a robot (a field-only case) shows its
    sources about the field's workspace. Call on all ranks.
    """
    grid = robot_grid(robot, robot.mesh.comm) if robot is not None else None
    if comm.rank != 0:
        return plot_mesh_groups(path, [], comm=comm)
    items: list[MeshItem] = []
    end = None
    if hasattr(case, "robot"):
        if grid is None:
            rm = create_robot_mesh(case.robot, case.mesh, MPI.COMM_SELF)
            grid = robot_grid(rm, MPI.COMM_SELF)
        grid = _placed_robot(case, grid)
        around = Region.of_bounds(grid.bounds)
        end = case.time.end
        items += contact_items(case.contacts, around, end)
        items.append(MeshItem(grid, label="robot", color="#d62728", show_edges=False))
    items = source_items(case.field, end) + items
    return plot_mesh_groups(path, items, title=title or case.name, view="iso", comm=comm)


def _placed_robot(case: Any, grid: Any) -> Any:
    """The robot grid moved to its ``[initial]`` placement (a copy; the grid if not placed)."""
    if not case.initial.moves:
        return grid
    px, py, pz = case.robot.position
    motion = initial_motion(case.initial, (px, py, pz + 0.5 * case.robot.thickness))
    placed = grid.copy()
    placed.points = motion.position(np.asarray(grid.points, dtype=float))
    return placed


SCENE_TITLE = "coil pair (115 mm, 35 mm thick, 70 mm apart) with a 7.5 mm trapezoid arm"


def _scene_case() -> Any:
    """The coil pair of the experiments (axis x) with the default trapezoid at its centre."""
    return parse_case(
        {
            "name": "coil_pair_scene",
            "robot": {"shape": "trapezoid", "thickness": "80 um"},
            "mesh": {"size": "0.5 mm"},
            "material": {"shear_modulus": "115 kPa", "density": "2130 kg/m^3"},
            "field": {
                "sources": [
                    {
                        "kind": "coil_pair",
                        "axis": [1, 0, 0],
                        "flux_density": "2 mT",
                        "waveform": {"kind": "dc"},
                    }
                ]
            },
        }
    )


def _gallery(outdir: Path) -> None:
    """Write robots_<shape>.png for every shape with default dimensions (rank 0)."""
    for shape in SHAPES:
        spec = from_table(RobotSpec, {"shape": shape, "thickness": "100 um"}, "robot")
        out = plot_robot(spec, outdir / f"robots_{shape}.png", title=f"{shape} (defaults)")
        if out is not None:
            print(out, flush=True)
    case = _scene_case()
    out = plot_scene(case, outdir / "scene_coil_pair.png", title=SCENE_TITLE)
    if out is not None:
        print(out, flush=True)


if __name__ == "__main__":
    _gallery(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("docs/figures"))
