"""MPI conveniences: rank-0 printing, progress bars, shared directories.

Every function here is safe to call on all ranks; the collective ones
(:func:`shared_directory`) must be called on all ranks of ``comm``.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path
from typing import Any

from mpi4py import MPI
from tqdm import tqdm

__all__ = ["is_root", "progress", "rank0_print", "shared_directory"]


def is_root(comm: MPI.Comm = MPI.COMM_WORLD) -> bool:
    """True on rank 0 of ``comm``."""
    return comm.rank == 0


def rank0_print(*args: Any, comm: MPI.Comm = MPI.COMM_WORLD, **kwargs: Any) -> None:
    """``print`` on rank 0 only (flushed, so progress shows under mpirun)."""
    if comm.rank == 0:
        kwargs.setdefault("flush", True)
        print(*args, **kwargs)


def progress(total: float, *, desc: str, unit: str = "", comm: MPI.Comm = MPI.COMM_WORLD) -> Any:
    """A tqdm progress bar shown on rank 0 (disabled elsewhere and off a terminal).

    Use ``bar.update(dx)`` and ``bar.set_postfix_str(...)``; all ranks may call
    them. Off a terminal (CI, redirected logs) the bar prints a line at most
    every 10 s, so long runs still show progress.
    """

    class _Bar(tqdm):  # type: ignore[misc]
        # a postfix change must not force a redraw: off a terminal the bar
        # would print a line per step instead of one every ``mininterval``
        def set_postfix_str(self, s: str = "", refresh: bool = False) -> None:
            super().set_postfix_str(s, refresh=False)

    interactive = sys.stderr.isatty()
    return _Bar(
        total=total,
        desc=desc,
        unit=unit,
        disable=comm.rank != 0,
        mininterval=0.2 if interactive else 10.0,
        dynamic_ncols=True,
        bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} {unit} [{elapsed}<{remaining}{postfix}]",
    )


def shared_directory(comm: MPI.Comm = MPI.COMM_WORLD, prefix: str = "magfem-") -> Path:
    """A fresh temporary directory created on rank 0, its path broadcast (collective)."""
    path = tempfile.mkdtemp(prefix=prefix) if comm.rank == 0 else None
    return Path(comm.bcast(path, root=0))
