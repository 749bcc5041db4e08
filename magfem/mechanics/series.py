"""The displacement as a VTU/PVD series: what pyvista (and ParaView) open directly.

The VTX file of a run (ADIOS2 BP4) holds the displacement at full degree,
but pip's VTK (pyvista) has no ADIOS2 reader. :class:`VtuSeries` writes, every
``[output] vtu_every`` steps and at the last step, the P1 interpolant of the
displacement on the mesh's vertices as one ``.vtu`` file per instant in a
folder next to a ``.pvd`` collection that lists them with their times.
The pieces of every rank are gathered on rank 0 into one grid whose points
are numbered by the global P1 dof numbers, so a file holds one point per
mesh vertex whatever the number of ranks. Strips (2D side views, (x, z))
are written in the x-z plane. Point data: ``displacement`` (m, 3
components); field data: ``time`` (s), ``step``.

Written on rank 0 with pyvista (VTK's XML writer, binary); the collection
is rewritten after each file, so a killed run leaves a readable series.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np
import pyvista
from dolfinx import fem, plot
from mpi4py import MPI

from magfem.mechanics.output import Writer

__all__ = ["VtuSeries"]


class VtuSeries(Writer):
    """The P1 displacement every ``every`` steps and at the end, as ``<stem>/NNNNNN.vtu`` + PVD.

    Args:
        path: the collection file, ``<outdir>/displacement.pvd``; the pieces go
            into the folder ``<outdir>/displacement/``.
        u: the displacement (m), vector Lagrange of any degree.
        comm: the mesh's communicator.
        every: write every this many steps (and the last step).
    """

    def __init__(self, path: Path, u: fem.Function, comm: MPI.Comm, every: int):
        self.path = Path(path)
        self.folder = self.path.with_suffix("")
        self.comm = comm
        self.every = every
        self.u = u
        mesh = u.function_space.mesh
        self.gdim = mesh.geometry.dim
        V1 = fem.functionspace(mesh, ("Lagrange", 1, (self.gdim,)))
        self.u1 = fem.Function(V1, name="displacement")
        imap = V1.dofmap.index_map
        self.n_owned = imap.size_local
        n_all = imap.size_local + imap.num_ghosts
        self.global_ids = np.asarray(imap.local_to_global(np.arange(n_all, dtype=np.int32)))
        cells = np.arange(mesh.topology.index_map(mesh.topology.dim).size_local, dtype=np.int32)
        topology, cell_types, x = plot.vtk_mesh(V1, cells)  # type: ignore[arg-type]
        self.entries: list[tuple[int, float, str]] = []  # (step, time, file name)
        self.grid = self._gather_grid(np.asarray(topology), np.asarray(cell_types), np.asarray(x))

    def _gather_grid(
        self, topology: Any, cell_types: Any, x: Any
    ) -> pyvista.UnstructuredGrid | None:
        """The grid on rank 0 (global vertex numbers), None elsewhere (collective)."""
        per = len(topology) // max(len(cell_types), 1)  # [n, i_0, ..., i_n-1] per cell
        rows = topology.reshape(-1, per).copy() if len(cell_types) else np.zeros((0, per), int)
        rows[:, 1:] = self.global_ids[rows[:, 1:]]
        owned_x = _as_xyz(x[: self.n_owned], self.gdim)
        pieces = self.comm.gather(
            (rows, cell_types, self.global_ids[: self.n_owned], owned_x), root=0
        )
        if self.comm.rank != 0:
            return None
        assert pieces is not None
        n = sum(len(p[2]) for p in pieces)
        points = np.zeros((n, 3))
        for _, _, ids, xs in pieces:
            points[ids] = xs
        cells = np.concatenate([p[0].ravel() for p in pieces]).astype(np.int64)
        types = np.concatenate([p[1] for p in pieces]).astype(np.uint8)
        return pyvista.UnstructuredGrid(cells, types, points)

    def write(self, step: int, t: float, row: Mapping[str, float] | None) -> None:
        if step % self.every == 0:
            self._write(step, t)

    def last(self, step: int, t: float, row: Mapping[str, float]) -> None:
        if not self.entries or self.entries[-1][0] != step:
            self._write(step, t)

    def _write(self, step: int, t: float) -> None:
        """Interpolate, gather on rank 0 and write one file, then the collection (collective)."""
        self.u1.interpolate(self.u)
        bs = self.gdim
        values = self.u1.x.array[: self.n_owned * bs].reshape(-1, bs)
        gathered = self.comm.gather((self.global_ids[: self.n_owned], values), root=0)
        name = f"{step:06d}.vtu"
        self.entries.append((step, float(t), name))
        if self.comm.rank != 0 or self.grid is None or gathered is None:
            return
        disp = np.zeros((self.grid.n_points, 3))
        for ids, vals in gathered:
            disp[ids] = _as_xyz(vals, self.gdim)
        grid = self.grid.copy()
        grid.point_data["displacement"] = disp
        grid.field_data["time"] = np.array([float(t)])
        grid.field_data["step"] = np.array([int(step)])
        self.folder.mkdir(parents=True, exist_ok=True)
        grid.save(self.folder / name, binary=True)
        self._write_collection()

    def _write_collection(self) -> None:
        lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1">']
        lines.append("  <Collection>")
        for _, t, name in self.entries:
            file = quoteattr(f"{self.folder.name}/{name}")
            lines.append(f'    <DataSet timestep="{t!r}" part="0" file={file}/>')
        lines += ["  </Collection>", "</VTKFile>", ""]
        tmp = self.path.with_suffix(".pvd.tmp")
        tmp.write_text("\n".join(lines), encoding="utf-8")
        tmp.replace(self.path)

    def state(self) -> dict[str, Any]:
        """The files written so far: [[step, time, name], ...]."""
        return {"entries": [list(e) for e in self.entries]}

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Keep the files of :meth:`state`; later ones (written after the checkpoint) go."""
        self.entries = [(int(s), float(t), str(n)) for s, t, n in state["entries"]]
        if self.comm.rank == 0:
            keep = {name for _, _, name in self.entries}
            for old in self.folder.glob("*.vtu"):
                if old.name not in keep:
                    old.unlink()
            self._write_collection()


def _as_xyz(values: np.ndarray, gdim: int) -> np.ndarray:
    """(N, gdim) -> (N, 3); strips' (x, z) go to the x-z plane."""
    values = np.asarray(values, dtype=float).reshape(len(values), -1)
    if gdim == 2:
        return np.column_stack([values[:, 0], np.zeros(len(values)), values[:, 1]])
    return values[:, :3]
