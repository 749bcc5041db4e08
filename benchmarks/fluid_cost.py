"""Cost of the fluid's terms and Newton's iterations with and without them.

One case (default ``cases/manta.toml``; ``--set`` overrides as in
``magfem run``) is run three ways: as written (water), in air (the same
terms, ~800 times weaker, so nearly the vacuum's motion) and without
``[fluid]`` (vacuum). Per variant: steps, mean Newton iterations per step,
step cuts, and the CPU time (``time.process_time``) per Jacobian and per
residual assembly (the fluid's terms are assembled with the body's) and per
step. The fluid's load is UFL of the unknowns with its exact derivative in
the Jacobian (docs/fluid.md), so Newton's iterations should not grow
because of it: the mean iterations of the three variants measure that.

In vacuum or air the scene's 2 mT throws the manta's fins at speeds its
5 ms step cannot follow; ``--set field.sources.0.flux_density=0.2mT`` gives
all three variants a motion the same steps resolve. From the repository
root::

    .venv/bin/python -m benchmarks.fluid_cost --set mesh.size=1mm --set time.end=50ms \
        --set field.sources.0.flux_density=0.2mT
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import dataclasses
import time
from pathlib import Path

from mpi4py import MPI

from benchmarks._common import Report
from magfem.case import Case, load_case
from magfem.mechanics.stepping import SimulationError
from magfem.pipeline import build_simulation

CASE = Path(__file__).resolve().parents[1] / "cases" / "manta.toml"
QUIET = ["output.vtx_every=0", "output.plot=false", "output.animation=false", "output.csv=false"]
PINNED = ["contact.self_contact=false", "time.max_step=5ms"]
"""The fluid's cost alone: the case's self-contact (fins meeting) is left out, and the steps
grow to 5 ms as when docs/fluid.md's numbers were measured (the case's 2 ms is for the whip
of the fins after a reversal, beyond the benchmark's 50 ms)."""


def variants(case: Case) -> dict[str, Case]:
    """The case in water (as written), in air and in vacuum (no ``[fluid]``)."""
    assert case.fluid is not None, "the case has no [fluid]"
    air = dataclasses.replace(case.fluid, medium="air", density=None, viscosity=None)
    return {
        "water": case,
        "air": dataclasses.replace(case, fluid=air),
        "vacuum": dataclasses.replace(case, fluid=None),
    }


def measure(case: Case, comm: MPI.Comm) -> dict[str, float]:
    """Steps, mean Newton iterations, cuts and CPU ms per assembly and per step of one run."""
    sim = build_simulation(case, comm)
    c0 = time.process_time()
    result = sim.run(progress=False)
    cpu = time.process_time() - c0
    s, st = result.summary, sim.solver.timings
    return {
        "steps": s["steps"],
        "newton": s["mean_newton_iterations"],
        "cuts": s["cuts"],
        "jacobian_ms": 1e3 * st.jacobian / max(st.jacobian_calls, 1),
        "residual_ms": 1e3 * st.residual / max(st.residual_calls, 1),
        "step_ms": 1e3 * cpu / max(s["steps"], 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--case", default=str(CASE))
    parser.add_argument("--set", action="append", default=[], help="KEY=VALUE (as magfem run)")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    case = load_case(Path(args.case), [*QUIET, *PINNED, *args.set])
    report = Report(
        f"Fluid terms on {Path(args.case).name} ({' '.join(args.set)}), {comm.size} rank(s)",
        "| fluid | steps | mean Newton it. | cuts | Jacobian (ms) | residual (ms) | step (ms) |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    )
    rows = {}
    for name, variant in variants(case).items():
        try:
            m = measure(variant, comm)
        except SimulationError as err:  # e.g. the violent motion in vacuum at a step for water
            report.row(f"| {name} | failed: {err} |")
            continue
        rows[name] = m
        report.row(
            f"| {name} | {m['steps']:.0f} | {m['newton']:.2f} | {m['cuts']:.0f} | "
            f"{m['jacobian_ms']:.1f} | {m['residual_ms']:.1f} | {m['step_ms']:.0f} |"
        )
    if "water" not in rows or "vacuum" not in rows:
        report.print()
        return
    w, v = rows["water"], rows["vacuum"]
    report.add(
        f"water / vacuum: Jacobian {w['jacobian_ms'] / v['jacobian_ms']:.2f}, "
        f"residual {w['residual_ms'] / v['residual_ms']:.2f}, "
        f"Newton iterations {w['newton'] / v['newton']:.2f}"
    )
    report.print()


if __name__ == "__main__":
    main()
