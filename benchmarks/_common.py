"""Helpers shared by the benchmark scripts (run as ``python -m benchmarks.<name>``)."""

from __future__ import annotations

from pathlib import Path

from magfem.parallel import rank0_print


class Report:
    """The text tables of a benchmark: rows shown as they are measured, the whole at the end.

    A run of several minutes shows each row on rank 0 as soon as it is
    known (so a killed run keeps what it measured); :meth:`print` then
    shows the tables together, headers included, to copy into the docs.
    """

    def __init__(self, *lines: str) -> None:
        self.lines: list[str] = list(lines)

    def add(self, *lines: str) -> None:
        """Titles, headers and reference rows: kept for the end, not shown now."""
        self.lines += lines

    def row(self, line: str) -> None:
        """A measured row: kept and shown now (rank 0)."""
        self.lines.append(line)
        rank0_print(line)

    def print(self) -> None:
        """All the tables (rank 0), after a blank line."""
        rank0_print("\n" + "\n".join(self.lines))


TRAPEZOID = Path(__file__).resolve().parents[1] / "cases" / "one_arm_trapezoid.toml"
"""The default case's file: its robot, material, drive, contact and gravity."""

TRAPEZOID_SOLID = (
    "mesh.model=solid",
    "mesh.size=1mm",
    "mesh.layers=1",
    "solver.degree=2",
    "solver.force_tolerance=0",
    "solver.reuse_jacobian=false",
    "solver.jacobian_free=false",
    "contact.penalty_onset=0.05",
    "fluid.medium=vacuum",
    "time.step=0.5ms",
    "time.end=100ms",
    "time.rho_inf=0.5",
)
"""Overrides that pin :data:`TRAPEZOID` to the configuration the benchmarks of the default
case were measured with (the 1 mm P2 solid at Δt 0.5 ms, which was the default case's until
the accurate shell replaced it), whatever the file says now."""


def pinned_trapezoid(*overrides: str) -> list[str]:
    """:data:`TRAPEZOID_SOLID` then ``overrides``, ``mesh.size_across`` = the last
    ``mesh.size`` unless an override sets it (the file's own ``size_across`` is not used)."""
    items = [*TRAPEZOID_SOLID, *overrides]
    sizes = [item.split("=", 1)[1] for item in items if item.startswith("mesh.size=")]
    if not any(item.startswith("mesh.size_across=") for item in items):
        items.append(f"mesh.size_across={sizes[-1]}")
    return items
