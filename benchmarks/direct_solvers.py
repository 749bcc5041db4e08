"""PETSc's own LU against MUMPS on the Jacobians of every model: where ``auto`` switches.

For each configuration the script builds the run, takes one step and then
factorises its Jacobian again and again with each direct solver (numeric
factorisation and solve, the symbolic one reused, as in Newton), printing
the CPU time per factorisation and the Jacobian's size and nonzeros.
``[solver] linear_solver = "auto"`` uses PETSc's LU up to
:data:`magfem.mechanics.solver_options.PETSC_LU_NONZEROS` nonzeros (one process).
Serial, from the repository root (~1 min):

    .venv/bin/python -m benchmarks.direct_solvers

``orderings``: the default case as its file stands (the P3 shell), its
Jacobian after 10 steps, factorised and solved by MUMPS with each
fill-reducing ordering (``mat_mumps_icntl_7``; magfem sets
:data:`~magfem.mechanics.solver_options.MUMPS_ORDERING`) and, on one rank,
by PETSc's LU: the wall time per numeric factorisation and per solve with
that factorisation (the two costs of a Newton iteration with a new and
with a kept Jacobian), on as many ranks as it is started on; on more than
one, also PETSc's ``redundant`` preconditioner (every rank factorises the
whole Jacobian by PETSc's LU or sequential MUMPS, so the solves need no
communication)::

    .venv/bin/mpirun -n 2 .venv/bin/python -m benchmarks.direct_solvers orderings
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import sys
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


ORDERINGS = [
    ("automatic", 7),
    ("METIS", 5),
    ("SCOTCH", 3),
    ("AMD", 0),
    ("AMF", 2),
    ("PORD", 4),
    ("QAMD", 6),
]
"""MUMPS's sequential orderings (ICNTL(7)); 7 lets MUMPS choose."""


def factor_and_solve(A: PETSc.Mat, b: PETSc.Vec, options: dict[str, Any]) -> tuple[float, float]:
    """Wall seconds per numeric factorisation and per solve of ``A x = b`` (collective)."""
    comm = A.comm.tompi4py()
    ksp = PETSc.KSP().create(A.comm)
    prefix = f"direct_{id(ksp)}_"
    ksp.setOptionsPrefix(prefix)
    db = PETSc.Options()
    for key, value in options.items():
        db[prefix + key] = value
    ksp.setFromOptions()
    ksp.setOperators(A)
    x = A.createVecRight()
    ksp.solve(b, x)  # symbolic factorisation
    times = []
    for repeats, refactor in ((REPEATS, True), (10 * REPEATS, False)):
        comm.barrier()
        start = time.perf_counter()
        for k in range(repeats):
            if refactor:
                A.scale(2.0 if k % 2 else 0.5)  # a changed matrix: factorised again
                ksp.setOperators(A)
            ksp.solve(b, x)
        comm.barrier()
        times.append((time.perf_counter() - start) / repeats)
    for key in options:
        db.delValue(prefix + key)
    ksp.destroy()
    # the refactorising loop also solved once each time (PCREDUNDANT factorises its
    # whole-matrix copy only at the solve)
    return times[0] - times[1], times[1]


def orderings() -> None:
    """The default case's Jacobian by MUMPS's orderings (and PETSc's LU on one rank)."""
    comm = MPI.COMM_WORLD
    sim = build_simulation(load_case(TRAPEZOID, [*QUIET, "output.animation=false"]), comm)
    sim.initialise()
    t = sim.time_spec.start
    for _ in range(10):
        t, _, _ = sim.step(t)
    A, b = sim.solver.problem.A, sim.solver.problem.b
    nonzeros = int(A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"])  # type: ignore[arg-type]
    report = Report(
        f"default case's Jacobian: {A.getSize()[0]} unknowns, {nonzeros} nonzeros, "
        f"{comm.size} rank(s)",
        "| solver | ordering (ICNTL(7)) | factorisation (ms) | solve (ms) |",
        "|---|---|---|---|",
    )
    lu = {"ksp_type": "preonly", "pc_type": "lu"}
    runs = [("MUMPS", f"{name} ({k})", {"mat_mumps_icntl_7": k}) for name, k in ORDERINGS]
    if comm.size == 1:
        petsc = {"pc_factor_mat_solver_type": "petsc", "pc_factor_zeropivot": 0.0}
        runs.append(
            ("PETSc LU", "nested dissection", petsc | {"pc_factor_mat_ordering_type": "nd"})
        )
    else:
        for inner in ("petsc", "mumps"):
            redundant = {
                "pc_type": "redundant",
                "redundant_pc_type": "lu",
                "redundant_pc_factor_mat_solver_type": inner,
            }
            if inner == "petsc":
                redundant |= {
                    "redundant_pc_factor_zeropivot": 0.0,
                    "redundant_pc_factor_mat_ordering_type": "nd",
                }
            else:
                redundant["redundant_mat_mumps_icntl_7"] = 3
            runs.append((f"redundant, {inner} LU", "whole Jacobian on each rank", redundant))
    for solver, ordering, options in runs:
        if solver == "MUMPS":
            options = {"pc_factor_mat_solver_type": "mumps"} | options
        factor, solve = factor_and_solve(A, b, lu | options)
        report.row(f"| {solver} | {ordering} | {factor * 1e3:.2f} | {solve * 1e3:.3f} |")
    report.print()


def main() -> None:
    if sys.argv[1:] == ["orderings"]:
        orderings()
        return
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
