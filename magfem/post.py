"""Reading a finished (or stopped) run back: history with units, meshes over time, the case.

    from magfem.post import load_run

    run = load_run("output/one_arm_trapezoid")
    run.history["angle_arm"], run.units["angle_arm"]    # (steps + 1,) array, "rad"
    run.case.robot.thickness                             # the resolved case (SI)
    grid = run.mesh(-1)                                  # pyvista grid of the last instant
    for t, grid in run.meshes(): ...                     # every instant of the series

A run folder holds ``history.csv`` (one row per accepted step, headers
``name [unit]``), ``case.resolved.toml`` (the case with every default, SI,
and the versions that ran it in ``[provenance]``) and the displacement
series ``displacement.pvd`` with ``displacement/NNNNNN.vtu`` (the P1
interpolant on the mesh vertices, :mod:`magfem.mechanics.series`). Meshes
come back as :class:`pyvista.UnstructuredGrid` with point data
``displacement`` (m), and by default in the deformed configuration
(points moved by the displacement); strips lie in the x-z plane.

Not collective: call it on one process (rank 0 of a job, or a notebook).
"""

from __future__ import annotations

import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyvista

from magfem.case import Case, load_case
from magfem.mechanics.columns import read_history

__all__ = ["Run", "load_run"]


@dataclass
class Run:
    """A run folder, read (:func:`load_run`).

    Attributes:
        directory: the folder.
        history: column name -> (rows,) array in SI units (empty without ``history.csv``).
        units: column name -> SI unit (``"1"``: dimensionless; None: unknown).
        case: the resolved case.
        provenance: versions of magfem, dolfinx, PETSc, Python and the git commit.
        series: (time in s, file) of every instant of the displacement series.
    """

    directory: Path
    history: dict[str, npt.NDArray[np.float64]]
    units: dict[str, str | None]
    case: Case
    provenance: dict[str, str] = field(default_factory=dict)
    series: list[tuple[float, Path]] = field(default_factory=list)

    @property
    def times(self) -> npt.NDArray[np.float64]:
        """Times of the displacement series (s)."""
        return np.array([t for t, _ in self.series])

    def mesh(self, index: int = -1, *, deformed: bool = True) -> pyvista.UnstructuredGrid:
        """The mesh at instant ``index`` of the series (negative: from the end).

        Args:
            deformed: move the points by the displacement (else the reference).

        Raises:
            FileNotFoundError: the run wrote no series (``[output] vtu_every = 0``).
        """
        if not self.series:
            raise FileNotFoundError(2, "no displacement series", str(self.directory))
        t, path = self.series[index]
        grid = pyvista.read(path)
        if not isinstance(grid, pyvista.UnstructuredGrid):
            raise OSError(f"{path}: not an unstructured grid ({type(grid).__name__})")
        if deformed:
            grid.points = grid.points + np.asarray(grid.point_data["displacement"])
        grid.field_data["time"] = np.array([t])
        return grid

    def meshes(self, *, deformed: bool = True) -> Iterator[tuple[float, pyvista.UnstructuredGrid]]:
        """(time in s, mesh) of every instant of the series, in order."""
        for i, (t, _) in enumerate(self.series):
            yield t, self.mesh(i, deformed=deformed)

    def column(self, name: str) -> tuple[npt.NDArray[np.float64], str | None]:
        """(values, unit) of a history column."""
        return self.history[name], self.units.get(name)


def load_run(directory: str | Path) -> Run:
    """Read the run in ``directory`` (module docstring).

    Raises:
        FileNotFoundError: no ``case.resolved.toml`` (not a run folder).
        magfem.config.CaseError: the resolved case cannot be read back.
    """
    directory = Path(directory)
    resolved = directory / "case.resolved.toml"
    if not resolved.is_file():
        raise FileNotFoundError(2, "not a run folder (no case.resolved.toml)", str(directory))
    case = load_case(resolved)
    data: dict[str, Any] = tomllib.loads(resolved.read_text(encoding="utf-8"))
    history: dict[str, npt.NDArray[np.float64]] = {}
    units: dict[str, str | None] = {}
    if (directory / "history.csv").is_file():
        history, units = read_history(directory / "history.csv")
    return Run(
        directory=directory,
        history=history,
        units=units,
        case=case,
        provenance=dict(data.get("provenance", {})),
        series=_series(directory / "displacement.pvd"),
    )


def _series(pvd: Path) -> list[tuple[float, Path]]:
    """(time, file) of the data sets of a PVD collection (empty when there is none)."""
    if not pvd.is_file():
        return []
    root = ET.parse(pvd).getroot()
    out = []
    for ds in root.iter("DataSet"):
        out.append((float(ds.attrib["timestep"]), pvd.parent / ds.attrib["file"]))
    return out
