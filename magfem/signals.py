"""SIGINT and SIGTERM as requests to stop a run at the end of its current step.

PETSc installs its own handler for SIGTERM (and others) when it starts: a
signal would then end the process inside the solver with a PETSc error, and
a Ctrl-C raised inside a solver callback becomes a PETSc error too, which
the step control takes for a diverged Newton solve. :class:`StopSignals`
replaces both handlers while a command runs: the first signal only sets
:attr:`StopSignals.received`; the time loop asks :meth:`StopSignals.agreed`
at the end of each step (collective: ``mpirun`` forwards SIGINT and SIGTERM
to every rank, a batch system may signal only some) and stops on every rank
at the same step. A second signal of the same kind takes the default action
(the process ends at once, without a checkpoint).

PETSc's own handlers (SIGTERM, SIGHUP, SIGPIPE, SIGSEGV, ...: they end the
process with "Caught signal number 15 Terminate" and ``MPI_Abort``) are
removed when a command starts (``PetscPopSignalHandler``, what the option
``-no_signal_handler`` does at start-up): a SIGTERM outside a run's loop
then ends the process as it would end any program, and a closed pipe is a
``BrokenPipeError``.

gmsh's initialisation sets SIGINT and SIGTERM back to their default action
in the C library; :mod:`magfem.geometry.gmshio` registers Python's handlers
again after it.

With ``immediate=True`` (commands without a time loop: mesh, field) the
first signal raises :class:`magfem.errors.RunInterrupted` at once.

The commands that start runs (sweep, report) use :class:`DriverSignals`
instead: PETSc's handlers off, and SIGTERM raises :class:`Terminated`, a
``KeyboardInterrupt``, so that a driver stopped by ``kill`` or a batch system
stops the runs it started (each writes its checkpoint) as on Ctrl-C, rather
than leaving them running without it.
"""

from __future__ import annotations

import os
import signal
import threading
from types import FrameType
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

from magfem.errors import RunInterrupted, Terminated

__all__ = ["STOP_SIGNALS", "DriverSignals", "StopSignals"]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopSignals:
    """Context manager: SIGINT/SIGTERM request a stop (module docstring).

    Attributes:
        received: the first signal received on this rank (0: none).
    """

    def __init__(self, *, immediate: bool = False):
        self.immediate = immediate
        self.received = 0
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        PETSc.Sys.popSignalHandler()  # PETSc's handlers off (module docstring)
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGPIPE, signal.SIG_IGN)  # Python's start-up choice, back
        if threading.current_thread() is threading.main_thread():
            for signum in STOP_SIGNALS:
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler if handler is not None else signal.SIG_DFL)
        self._previous.clear()

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.received == signum:  # the second one: end now
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        self.received = self.received or signum
        if self.immediate:
            raise RunInterrupted(signum, "nothing to resume (no time loop was running)")

    def agreed(self, comm: MPI.Comm) -> int:
        """The signal any rank of ``comm`` received (0: none), identical on all (collective)."""
        return int(comm.allreduce(self.received, op=MPI.MAX))


class DriverSignals:
    """Context manager of the drivers: SIGTERM raises :class:`Terminated` (module docstring)."""

    def __init__(self) -> None:
        self._previous: Any = None

    def __enter__(self) -> DriverSignals:
        PETSc.Sys.popSignalHandler()
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGTERM, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGTERM, self._previous)
            self._previous = None

    @staticmethod
    def _handle(signum: int, frame: FrameType | None) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a second SIGTERM ends the driver at once
        raise Terminated()
