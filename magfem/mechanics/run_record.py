"""What a run records: its result, and the lines about its events."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

__all__ = ["EventLog", "SimulationResult"]


@dataclass
class SimulationResult:
    """What a run produced (identical on every rank).

    Attributes:
        history: column name -> (steps + 1,) array (SI units; angles in rad).
        summary: scalar results (step counts, max angles over the first
            one/two periods in rad, largest strain, energy/power density, ...).
        paths: name -> written file (csv, vtx, png, gif), possibly empty.
        log: step-control events, one line each.
        timings: wall time split (s) on rank 0: mesh_and_field, compile,
            residual, jacobian, linear_solve, total.
        effort: Newton iterations and Jacobians assembled in this process's
            run (a resumed run counts from its checkpoint); with a kept
            Jacobian, ``rebuilt_<reason>`` per reason of ``REBUILD_REASONS``.
    """

    history: dict[str, npt.NDArray[np.float64]]
    summary: dict[str, float]
    paths: dict[str, Path] = field(default_factory=dict)
    log: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    effort: dict[str, int] = field(default_factory=dict)


LOG = logging.getLogger("magfem.run")


class EventLog:
    """Lines about a run's events, kept, and logged (shown on rank 0, above the progress bar)."""

    def __init__(self, comm: MPI.Comm):
        self.comm = comm
        self.lines: list[str] = []
        self.bar: Any = None

    def say(self, msg: str) -> None:
        """Record ``msg`` and log it."""
        self.lines.append(msg)
        LOG.info(msg)
