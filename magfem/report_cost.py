"""The cost of the whole ``magfem report``: the runs' wall times, summed and packed on cores.

``magfem report --run`` runs the scenes' runs in one queue on ``--jobs`` workers,
scene after scene in the page's order and each scene's in the study's order,
each run starting on the first worker to free (:func:`magfem.sweep.run_plans`).
:func:`packed_wall` is that schedule's wall time; the page states it for
:data:`REPORT_JOBS` cores under its summary table (:func:`cost_line`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

__all__ = ["REPORT_JOBS", "SO_FAR", "cost_line", "packed_wall", "run_wall", "section_walls"]


REPORT_JOBS = 2
"""Runs at a time in the cost estimate of the whole report (the two cores it is sized for)."""


SO_FAR = " so far"
"""Suffix of a stopped run's wall time in the runs' tables (its runs until now)."""


def run_wall(record: dict[str, Any]) -> tuple[float | None, str]:
    """(wall s to count, the table's cell) of a run's record: a finished or failed run's
    ``wall_s``; a stopped one's ``stopped_wall_s``, its runs until now (the cell says so);
    else (None, "–")."""
    if "wall_s" in record:
        wall = float(record["wall_s"])
        return wall, f"{wall:.0f}"
    if "stopped_wall_s" in record:
        wall = float(record["stopped_wall_s"])
        return wall, f"{wall:.0f}{SO_FAR}"
    return None, "–"


def packed_wall(walls: Sequence[float], jobs: int) -> float:
    """Wall time (s) of runs of ``walls`` (s) started in order, each on the first of ``jobs``
    workers to free (the sweep's local runner)."""
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    free = [0.0] * jobs
    for wall in walls:
        free[free.index(min(free))] += wall
    return max(free)


def cost_line(walls: list[list[float]], unfinished: bool) -> str:
    """The whole report's cost: the runs' wall times (each scene's, in the page's order)
    summed, and packed on two cores in one queue as ``magfem report --run`` runs them."""
    queue = [w for scene in walls for w in scene]
    total = sum(queue)
    packed = packed_wall(queue, REPORT_JOBS)
    line = (
        f"All runs: {total / 3600:.1f} h of one core (the wall times above, summed). "
        f"`magfem report --run --jobs {REPORT_JOBS}` runs them in one queue, {REPORT_JOBS} at a "
        f"time: about {packed / 3600:.1f} h on {REPORT_JOBS} cores at these wall times (the "
        "scenes in the page's order, each scene's runs in the study's, each run started as a "
        "core frees)"
    )
    if unfinished:
        line += ", more once the unfinished runs are done"
    return line + "."


def section_walls(section: list[str]) -> tuple[list[float], bool]:
    """(the wall times of the runs in a scene's section as the page has it, whether a run
    there is not done), read from its runs' table."""
    walls: list[float] = []
    unfinished = False
    columns: list[str] | None = None
    for line in section:
        if not line.startswith("|"):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if columns is None:
            if "status" in cells and "wall (s)" in cells:
                columns = cells
            continue
        if len(cells) != len(columns) or set(line) <= set("|- "):
            continue
        row = dict(zip(columns, cells, strict=True))
        unfinished |= row["status"] != "done"
        if row["wall (s)"] not in ("", "–"):
            walls.append(float(row["wall (s)"].removesuffix(SO_FAR)))
    return walls, unfinished or columns is None
