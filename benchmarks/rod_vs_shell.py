"""The rod against the shell on a narrow arm over the first half period of the default drive.

The elastica's cantilever (80 µm, 7.5 mm with a 1 mm bonded root strip,
μ = 115 kPa, M = 123 kA/m), 0.25 mm wide (≈ 3 h, one shell element across),
in cases/one_arm_trapezoid.toml's field (2 mT along −x, 20 Hz square wave),
no gravity, no ground, for the first 25 ms (the arm rises past vertical by
~6 ms and swings there). Both models P3 at Δt = 0.125 ms (fixed, ρ∞ = 0.5):
the shell at 0.25 mm, the rod at 0.25 and 0.125 mm. Prints the shell's tip
angle every millisecond (the table :data:`verification.references.
NARROW_SHELL_DRIVE_DEG`) and each rod's difference from it. ``--widths``
instead compares the two, P3 at 0.25 mm along the arm (the shell 0.25 mm or
0.5 mm across), Δt = 62.5 µs, on arms 0.5, 1 and 2 mm wide over the rise
(0–3.5 ms, before the arm nears vertical and the step sets the error): how
wide an arm the rod holds (:mod:`magfem.accuracy`). From the repository
root (~1.5 min; ``--widths`` ~2 min):

    .venv/bin/python -m benchmarks.rod_vs_shell [--widths]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from mpi4py import MPI

from magfem.parallel import rank0_print
from magfem.pipeline import build_simulation
from verification import setups as vc

STEP = 0.125e-3  # s


def widths(comm: MPI.Comm) -> None:
    """Rod − shell over the rise of arms 0.5, 1 and 2 mm wide (``--widths``)."""
    samples = np.arange(0.0, 3.5e-3 + 1e-9, 0.5e-3)
    for width in (0.5e-3, 1e-3, 2e-3):
        angles = {}
        for model in ("rod", "surface"):
            case = vc.cantilever_case(
                model,
                0.25e-3,
                width,
                "strain",
                name="rod_vs_shell",
                size_across=min(width / 2, 0.5e-3) if model == "surface" else None,
                field=vc.DRIVE,
                time={"end": 3.5e-3, "step": 62.5e-6, "adaptive": False, "rho_inf": 0.5},
                solver={"degree": 3},
            )
            history = build_simulation(case, comm).run(progress=False).history
            angles[model] = np.interp(samples, history["time"], np.degrees(history["angle_arm"]))
        gap = np.max(np.abs(angles["rod"] - angles["surface"]))
        rank0_print(f"{width * 1e3:g} mm wide: max |rod - shell| over 0-3.5 ms {gap:.2f} deg")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--widths", action="store_true", help="arms 0.5, 1 and 2 mm wide")
    comm = MPI.COMM_WORLD
    if parser.parse_args().widths:
        widths(comm)
        return
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
