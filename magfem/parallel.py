"""MPI conveniences: logging and printing on rank 0, progress bars, work done on rank 0
with its failure shared, agreement on a failure, shared directories.

Every function here is safe to call on all ranks; the collective ones
(:func:`shared_directory`, :func:`root_call`, :func:`agree`) must be called
on all ranks of ``comm``.

Messages of the library go through :mod:`logging` (logger ``magfem`` and
its children). :func:`configure_logging` shows them on rank 0 only:
information on stdout, warnings and errors on stderr as ``magfem: warning:
...``, written above a running progress bar. Without it, the library is
silent (the ``magfem`` logger has a :class:`logging.NullHandler`).
"""

from __future__ import annotations

import logging
import pickle
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

from mpi4py import MPI
from tqdm import tqdm

__all__ = [
    "JIT_WAIT",
    "LOGGER",
    "agree",
    "configure_logging",
    "is_root",
    "progress",
    "rank0_print",
    "root_call",
    "shared_directory",
]

LOGGER = logging.getLogger("magfem")

JIT_WAIT: dict[str, Any] = {"timeout": 900}
"""dolfinx JIT option of every magfem form: how long (s) a process waits for another process
that compiles the same form into the shared cache (sweep points run side by side, test workers)
before it gives up. dolfinx's default, 10 s, is shorter than a cold compile of a large Jacobian
on a loaded machine, and the waiting process then fails with a TimeoutError."""
"""The parent logger of every magfem module."""
LOGGER.addHandler(logging.NullHandler())


class _Rank0Handler(logging.Handler):
    """Writes records through tqdm (above a progress bar) to stdout (< WARNING) or stderr."""

    def __init__(self, out: TextIO | None = None, err: TextIO | None = None):
        super().__init__()
        self.out, self.err = out, err

    def emit(self, record: logging.LogRecord) -> None:
        try:
            message = self.format(record)
            if record.levelno >= logging.WARNING:
                error = record.levelno >= logging.ERROR
                prefix = "magfem: error: " if error else "magfem: warning: "
                tqdm.write(prefix + message, file=self.err or sys.stderr)
            else:
                tqdm.write(message, file=self.out or sys.stdout)
            (self.err or sys.stderr).flush()
            (self.out or sys.stdout).flush()
        except Exception:  # logging must never raise into the run
            self.handleError(record)


def configure_logging(comm: MPI.Comm = MPI.COMM_WORLD, level: int = logging.INFO) -> None:
    """Show magfem's log records at ``level`` and above on rank 0 of ``comm``, none elsewhere.

    Replaces the handlers an earlier call installed (the command line calls it
    once per command, tests may call it several times).
    """
    for handler in list(LOGGER.handlers):
        if isinstance(handler, _Rank0Handler):
            LOGGER.removeHandler(handler)
    LOGGER.setLevel(level)
    if comm.rank == 0:
        LOGGER.addHandler(_Rank0Handler())


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


def root_call[R](comm: MPI.Comm, fn: Callable[[], R]) -> R | None:
    """Run ``fn()`` on rank 0 and raise its exception on every rank (collective).

    Work that only rank 0 does (creating the output folder, writing a file)
    followed by a barrier would leave the other ranks waiting forever when
    it fails: here every rank learns of the failure and raises it (a copy of
    the exception; one that cannot be pickled becomes a ``RuntimeError`` with
    its message). Returns ``fn()``'s result on rank 0, None elsewhere.
    """
    result: R | None = None
    failure: BaseException | None = None
    if comm.rank == 0:
        try:
            result = fn()
        except Exception as err:
            failure = err
    failure = comm.bcast(_portable(failure), root=0)
    if failure is not None:
        raise failure
    return result


def _portable(err: BaseException | None) -> BaseException | None:
    """``err``, or a RuntimeError with its message when it cannot travel through pickle."""
    if err is None:
        return None
    try:
        pickle.loads(pickle.dumps(err))
    except Exception:
        return RuntimeError(" ".join(str(err).split()))
    return err


def agree(comm: MPI.Comm, timeout: float) -> bool:
    """Whether every rank of ``comm`` calls this within ``timeout`` seconds (collective).

    A non-blocking barrier polled until ``timeout``: the ranks that failed
    together learn it and can end together; a rank that fails alone learns
    that the others are busy elsewhere (in a collective call that will never
    complete) and must end the job itself. Use a communicator reserved for
    this (``comm.Dup()`` made at start), so that the barrier cannot match
    another collective call.
    """
    request = comm.Ibarrier()
    deadline = time.monotonic() + timeout
    while not request.Test():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True
