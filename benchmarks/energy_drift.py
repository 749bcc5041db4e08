"""Energy drift of undamped free vibration after a field switch-off (ρ∞ = 1).

The cantilever of :func:`verification.setups.switch_off_energy_drift` per
model (plane-strain strip, shell, solid; K = 100 μ), pushed by 2 mT for
3 ms, then free with the step changing on most steps: the largest relative
change of the total energy at steps dt, dt/2, dt/4 and the observed order
log2(drift(dt)/drift(dt/2)). Wall times in s. From the repository root::

    .venv/bin/python -m benchmarks.energy_drift
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import math
import time

from mpi4py import MPI

from benchmarks._common import Report
from verification.setups import switch_off_energy_drift

RUNS = (
    ("strip", 1e-3, 4e-3, 2.5e-4, 25e-3),
    ("surface", 2e-3, 1e-3, 2.5e-4, 25e-3),
    ("solid", 2e-3, 2e-3, 1.25e-4, 6e-3),
)
"""(model, mesh size, width, coarsest dt, span), SI."""


def main() -> None:
    comm = MPI.COMM_WORLD
    report = Report(
        "energy drift after the switch-off, rho_inf = 1, varying steps",
        f"{'model':8} {'dt (s)':>9} {'span (s)':>9} {'drift':>10} {'order':>6} {'wall':>6}",
    )
    for model, size, width, dt, span in RUNS:
        previous = None
        for k in range(3):
            t0 = time.perf_counter()
            drift = switch_off_energy_drift(comm, model, size, width, dt / 2**k, span)
            wall = time.perf_counter() - t0
            order = math.log2(previous / drift) if previous else float("nan")
            report.row(
                f"{model:8} {dt / 2**k:9.3g} {span:9.3g} {drift:10.3g} {order:6.2f} {wall:6.1f}"
            )
            previous = drift
    report.print()


if __name__ == "__main__":
    main()
