"""Why a robot pressed on an obstacle costs so many steps: Newton on the tweezers' prongs.

The tweezers scene (cases/tweezers.toml, 0.8 mm) is run to 25 ms, just before
the robot meets the prongs at ~1.5 m/s, with a checkpoint. From that state
the next 0.6 ms is run again with the contact law's parts switched off one by
one, and with the magnet all but off, and this prints for each variant the
accepted steps, Newton iterations, cut steps and the share of *slow* Newton
iterations (the residual falls by less than half: the line search has cut
the full Newton step back). At the first slow iteration of the case as it is,
the residual along the Newton direction d (J d = R) is compared with its
linear model: ‖R(x − ε d) − (1 − ε) R(x)‖ / (ε ‖R(x)‖) falls in proportion to
ε where the residual is smooth; a jump between two ε marks a switch (a point
entering or leaving the contact's onset, a change of the nearest face)
within that fraction of the step. From the repository root, serially:

    .venv/bin/python -m benchmarks.obstacle_newton [--out DIR]

(~2 min for the first 25 ms, ~1-2 min per variant on one core).
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from magfem.case import load_case
from magfem.mechanics.checkpoint import RunControl, read_checkpoint
from magfem.mechanics.columns import read_history
from magfem.pipeline import build_simulation, simulate
from magfem.rundir import CHECKPOINT

CASE = Path(__file__).resolve().parents[1] / "cases" / "tweezers.toml"
BASE = ["mesh.size=0.8mm", "output.vtx_every=0", "output.plot=false", "output.animation=false"]
START, END = "25ms", "25.6ms"

VARIANTS: dict[str, list[str]] = {
    "as in the case (bt line search)": [],
    "no friction on the prongs": ["contacts.0.friction=0"],
    "no contact dashpot": ["contacts.0.damping=0"],
    "no friction, no dashpot": ["contacts.0.friction=0", "contacts.0.damping=0"],
    "penalty 10x softer (kappa = 1)": ["contacts.0.penalty=1"],
    "magnet 1e-6 T (no pull)": ["field.sources.0.remanence=1e-6T"],
}
"""name -> case overrides for the run from the 25 ms checkpoint to 25.6 ms."""


class NewtonLog:
    """Counts Newton iterations whose residual fell by less than half (SNES monitor)."""

    def __init__(self, check_jacobian: bool) -> None:
        self.iterations = 0
        self.slow = 0
        self.previous = np.inf
        self.check_jacobian = check_jacobian
        self.check: list[tuple[float, float]] = []

    def __call__(self, snes: Any, it: int, norm: float) -> None:
        if it > 0:
            self.iterations += 1
            if norm > 0.5 * self.previous:
                self.slow += 1
                if self.check_jacobian and not self.check:
                    self.check = directional_check(snes)
        self.previous = norm


def directional_check(snes: Any) -> list[tuple[float, float]]:
    """(ε, ‖R(x − ε d) − (1 − ε) R(x)‖ / (ε ‖R(x)‖)) along the Newton direction d at x."""
    x = snes.getSolution().copy()
    r0 = x.duplicate()
    snes.computeFunction(x, r0)
    J, P, _ = snes.getJacobian()
    snes.computeJacobian(x, J, P)
    ksp = PETSc.KSP().create(x.comm)
    ksp.setOperators(J)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    d = x.duplicate()
    ksp.solve(r0, d)
    norm = r0.norm()
    out = []
    xe, re = x.duplicate(), x.duplicate()
    for eps in (1.0, 0.1, 1e-2, 1e-3, 1e-4):
        x.copy(xe)
        xe.axpy(-eps, d)
        snes.computeFunction(xe, re)
        re.axpy(-(1.0 - eps), r0)
        out.append((eps, re.norm() / (eps * norm)))
    snes.computeFunction(x, r0)  # leave the solver's functions at x
    ksp.destroy()
    return out


def _variant(name: str, sets: list[str], base: Path, first: bool) -> dict[str, Any]:
    case = load_case(CASE, [*BASE, *sets, f"time.end={END}"])
    sim = build_simulation(case)
    log = NewtonLog(check_jacobian=first)
    sim.solver.snes.setMonitor(log)
    meta, state = read_checkpoint(base / CHECKPOINT, MPI.COMM_WORLD)
    t0 = time.perf_counter()
    state = {**state, "writers": []}  # no writers here: only the simulation's state
    result = sim.run(progress=False, control=RunControl(resume=state))
    wall = time.perf_counter() - t0
    new = result.history["time"] > float(meta["time"]) + 1e-12
    return {
        "name": name,
        "steps": int(np.count_nonzero(new)),
        "newton": log.iterations,
        "cuts": int(np.sum(result.history["cuts"][new])),
        "slow": log.slow / max(log.iterations, 1),
        "wall": wall,
        "check": log.check,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("output/benchmarks/obstacle_newton"))
    args = parser.parse_args()
    base = args.out / "to_25ms"
    if not (base / CHECKPOINT).exists():
        simulate(load_case(CASE, [*BASE, f"time.end={START}"]), base, progress=False)
    history, _ = read_history(base / "history.csv")
    rows = [
        _variant(name, sets, base, first=i == 0) for i, (name, sets) in enumerate(VARIANTS.items())
    ]
    if MPI.COMM_WORLD.rank:
        return
    print(f"tweezers, 0.8 mm, from {START} (com_z {history['com_z'][-1] * 1e3:.2f} mm) to {END}")
    heads = ("steps", "Newton", "cuts", "slow it.", "wall s")
    print(f"{'variant':34s} " + " ".join(f"{h:>8s}" for h in heads))
    for r in rows:
        print(
            f"{r['name']:34s} {r['steps']:8d} {r['newton']:8d} {r['cuts']:8d} "
            f"{100 * r['slow']:7.0f}% {r['wall']:8.0f}"
        )
    check = rows[0]["check"]
    if check:
        print("Jacobian along the Newton direction at the first slow iteration (case as is):")
        print("  " + "  ".join(f"eps={e:g}: {v:.2e}" for e, v in check))
    print(f"nominal step: 0.25 ms ({0.6 / 0.25:.1f} steps for the 0.6 ms)")


if __name__ == "__main__":
    main()
