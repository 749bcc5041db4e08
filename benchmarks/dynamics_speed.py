"""Speed of the dynamic solver on the default case: assembly and whole runs.

Two parts, both on ``cases/one_arm_trapezoid.toml`` pinned to the 1 mm solid
(``benchmarks._common.TRAPEZOID_SOLID``: 3D P2 hexahedra, one layer, 1647
dofs, Δt 0.5 ms; ``--set`` overrides come after), CPU time (``time.process_time``, robust against a
loaded machine) next to wall time:

* ``assembly``: ms per Jacobian and per residual assembly, the residual with
  dolfinx's ``assemble_residual`` (lifting included) and with the
  homogeneous-support shortcut of :class:`magfem.mechanics.solver.NewtonSolver`,
  for ground contact on the whole boundary, on ``bottom`` + ``clamp`` only,
  and off;
* ``run``: a run of the case (``--set`` overrides as in ``magfem run``):
  steps, mean Newton iterations, cuts, maximum and final tip angle (deg),
  and the wall-time split of :meth:`Simulation.timings`;
* ``fused``: ms per assembly of the step residual with one kernel per block and
  with one fused kernel (:mod:`magfem.mechanics.fused_residual`), for the case as
  it stands (the P3 shell) and the pinned 1 mm solid (displacement and pressure);
* ``residual``: not pinned, the case as it stands (the P3 shell in air on the
  ground): ms per assembly of each block of the step residual, with the air
  and the ground contact switched off in turn, and the count of UFL
  integrals per block (all share one quadrature rule, so each block is one
  generated kernel).

From the repository root::

    .venv/bin/python -m benchmarks.dynamics_speed assembly
    .venv/bin/python -m benchmarks.dynamics_speed run --set time.end=10ms --save /tmp/a.npy
    .venv/bin/python -m benchmarks.dynamics_speed compare /tmp/ref.npy /tmp/a.npy
    .venv/bin/python -m benchmarks.dynamics_speed residual
    .venv/bin/python -m benchmarks.dynamics_speed fused
    .venv/bin/mpirun -n 2 .venv/bin/python -m benchmarks.dynamics_speed run --set time.end=10ms
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import math
import time
from typing import Any

import numpy as np
from mpi4py import MPI

from benchmarks._common import TRAPEZOID, pinned_trapezoid

CASE = TRAPEZOID


def _timed(fn, n: int) -> tuple[float, float]:
    """(cpu, wall) ms per call of ``fn`` over ``n`` calls after one warm-up call."""
    fn()
    c0, t0 = time.process_time(), time.perf_counter()
    for _ in range(n):
        fn()
    return 1e3 * (time.process_time() - c0) / n, 1e3 * (time.perf_counter() - t0) / n


def _assembly_times(sets: list[str], n: int) -> dict[str, tuple[float, float]]:
    """(cpu, wall) ms per call of the step's Jacobian and residual for case overrides ``sets``."""
    from dolfinx.fem import petsc as fem_petsc

    from magfem.case import load_case
    from magfem.pipeline import build_simulation

    comm = MPI.COMM_WORLD
    # the displacement formulation: its Jacobian's kernels are what is timed
    sets = ["solver.mixed_pressure=off", *sets]
    sim = build_simulation(load_case(CASE, pinned_trapezoid(*sets)), comm)
    problem, snes, bcs = sim.solver.problem, sim.solver.snes, sim.model.bcs
    rng = np.random.default_rng(comm.rank)
    sim.u.x.array[:] = 1e-6 * rng.random(sim.u.x.array.size)
    for bc in bcs:
        bc.set(sim.u.x.array, alpha=0.0)
    fem_petsc.assign(sim.u, problem.x)
    x, b, A = problem.x, problem.b, problem.A

    def jac() -> None:
        snes.computeJacobian(x, A, problem.P_mat)

    def res_ours() -> None:
        snes.computeFunction(x, b)

    def res_dolfinx() -> None:
        fem_petsc.assemble_residual(snes, x, b, problem.u, problem.F, problem.J, bcs)

    rows = {
        "jacobian": _timed(jac, n),
        **_kernel_times(sim, n),
        "residual (no lifting)": _timed(res_ours, n),
        "residual (dolfinx, lifting)": _timed(res_dolfinx, n),
    }
    from petsc4py import PETSc

    jac()
    rhs, sol = A.createVecLeft(), A.createVecRight()
    rhs.set(1.0)
    for factor in ("mumps", "petsc", "superlu_dist"):
        if comm.size > 1 and factor == "petsc":
            continue
        ksp = PETSc.KSP().create(comm)  # type: ignore[arg-type]
        ksp.setOperators(A)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType(factor)

        def lu(ksp: PETSc.KSP = ksp) -> None:
            A.assemble()  # new matrix state: numeric refactorisation, as in Newton
            ksp.setOperators(A)
            ksp.solve(rhs, sol)

        rows[f"LU {factor} (factor + solve)"] = _timed(lu, n)
        ksp.destroy()
    return rows


