"""The elastomer's material damping on one scene: the two-arm strip at 20 Hz, 2 mT.

Runs cases/two_arm_20hz.toml (its report study: 50 ms, two and a half
periods) without material damping and with the Kelvin–Voigt damping of
``[[loads]] kind = "material_damping"`` at loss tangents tan δ = 0.05, 0.1
and 0.2 at the drive frequency, and prints how far each run got (a run whose
Newton fails at the smallest step stops there: the message is printed), the
scene's observables over that time (largest angle of each arm, bending speed
0° → 90°, largest strain) and the largest difference of each arm's angle
history from the undamped run over the time both ran. From the repository
root (~2 min on one core):

    .venv/bin/python -m benchmarks.material_damping_effect [--out DIR]
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

from magfem.case import load_case
from magfem.mechanics.columns import read_history
from magfem.mechanics.observers import history_summary
from magfem.mechanics.stepping import SimulationError
from magfem.pipeline import simulate

CASE = Path(__file__).resolve().parents[1] / "cases" / "two_arm_20hz.toml"
QUIET = ["time.end=50ms", "output.vtx_every=0", "output.plot=false", "output.animation=false"]
LOSS_TANGENTS = (0.0, 0.05, 0.1, 0.2)
ARMS = ("right", "left")


def _run(loss_tangent: float, out: Path) -> tuple[dict[str, np.ndarray], float, str]:
    """(history, wall time, the failure's message or "")."""
    sets = list(QUIET)
    if loss_tangent > 0.0:
        sets.append(
            f'loads=[{{kind="material_damping", loss_tangent={loss_tangent}, frequency="20Hz"}}]'
        )
    case = load_case(CASE, sets)
    folder = out / f"tan_delta_{loss_tangent:g}"
    t0 = time.perf_counter()
    failure = ""
    try:
        simulate(case, folder, MPI.COMM_WORLD, progress=False)
    except SimulationError as err:  # the history until the failure is on disk
        failure = str(err)
    history, _ = read_history(folder / "history.csv")
    return history, time.perf_counter() - t0, failure


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("output/benchmarks/material_damping"))
    args = parser.parse_args()
    runs = {tan: _run(tan, args.out) for tan in LOSS_TANGENTS}
    if MPI.COMM_WORLD.rank:
        return
    ref = runs[0.0][0]
    print("two-arm strip, 2 mT square wave at 20 Hz, 0-50 ms (cases/two_arm_20hz.toml)")
    head = ["tan δ", "reached (ms)", "max angle R", "max angle L", "speed R °/ms", "speed L °/ms"]
    head += ["max strain", "max |Δ angle| R", "max |Δ angle| L", "wall s"]
    print(" | ".join(head))
    for tan, (history, wall, failure) in runs.items():
        summary = history_summary(history, start=0.0, frequency=20.0)
        end = float(history["time"][-1])
        cells = [f"{tan:g}", f"{1e3 * end:.2f}"]
        cells += [f"{np.degrees(summary[f'max_angle_arm_{a}']):.1f}°" for a in ARMS]
        cells += [f"{np.degrees(summary[f'bending_speed_arm_{a}']) / 1e3:.2f}" for a in ARMS]
        cells.append(f"{summary['max_strain']:.3f}")
        both = ref["time"] <= end
        for a in ARMS:
            key = f"angle_arm_{a}"
            other = np.interp(ref["time"][both], history["time"], history[key])
            cells.append(f"{np.degrees(np.max(np.abs(other - ref[key][both]))):.1f}°")
        cells.append(f"{wall:.0f}")
        print(" | ".join(cells))
        if failure:
            print(f"    stopped: {failure}")


if __name__ == "__main__":
    main()
