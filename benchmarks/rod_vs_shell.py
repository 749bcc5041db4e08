"""The rod against the shell on a narrow arm over the first half period of the default drive.

The elastica's cantilever (80 µm, 7.5 mm with a 1 mm bonded root strip,
μ = 115 kPa, M = 123 kA/m), 0.25 mm wide (≈ 3 h, one shell element across),
in cases/one_arm_trapezoid.toml's field (2 mT along −x, 20 Hz square wave),
no gravity, no ground, for the first 25 ms (the arm rises past vertical by
~6 ms and swings there). Both models P3 at Δt = 0.125 ms (fixed, ρ∞ = 0.5):
the shell at 0.25 mm, the rod at 0.25 and 0.125 mm. Prints the shell's tip
angle every millisecond (the table :data:`verification.references.
NARROW_SHELL_DRIVE_DEG`) and each rod's difference from it. From the
repository root (~1.5 min):

    .venv/bin/python -m benchmarks.rod_vs_shell
"""

from __future__ import annotations

import time

import numpy as np
from mpi4py import MPI

from verification import setups as vc

STEP = 0.125e-3  # s


def main() -> None:
    comm = MPI.COMM_WORLD
    samples = np.arange(0.0, vc.HALF_PERIOD + 1e-9, 1e-3)
    traces = {}
    for model, size in (("surface", 0.25e-3), ("rod", 0.25e-3), ("rod", 0.125e-3)):
        start = time.perf_counter()
        t, angle = vc.narrow_drive_history(comm, model=model, size=size, degree=3, step=STEP)
        traces[model, size] = np.interp(samples, t, np.degrees(angle))
        if comm.rank == 0:
            print(f"{model} {size * 1e3:g} mm: {time.perf_counter() - start:.1f} s", flush=True)
    shell = traces["surface", 0.25e-3]
    if comm.rank == 0:
        print("shell tip angle (deg) every ms:", np.round(shell, 2).tolist())
        for (model, size), trace in traces.items():
            if model == "rod":
                d = trace - shell
                print(f"rod {size * 1e3:g} mm - shell: max |d| {np.max(np.abs(d)):.2f} deg,")
                print("  every ms:", np.round(d, 2).tolist())


if __name__ == "__main__":
    main()
