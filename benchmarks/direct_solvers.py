"""PETSc's own LU against MUMPS on the Jacobians of every model: where ``auto`` switches.

For each configuration the script builds the run, takes one step and then
factorises its Jacobian again and again with each direct solver (numeric
factorisation and solve, the symbolic one reused, as in Newton), printing
the CPU time per factorisation and the Jacobian's size and nonzeros.
``[solver] linear_solver = "auto"`` uses PETSc's LU up to
:data:`magfem.mechanics.solver_options.PETSC_LU_NONZEROS` nonzeros (one process).
Serial, from the repository root (~1 min):

    .venv/bin/python -m benchmarks.direct_solvers
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

from benchmarks._common import TRAPEZOID, Report, pinned_trapezoid
from magfem.case import Case, load_case
from magfem.pipeline import build_simulation
from verification import setups as vc

CASES = Path(__file__).resolve().parents[1] / "cases"
QUIET = ["time.end=1ms", "output.vtx_every=0", "output.plot=false", "output.csv=false"]
REPEATS = 10


def rod(size: float) -> Case:
    """The rod of benchmarks/pyelastica_comparison.py, P3 at ``size`` (m)."""
    return vc.cantilever_case(
        "rod",
        size,
        vc.NARROW_WIDTH,
        "strain",
        root="rigid",
        mesh_options={"rod_bending": "beam"},
        field=vc.DRIVE,
        time={"end": 1e-3, "step": 3.125e-5, "rho_inf": 0.5},
        solver={"degree": 3},
    )


CONFIGURATIONS: list[tuple[str, Any]] = [
    ("rod 0.25 mm P3", lambda: rod(0.25e-3)),
    ("rod 0.125 mm P3", lambda: rod(0.125e-3)),
    ("strip 0.5 mm (two_arm_20hz)", lambda: load_case(CASES / "two_arm_20hz.toml", QUIET)),
    (
        "shell 1 mm",
        lambda: load_case(
            TRAPEZOID, pinned_trapezoid("mesh.model=surface", "mesh.size=1mm", *QUIET)
        ),
    ),
    (
        "shell 0.5 mm",
        lambda: load_case(
            TRAPEZOID, pinned_trapezoid("mesh.model=surface", "mesh.size=0.5mm", *QUIET)
        ),
    ),
    (
        "shell 0.35 mm",
        lambda: load_case(
            TRAPEZOID, pinned_trapezoid("mesh.model=surface", "mesh.size=0.35mm", *QUIET)
        ),
    ),
    ("solid 1 mm (former default case)", lambda: load_case(TRAPEZOID, pinned_trapezoid(*QUIET))),
    ("solid 0.5 mm", lambda: load_case(TRAPEZOID, pinned_trapezoid("mesh.size=0.5mm", *QUIET))),
]


def factorisation_time(A: PETSc.Mat, solver: str) -> float:
    """CPU seconds per numeric LU factorisation and solve of ``A`` by ``solver``."""
    ksp = PETSc.KSP().create(A.comm)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("lu")
    pc.setFactorSolverType(solver)
    if solver == "petsc":
        pc.setFactorPivot(zeropivot=0.0)
    ksp.setOperators(A)
    b, x = A.createVecLeft(), A.createVecRight()
    b.set(1.0)
    ksp.solve(b, x)  # symbolic factorisation
    start = time.process_time()
    for k in range(REPEATS):
        A.scale(2.0 if k % 2 else 0.5)  # a changed matrix: factorised again
        ksp.solve(b, x)
    elapsed = (time.process_time() - start) / REPEATS
    ksp.destroy()
    return elapsed


def main() -> None:
    report = Report(
        "| Jacobian | unknowns | nonzeros | PETSc LU (ms) | MUMPS (ms) |",
        "|---|---|---|---|---|",
    )
    for label, make in CONFIGURATIONS:
        sim = build_simulation(make(), MPI.COMM_SELF)
        sim.initialise()
        sim.step(sim.time_spec.start)
        A = sim.solver.problem.A
        nonzeros = int(A.getInfo()["nz_used"])
        petsc, mumps = (factorisation_time(A, s) for s in ("petsc", "mumps"))
        report.row(
            f"| {label} | {A.getSize()[0]} | {nonzeros} | {petsc * 1e3:.2f} | {mumps * 1e3:.2f} |"
        )
    report.print()


if __name__ == "__main__":
    main()
