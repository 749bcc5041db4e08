"""Air's effect on a scene against the scene's numerical uncertainty.

A case is run three ways (``--set`` overrides as in ``magfem run``): in
vacuum (without its ``[fluid]`` table, if it has one), with ``[fluid] medium
= "air"`` (20 °C; the reduced model of docs/fluid.md), and refined in vacuum
(``--refine KEY=VALUE``, e.g. the time step or the mesh size halved). Air's
effect on each summary scalar (``--observe``, default ``max_angle_<arm>`` of
every arm, in degrees for angles) is the difference air − vacuum; the
numerical uncertainty is the difference refined − vacuum. Air is worth
turning on by default only where its effect exceeds the uncertainty.

From the repository root (one_arm_shapes at 50 Hz, two-arm-20hz, the
default case at the end of its first swing)::

    .venv/bin/python -m benchmarks.fluid_air --case cases/one_arm_shapes_rectangle.toml \\
        --set field.sources.0.waveform.frequency=50Hz --set time.end=40ms \\
        --refine time.step=0.125ms --refine mesh.size=0.05mm
    .venv/bin/python -m benchmarks.fluid_air --case cases/two_arm_20hz.toml \\
        --set time.end=50ms --refine time.step=0.125ms --refine mesh.size=0.05mm
    .venv/bin/python -m benchmarks.fluid_air --case cases/one_arm_trapezoid.toml \\
        --set time.end=10ms --refine time.step=0.025ms --refine mesh.size=0.25mm
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import dataclasses
import math
from pathlib import Path

from mpi4py import MPI

from benchmarks._common import Report
from magfem.case import load_case
from magfem.pipeline import build_simulation

QUIET = ["output.vtx_every=0", "output.plot=false", "output.animation=false", "output.csv=false"]


def summary(
    case_path: Path, sets: list[str], comm: MPI.Comm, *, vacuum: bool = False
) -> dict[str, float]:
    """The run's summary scalars; ``vacuum``: without the case's ``[fluid]`` table."""
    case = load_case(case_path, [*QUIET, *sets])
    if vacuum:
        case = dataclasses.replace(case, fluid=None)
    return dict(build_simulation(case, comm).run(progress=False).summary)


def _value(key: str, value: float) -> float:
    return math.degrees(value) if "angle" in key else value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--case", required=True)
    parser.add_argument("--set", action="append", default=[], help="KEY=VALUE (as magfem run)")
    parser.add_argument("--refine", action="append", default=[], help="KEY=VALUE of a refined run")
    parser.add_argument("--observe", action="append", default=[], help="summary scalar")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    path = Path(args.case)
    runs = {"vacuum": args.set, "air": [*args.set, "fluid.medium=air"]}
    runs |= {f"refined {r}": [*args.set, r] for r in args.refine}
    # a case with air on already has [fluid]: every run but the air one leaves it out
    results = {name: summary(path, sets, comm, vacuum=name != "air") for name, sets in runs.items()}
    keys = args.observe or sorted(k for k in results["vacuum"] if k.startswith("max_angle_"))
    keys = [k for k in keys if not k.startswith(("max_angle_halfperiod", "max_angle_1period"))]
    report = Report(
        f"Air on {path.name} ({' '.join(args.set)}), angles in degrees",
        "| scalar | vacuum | air − vacuum | "
        + " | ".join(f"{r} − vacuum" for r in args.refine)
        + " |",
        "| --- " * (3 + len(args.refine)) + "|",
    )
    for key in keys:
        base = _value(key, results["vacuum"][key])
        if math.isnan(base):  # e.g. a two-period maximum of a shorter run
            continue
        diffs = [_value(key, results[name][key]) - base for name in runs if name != "vacuum"]
        report.row(f"| {key} | {base:.3f} | " + " | ".join(f"{d:+.3f}" for d in diffs) + " |")
    report.print()


if __name__ == "__main__":
    main()
