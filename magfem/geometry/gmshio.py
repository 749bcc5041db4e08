"""Run a gmsh model builder on rank 0 and distribute the mesh with named groups.

This is the one place where a gmsh session is opened. A *builder* is a
function ``builder(gmsh_module) -> None`` that, on rank 0, adds geometry and
physical groups (by name) to the current model and generates the mesh. The
resulting :class:`dolfinx.io.gmsh.MeshData` carries ``physical_groups`` by
name; regions are looked up by those names, never by integer tags.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gmsh
from dolfinx import graph
from dolfinx import mesh as dmesh
from dolfinx.io import gmsh as gmshio
from mpi4py import MPI

__all__ = ["GmshError", "build_mesh"]


class GmshError(RuntimeError):
    """gmsh failed to build or mesh a model (message from rank 0).

    Attributes:
        cause: the class name of the builder's exception (e.g. ``MeshQualityError``).
        detail: its message.
    """

    def __init__(self, message: str, cause: str = "", detail: str = "") -> None:
        super().__init__(message)
        self.cause = cause
        self.detail = detail


def _restore_signal_handlers() -> None:
    """Register Python's SIGINT and SIGTERM handlers with the operating system again.

    gmsh's initialisation sets them back to their default action in the C library while
    Python still reports its own handler: a ``kill`` would then end a run at once, without
    the checkpoint that :mod:`magfem.signals` writes. Main thread only (elsewhere a no-op).
    """
    if threading.current_thread() is not threading.main_thread():
        return
    for signum in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(signum)
        if handler is not None:
            signal.signal(signum, handler)


def build_mesh(
    builder: Callable[[Any], None],
    comm: MPI.Comm,
    *,
    gdim: int,
    name: str = "model",
    msh_path: Path | str | None = None,
    verbosity: int = 0,
) -> Any:
    """Build a gmsh model on rank 0 with ``builder`` and distribute it.

    Args:
        builder: adds geometry, physical groups and generates the mesh;
            called on rank 0 inside an initialised gmsh session.
        comm: communicator the dolfinx mesh lives on (collective).
        gdim: geometric dimension of the dolfinx mesh (2 for (r, z) or strips).
        name: gmsh model name.
        msh_path: if given, rank 0 also writes the gmsh ``.msh`` file there.
        verbosity: gmsh ``General.Verbosity`` (0 silent, 5 debug).

    Returns:
        ``dolfinx.io.gmsh.MeshData`` (mesh, cell/facet/ridge tags, physical groups).

    Raises:
        GmshError: on every rank, if the builder or gmsh failed on rank 0.
    """
    error: tuple[str, str] | None = None
    if comm.rank == 0:
        initialized_here = not gmsh.isInitialized()
        if initialized_here:
            gmsh.initialize(interruptible=False)
            _restore_signal_handlers()
        # options are global to the gmsh session: a robot's Mesh.MeshSizeMax of
        # 0.5 mm must not leak into the next model (a 0.3 m air region meshed at
        # 0.5 mm took minutes and 6 GB), so every model starts from the defaults
        gmsh.option.restoreDefaults()
        gmsh.option.setNumber("General.Terminal", 1 if verbosity else 0)
        gmsh.option.setNumber("General.Verbosity", verbosity)
        gmsh.model.add(name)
        try:
            builder(gmsh)
            if msh_path is not None:
                Path(msh_path).parent.mkdir(parents=True, exist_ok=True)
                gmsh.write(str(msh_path))
        except Exception as err:  # reported collectively below
            error = (type(err).__name__, str(err))
    error = comm.bcast(error, root=0)
    if error is not None:
        if comm.rank == 0:
            gmsh.model.remove()
        cause, detail = error
        raise GmshError(f"building '{name}' failed: {cause}: {detail}", cause, detail)
    # ghost cells across shared facets: interior-facet integrals (dS) need them
    partitioner = dmesh.create_cell_partitioner(
        graph.partitioner(), dmesh.GhostMode.shared_facet, 2
    )
    try:
        data = gmshio.model_to_mesh(
            gmsh.model if comm.rank == 0 else None, comm, 0, gdim=gdim, partitioner=partitioner
        )
    finally:
        if comm.rank == 0:
            gmsh.model.remove()
    return data
