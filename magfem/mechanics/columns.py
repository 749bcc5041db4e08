"""The columns of a run's history: their units, and reading ``history.csv`` back.

``history.csv`` names every column with its SI unit, ``name [unit]``:
``time [s]``, ``angle_arm [rad]``, ``Bx [T]``, ``energy_total [J]``,
``strain [1]`` (``1``: dimensionless). Inside magfem (the run's history,
summaries, sweeps) columns go by their bare names; :func:`read_history`
returns both. A part that adds columns whose names are not in
:data:`UNITS` gives their units with a ``units() -> dict`` method.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
import numpy.typing as npt

__all__ = ["UNITS", "header", "read_history", "split_header", "unit_of"]

UNITS: tuple[tuple[str, str], ...] = (
    (r"time|dt", "s"),
    (r"newton_iterations|cuts|folds_.+", "1"),
    (r"angle_.+", "rad"),
    (r"B[xyz]", "T"),
    (r"energy_density", "J/m^3"),
    (r"energy_.+|self_contact_absorbed", "J"),
    (r"strain|bending_strain|tip_normal_.+|tip_lateral_.+|spread_.+", "1"),
    (r"active_length_.+|self_contact_penetration|self_contact_[xyz]", "m"),
    (r"curvature_.+", "1/m"),
    (r"contact_force|friction_force|self_contact_force(_.+)?|obstacle_.+_[xyz]", "N"),
)
"""(regular expression of a column name, its SI unit), first match wins."""

_HEADER = re.compile(r"^(.*?)\s*\[([^\]]*)\]\s*$")


def unit_of(column: str, declared: Mapping[str, str] | None = None) -> str | None:
    """The SI unit of history column ``column`` (``declared`` first), or None if unknown."""
    if declared and column in declared:
        return declared[column]
    for pattern, unit in UNITS:
        if re.fullmatch(pattern, column):
            return unit
    return None


def header(columns: Iterable[str], declared: Mapping[str, str] | None = None) -> list[str]:
    """CSV header cells ``name [unit]`` (``name`` alone when the unit is unknown)."""
    cells = []
    for c in columns:
        unit = unit_of(c, declared)
        cells.append(f"{c} [{unit}]" if unit is not None else c)
    return cells


def split_header(cell: str) -> tuple[str, str | None]:
    """``"angle_arm [rad]"`` -> ("angle_arm", "rad"); a cell without brackets -> (cell, None)."""
    match = _HEADER.match(cell)
    if match is None:
        return cell.strip(), None
    return match.group(1), match.group(2)


def read_history(
    path: Path,
) -> tuple[dict[str, npt.NDArray[np.float64]], dict[str, str | None]]:
    """The columns of a ``history.csv`` by bare name (empty cells: NaN), and their units.

    Reads headers with units (``time [s]``) and without (older runs) alike;
    a last row cut short (a run killed while writing it) is left out. Every
    column is empty for a file without rows; ({}, {}) for an empty file.
    """
    with Path(path).open(newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        return {}, {}
    names = [split_header(c)[0] for c in rows[0]]
    units = {n: split_header(c)[1] for n, c in zip(names, rows[0], strict=True)}
    body = [r for r in rows[1:] if len(r) == len(names)]
    data = np.array([[float(v) if v else np.nan for v in r] for r in body], dtype=float)
    data = data.reshape(len(body), len(names))
    return {n: data[:, i].copy() for i, n in enumerate(names)}, units