def _kernel_times(sim: object, n: int) -> dict[str, tuple[float, float]]:
    """(cpu, wall) ms per assembly of each integral of the step Jacobian on its own.

    UFL groups the Jacobian's integrals by measure and quadrature degree; each
    group is one generated kernel. Timing them separately shows where the
    Jacobian's cost goes (elastic + magnetic at degree 4, the reduced-degree
    volumetric term, inertia, ground contact on the boundary).
    """
    import ufl
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc

    from magfem.mechanics.solver import FORM_COMPILER_OPTIONS, JIT_OPTIONS

    problem = sim.problem  # type: ignore[attr-defined]
    jacobian = ufl.derivative(problem.residual, problem.model.u)
    out: dict[str, tuple[float, float]] = {}
    for i, integral in enumerate(jacobian.integrals()):
        form = fem.form(
            ufl.Form([integral]),
            form_compiler_options=FORM_COMPILER_OPTIONS,
            jit_options=JIT_OPTIONS,
        )
        A = fem_petsc.create_matrix(form)

        def assemble(A: object = A, form: object = form) -> None:
            A.zeroEntries()  # type: ignore[attr-defined]
            fem_petsc.assemble_matrix(A, form)  # type: ignore[arg-type]
            A.assemble()  # type: ignore[attr-defined]

        degree = integral.metadata().get("quadrature_degree")
        out[f"  kernel {i}: {integral.integral_type()} q={degree}"] = _timed(assemble, n)
        A.destroy()
    return out


def assembly(n: int) -> None:
    for label, sets in (
        ("contact on the whole boundary", []),
        ("contact on bottom + clamp", ['contact.surfaces=["bottom", "clamp"]']),
        ("no contact", ["contact.ground=false"]),
    ):
        rows = _assembly_times(sets, n)
        if MPI.COMM_WORLD.rank == 0:
            print(f"{label}:")
            for name, (cpu, wall) in rows.items():
                print(f"  {name:28s} cpu {cpu:7.1f} ms  wall {wall:7.1f} ms per call")


def _residual_times(sets: list[str], n: int) -> list[tuple[int, float, float]]:
    """(UFL integrals, cpu ms, wall ms) per assembly of each block of the step residual of
    the case as it stands with overrides ``sets``."""
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc

    from magfem.case import load_case
    from magfem.mechanics.solver import FORM_COMPILER_OPTIONS, JIT_OPTIONS
    from magfem.pipeline import build_simulation

    sim = build_simulation(load_case(CASE, sets), MPI.COMM_WORLD)
    residual = sim.problem.residual
    rows = []
    for block in residual if isinstance(residual, list) else [residual]:
        form = fem.form(block, form_compiler_options=FORM_COMPILER_OPTIONS, jit_options=JIT_OPTIONS)
        vector = fem_petsc.create_vector(form.function_spaces[0])

        def assemble(vector: object = vector, form: object = form) -> None:
            with vector.localForm() as local:  # type: ignore[attr-defined]
                local.set(0.0)
            fem_petsc.assemble_vector(vector, form)  # type: ignore[arg-type]

        rows.append((len(block.integrals()), *_timed(assemble, n)))
    return rows


def residual(n: int) -> None:
    for label, sets in (
        ("the case (air, ground contact)", []),
        ("no air", ["fluid.medium=vacuum"]),
        ("no ground contact", ["contact.ground=false"]),
        ("neither", ["fluid.medium=vacuum", "contact.ground=false"]),
    ):
        rows = _residual_times(sets, n)
        if MPI.COMM_WORLD.rank == 0:
            blocks = ", ".join(
                f"block {i}: {k} integrals, cpu {cpu:.3f} ms, wall {wall:.3f} ms"
                for i, (k, cpu, wall) in enumerate(rows)
            )
            total = sum(cpu for _, cpu, _ in rows)
            print(f"{label:32s} {blocks}; cpu {total:.3f} ms in all")


