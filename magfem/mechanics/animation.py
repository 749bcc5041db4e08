"""Animation of a run: boundary-surface snapshots while it goes, a GIF at the end.

The animation is made from light-weight snapshots rather than from the VTX
file (reading BP4 back needs the ``adios2`` Python package, which the stack
does not ship): :class:`MotionSnapshots` gathers the displacement on rank 0
at ``[output] animation_frames`` equally spaced instants (the first accepted
step at or after each), keeps only the points of the boundary surface
(linearised, ``extract_surface``) and writes each snapshot at once as
``snapshots/frame_NNNNN.npz`` (float32), so the frames of a killed run are
on disk. :func:`write_animation` renders them off screen with pyvista into a
GIF (Pillow) with the time and the applied field in the corner; the run
calls it at its end (also after a solver failure), and it can be called by
hand on the ``snapshots`` folder of a killed run.
"""

from __future__ import annotations

import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyvista
from dolfinx import plot
from mpi4py import MPI
from PIL import Image

__all__ = ["MotionSnapshots", "remove_snapshots", "write_animation"]


class MotionSnapshots:
    """Boundary-surface snapshots of the deformed body, one file each, on rank 0 (collective).

    Args:
        directory: folder of the snapshot files (created; emptied of old frames).
        u: displacement (m), vector Lagrange on the robot mesh.
        comm: the mesh's communicator.
        frames: number of equally spaced instants over [start, end] (at least 2).
        start, end: time span of the run (s).

    Files: ``surface.npz`` (``points`` (P, 3) reference positions of the
    surface points, m; ``faces`` the pyvista face array) and per snapshot
    ``frame_NNNNN.npz`` (``time`` s, ``field`` (3,) T, ``displacement``
    (P, 3) float32 m). Strips (gdim 2, coordinates (x, z)) are stored in the
    x–z plane.
    """

    def __init__(
        self,
        directory: Path,
        u: Any,
        comm: MPI.Comm,
        *,
        frames: int,
        start: float,
        end: float,
    ):
        self.directory = Path(directory)
        self.u = u
        self.comm = comm
        self.interval = (end - start) / max(frames - 1, 1)
        self.next_time = start
        self.count = 0
        V = u.function_space
        msh = V.mesh
        tdim = msh.topology.dim
        self.gdim = msh.geometry.dim
        self.bs = V.dofmap.index_map_bs
        n_owned = msh.topology.index_map(tdim).size_local
        owned = np.arange(n_owned, dtype=np.int32)
        topology, cell_types, x = plot.vtk_mesh(V, owned)  # type: ignore[arg-type]
        self.n_local = len(x)
        gathered = comm.gather((topology, cell_types, _as_xyz(np.asarray(x), self.gdim)), root=0)
        self.ids: np.ndarray | None = None
        if comm.rank == 0:
            topo_all, types_all, x_all = [], [], []
            offset = 0
            for topo, ctypes, xs in gathered or []:
                if len(ctypes):
                    per = len(topo) // len(ctypes)  # one cell type: rows [n, i_0..i_n-1]
                    rows = np.asarray(topo).reshape(-1, per).copy()
                    rows[:, 1:] += offset
                    topo_all.append(rows.ravel())
                    types_all.append(ctypes)
                x_all.append(xs)
                offset += len(xs)
            grid = pyvista.UnstructuredGrid(
                np.concatenate(topo_all), np.concatenate(types_all), np.concatenate(x_all)
            )
            surface = grid.extract_surface(
                pass_pointid=True, nonlinear_subdivision=0, algorithm="dataset_surface"
            )
            self.ids = np.asarray(surface.point_data["vtkOriginalPointIds"], dtype=np.int64)
            self.directory.mkdir(parents=True, exist_ok=True)
            for old in self.directory.glob("frame_*.npz"):
                old.unlink()
            np.savez(
                self.directory / "surface.npz",
                points=np.asarray(surface.points, dtype=float),
                faces=np.asarray(surface.faces),
            )

    def due(self, t: float) -> bool:
        """Whether a snapshot is due at time t (same answer on every rank)."""
        return t >= self.next_time - 1e-9 * self.interval

    def write(self, t: float, field: Sequence[float]) -> None:
        """Snapshot the current displacement at time t (s) with the applied field (T)."""
        values = np.asarray(self.u.x.array[: self.n_local * self.bs]).reshape(-1, self.bs)
        gathered = self.comm.gather(values, root=0)
        self.count += 1
        while self.next_time <= t + 1e-9 * self.interval:
            self.next_time += self.interval
        if self.comm.rank != 0 or self.ids is None:
            return
        disp = _as_xyz(np.concatenate(gathered or []), self.gdim)[self.ids]
        np.savez(
            self.directory / f"frame_{self.count - 1:05d}.npz",
            time=float(t),
            field=np.asarray(field, dtype=float),
            displacement=disp.astype(np.float32),
        )


