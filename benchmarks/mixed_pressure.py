"""Newton with and without the mixed pressure on the near-incompressible models (K = 100 μ).

``[solver] mixed_pressure`` (:mod:`magfem.mechanics.models.pressure`) makes
Newton solve for the pressure at the volumetric quadrature points with the
displacement: the same discrete solution, another Newton path. Runs with
``mixed_pressure`` off and on side by side (column ``mixed``; the default
``auto`` is on for the solid, off for the strip):

* free vibration (ρ∞ = 1, no gravity): the cantilever of
  :func:`verification.setups.switch_off_case` (80 µm, 2 mT push for 3 ms, then
  free) for 10 ms: the 0.5 mm plane-strain strip at Δt 0.25 ms and the 2 mm
  solid at Δt 0.5 ms, fixed steps or the steps of the energy tests after the
  push (Δt × :data:`verification.setups.STEP_PATTERN`); Newton rtol 1e-10 (the
  energy tests'), 1e-6 (the default) and 1e-6 with ``force_tolerance`` 0.1;
  the drift of the total energy after the push;
* the drives of ``benchmarks.regression_histories`` (``one_arm_trapezoid``
  8 ms solid, ``two_arm_20hz`` 15 ms strip) with adaptive steps as a user runs
  them, and both variants replaying the displacement run's steps ("same"),
  where they must agree to Newton's tolerance.

Columns: steps, Newton iterations per step, step cuts, CPU time of the
process (s: the time loop; for the adaptive drives the whole run, with the
forms' compilation cached; CPU rather than wall time, as the machine is
shared) and the largest angle difference from the displacement formulation
(deg). From the repository root (serial)::

    .venv/bin/python -m benchmarks.mixed_pressure
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from benchmarks._common import Report
from magfem.case import load_case
from magfem.pipeline import build_simulation, simulate
from verification.setups import (
    SHEAR_MODULUS,
    STEP_PATTERN,
    SWITCH_OFF,
    relative_drift,
    switch_off_case,
)

CASES = Path(__file__).resolve().parents[1] / "cases"
QUIET = ["output.vtx_every=0", "output.vtu_every=0", "output.plot=false", "output.animation=false"]
FREE = {"strip": (0.5e-3, 4e-3, 2.5e-4), "solid": (2e-3, 2e-3, 5e-4)}
"""model -> (mesh size, width, Δt), SI: the free-vibration runs."""
TOLERANCES = {
    "1e-10": {"rtol": 1e-10},
    "1e-6": {"rtol": 1e-6},
    "1e-6+ft": {"rtol": 1e-6, "force_tolerance": 0.1},
}
"""Newton settings: rtol 1e-10 (the energy tests'), 1e-6 (the default), and with force_tolerance."""
SHOWN = 5e-3  # s: the step whose residual norms per iteration are printed
DRIVES = (
    ("one_arm_trapezoid.toml", ["time.end=8ms"]),
    ("two_arm_20hz.toml", ["time.end=15ms", "mesh.size=0.5mm"]),
)


def free_vibration(
    model: str, mixed: bool, solver: dict[str, float], pattern: bool, bulk: float | None = None
):
    """(steps, iterations, cuts, cpu, drift, tip angles, residual norms of the step ending
    nearest :data:`SHOWN`) of a free-vibration run; ``bulk``: K (Pa), None: 100 μ."""
    size, width, dt = FREE[model]
    case = switch_off_case(model, size, width, dt, steps=1000)
    switch = "on" if mixed else "off"
    case = replace(case, solver=replace(case.solver, mixed_pressure=switch, **solver))
    case = replace(case, material=replace(case.material, bulk_modulus=bulk))
    sim = build_simulation(case, MPI.COMM_WORLD)
    sim.initialise()
    norms: list[list[float]] = []
    sim.solver.snes.setMonitor(lambda snes, it, norm: norms[-1].append(norm))
    t, iterations, cuts, energy, angles, k, shown = 0.0, 0, 0, [], [], 0, (1.0, [])
    t0 = time.process_time()
    while t < 10e-3 - 1e-9:
        free = t > SWITCH_OFF + 1e-9
        sim.controller.dt = dt * (STEP_PATTERN[k % len(STEP_PATTERN)] if free and pattern else 1)
        k += free
        norms.append([])
        t, report, c = sim.step(t)
        shown = min(shown, (abs(t - SHOWN), norms[-1]))
        iterations += report.iterations
        cuts += c
        row = sim.observe(t)
        angles.append(row["angle_arm"])
        if t > SWITCH_OFF + 1e-9:
            energy.append(row["energy_total"])
    cpu = time.process_time() - t0
    drift = relative_drift(np.array(energy))
    return len(angles), iterations, cuts, cpu, drift, np.array(angles), shown[1]


def _case(case_file: str, sets: list[str], mixed: bool) -> Any:
    switch = "on" if mixed else "off"
    return load_case(CASES / case_file, [*sets, *QUIET, f"solver.mixed_pressure={switch}"])


def drive(case_file: str, sets: list[str], mixed: bool):
    """(times, angles, iterations, cuts, cpu) of a drive with adaptive steps."""
    case = _case(case_file, sets, mixed)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.process_time()
        result = simulate(case, Path(tmp) / "run", MPI.COMM_WORLD, progress=False)
        cpu = time.process_time() - t0
    history = result.history
    its, cuts = history["newton_iterations"].sum(), history["cuts"].sum()
    return history["time"], _angles(history), int(its), int(cuts), cpu


def replay(case_file: str, sets: list[str], mixed: bool, times: np.ndarray):
    """(times, angles, iterations, cuts, cpu) of a drive that takes the steps of ``times``."""
    case = _case(case_file, sets, mixed)
    sim = build_simulation(case, MPI.COMM_WORLD)
    sim.initialise()
    t, its, cuts, rows, reached = 0.0, 0, 0, [sim.observe(0.0)], [0.0]
    t0 = time.process_time()
    for dt in np.diff(times):
        sim.controller.dt = float(dt)
        t, report, c = sim.step(t)
        its, cuts = its + report.iterations, cuts + c
        rows.append(sim.observe(t))
        reached.append(t)
    cpu = time.process_time() - t0
    angles = np.array([[v for k, v in row.items() if k.startswith("angle")] for row in rows])
    return np.array(reached), angles, its, cuts, cpu


def _angles(history: dict[str, Any]) -> np.ndarray:
    return np.column_stack([v for k, v in history.items() if k.startswith("angle")])


def _difference(ref: tuple[np.ndarray, np.ndarray], times: np.ndarray, angles: np.ndarray) -> float:
    """Largest |Δangle| (deg), ``angles`` interpolated onto the reference's times."""
    t_ref, a_ref = ref
    other = np.column_stack([np.interp(t_ref, times, a) for a in angles.T])
    return float(np.degrees(np.nanmax(np.abs(other - a_ref))))


def main() -> None:
    report = Report(
        "free vibration, rho_inf = 1, 10 ms (push 3 ms); steps: fixed or the energy tests' pattern",
        f"{'model':13} {'steps':7} {'newton':8} {'mixed':>5} {'steps':>5} {'it/step':>7} "
        f"{'cuts':>4} {'cpu s':>6} {'drift':>8} {'max dangle':>10}",
    )
    residuals = Report("", "residual norm per Newton iteration, fixed steps, rtol 1e-10, t = 5 ms")
    for model in FREE:
        for pattern in (False, True):
            for tol, solver in TOLERANCES.items():
                if pattern and tol != "1e-10":
                    continue
                ref = None
                variants = [(False, None), (True, None)]
                if tol == "1e-10" and not pattern:
                    variants.append((False, 10 * SHEAR_MODULUS))
                for mixed, bulk in variants:
                    n, its, cuts, cpu, drift, ang, norms = free_vibration(
                        model, mixed, solver, pattern, bulk
                    )
                    diff = 0.0 if ref is None else float(np.degrees(np.max(np.abs(ang - ref))))
                    ref = ang if ref is None else ref
                    label = f"{model}{'' if bulk is None else ' K=10mu'}"
                    report.row(
                        f"{label:13} {'pattern' if pattern else 'fixed':7} {tol:8} {mixed!s:>5} "
                        f"{n:5d} {its / n:7.2f} {cuts:4d} {cpu:6.1f} {drift:8.1e} {diff:10.2e}"
                    )
                    if tol == "1e-10" and not pattern:
                        residuals.add(
                            f"{label} mixed={mixed}: " + " ".join(f"{r:.1e}" for r in norms)
                        )
    report.add(
        "",
        "drives: adaptive steps as a user runs them; same: the displacement run's steps",
        f"{'case':18} {'steps':8} {'mixed':>5} {'steps':>5} {'it/step':>7} {'cuts':>4} "
        f"{'cpu s':>6} {'max dangle':>10}",
    )
    for case_file, sets in DRIVES:
        ref = None
        for label in ("adaptive", "same"):
            for mixed in (False, True):
                if label == "adaptive":
                    times, angles, its, cuts, cpu = drive(case_file, sets, mixed)
                else:
                    times, angles, its, cuts, cpu = replay(case_file, sets, mixed, ref[0])
                ref = (times, angles) if ref is None else ref
                n = len(times) - 1
                report.row(
                    f"{case_file[:-5]:18} {label:8} {mixed!s:>5} {n:5d} {its / n:7.2f} "
                    f"{cuts:4d} {cpu:6.1f} {_difference(ref, times, angles):10.2e}"
                )
    report.lines += residuals.lines
    report.print()


if __name__ == "__main__":
    main()
