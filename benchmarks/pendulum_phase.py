"""Phase error of a free plate's rigid rotation at ρ∞ = 1: forces averaged over the step or not.

The magnetic pendulum of tests/test_mechanics_observers_body.py (a stiff free
4 × 2 mm plate swinging through 120° in 12 ms in a uniform 2 mT field;
:func:`verification.setups.magnetic_pendulum_error`), on the shell at 1 mm,
for the average vector field (``[time] average_forces = "on"``) and the
implicit midpoint rule (``"off"``, what ``"auto"`` picks for a free body). From the repository root:

    .venv/bin/python -m benchmarks.pendulum_phase
"""

from __future__ import annotations

import math
import time

from mpi4py import MPI

from verification.setups import magnetic_pendulum_error


def main() -> None:
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        print(f"{'dt ms':>6} {'average_forces':>15} {'error deg':>10} {'wall s':>7}")
    for dt in (2e-4, 1e-4, 5e-5):
        for average in ("on", "off"):
            t0 = time.perf_counter()
            error = magnetic_pendulum_error(comm, "surface", dt, average_forces=average)
            wall = time.perf_counter() - t0
            if comm.rank == 0:
                print(f"{1e3 * dt:6.3f} {average:>15} {math.degrees(error):10.4f} {wall:7.1f}")


if __name__ == "__main__":
    main()
