"""Newton with and without the mixed pressure on the near-incompressible models (K = 100 μ).

``[solver] mixed_pressure`` (:mod:`magfem.mechanics.models.pressure`) makes
Newton solve for the pressure at the volumetric quadrature points with the
displacement: the same discrete solution, another Newton path. Two sets of
runs, each with ``mixed_pressure`` true and false, side by side:

* free vibration (ρ∞ = 1, no gravity): the cantilever of
  :func:`verification.setups.switch_off_energies` pushed by 2 mT for 3 ms and
  then free, at a fixed step: the 0.5 mm plane-strain strip (Δt 0.25 ms) and
  the 2 mm solid (Δt 0.5 ms), 10 ms, Newton rtol 1e-10 (the energy tests')
  and 1e-6 (the default); the drift of the total energy after the push;
* the drives of ``benchmarks.regression_histories`` (``one_arm_trapezoid``
  8 ms solid, ``two_arm_20hz`` 15 ms strip), adaptive steps as a user runs
  them, and at the fixed steps of the displacement formulation's run
  (``time.adaptive = false``), where the two must agree to Newton's tolerance.

Columns: steps, Newton iterations per step, step cuts, wall time of the
time loop (s, compilation excluded; wall times vary with the load of the
shared machine) and the largest angle difference between the two variants
(deg). From the repository root (serial)::

    .venv/bin/python -m benchmarks.mixed_pressure
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from benchmarks._common import Report
from magfem.case import load_case
from magfem.pipeline import build_simulation, simulate
from verification.setups import cantilever_case, relative_drift

CASES = Path(__file__).resolve().parents[1] / "cases"
QUIET = ["output.vtx_every=0", "output.vtu_every=0", "output.plot=false", "output.animation=false"]
PUSH = 3e-3  # s
FREE = (("strip", 0.5e-3, 4e-3, 2.5e-4), ("solid", 2e-3, 2e-3, 5e-4))
"""(model, mesh size, width, Δt), SI: the free-vibration runs."""
DRIVES = (
    ("one_arm_trapezoid.toml", ["time.end=8ms"], 1e-4),
    ("two_arm_20hz.toml", ["time.end=15ms", "mesh.size=0.5mm"], 1e-4),
)
"""(case, overrides, the fixed step (s) of the comparison at equal steps)."""


def free_vibration(model: str, size: float, width: float, dt: float, rtol: float, mixed: bool):
    """(steps, iterations, cuts, wall, drift, tip angles) of the free-vibration run."""
    field = {
        "sources": [
            {
                "kind": "uniform",
                "flux_density": "2 mT",
                "direction": [-1, 0, 0],
                "waveform": {"kind": "dc", "duration": PUSH},
            }
        ]
    }
    case = cantilever_case(
        model,
        size,
        width,
        "strain",
        name="mixed",
        field=field,
        solver={"rtol": rtol, "mixed_pressure": mixed},
        time={"end": 1.0, "step": dt, "rho_inf": 1.0},
    )
    sim = build_simulation(case, MPI.COMM_WORLD)
    sim.initialise()
    t, iterations, cuts, energy, angles = 0.0, 0, 0, [], []
    t0 = time.perf_counter()
    for _ in range(round(10e-3 / dt)):
        sim.controller.dt = dt
        t, report, c = sim.step(t)
        iterations += report.iterations
        cuts += c
        row = sim.observe(t)
        angles.append(row["angle_arm"])
        if t > PUSH + 1e-9:
            energy.append(row["energy_total"])
    wall = time.perf_counter() - t0
    steps = len(angles)
    return steps, iterations, cuts, wall, relative_drift(np.array(energy)), np.array(angles)


def drive(case_file: str, sets: list[str], mixed: bool, step: float | None = None):
    """(history, wall) of a drive; ``step``: a fixed step (s), None: adaptive steps."""
    extra = [f"solver.mixed_pressure={'true' if mixed else 'false'}"]
    if step is not None:
        extra += ["time.adaptive=false", f"time.step={step!r} s"]
    case = load_case(CASES / case_file, [*sets, *QUIET, *extra])
    with tempfile.TemporaryDirectory() as tmp:
        result = simulate(case, Path(tmp) / "run", MPI.COMM_WORLD, progress=False)
    timings = result.timings
    wall = timings.get("total", 0.0) - timings.get("compile", 0.0) - timings["mesh_and_field"]
    return result.history, wall


def _angles(history: dict[str, Any]) -> np.ndarray:
    return np.column_stack([v for k, v in history.items() if k.startswith("angle")])


def main() -> None:
    report = Report(
        "free vibration, rho_inf = 1, fixed step, 10 ms (push 3 ms)",
        f"{'model':6} {'rtol':>6} {'mixed':>5} {'steps':>5} {'it/step':>7} {'cuts':>4} "
        f"{'wall s':>6} {'drift':>8} {'max dangle':>10}",
    )
    for model, size, width, dt in FREE:
        for rtol in (1e-10, 1e-6):
            ref = None
            for mixed in (False, True):
                n, its, cuts, wall, drift, ang = free_vibration(model, size, width, dt, rtol, mixed)
                diff = 0.0 if ref is None else float(np.degrees(np.max(np.abs(ang - ref))))
                ref = ang if ref is None else ref
                report.row(
                    f"{model:6} {rtol:6.0e} {mixed!s:>5} {n:5d} {its / n:7.2f} {cuts:4d} "
                    f"{wall:6.1f} {drift:8.1e} {diff:10.2e}"
                )
    report.add(
        "",
        "drives (adaptive: as a user runs them; fixed: steps of 0.1 ms)",
        f"{'case':18} {'steps':>6} {'mixed':>5} {'steps':>5} {'it/step':>7} {'cuts':>4} "
        f"{'wall s':>6} {'max dangle':>10}",
    )
    for case_file, sets, fixed in DRIVES:
        for adaptive in (True, False):
            ref = None
            for mixed in (False, True):
                history, wall = drive(case_file, sets, mixed, None if adaptive else fixed)
                n = len(history["time"]) - 1
                its, cuts = history["newton_iterations"].sum(), history["cuts"].sum()
                ang = _angles(history)
                diff = 0.0
                if ref is not None:
                    t_ref, a_ref = ref
                    other = np.column_stack([np.interp(t_ref, history["time"], a) for a in ang.T])
                    diff = float(np.degrees(np.nanmax(np.abs(other - a_ref))))
                else:
                    ref = (history["time"], ang)
                label = "adaptive" if adaptive else "fixed"
                report.row(
                    f"{case_file[:-5]:18} {label:>6} {mixed!s:>5} {n:5d} {its / n:7.2f} "
                    f"{int(cuts):4d} {wall:6.1f} {diff:10.2e}"
                )
    report.print()


if __name__ == "__main__":
    main()
