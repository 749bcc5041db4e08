"""How a magfem command ends: its exit status and its one line, on one rank or many.

Exit statuses of the ``magfem`` command (docs/running.md, "Exit statuses"):

====  ==========================================================================
0     done
1     ``sweep``/``report``: some points did not finish (the others are kept)
2     input: the case file, ``--set``, the command line, PETSc options, an
      output folder that holds a previous run (``--resume``/``--overwrite``),
      a checkpoint that does not fit the case
3     solver: Newton failed at the smallest step, or PETSc failed
4     I/O: a file or folder could not be read or written
70    internal error (a bug: run again with ``--debug`` and report the traceback)
130   stopped by SIGINT (Ctrl-C), after writing a checkpoint and the outputs
143   stopped by SIGTERM (``kill``, a batch system), likewise
====  ==========================================================================

:func:`describe` maps an exception to its status and line. :func:`end_with`
ends a command that failed, on every rank of a job: the ranks that failed
together (the usual case: a bad case file, a Newton failure, an output
folder rank 0 could not create) agree within :data:`AGREE_TIMEOUT` seconds
and return the status with one line printed by rank 0; a rank that failed
alone while the others wait in a collective call prints its line and ends
the process, which makes ``mpirun`` end the other ranks.
"""

from __future__ import annotations

import os
import signal
import sys
import traceback
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

from magfem.config import CaseError
from magfem.mechanics.stepping import SimulationError
from magfem.parallel import agree

__all__ = [
    "AGREE_TIMEOUT",
    "EXIT_FAILED",
    "EXIT_INPUT",
    "EXIT_INTERNAL",
    "EXIT_IO",
    "EXIT_SOLVER",
    "RunInterrupted",
    "Terminated",
    "describe",
    "end_with",
]

EXIT_FAILED = 1
EXIT_INPUT = 2
EXIT_SOLVER = 3
EXIT_IO = 4
EXIT_INTERNAL = 70

AGREE_TIMEOUT = float(os.environ.get("MAGFEM_FAILURE_TIMEOUT", "10"))
"""Seconds the failed ranks of a job wait for each other before a rank ends alone
(environment variable ``MAGFEM_FAILURE_TIMEOUT``, default 10)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM received by a driver (sweep, report): handled as Ctrl-C, exit status 143
    (:class:`magfem.signals.DriverSignals`)."""


class RunInterrupted(Exception):
    """A run stopped at the end of a step on a signal, its checkpoint and outputs written.

    Args:
        signum: the signal (SIGINT, SIGTERM).
        message: what was written and how to resume.
    """

    def __init__(self, signum: int, message: str = ""):
        self.signum = int(signum)
        self.message = message
        super().__init__(message or signal.Signals(self.signum).name)

    @property
    def exit_code(self) -> int:
        """128 + the signal number (130 for SIGINT, 143 for SIGTERM)."""
        return 128 + self.signum

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        return (RunInterrupted, (self.signum, self.message))


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


def describe(err: BaseException) -> tuple[int, str]:
    """The exit status of ``err`` and the one line that says what happened."""
    if isinstance(err, RunInterrupted):
        name = signal.Signals(err.signum).name
        return err.exit_code, f"magfem: stopped by {name}: {_one_line(err.message)}"
    if isinstance(err, Terminated):
        return 128 + signal.SIGTERM, (
            "magfem: stopped by SIGTERM: the runs it started were stopped at their checkpoints; "
            "the same command continues them"
        )
    if isinstance(err, KeyboardInterrupt):
        return 128 + signal.SIGINT, "magfem: interrupted (SIGINT); nothing to resume"
    if isinstance(err, CaseError):
        return EXIT_INPUT, f"magfem: error: {_one_line(err)}"
    if isinstance(err, SimulationError):
        return EXIT_SOLVER, f"magfem: error: solver: {_one_line(err)}"
    if isinstance(err, PETSc.Error):
        code = getattr(err, "ierr", "?")
        return EXIT_SOLVER, f"magfem: error: PETSc error {code}: {_one_line(err)}"
    if isinstance(err, OSError):
        where = f"{err.filename}: " if err.filename else ""
        what = err.strerror or _one_line(err)
        return EXIT_IO, f"magfem: error: I/O: {where}{what}"
    if isinstance(err, MemoryError):
        return EXIT_INTERNAL, "magfem: error: out of memory (a smaller mesh, or more ranks)"
    return EXIT_INTERNAL, (
        f"magfem: internal error: {type(err).__name__}: {_one_line(err)} "
        "(run again with --debug for the traceback, and report it)"
    )


def end_with(err: BaseException, comm: MPI.Comm, failures: MPI.Comm, *, debug: bool = False) -> int:
    """End a command that raised ``err``: one line, the exit status (module docstring).

    Args:
        comm: the command's communicator.
        failures: a duplicate of ``comm`` used only here (:func:`magfem.parallel.agree`).
        debug: print the traceback too (rank 0; a rank that fails alone prints its own).

    Returns:
        the exit status, on every rank, when the ranks failed together; a rank
        that failed alone does not return (``os._exit``).
    """
    code, line = describe(err)
    if comm.size == 1 or agree(failures, AGREE_TIMEOUT):
        codes = failures.gather(code, root=0)
        if comm.rank == 0:
            code = max(codes or [code])  # the same status everywhere, the worst if they differ
            _print(line, err, debug)
        return int(failures.bcast(code, root=0))
    _print(f"{line} (rank {comm.rank}; the other ranks are stopped)", err, debug)
    os._exit(code)


def _print(line: str, err: BaseException, debug: bool) -> None:
    if debug and not isinstance(err, RunInterrupted):
        traceback.print_exception(err, file=sys.stderr)
    print(line, file=sys.stderr, flush=True)
    sys.stdout.flush()
