"""Helpers shared by the benchmark scripts (run as ``python -m benchmarks.<name>``)."""

from __future__ import annotations

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
