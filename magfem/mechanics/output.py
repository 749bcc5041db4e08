"""Writers of a run: CSV history, VTX displacement, PNG angle plot, GIF of the motion.

Everything is written *as the run goes* so that a killed run keeps all it
had computed: the CSV is flushed after every accepted step (rank 0 writes;
its header names every column with its unit, :mod:`.columns`), the VTX file
(ADIOS2 BP4, which ParaView reads from 5.9 on; BP5 needs 5.12.1) gets the
displacement every N steps (collective), as does the VTU/PVD series that
pyvista reads (:mod:`.series`), the motion snapshots are written as they
fall due (:mod:`.animation`), and the PNG of the bending angle against time
with the field waveform is drawn at the end.

The time loop holds a list of :class:`Writer`; it calls :meth:`Writer.write`
after every accepted step (and at t₀), with the history row or, at a step
whose row the history does not keep (``[output] history_interval``), None;
a writer that needs a row at a step says so in :meth:`Writer.wants_row`.
When the loop ends (complete,
stopped by a signal, or failed) :meth:`Writer.last` with the last step (the
field series write the final state there), :meth:`Writer.close`, and
:meth:`Writer.finish` with the history. Writers that a resumed run continues
keep their progress through ``state()``/``restore()``
(:mod:`magfem.mechanics.checkpoint`): the CSV is cut back to the
checkpoint's rows and appended to, a resumed VTX series goes on in a new
file ``displacement.<k>.bp`` (a BP4 file cannot be reopened for appending).
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
from magfem.mechanics.columns import header

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

    def write(self, step: int, t: float, row: Mapping[str, float] | None) -> None:
        """After accepted step ``step`` (0: the initial state) ending at t (s), with its
        history row, or None where the history does not keep it."""

    def wants_row(self, step: int, t: float) -> bool:
        """Whether this writer needs the row of the step ending at t (same on every rank)."""
        return False

    def late(self, step: int, t: float, row: Mapping[str, float]) -> None:
        """The row of step ``step``, kept after :meth:`write` had None for it: the last
        step of a stopped or failed run (before :meth:`last`)."""

    def last(self, step: int, t: float, row: Mapping[str, float]) -> None:
        """The loop ended after step ``step`` at t (collective): write the state if skipped."""

    def close(self) -> None:
        """The loop has ended (normally or not): release files (collective)."""

    def finish(self, history: History, *, complete: bool) -> None:
        """After the loop, with the history so far (``complete``: the run reached its end)."""


class CsvHistory:
    """A CSV file with fixed columns, one row per accepted step, flushed each row.

    The header names each column with its unit (:func:`magfem.mechanics.columns.header`).
    The file is opened at the first row; :meth:`resume` makes it keep its first
    rows and append. Only rank 0 touches the file; every rank may call the methods.

    Args:
        units: units of columns that :data:`magfem.mechanics.columns.UNITS` does not know.
    """

    def __init__(
        self,
        path: Path,
        columns: Sequence[str],
        comm: MPI.Comm,
        units: Mapping[str, str] | None = None,
    ):
        self.path = Path(path)
        self.columns = list(columns)
        self.units = dict(units or {})
        self.comm = comm
        self.rows = 0
        self._keep: int | None = None  # rows to keep of an existing file (resume)
        self._file: TextIO | None = None
        self._writer: Any = None

    def _open(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if self._keep is None:
            self._file = self.path.open("w", newline="", encoding="utf-8")
            self._writer = csv.writer(self._file)
            self._writer.writerow(header(self.columns, self.units))
        else:
            with self.path.open(newline="", encoding="utf-8") as fh:
                kept = fh.readlines()[: 1 + self._keep]
            self._file = self.path.open("w", newline="", encoding="utf-8")
            self._file.writelines(kept)
            self._writer = csv.writer(self._file)
        self._file.flush()

    def resume(self, rows: int) -> None:
        """Keep the header and the first ``rows`` rows of the file; append after them."""
        self._keep = int(rows)
        self.rows = int(rows)

    def write(self, row: Mapping[str, float]) -> None:
        """Append one row (missing columns are empty) and flush."""
        self.rows += 1
        if self.comm.rank != 0:
            return
        if self._file is None:
            self._open()
        assert self._file is not None
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


def segment_path(path: Path, segment: int) -> Path:
    """``displacement.bp`` for segment 0, ``displacement.<k>.bp`` for the k-th resumed one."""
    path = Path(path)
    return path if segment == 0 else path.with_name(f"{path.stem}.{segment}{path.suffix}")


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
    """The history CSV (:class:`CsvHistory`), one line per kept row."""

    def __init__(self, csv: CsvHistory):
        self.csv = csv
        self.path = csv.path

    def write(self, step: int, t: float, row: Mapping[str, float] | None) -> None:
        if row is not None:
            self.csv.write(row)

    def late(self, step: int, t: float, row: Mapping[str, float]) -> None:
        self.csv.write(row)

    def close(self) -> None:
        self.csv.close()

    def state(self) -> dict[str, Any]:
        """Rows written so far."""
        return {"rows": self.csv.rows}

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Cut the file back to the rows of :meth:`state` and append after them."""
        self.csv.resume(int(state["rows"]))