def _as_xyz(values: np.ndarray, gdim: int) -> np.ndarray:
    """(N, gdim) -> (N, 3); strips' (x, z) go to the x–z plane."""
    values = np.asarray(values, dtype=float).reshape(len(values), -1)
    if gdim == 2 or values.shape[1] == 2:
        return np.column_stack([values[:, 0], np.zeros(len(values)), values[:, 1]])
    return values


def write_animation(
    directory: Path,
    path: Path,
    *,
    title: str = "",
    window_size: tuple[int, int] = (480, 320),
    duration: float = 4.0,
    view: str | None = None,
) -> Path | None:
    """Render the snapshots in ``directory`` (:class:`MotionSnapshots`) into the GIF ``path``.

    Not collective: call it on one process (the run calls it on rank 0). The
    camera is fixed so that every frame fits; each frame shows the time (ms)
    and the applied field (mT) in its upper-left corner; the reference
    configuration is drawn in light grey.

    Args:
        duration: total playing time of the GIF (s).
        view: ``"xz"`` (side, default for strips: all points have y = 0) or
            ``"iso"`` (default otherwise).

    Returns:
        ``path``, or None when there are fewer than two snapshots.
    """
    pyvista.OFF_SCREEN = True
    loaded = _load_snapshots(Path(directory))
    if loaded is None:
        return None
    points, faces, frames = loaded
    if view is None:
        view = "xz" if np.all(points[:, 1] == 0) else "iso"
    plotter, moving = _stage(points, faces, frames, view, window_size)
    images = []
    for t, b, d in frames:
        moving.points = points + d
        label = f"t = {1e3 * t:.2f} ms\nB = ({', '.join(f'{1e3 * v:+.2f}' for v in b)}) mT"
        if title:
            label = f"{title}\n{label}"
        plotter.add_text(label, position="upper_left", font_size=9, color="black", name="label")
        plotter.render()
        image = plotter.screenshot(return_img=True)
        images.append(
            Image.fromarray(np.asarray(image)).convert("P", palette=Image.Palette.ADAPTIVE)
        )
    plotter.close()
    path = Path(path)
    images[0].save(
        path,
        save_all=True,
        append_images=images[1:],
        duration=max(int(1000 * duration / len(images)), 20),
        loop=0,
        optimize=True,
    )
    return path


Frame = tuple[float, np.ndarray, np.ndarray]
"""A snapshot: time (s), applied field (T, 3) and displacement of the surface points (m)."""


def _load_snapshots(directory: Path) -> tuple[np.ndarray, np.ndarray, list[Frame]] | None:
    """Surface points, faces and frames of a snapshot folder (None: fewer than two frames)."""
    files = sorted(directory.glob("frame_*.npz"))
    if len(files) < 2 or not (directory / "surface.npz").is_file():
        return None
    with np.load(directory / "surface.npz") as data:
        points = np.asarray(data["points"], dtype=float)
        faces = np.asarray(data["faces"])
    frames = []
    for f in files:
        with np.load(f) as data:
            frames.append(
                (float(data["time"]), np.asarray(data["field"]), np.asarray(data["displacement"]))
            )
    return points, faces, frames


def _stage(
    points: np.ndarray,
    faces: np.ndarray,
    frames: list[Frame],
    view: str,
    window_size: tuple[int, int],
) -> tuple[Any, Any]:
    """An off-screen plotter showing the reference surface, with a camera every frame fits in.

    Returns the plotter and the moving surface (its points are set per frame).
    """
    reference = pyvista.PolyData(points.copy(), faces)
    moving = pyvista.PolyData(points.copy(), faces)
    every = np.vstack([points + d for _, _, d in frames] + [points])
    lo, hi = every.min(axis=0), every.max(axis=0)
    pad = 0.05 * float(np.max(hi - lo))
    bounds = (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad, lo[2] - pad, hi[2] + pad)
    plotter: Any = pyvista.Plotter(off_screen=True, window_size=list(window_size))
    plotter.set_background("white")
    plotter.add_mesh(reference, color="lightgrey", opacity=0.4)
    side = view == "xz"  # a thin strip seen edge-on: draw its outline thick
    plotter.add_mesh(
        moving,
        color="tan",
        show_edges=True,
        edge_color="saddlebrown" if side else "grey",
        line_width=3 if side else 1,
    )
    if side:
        plotter.view_xz()
    else:
        plotter.view_isometric()
    plotter.reset_camera(bounds=bounds)
    return plotter, moving


def remove_snapshots(directory: Path) -> None:
    """Delete a snapshot folder once its GIF is written (rank 0 only)."""
    shutil.rmtree(directory, ignore_errors=True)
