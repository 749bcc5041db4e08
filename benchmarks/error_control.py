"""Error-controlled steps (``[time] tolerance``) against the Newton-cost controller.

Runs a case with the default controller and with ``time.tolerance`` at a few
values, and a reference at a fixed step ``--reference-step``; prints steps,
rejected steps, Newton iterations, wall time (s) and the largest difference
of every ``angle*`` column from the reference (deg, the run interpolated
onto the reference's times). From the repository root::

    .venv/bin/python -m benchmarks.error_control cases/one_arm_trapezoid.toml \\
        --set time.end=0.01 --reference-step 2.5e-5
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
from magfem.case import load_case
from magfem.pipeline import build_simulation

QUIET = ["output.csv=false", "output.vtx_every=0", "output.plot=false"]


def _run(path: Path, sets: list[str]) -> tuple[dict[str, np.ndarray], dict[str, float], float]:
    case = load_case(path, [*sets, *QUIET])
    sim = build_simulation(case, MPI.COMM_WORLD)
    t0 = time.perf_counter()
    result = sim.run(progress=False)
    return result.history, result.summary, time.perf_counter() - t0


def _angle_error(ref: dict[str, np.ndarray], run: dict[str, np.ndarray]) -> float:
    worst = 0.0
    for key, a in ref.items():
        if key.startswith("angle") and key in run:
            b = np.interp(ref["time"], run["time"], run[key])
            worst = max(worst, float(np.degrees(np.nanmax(np.abs(a - b)))))
    return worst


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("case", type=Path)
    p.add_argument("--set", action="append", default=[])
    p.add_argument("--reference-step", type=float, required=True)
    p.add_argument("--tolerance", type=float, action="append", default=[])
    args = p.parse_args()
    ref, _, ref_wall = _run(
        args.case, [*args.set, f"time.step={args.reference_step}", "time.adaptive=false"]
    )
    report = Report(
        f"{args.case.name} {' '.join(args.set)}: reference dt = {args.reference_step:g} s "
        f"({len(ref['time']) - 1} steps, {ref_wall:.1f} s)",
        f"{'controller':18} {'steps':>6} {'rejected':>8} {'newton':>7} {'wall':>7} {'err':>8}",
    )
    for tol in [None, *(args.tolerance or [1e-3, 1e-4, 1e-5])]:
        sets = args.set if tol is None else [*args.set, f"time.tolerance={tol}"]
        hist, summary, wall = _run(args.case, sets)
        name = "newton cost" if tol is None else f"tolerance {tol:g}"
        report.row(
            f"{name:18} {summary['steps']:6.0f} {summary.get('rejected_steps', 0):8.0f} "
            f"{summary['newton_iterations']:7.0f} {wall:7.1f} {_angle_error(ref, hist):8.3g}"
        )
    report.print()


if __name__ == "__main__":
    main()