def fused(n: int) -> None:
    """CPU per assembly of the step residual with one kernel per block and with the fused
    kernel, at the initial state of the case as it stands and of the 1 mm solid (rank 0)."""
    from dolfinx.fem import petsc as fem_petsc
    from petsc4py import PETSc

    from magfem.case import load_case
    from magfem.pipeline import build_simulation

    for label, case in (
        ("the case (P3 shell)", load_case(CASE, [])),
        ("the 1 mm solid", load_case(CASE, pinned_trapezoid())),
    ):
        sim = build_simulation(case, MPI.COMM_WORLD)
        solver = sim.solver
        problem = solver.problem
        if solver.fused is None:
            print(f"{label}: one unknown, nothing to fuse")
            continue
        x: Any = problem.x
        b: Any = problem.b
        fem_petsc.assign(solver.u, x)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

        def blocks(b: object = b, problem: object = problem) -> None:
            with b.localForm() as local:  # type: ignore[attr-defined]
                local.set(0.0)
            fem_petsc.assemble_vector(b, problem.F)  # type: ignore[arg-type, attr-defined]
            b.ghostUpdate(  # type: ignore[attr-defined]
                addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE
            )

        def one(x: object = x, b: object = b, solver: object = solver) -> None:
            solver.fused.assemble(x, b)  # type: ignore[attr-defined]

        (cb, wb), (cf, wf) = _timed(blocks, n), _timed(one, n)
        if MPI.COMM_WORLD.rank == 0:
            print(
                f"{label}: blocks cpu {cb:.3f} ms (wall {wb:.3f}), fused cpu {cf:.3f} ms "
                f"(wall {wf:.3f}): {cb / cf:.2f} x less CPU"
            )


def run(sets: list[str], save: str | None = None) -> None:
    from magfem.case import load_case
    from magfem.pipeline import build_simulation

    comm = MPI.COMM_WORLD
    c0, t0 = time.process_time(), time.perf_counter()
    # the displacement formulation: its Jacobian's kernels are what is timed
    sets = ["solver.mixed_pressure=off", *sets]
    sim = build_simulation(load_case(CASE, pinned_trapezoid(*sets)), comm)
    result = sim.run(progress=False)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    s, st = result.summary, sim.solver.timings
    if comm.rank == 0:
        print(f"case {CASE.name} {' '.join(sets)} ranks {comm.size}")
        print(
            f"steps {s['steps']:.0f}, mean Newton {s['mean_newton_iterations']:.2f}, "
            f"cuts {s['cuts']:.0f}, Jacobians {st.jacobian_calls}, residuals {st.residual_calls}"
        )
        print(
            f"max angle {math.degrees(s['max_angle_arm']):.3f} deg, "
            f"final angle {math.degrees(s['final_angle_arm']):.3f} deg, "
            f"max strain {s['max_strain']:.4f}"
        )
        split = ", ".join(f"{k} {v:.2f}" for k, v in result.timings.items())
        print(f"wall split (s, rank 0): {split}")
        print(f"rank 0: cpu {cpu:.1f} s, wall {wall:.1f} s")
        if save:
            h = result.history
            np.save(save, np.column_stack([h["time"], h["angle_arm"]]))


def compare(reference: str, others: list[str]) -> None:
    """Largest and mean |angle − reference| (deg) of saved histories, on their own times."""
    ref = np.load(reference)
    for path in others:
        a = np.load(path)
        end = min(a[-1, 0], ref[-1, 0])
        a = a[a[:, 0] <= end + 1e-12]
        err = np.degrees(np.abs(a[:, 1] - np.interp(a[:, 0], ref[:, 0], ref[:, 1])))
        print(
            f"{path}: max |Δangle| {err.max():.3f} deg at {1e3 * a[err.argmax(), 0]:.2f} ms, "
            f"mean {err.mean():.3f} deg, up to {1e3 * end:.1f} ms"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="part", required=True)
    a = sub.add_parser("assembly")
    a.add_argument("-n", type=int, default=20, help="calls per timing")
    res = sub.add_parser("residual")
    res.add_argument("-n", type=int, default=200, help="calls per timing")
    fu = sub.add_parser("fused")
    fu.add_argument("-n", type=int, default=200, help="calls per timing")
    r = sub.add_parser("run")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    r.add_argument("--save", help="write (time s, angle rad) of the run to this .npy")
    c = sub.add_parser("compare")
    c.add_argument("reference", help=".npy saved by run --save")
    c.add_argument("others", nargs="+")
    args = parser.parse_args()
    if args.part == "assembly":
        assembly(args.n)
    elif args.part == "residual":
        residual(args.n)
    elif args.part == "fused":
        fused(args.n)
    elif args.part == "run":
        run(args.set, args.save)
    else:
        compare(args.reference, args.others)


if __name__ == "__main__":
    main()
