"""Writers of a run: CSV history, VTX displacement, PNG angle plot, GIF of the motion.

Everything is written *as the run goes* so that a killed run keeps all it
had computed: the CSV is flushed after every accepted step (rank 0 writes),
the VTX file (ADIOS2 BP4, which ParaView reads from 5.9 on; BP5 needs
5.12.1) gets the displacement every N steps (collective), the motion
snapshots are written as they fall due (:mod:`.animation`), and the PNG of
the bending angle against time with the field waveform is drawn at the end.

The time loop holds a list of :class:`Writer`; it calls :meth:`Writer.write`
after every accepted step (and at t₀), :meth:`Writer.close` when the loop
ends for any reason, and :meth:`Writer.finish` with the history.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TextIO

import matplotlib
import numpy as np
import numpy.typing as npt
from dolfinx import io
from mpi4py import MPI

from magfem.mechanics.animation import MotionSnapshots, remove_snapshots, write_animation

matplotlib.use("Agg")
import matplotlib.pyplot as plt

__all__ = [
    "AnglePlotWriter",
    "CsvHistory",
    "CsvWriter",
    "MotionWriter",
    "VtxOutput",
    "VtxWriter",
    "Writer",
    "plot_angles",
]

History = Mapping[str, npt.NDArray[np.float64]]


class Writer:
    """An output of a run, written while it goes (module docstring)."""

    def write(self, step: int, t: float, row: Mapping[str, float]) -> None:
        """After accepted step ``step`` (0: the initial state) ending at t (s)."""

    def close(self) -> None:
        """The loop has ended (normally or not): release files (collective)."""

    def finish(self, history: History, *, complete: bool) -> None:
        """After the loop, with the history so far (``complete``: the run reached its end)."""


class CsvHistory:
    """A CSV file with fixed columns, one row per accepted step, flushed each row.

    Only rank 0 touches the file; every rank may call the methods.
    """

    def __init__(self, path: Path, columns: Sequence[str], comm: MPI.Comm):
        self.path = Path(path)
        self.columns = list(columns)
        self.comm = comm
        self._file: TextIO | None = None
        self._writer: Any = None
        if comm.rank == 0:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = self.path.open("w", newline="", encoding="utf-8")
            self._writer = csv.writer(self._file)
            self._writer.writerow(self.columns)
            self._file.flush()

    def write(self, row: Mapping[str, float]) -> None:
        """Append one row (missing columns are empty) and flush."""
        if self._writer is None or self._file is None:
            return
        self._writer.writerow([_fmt(row.get(c)) for c in self.columns])
        self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
            self._writer = None


def _fmt(value: float | None) -> str:
    if value is None:
        return ""
    return repr(float(value))


class VtxOutput:
    """Displacement (and velocity) in an ADIOS2 BP4 file for ParaView (collective)."""

    def __init__(self, path: Path, functions: Sequence[Any], comm: MPI.Comm):
        self.path = Path(path)
        self.writer = io.VTXWriter(comm, str(self.path), list(functions), engine="BP4")

    def write(self, t: float) -> None:
        self.writer.write(float(t))

    def close(self) -> None:
        self.writer.close()


def plot_angles(
    path: Path,
    time: np.ndarray,
    angles: Mapping[str, np.ndarray],
    field_time: np.ndarray,
    field_values: np.ndarray,
    *,
    title: str = "",
) -> Path:
    """PNG of bending angle(s) (deg) against time (ms) with the field waveform (mT).

    Args:
        time: (N,) s. angles: arm name -> (N,) rad.
        field_time: (M,) s. field_values: (M, 3) flux density at the robot, T.
    """
    fig, ax = plt.subplots(figsize=(7, 4), dpi=120)
    for name, values in angles.items():
        ax.plot(1e3 * np.asarray(time), np.degrees(values), label=f"angle {name}")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("bending angle (deg)")
    ax.grid(True, alpha=0.3)
    ax2 = ax.twinx()
    fv = np.asarray(field_values).reshape(-1, 3)
    for i, comp in enumerate("xyz"):
        if np.any(fv[:, i] != 0):
            ax2.plot(
                1e3 * np.asarray(field_time),
                1e3 * fv[:, i],
                "--",
                lw=0.8,
                color=f"C{3 + i}",
                label=f"B{comp}",
            )
    ax2.set_ylabel("applied field (mT)")
    lines = ax.get_legend_handles_labels()
    lines2 = ax2.get_legend_handles_labels()
    ax.legend(lines[0] + lines2[0], lines[1] + lines2[1], loc="best", fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path)
    plt.close(fig)
    return path


class CsvWriter(Writer):
    """The history CSV (:class:`CsvHistory`), one row per accepted step."""

    def __init__(self, path: Path, columns: Sequence[str], comm: MPI.Comm):
        self.path = Path(path)
        self.csv = CsvHistory(path, columns, comm)

    def write(self, step: int, t: float, row: Mapping[str, float]) -> None:
        self.csv.write(row)

    def close(self) -> None:
        self.csv.close()


class VtxWriter(Writer):
    """The displacement every ``every`` steps in a VTX (BP4) file (collective)."""

    def __init__(self, path: Path, functions: Sequence[Any], comm: MPI.Comm, every: int):
        self.path = Path(path)
        self.every = every
        self.vtx = VtxOutput(path, functions, comm)

    def write(self, step: int, t: float, row: Mapping[str, float]) -> None:
        if step % self.every == 0:
            self.vtx.write(t)

    def close(self) -> None:
        self.vtx.close()


class MotionWriter(Writer):
    """Snapshots of the motion as they fall due, and the GIF at the end (rank 0).

    The GIF is made also after a failed run (the motion up to the failure); its
    snapshot folder is removed once the GIF exists.
    """

    def __init__(self, path: Path, snapshots: MotionSnapshots, comm: MPI.Comm, title: str):
        self.path = Path(path)
        self.snapshots = snapshots
        self.comm = comm
        self.title = title

    def write(self, step: int, t: float, row: Mapping[str, float]) -> None:
        if step == 0 or self.snapshots.due(t):
            self.snapshots.write(t, (row["Bx"], row["By"], row["Bz"]))

    def finish(self, history: History, *, complete: bool) -> None:
        if self.comm.rank == 0:
            directory = self.snapshots.directory
            if write_animation(directory, self.path, title=self.title):
                remove_snapshots(directory)


class AnglePlotWriter(Writer):
    """The PNG of the arms' angles and the applied field against time, after a complete run."""

    def __init__(self, path: Path, arms: Sequence[str], comm: MPI.Comm, title: str):
        self.path = Path(path)
        self.arms = list(arms)
        self.comm = comm
        self.title = title

    def finish(self, history: History, *, complete: bool) -> None:
        if complete and self.comm.rank == 0:
            plot_angles(
                self.path,
                history["time"],
                {n: history[f"angle_{n}"] for n in self.arms},
                history["time"],
                np.column_stack([history["Bx"], history["By"], history["Bz"]]),
                title=self.title,
            )
