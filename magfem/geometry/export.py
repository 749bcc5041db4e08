"""Export a robot's gmsh mesh, with its named groups, for other tools (meshio).

``magfem mesh CASE --format vtu`` writes the mesh that gmsh made
(:func:`magfem.geometry.robot_mesh.create_robot_mesh` with ``msh_path``)
also as a VTK file for ParaView, VTK or pyvista. The file holds every gmsh
element of the physical groups: the cells (hexahedra, or quadrilaterals /
triangles of the strip and surface models) and the facets of the facet
groups (``bottom``, ``clamp``, ``top``, ``tip*``), with cell data

* ``group``: the gmsh physical tag of the element (``RobotMesh.groups``);
* one 0/1 array per group name (``arm``, ``clamp``, ...), so a group is
  selected by name (e.g. ParaView's Threshold on ``clamp`` >= 1).

Strip meshes, whose gmsh coordinates are magfem's (x, z), are written in the
x–z plane (y = 0), as the pictures show them. The surface model's ``clamp``
edges are computed after distribution and are not in the gmsh file.
"""

from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np
import numpy.typing as npt
from mpi4py import MPI

__all__ = ["EXPORT_FORMATS", "export_robot_mesh"]

EXPORT_FORMATS: dict[str, str] = {"vtu": "vtu", "vtk": "vtk"}
"""``--format`` value -> meshio file format (the value is also the file extension)."""


def _merged(mesh: meshio.Mesh) -> tuple[list[tuple[str, npt.NDArray[np.int64]]], list[npt.NDArray]]:
    """Cell blocks merged by element type (order of first appearance) and their physical tags."""
    physical = mesh.cell_data["gmsh:physical"]
    types = list(dict.fromkeys(block.type for block in mesh.cells))
    cells, tags = [], []
    for kind in types:
        blocks = [i for i, block in enumerate(mesh.cells) if block.type == kind]
        cells.append((kind, np.concatenate([mesh.cells[i].data for i in blocks])))
        tags.append(np.concatenate([physical[i] for i in blocks]).astype(np.int32))
    return cells, tags


def _convert(msh_path: Path, path: Path, file_format: str, *, strip: bool) -> None:
    source = meshio.read(msh_path, file_format="gmsh")
    cells, tags = _merged(source)
    points = np.asarray(source.points, dtype=np.float64)
    if strip:  # gmsh (x, y) = magfem (x, z)
        points = np.column_stack([points[:, 0], np.zeros(len(points)), points[:, 1]])
    cell_data: dict[str, list[npt.NDArray]] = {"group": tags}
    for name, (tag, _dim) in sorted(source.field_data.items()):
        cell_data[name] = [(t == tag).astype(np.int8) for t in tags]
    path.parent.mkdir(parents=True, exist_ok=True)
    meshio.write(path, meshio.Mesh(points, cells, cell_data=cell_data), file_format=file_format)


def export_robot_mesh(
    msh_path: Path | str, fmt: str, comm: MPI.Comm, *, strip: bool = False
) -> Path:
    """Convert the gmsh file ``msh_path`` to ``fmt`` next to it (rank 0 writes; collective).

    Args:
        msh_path: the ``.msh`` file written by ``create_robot_mesh`` (on rank 0).
        fmt: a key of :data:`EXPORT_FORMATS`.
        comm: every rank calls; rank 0 converts.
        strip: the mesh is a ``strip`` model (coordinates (x, z)).

    Returns:
        The written file (``msh_path`` with the extension ``fmt``).

    Raises:
        ValueError: unknown ``fmt``.
        RuntimeError: on every rank, if meshio failed on rank 0.
    """
    if fmt not in EXPORT_FORMATS:
        raise ValueError(f"format {fmt!r}: allowed are " + ", ".join(EXPORT_FORMATS))
    path = Path(msh_path).with_suffix(f".{fmt}")
    error = None
    if comm.rank == 0:
        try:
            _convert(Path(msh_path), path, EXPORT_FORMATS[fmt], strip=strip)
        except Exception as err:  # reported collectively below
            error = f"{type(err).__name__}: {err}"
    error = comm.bcast(error, root=0)
    if error is not None:
        raise RuntimeError(f"exporting {msh_path} as {fmt} failed: {error}")
    return path
