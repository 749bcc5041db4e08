"""Direct against Krylov solvers on large shell Jacobians; whole steps on more ranks.

The problem is the one that makes the largest meshes of the scenes: a failure
triangle (``cases/failure.toml``, 45 µm, 4 mT) on the shell at P2, where
ℓ/3 needs elements of ~0.1 mm (docs/scenes.md, failure). Type II at 0.3 and
0.15 mm has 21 k and 74 k unknowns, type III at 0.15 mm 293 k. Two parts,
from the repository root:

* ``solvers``: takes two steps (the Jacobian of a bent, moving membrane),
  then solves with that Jacobian and the last Newton residual by each
  solver: MUMPS and PETSc's LU (one rank), and GMRES (restart 200,
  right-preconditioned, so the relative tolerance 1e-8 is the true
  residual's) with GAMG, additive Schwarz (ILU(0), ILU(2), LU blocks with
  overlap 1) and block Jacobi with LU blocks. Per solver: the wall time of
  the first solve (set-up included) and of a second one after the matrix
  changed (numeric set-up again, as in Newton), the Krylov iterations and
  the true relative residual. Run on one rank and under ``mpirun -n 2``::

      .venv/bin/python -m benchmarks.linear_solvers solvers --size 0.3mm --size 0.15mm
      .venv/bin/mpirun -n 2 .venv/bin/python -m benchmarks.linear_solvers solvers --size 0.15mm

* ``scaling``: the same case run for ``--steps`` steps with the solver that
  ``linear_solver = "auto"`` picks, under ``mpirun -n K`` for each
  ``--ranks K`` (started by this script, ``mpirun`` next to the Python
  executable), and the wall time per Newton iteration of the steps after
  the first (the first step's symbolic factorisation and compilation left
  out), its split, and the speed-up against the first ``--ranks``::

      .venv/bin/python -m benchmarks.linear_solvers scaling --size 0.15mm --ranks 1 2

  On a machine with more cores: ``--ranks 1 2 4 8 16``. ``--krylov NAME``
  runs the steps with a Krylov solver of :data:`KRYLOV` instead, and
  ``--set KEY=VALUE`` passes any other case override.

* ``lagged``: one rank, the direct solve at every Newton iteration against
  GMRES preconditioned by the LU of an earlier Jacobian (:data:`LAGGED`)::

      .venv/bin/python -m benchmarks.linear_solvers lagged --size 0.3mm --steps 11
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

from benchmarks._common import Report
from magfem.case import Case, load_case
from magfem.parallel import rank0_print
from magfem.pipeline import build_simulation

FAILURE = Path(__file__).resolve().parents[1] / "cases" / "failure.toml"
QUIET = ["output.vtx_every=0", "output.plot=false", "output.csv=false", "output.animation=false"]

GMRES = {
    "ksp_type": "gmres",
    "ksp_gmres_restart": 200,
    "ksp_pc_side": "right",
    "ksp_rtol": 1e-8,
    "ksp_max_it": 500,
}
LU_BLOCKS = {"sub_pc_type": "lu", "sub_pc_factor_mat_ordering_type": "nd"}
SOLVERS: list[tuple[str, dict[str, Any], bool]] = [
    ("MUMPS", {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}, True),
    (
        "PETSc LU",
        {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_ordering_type": "nd"},
        False,
    ),
    ("GMRES + GAMG", GMRES | {"pc_type": "gamg"}, True),
    ("GMRES + ASM ILU(0)", GMRES | {"pc_type": "asm", "sub_pc_type": "ilu"}, True),
    (
        "GMRES + ASM ILU(2)",
        GMRES | {"pc_type": "asm", "sub_pc_type": "ilu", "sub_pc_factor_levels": 2},
        True,
    ),
    (
        "GMRES + ASM LU, 4 blocks per rank, overlap 1",
        GMRES | {"pc_type": "asm", "pc_asm_overlap": 1} | LU_BLOCKS,
        True,
    ),
    ("GMRES + block Jacobi LU, 4 per rank", GMRES | {"pc_type": "bjacobi"} | LU_BLOCKS, True),
]
"""(name, PETSc options, runs on several ranks)."""

_OPTIONS = {name: options for name, options, _ in SOLVERS}
KRYLOV = {  # the blocks per rank that _solve sets as a total
    "bjacobi": _OPTIONS["GMRES + block Jacobi LU, 4 per rank"] | {"pc_bjacobi_local_blocks": 4},
    "asm-lu": _OPTIONS["GMRES + ASM LU, 4 blocks per rank, overlap 1"] | {"pc_asm_local_blocks": 4},
    "gamg": _OPTIONS["GMRES + GAMG"],
}
"""Krylov solvers that ``scaling --krylov NAME`` runs whole steps with instead of ``auto``."""


def krylov_overrides(name: str) -> list[str]:
    """The case overrides that make the Newton solver use ``KRYLOV[name]``."""
    options = KRYLOV[name] | (
        {"sub_pc_factor_zeropivot": 0} if "sub_pc_type" in KRYLOV[name] else {}
    )
    return [f"solver.petsc_options.{key}={value}" for key, value in options.items()]


def failure_shell(size: str, kind: str, *overrides: str) -> Case:
    """The failure triangle of type ``kind`` on the P2 shell at ``size`` (e.g. "0.15mm")."""
    return load_case(
        FAILURE,
        [
            f"robot.type={kind}",
            "mesh.model=surface",
            f"mesh.size={size}",
            "solver.degree=2",
            *QUIET,
            *overrides,
        ],
    )


def _solve(A: PETSc.Mat, b: PETSc.Vec, options: dict[str, Any]) -> tuple[float, float, int, float]:
    """(first solve s, second solve s, iterations, true relative residual) of A x = b."""
    comm = A.comm.tompi4py()
    ksp = PETSc.KSP().create(A.comm)
    prefix = f"bench_{id(ksp)}_"
    ksp.setOptionsPrefix(prefix)
    opts = PETSc.Options()
    blocks = {"pc_asm_blocks", "pc_bjacobi_blocks"}
    if options.get("pc_type") in ("asm", "bjacobi"):
        options = options | {f"pc_{options['pc_type']}_blocks": 4 * comm.size}
    for key, value in options.items():
        opts[prefix + key] = value
    if options.get("pc_type") == "lu" and comm.size == 1:
        opts[prefix + "pc_factor_zeropivot"] = 0.0
    if "sub_pc_type" in options:
        opts[prefix + "sub_pc_factor_zeropivot"] = 0.0
    ksp.setFromOptions()
    ksp.setOperators(A)
    x = A.createVecRight()
    times = []
    for k in range(2):
        if k:
            A.scale(1.0 + 1e-7)  # a changed matrix: set up (factorised) again
            ksp.setOperators(A)
        comm.barrier()
        start = time.perf_counter()
        ksp.solve(b, x)
        comm.barrier()
        times.append(time.perf_counter() - start)
    r = b.copy()
    A.mult(x, r)
    r.aypx(-1.0, b)
    residual = r.norm() / b.norm()
    iterations = ksp.getIterationNumber()
    for key in [*options, *blocks, "pc_factor_zeropivot", "sub_pc_factor_zeropivot"]:
        opts.delValue(prefix + key)
    ksp.destroy()
    return times[0], times[1], iterations, residual


def solvers(sizes: list[str], kind: str) -> None:
    """The solver table for each size (rows shown as measured)."""
    comm = MPI.COMM_WORLD
    report = Report(
        f"failure type {kind} on the P2 shell, Jacobian after 2 steps, {comm.size} rank(s)",
        "| mesh | unknowns | solver | first solve (s) | again (s) | iterations | rel. residual |",
        "|---|---|---|---|---|---|---|",
    )
    for size in sizes:
        sim = build_simulation(failure_shell(size, kind), comm)
        sim.initialise()
        t = sim.time_spec.start
        for _ in range(2):
            t, _, _ = sim.step(t)
        A = sim.solver.problem.A
        b = sim.solver.problem.b
        unknowns = A.getSize()[0]
        for name, options, parallel in SOLVERS:
            if comm.size > 1 and not parallel:
                continue
            first, again, its, res = _solve(A, b, options)
            report.row(
                f"| {size} | {unknowns} | {name} | {first:.3f} | {again:.3f} | {its} | {res:.1e} |"
            )
    report.print()


LAGGED = (
    "solver.petsc_options.ksp_type=gmres",
    "solver.petsc_options.ksp_pc_side=right",
    "solver.petsc_options.ksp_rtol=1e-8",
    "solver.petsc_options.ksp_gmres_restart=100",
    "solver.petsc_options.ksp_max_it=100",
    "solver.petsc_options.snes_lag_preconditioner=10",
    "solver.petsc_options.snes_lag_preconditioner_persists=1",
)
"""GMRES preconditioned by the LU of an earlier Jacobian: factorised at every tenth Newton
iteration, counted over the steps."""


def steps(size: str, kind: str, count: int, *overrides: str) -> dict[str, Any]:
    """Wall time and its split over ``count`` steps after the first, on this communicator."""
    comm = MPI.COMM_WORLD
    sim = build_simulation(failure_shell(size, kind, *overrides), comm)
    sim.initialise()
    t, report, _ = sim.step(sim.time_spec.start)
    before = dict(sim.timings())
    comm.barrier()
    start = time.perf_counter()
    iterations = linear = 0
    for _ in range(count):
        t, report, _ = sim.step(t)
        iterations += report.iterations
        linear += report.linear_iterations
    comm.barrier()
    wall = time.perf_counter() - start
    after = sim.timings()
    split = {
        key: comm.allreduce(after[key] - before[key], op=MPI.MAX)
        for key in ("residual", "jacobian", "linear_solve")
    }
    return {
        "ranks": comm.size,
        "unknowns": sim.solver.problem.A.getSize()[0],
        "solver": sim.solver.linear_solver,
        "iterations": iterations,
        "linear_iterations": linear,
        "wall": wall,
        "t": t,
        **split,
    }


def scaling(
    sizes: list[str], kind: str, ranks: list[int], count: int, overrides: list[str]
) -> None:
    """Runs :func:`steps` under ``mpirun -n K`` per K and prints the speed-up table."""
    mpirun = Path(sys.executable).parent / "mpirun"
    report = Report(
        f"failure type {kind} on the P2 shell, {count} steps after the first, per Newton iteration",
        "| mesh | unknowns | ranks | solver | iterations | wall (s) | residual | Jacobian "
        "| linear solve | speed-up |",
        "|---|---|---|---|---|---|---|---|---|---|",
    )
    for size in sizes:
        base = None
        for k in ranks:
            cmd = [str(mpirun), "-n", str(k), sys.executable, "-m", "benchmarks.linear_solvers"]
            cmd += ["steps", "--size", size, "--type", kind, "--steps", str(count)]
            cmd += [f"--set={item}" for item in overrides]
            out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
            # the last JSON line: PETSc may warn of unused options after it
            run = json.loads([line for line in out.splitlines() if line.startswith("{")][-1])
            per = run["wall"] / run["iterations"]
            base = base or per
            split = " | ".join(
                f"{run[key] / run['iterations']:.3f}"
                for key in ("residual", "jacobian", "linear_solve")
            )
            report.row(
                f"| {size} | {run['unknowns']} | {k} | {run['solver']} | {run['iterations']} "
                f"| {per:.3f} | {split} | {base / per:.2f} |"
            )
    report.print()


def lagged(size: str, kind: str, count: int) -> None:
    """A new factorisation at every Newton iteration against :data:`LAGGED` (one rank)."""
    report = Report(
        f"failure type {kind} on the P2 shell, {size}, {count} steps after the first",
        "| linear solver | Newton iterations | linear iterations | wall (s) |",
        "|---|---|---|---|",
    )
    for name, overrides in (("LU at every iteration", ()), ("GMRES + lagged LU", LAGGED)):
        run = steps(size, kind, count, *overrides)
        report.row(
            f"| {name} | {run['iterations']} | {run['linear_iterations']} | {run['wall']:.2f} |"
        )
    report.print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("part", choices=("solvers", "scaling", "lagged", "steps"))
    parser.add_argument("--size", action="append", help="mesh.size (repeat); default 0.15mm")
    parser.add_argument("--type", default="II", choices=("I", "II", "III"), help="triangle")
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--steps", type=int, default=3, help="steps timed after the first")
    parser.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="case override (repeat)"
    )
    parser.add_argument("--krylov", choices=sorted(KRYLOV), help="scaling: whole steps with it")
    args = parser.parse_args()
    sizes = args.size or ["0.15mm"]
    if args.part == "solvers":
        solvers(sizes, args.type)
    elif args.part == "scaling":
        extra = krylov_overrides(args.krylov) if args.krylov else []
        scaling(sizes, args.type, args.ranks, args.steps, args.set + extra)
    elif args.part == "lagged":
        lagged(sizes[0], args.type, args.steps)
    else:
        rank0_print(json.dumps(steps(sizes[0], args.type, args.steps, *args.set)))


if __name__ == "__main__":
    main()
