"""Speed and accuracy of every model (rod, strip, shell, solid) on one problem.

The narrow arm of benchmarks/rod_vs_shell.py (80 µm × 0.25 mm, 6.5 mm free
beyond a 1 mm bonded root strip) in the default case's drive (2 mT along −x)
while it rises to vertical (0–6 ms, where every model describes the same
beam). Each model at two resolutions (fixed steps, ρ∞ = 0.5); error: the
largest tip-angle difference over 0–6 ms (every 0.25 ms) from the rod at
0.125 mm P3, Δt = 15.6 µs; the last level of each model takes that step, so
what is left there is the model and its mesh.
The strip is the side view in plane stress (a narrow arm bends as a beam).
CPU seconds of the process, one core, compilation excluded (a warm-up run
of each model first). From the repository root (~4 min; ``--solid`` adds
the 3D solid at two levels, ~10 min more):

    .venv/bin/python -m benchmarks.model_speed_accuracy [--solid]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from mpi4py import MPI

from benchmarks._common import Report
from verification import setups as vc

END = 6e-3  # s
SAMPLES = np.arange(0.0, END + 1e-9, 0.25e-3)
FINE = 0.015625e-3  # s, the reference's step: what is left is the model and the mesh
LEVELS = {  # model: [(size m, degree, step s)]; the strip's size <= the width
    "rod": [(0.5e-3, 2, 0.125e-3), (0.25e-3, 3, 0.0625e-3), (0.25e-3, 3, FINE)],
    "strip": [(0.25e-3, 2, 0.125e-3), (0.125e-3, 2, 0.0625e-3), (0.125e-3, 2, FINE)],
    "surface": [(0.5e-3, 2, 0.125e-3), (0.25e-3, 3, 0.0625e-3), (0.25e-3, 3, FINE)],
    "solid": [(0.25e-3, 2, 0.125e-3), (0.125e-3, 2, 0.0625e-3)],
}


def tip_angles(
    model: str, size: float, degree: int, step: float, end: float = END
) -> tuple[float, np.ndarray]:
    """(CPU s, tip angle in degrees at SAMPLES) of one run to ``end`` (s)."""
    start = time.process_time()
    t, angle = vc.narrow_drive_history(
        MPI.COMM_SELF,
        model=model,
        size=size,
        degree=degree,
        step=step,
        end=end,
        plane="stress" if model == "strip" else "strain",
    )
    return time.process_time() - start, np.interp(SAMPLES, t, np.degrees(angle))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--solid", action="store_true", help="add the 3D solid")
    args = parser.parse_args()
    tip_angles("rod", 0.5e-3, 3, 0.125e-3, 0.25e-3)  # compilation
    _, reference = tip_angles("rod", 0.125e-3, 3, FINE)
    report = Report(
        "| model | resolution | CPU (s, 1 core) | max error 0-6 ms (deg) |", "|---|---|---|---|"
    )
    for model, levels in LEVELS.items():
        if model == "solid" and not args.solid:
            continue
        tip_angles(model, *levels[0], end=2 * levels[0][2])  # compilation
        for size, degree, step in levels:
            cpu, angles = tip_angles(model, size, degree, step)
            error = np.max(np.abs(angles - reference))
            label = f"{size * 1e3:g} mm P{degree}, dt {step * 1e3:g} ms"
            report.row(f"| {model} | {label} | {cpu:.2f} | {error:.3f} |")
    report.print()


if __name__ == "__main__":
    main()
