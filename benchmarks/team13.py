"""TEAM problem 13 (cases/team13_field.toml): |B| in the air gap, computed against measured.

The measured |B| (3000 AT, Hall probe) along the line 10 <= x <= 110 mm,
y = 20 mm, z = 55 mm, between the coil's top and the channel's top plate, is
Table 7 of T. Nakata and K. Fujiwara, COMPEL 11(3), 345-369 (1992). The case
is solved at two element sizes on the iron surfaces (the nonlinear 3D
reduced/total-potential solve of :mod:`magfem.field.iron`, P2) so that the
numerical error shows next to the model-vs-measurement difference. Times are
wall times of the whole field build (mesh, source field at the iron's nodes,
form compilation when not cached, Newton, recovery).

Usage::

    python -m benchmarks.team13                       # 12 and 6 mm (~7 min on one core)
    python -m benchmarks.team13 --sizes 10mm 6mm      # other element sizes
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from benchmarks._common import Report
from magfem.case import load_field_case
from magfem.field.build import build_terms
from magfem.field.racetrack import racetrack_distance, racetrack_local

COMM = MPI.COMM_WORLD
CASE = Path(__file__).resolve().parents[1] / "cases" / "team13_field.toml"
X_MM = np.arange(10.0, 111.0, 10.0)
MEASURED_MT = np.array([59.3, 40.0, 33.6, 30.4, 28.3, 26.0, 23.1, 18.2, 11.6, 6.1, 4.06])
"""|B| (mT) at X_MM, y = 20 mm, z = 55 mm: Nakata & Fujiwara (1992), Table 7, 3000 AT."""


def solve(size: str) -> tuple[np.ndarray, np.ndarray, dict[str, float], float]:
    """(|B| of the sources alone, |B| with the iron) on the line (mT), the solve info, wall s."""
    spec = load_field_case(CASE, [f"field.solve.mesh_size={size}"]).field
    t0 = time.perf_counter()
    (term,) = build_terms(spec, COMM)
    wall = time.perf_counter() - t0
    pts = np.column_stack([X_MM * 1e-3, np.full_like(X_MM, 0.02), np.full_like(X_MM, 0.055)])
    fields = term.field.fields  # type: ignore[attr-defined]
    source = np.linalg.norm(fields[0].flux_density(pts), axis=1) * 1e3
    total = np.linalg.norm(term.field.flux_density(pts), axis=1) * 1e3
    return source, total, fields[-1].info, wall


def source_cost(report: Report) -> None:
    """Wall time of the TEAM-13 coil's B (and ∇B) at 10⁴ points 18-22 mm from its winding."""
    geometry = (0.05, 0.05, 0.025, 0.05, 0.1)  # spine half-sides, offsets, length (m)
    p = np.random.default_rng(0).uniform(-0.2, 0.2, (1_000_000, 3))
    p = p[np.abs(racetrack_distance(*geometry, p) - 0.02) < 0.002][:10_000]
    times = []
    for grad in (False, True):
        t0 = time.perf_counter()
        racetrack_local(*geometry, 3000.0, p, grad=grad)
        times.append(time.perf_counter() - t0)
    report.row(
        f"racetrack coil at {len(p):,} points 20 mm from its winding: B {times[0]:.2f} s,"
        f" B and grad B {times[1]:.2f} s"
    )


def main() -> None:
    """Parse the options, print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["12mm", "6mm"], help="iron element sizes")
    args = parser.parse_args()
    report = Report(f"team13.py on {COMM.size} rank(s)", "")
    source_cost(report)
    runs = []
    for size in args.sizes:
        source, total, info, wall = solve(size)
        runs.append(total)
        report.row(
            f"h = {size}: {int(info['dofs']):,} dofs, {int(info['newton_iterations'])} Newton"
            f" iterations, mesh {info['mesh_s']:.1f} s, build {wall:.1f} s"
        )
    head = " | ".join(f"h = {s} (mT, %)" for s in args.sizes)
    report.add(
        "",
        "|B| at y = 20 mm, z = 55 mm (air gap), 3000 AT: measured (Nakata & Fujiwara 1992,"
        " Table 7), the coil alone, and computed (difference to measured):",
        "",
        f"| x (mm) | measured (mT) | coil alone (mT) | {head} |",
        "|---" * (3 + len(runs)) + "|",
    )
    for k, x in enumerate(X_MM):
        cells = " | ".join(f"{r[k]:.2f} ({100 * (r[k] / MEASURED_MT[k] - 1):+.1f})" for r in runs)
        report.add(f"| {x:.0f} | {MEASURED_MT[k]:.2f} | {source[k]:.2f} | {cells} |")
    mean = " | ".join(f"{100 * np.mean(r / MEASURED_MT - 1):+.1f} %" for r in runs)
    report.add(f"| mean difference | | | {mean} |")
    report.print()


if __name__ == "__main__":
    main()