class VtxWriter(Writer):
    """The displacement every ``every`` steps and at the end in a VTX (BP4) file (collective).

    The file is opened at the first write; a resumed run writes the next
    segment, ``<stem>.<k>.bp`` (:func:`segment_path`).
    """

    def __init__(self, path: Path, functions: Sequence[Any], comm: MPI.Comm, every: int):
        self.path = Path(path)
        self.functions = list(functions)
        self.comm = comm
        self.every = every
        self.segment = 0
        self.vtx: VtxOutput | None = None
        self.written = -1  # the last step written

    def write(self, step: int, t: float, row: Mapping[str, float] | None) -> None:
        if step % self.every == 0:
            self._write(step, t)

    def _write(self, step: int, t: float) -> None:
        if self.vtx is None:
            self.vtx = VtxOutput(segment_path(self.path, self.segment), self.functions, self.comm)
        self.vtx.write(t)
        self.written = step

    def last(self, step: int, t: float, row: Mapping[str, float]) -> None:
        if step != self.written:
            self._write(step, t)

    def close(self) -> None:
        if self.vtx is not None:
            self.vtx.close()
            self.vtx = None

    def state(self) -> dict[str, Any]:
        """The segment being written."""
        return {"segment": self.segment}

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Go on in the next segment (a BP4 file is not reopened)."""
        self.segment = int(state["segment"]) + 1


class MotionWriter(Writer):
    """Snapshots of the motion as they fall due, and the GIF at the end (rank 0).

    The GIF is made also after a stopped or failed run (the motion up to
    then, the last state included); the snapshot folder is removed once the
    GIF of a complete run exists, and kept otherwise (a resumed run adds to it).
    """

    def __init__(self, path: Path, snapshots: MotionSnapshots, comm: MPI.Comm, title: str):
        self.path = Path(path)
        self.snapshots = snapshots
        self.comm = comm
        self.title = title

    def wants_row(self, step: int, t: float) -> bool:
        return self.snapshots.due(t)

    def write(self, step: int, t: float, row: Mapping[str, float] | None) -> None:
        if step == 0:
            self.snapshots.clear()
        if row is not None and (step == 0 or self.snapshots.due(t)):
            self.snapshots.write(t, (row["Bx"], row["By"], row["Bz"]))

    def last(self, step: int, t: float, row: Mapping[str, float]) -> None:
        if self.snapshots.last_time != t:
            self.snapshots.write(t, (row["Bx"], row["By"], row["Bz"]))

    def finish(self, history: History, *, complete: bool) -> None:
        if self.comm.rank == 0:
            directory = self.snapshots.directory
            if write_animation(directory, self.path, title=self.title) and complete:
                remove_snapshots(directory)

    def state(self) -> dict[str, Any]:
        """Snapshots written, and when the next is due."""
        return self.snapshots.state()

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Drop the snapshots written after :meth:`state` and go on from there."""
        self.snapshots.load_state(state)


class AnglePlotWriter(Writer):
    """The PNG of the arms' angles and the applied field against time, at the end of a run."""

    def __init__(self, path: Path, arms: Sequence[str], comm: MPI.Comm, title: str):
        self.path = Path(path)
        self.arms = list(arms)
        self.comm = comm
        self.title = title

    def finish(self, history: History, *, complete: bool) -> None:
        if self.comm.rank == 0 and len(history["time"]) > 1:
            plot_angles(
                self.path,
                history["time"],
                {n: history[f"angle_{n}"] for n in self.arms},
                history["time"],
                np.column_stack([history["Bx"], history["By"], history["Bz"]]),
                title=self.title if complete else f"{self.title} (stopped)",
            )
