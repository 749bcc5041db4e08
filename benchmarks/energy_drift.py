"""Energy drift of undamped free vibration after a field switch-off (ρ∞ = 1).

The cantilever of :func:`verification.setups.switch_off_energies` per model
(plane-strain strip, shell, solid, rod; K = 100 μ), pushed by 2 mT for 3 ms,
then free for 1000 steps of dt × the step pattern (the step changes on most
steps): the largest relative change of the total energy over the 1000 steps,
over the first 160 of them, at dt/2 over the same span (320 steps), their
ratio (4 at second order) and the wall times (s). The parameters are those of
``tests/test_mechanics_integrator.py -k 1000_steps``. From the repository root::

    .venv/bin/python -m benchmarks.energy_drift
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import time

from mpi4py import MPI

from benchmarks._common import Report
from verification.setups import relative_drift, switch_off_energies

RUNS = (
    ("strip", 1e-3, 4e-3, 2.5e-4),
    ("surface", 2e-3, 1e-3, 2.5e-4),
    ("solid", 3.75e-3, 3.75e-3, 1e-4),
    ("rod", 0.5e-3, 2e-3, 1e-4),
)
"""(model, mesh size, width, dt), SI."""
STEPS = 1000
SHORT = 160  # a multiple of the step pattern's 8: dt/2 then takes the same steps, halved


def main() -> None:
    comm = MPI.COMM_WORLD
    report = Report(
        f"energy drift after the switch-off, rho_inf = 1, varying steps, {STEPS} steps",
        f"{'model':8} {'dt (s)':>8} {'drift':>9} {f'{SHORT} st':>9} {'dt/2':>9} "
        f"{'ratio':>6} {'wall':>6} {'wall/2':>6}",
    )
    for model, size, width, dt in RUNS:
        t0 = time.perf_counter()
        coarse = switch_off_energies(comm, model, size, width, dt, steps=STEPS)
        t1 = time.perf_counter()
        fine = switch_off_energies(comm, model, size, width, dt / 2, steps=2 * SHORT)
        t2 = time.perf_counter()
        short, half = relative_drift(coarse[: SHORT + 1]), relative_drift(fine)
        report.row(
            f"{model:8} {dt:8.3g} {relative_drift(coarse):9.3g} {short:9.3g} {half:9.3g} "
            f"{short / half:6.1f} {t1 - t0:6.1f} {t2 - t1:6.1f}"
        )
    report.print()


if __name__ == "__main__":
    main()
