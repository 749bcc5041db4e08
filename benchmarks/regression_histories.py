"""Histories of a few short runs, saved and compared: does a change alter the physics?

A refactor must leave every number where it was. This script runs a fixed
set of short runs that together touch every model and load of magfem (3D
solid with ground contact and friction, the shell, a 2D strip, self-contact,
a radial robot, the quasi-static scheme) and either saves their histories or
compares them with saved ones column by column. From the repository root:

    .venv/bin/python -m benchmarks.regression_histories save DIR
    .venv/bin/python -m benchmarks.regression_histories compare DIR [--rtol 1e-9]
    .venv/bin/python -m benchmarks.regression_histories compare DIR --only default_solid

``compare`` prints, per run, the largest difference of each column relative
to the column's largest magnitude, and exits 1 if any exceeds ``--rtol``.
Runs are serial; ``mpirun -n 2`` works too (the histories are the same on
every rank).
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from benchmarks._common import pinned_trapezoid
from magfem.case import load_case
from magfem.mechanics.columns import read_history
from magfem.pipeline import simulate

CASES = Path(__file__).resolve().parents[1] / "cases"

RUNS: dict[str, tuple[str, list[str]]] = {
    "default_solid": ("one_arm_trapezoid.toml", pinned_trapezoid("time.end=8ms")),
    "default_shell": (
        "one_arm_trapezoid.toml",
        pinned_trapezoid("time.end=8ms", "mesh.model=surface", "mesh.size=1mm"),
    ),
    "two_arm_strip": ("two_arm_20hz.toml", ["time.end=15ms", "mesh.size=0.5mm"]),
    "bow_tie_self_contact": (  # the solid this history was saved with, penalty contact alone
        "bow_tie.toml",
        [
            "time.end=20ms",
            "mesh.size=1mm",
            "field.sources.0.waveform.frequency=30Hz",
            "mesh.model=solid",
            "solver.degree=2",
            "time.step=0.25ms",
            "contact.self_contact_inelastic=false",
            "solver.line_search=basic",
        ],
    ),
    "flower_radial": (  # the solid this history was saved with
        "flower.toml",
        [
            "time.end=6ms",
            "mesh.size=2mm",
            "mesh.model=solid",
            "solver.degree=2",
            "time.step=0.5ms",
            "solver.reuse_jacobian=false",
            "solver.jacobian_free=false",
        ],
    ),
    "active_length_quasi_static": ("active_length.toml", ["mesh.size=1mm", "robot.length=10mm"]),
}
"""name -> (case file, overrides). Outputs other than the history are switched off."""

QUIET = ["output.vtx_every=0", "output.vtu_every=0", "output.plot=false", "output.animation=false"]


def _run(name: str, outdir: Path) -> dict[str, np.ndarray]:
    case_file, sets = RUNS[name]
    case = load_case(CASES / case_file, [*sets, *QUIET])
    t0 = time.perf_counter()
    result = simulate(case, outdir / name, MPI.COMM_WORLD, progress=False)
    if MPI.COMM_WORLD.rank == 0:
        steps = len(result.history["time"]) - 1
        print(f"{name:28s} {steps:5d} steps  {time.perf_counter() - t0:7.1f} s", flush=True)
    return result.history


def _read(path: Path) -> dict[str, np.ndarray]:
    return read_history(path)[0]  # headers with units (time [s]) or without


def _interpolated(ref: dict[str, np.ndarray], new: dict[str, np.ndarray]) -> tuple[float, str]:
    """Largest |Δ| (deg) of the angle columns, ``new`` interpolated onto ``ref``'s times."""
    worst, where = 0.0, "no angle column"
    for key, a in ref.items():
        if not key.startswith("angle") or key not in new:
            continue
        b = np.interp(ref["time"], new["time"], new[key])
        ok = np.isfinite(a) & np.isfinite(b)
        diff = float(np.degrees(np.max(np.abs(a[ok] - b[ok])))) if ok.any() else 0.0
        if diff >= worst:
            worst, where = diff, f"max |d{key}| (deg, interpolated)"
    return worst, where


def _compare(ref: dict[str, np.ndarray], new: dict[str, np.ndarray]) -> tuple[float, str]:
    """(worst relative difference, column) over the columns of ``ref``."""
    if len(ref["time"]) != len(new["time"]):
        angle, key = _interpolated(ref, new)
        return np.inf, f"steps {len(ref['time'])} -> {len(new['time'])}; {key} {angle:.3g}"
    worst, where = 0.0, ""
    for key, a in ref.items():
        b = new.get(key)
        if b is None:
            return np.inf, f"column {key} missing"
        ok = np.isfinite(a) & np.isfinite(b)
        if not np.array_equal(np.isfinite(a), np.isfinite(b)):
            return np.inf, f"column {key}: NaN pattern differs"
        scale = float(np.max(np.abs(a[ok]))) if ok.any() else 0.0
        diff = float(np.max(np.abs(a[ok] - b[ok]))) if ok.any() else 0.0
        rel = diff / scale if scale > 0 else diff
        if rel > worst:
            worst, where = rel, key
    return worst, where


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("action", choices=("save", "compare"))
    p.add_argument("directory", type=Path)
    p.add_argument("--only", action="append", default=[], choices=sorted(RUNS))
    p.add_argument("--rtol", type=float, default=1e-9)
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    names = args.only or list(RUNS)
    failed = False
    for name in names:
        if args.action == "save":
            _run(name, args.directory)
            continue
        ref = _read(args.directory / name / "history.csv")
        new = _run(name, args.directory / "_compare")
        worst, where = _compare(ref, new)
        bad = not worst <= args.rtol
        failed |= bad
        if comm.rank == 0:
            print(f"  {'DIFFERS' if bad else 'same':7s} worst {worst:.3g} ({where})", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
