"""PETSc solvers: the only module of magfem that builds them.

:class:`NewtonSolver` wraps ``dolfinx.fem.petsc.NonlinearProblem`` (PETSc
SNES, Newton line search) with the options of a :class:`SolverSpec`, times
form compilation, assembly and linear solves separately (for benchmarks),
and reports convergence without ever ignoring it: :meth:`NewtonSolver.solve`
returns a :class:`NewtonReport` whose ``converged`` is
``SNES.getConvergedReason() > 0``.

Default options (measured on thin cantilevers, docs/mechanics.md): Newton with
``basic`` line search (``bt`` stalled), direct LU chosen by size
(:func:`~magfem.mechanics.solver_options.choose_linear_solver`: PETSc's own LU
for small Jacobians on one process, MUMPS otherwise), and
``snes_divergence_tolerance = 1e12`` (practically unlimited: PETSc's default 1e4 stops
Newton on thin plates whose first iterate raises ‖R‖ a thousandfold).
Options in ``SolverSpec.petsc_options`` override these; every problem has
its own options prefix.

Convergence: SNES's tests (``rtol`` relative to the residual at the
predictor, ``atol``, ``stol``) plus a force-scaled absolute test, ‖R‖ <=
``SolverSpec.force_tolerance`` × F_ref, with the force scale F_ref (N) given
by the caller (:meth:`NewtonSolver.set_force_scale`, usually the norm of the
weight load vector, :func:`load_norm`); it enters SNES as its absolute
tolerance max(atol, force_tolerance × F_ref).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from magfem.mechanics.forms import FORM_COMPILER_OPTIONS, JIT_OPTIONS
from magfem.mechanics.fused_residual import FusedResidual
from magfem.mechanics.jacobian_reuse import JacobianReuse
from magfem.mechanics.solver_options import (
    FACTORISATIONS,
    MUMPS_ORDERING,
    MUMPS_ORDERING_NONZEROS,
    choose_linear_solver,
    factor_options,
    newton_options,
    reuse_contraction,
)
from magfem.mechanics.spec import SolverSpec

__all__ = [
    "JacobianReuse",
    "NewtonReport",
    "NewtonSolver",
    "SolverTimings",
    "load_norm",
    "solve_linear",
]

_COUNTER = itertools.count()


@dataclass
class SolverTimings:
    """Accumulated wall time (s) on this rank."""

    compile: float = 0.0
    residual: float = 0.0
    jacobian: float = 0.0
    linear_solve: float = 0.0
    residual_calls: int = 0
    jacobian_calls: int = 0
    jacobian_reuses: int = 0
    """Newton iterations that kept the factorised Jacobian (``reuse_jacobian``)."""
    linear_iterations: int = 0
    """Krylov iterations of the linear solves (GMRES with ``jacobian_free``; 0 with ``preonly``,
    the direct solve)."""

    @property
    def assembly(self) -> float:
        """Residual plus Jacobian assembly (s)."""
        return self.residual + self.jacobian


@dataclass(frozen=True)
class NewtonReport:
    """Outcome of one Newton solve."""

    converged: bool
    reason: int
    iterations: int
    linear_iterations: int
    residual_norm: float
    jacobians: int | None = None
    """Jacobians assembled (``reuse_jacobian``); None: one per iteration."""

    @property
    def effort(self) -> int:
        """Newton iterations with a freshly assembled Jacobian: what the step
        controller judges a solve's difficulty by (kept-Jacobian iterations are cheap
        and say how stale the Jacobian is, not how hard the step)."""
        return self.iterations if self.jacobians is None else self.jacobians

    @property
    def reason_name(self) -> str:
        """PETSc's name of the converged/diverged reason."""
        names = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}
        return names.get(self.reason, str(self.reason))


class NewtonSolver:
    """Newton solver for ``F(u) = 0`` with Dirichlet conditions ``bcs``.

    Args:
        F: residual form (UFL), linear in the test function; or the list of
            block residuals of several unknowns (one monolithic matrix).
        u: unknown (and initial guess), updated in place by :meth:`solve`; or
            the list of unknowns of the blocks of ``F``.
        bcs: Dirichlet conditions on ``u`` (values applied by Newton).
        spec: solver settings.
        name: a word for the options prefix (``magfem_<name>_<n>_``).
        J: Jacobian form (default ``ufl.derivative(F, u)``).
        force_scale: F_ref (N; N/m for strips), the force against which
            ``spec.force_tolerance`` is measured (see :meth:`set_force_scale`);
            None: no force-scaled test.
        homogeneous_bcs: every condition in ``bcs`` prescribes zero and the
            initial ``u`` is zero on its dofs. Newton then never moves those
            dofs, the lifting term A (g − x) of dolfinx's residual is exactly
            zero, and the residual skips it (``apply_lifting`` computes the
            element Jacobians of every cell touching a constrained dof: on the
            default case that was 15 ms of a 27 ms residual).
        refresh_on: with ``spec.reuse_jacobian``, constants of the Jacobian whose
            change makes the kept Jacobian stale (:class:`JacobianReuse`).
        fuse_blocks: with ``homogeneous_bcs``, assemble block residuals of several
            Lagrange unknowns by one kernel on their mixed space
            (:class:`~magfem.mechanics.fused_residual.FusedResidual`; the same residual
            to round-off); False: one kernel per block.

    The forms are compiled once here (timed in ``timings.compile``).
    """

    def __init__(
        self,
        F: ufl.Form | Sequence[ufl.Form],
        u: fem.Function | Sequence[fem.Function],
        bcs: Sequence[fem.DirichletBC],
        spec: SolverSpec,
        *,
        name: str = "newton",
        J: ufl.Form | None = None,
        force_scale: float | None = None,
        homogeneous_bcs: bool = False,
        refresh_on: Sequence[fem.Constant] = (),
        fuse_blocks: bool = True,
    ):
        self.u = u
        self.spec = spec
        self.timings = SolverTimings()
        self.prefix = f"magfem_{name}_{next(_COUNTER)}_"
        if J is None and isinstance(F, Sequence) and isinstance(u, Sequence):
            J = [  # type: ignore[assignment]
                [ufl.derivative(Fi, uj, ufl.TrialFunction(uj.function_space)) for uj in u]
                for Fi in F
            ]
        elif J is None and isinstance(u, fem.Function):
            J = ufl.derivative(F, u, ufl.TrialFunction(u.function_space))
        t0 = time.perf_counter()
        self.problem = fem_petsc.NonlinearProblem(
            F,
            u,
            petsc_options_prefix=self.prefix,
            bcs=list(bcs),
            J=J,
            petsc_options=newton_options(spec),
            form_compiler_options=FORM_COMPILER_OPTIONS,
            jit_options=JIT_OPTIONS,
        )
        self.fused = FusedResidual.build(F, u) if fuse_blocks and homogeneous_bcs else None
        """Block residuals assembled by one kernel (:mod:`magfem.mechanics.fused_residual`),
        or None: each block's form."""
        self.timings.compile += time.perf_counter() - t0
        self.linear_solver = self._choose_linear_solver()
        """The direct solver factorising the Jacobian (``petsc``, ``mumps``, ``superlu_dist``)."""
        self.residual_hooks: list[Callable[[PETSc.Vec, PETSc.Vec], None]] = []
        """Called as ``hook(x, b)`` after the form residual is assembled and
        ghost-accumulated, before the Dirichlet rows are set: add non-local
        terms (e.g. self-contact) to the owned entries of ``b``."""
        self.jacobian_hooks: list[Callable[[PETSc.Vec, PETSc.Mat], None]] = []
        """Called as ``hook(x, A)`` after the form Jacobian is assembled (A final):
        add entries off the Dirichlet rows and columns, then call ``A.assemble()``."""
        krylov = spec.krylov_iterations if spec.jacobian_free else None
        self.reuse = (
            JacobianReuse(reuse_contraction(spec), refresh_on, krylov)
            if spec.reuse_jacobian
            else None
        )
        """The policy that keeps the Jacobian across iterations and steps, or None."""
        self._wrap_callbacks(list(bcs), homogeneous_bcs)
        self.force_scale: float | None = None
        self._residual_functions: list[fem.Function] | None = None
        if force_scale is not None:
            self.set_force_scale(force_scale)

    def _choose_linear_solver(self) -> str:
        """Set the LU's solver by the Jacobian's size (collective); returns its name.

        ``pc_factor_*`` options in ``spec.petsc_options`` win over the choice. MUMPS
        orders Jacobians of up to ``MUMPS_ORDERING_NONZEROS`` nonzeros by
        ``MUMPS_ORDERING`` unless the case sets ``mat_mumps_icntl_7``.
        """
        A = self.problem.A
        nonzeros = int(A.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_allocated"])  # type: ignore[arg-type]
        chosen = choose_linear_solver(self.spec, nonzeros, A.comm.getSize())
        pc = self.snes.getKSP().getPC()
        user = self.spec.petsc_options
        if pc.getType() not in FACTORISATIONS:
            return str(pc.getType())
        solver = str(user.get("pc_factor_mat_solver_type", chosen))
        small = nonzeros <= MUMPS_ORDERING_NONZEROS
        if solver == "mumps" and small and "mat_mumps_icntl_7" not in user:
            pc.setFactorSetUpSolverType()  # the factor matrix, before its first factorisation
            pc.getFactorMatrix().setMumpsIcntl(7, MUMPS_ORDERING)
        if "pc_factor_mat_solver_type" in user:
            return solver
        if chosen == newton_options(self.spec)["pc_factor_mat_solver_type"]:
            return chosen
        # PETSc LU instead of the MUMPS that newton_options set for ``auto``: the
        # factorisation is made at the first setUp, so the PC can still change its solver,
        # its ordering (nested dissection, PETSc LU's own default; MUMPS orders
        # externally) and its zero pivot
        pc.setFactorSolverType(chosen)
        if "pc_factor_mat_ordering_type" not in user:
            pc.setFactorOrdering("nd")
        if "pc_factor_zeropivot" not in user:
            pc.setFactorPivot(zeropivot=factor_options(chosen)["pc_factor_zeropivot"])
        return chosen

    def set_force_scale(self, force_scale: float) -> float:
        """Measure the residual against the force F_ref = ``force_scale`` (N; N/m for strips).

        Newton then also converges when ‖R‖ <= ``spec.force_tolerance`` × F_ref:
        SNES's absolute tolerance becomes max(``spec.atol``, that), unless
        ``spec.petsc_options`` sets ``snes_atol`` itself. F_ref = 0 leaves
        ``atol`` alone. Returns the absolute tolerance in force (N).

        Raises:
            ValueError: ``force_scale`` negative or not finite (a programming error).
        """
        if not math.isfinite(force_scale) or force_scale < 0.0:
            raise ValueError(f"force_scale must be finite and >= 0, got {force_scale!r}")
        self.force_scale = float(force_scale)
        atol = max(self.spec.atol, self.spec.force_tolerance * self.force_scale)
        if "snes_atol" not in self.spec.petsc_options:
            self.snes.setTolerances(atol=atol)
        return float(self.snes.getTolerances()[1])

    def _wrap_callbacks(self, bcs: list[fem.DirichletBC], homogeneous: bool) -> None:
        """Re-register dolfinx's assembly callbacks with timers around them."""
        # the callbacks hold what they use, not the problem or this object: the SNES holds
        # the callbacks, and a cycle through a PETSc object is never collected (each leaked
        # problem keeps its MPI communicators; a test session then runs out of them)
        problem = self.problem
        snes = problem.solver
        u, F, J = problem.u, problem.F, problem.J
        timings, fused = self.timings, self.fused
        residual_hooks, jacobian_hooks = self.residual_hooks, self.jacobian_hooks
        blocks: Any = problem.b.getAttr("_blocks")  # layout of block residuals, else None
        # the conditions of each block's unknown (blocks), else all of them
        block_bcs: Any = bcs
        if blocks is not None:
            block_bcs = fem.bcs_by_block(fem.extract_function_spaces(F), bcs)  # type: ignore[arg-type]

        def residual(snes_: Any, x: Any, b: Any) -> None:
            t0 = time.perf_counter()
            if homogeneous:
                if blocks is not None:  # x may be a work vector of the line search
                    x.setAttr("_blocks", blocks)
                    b.setAttr("_blocks", blocks)
                x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
                fem_petsc.assign(x, u)  # type: ignore[arg-type]
                if fused is not None:
                    fused.assemble(x, b)
                else:
                    with b.localForm() as b_local:
                        b_local.set(0.0)
                    fem_petsc.assemble_vector(b, F)  # type: ignore[arg-type]
                    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                for hook in residual_hooks:
                    hook(x, b)
                fem_petsc.set_bc(b, block_bcs, x0=x, alpha=-1.0)
                b.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            else:
                fem_petsc.assemble_residual(snes_, x, b, u, F, J, bcs, blocks)
                if residual_hooks:
                    for hook in residual_hooks:
                        hook(x, b)
                    # the hooks may have touched constrained rows: set them again to x − g
                    fem_petsc.set_bc(b, bcs, x0=x, alpha=-1.0)
                    b.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            timings.residual += time.perf_counter() - t0
            timings.residual_calls += 1

        reuse = self.reuse

        def jacobian(snes_: Any, x: Any, A: Any, P: Any) -> None:
            if A.handle != P.handle:
                # Jacobian-free (snes_mf_operator): A is the finite-difference operator, whose
                # assembly sets its base point to this iterate; the assembled Jacobian goes
                # into P, the preconditioner's matrix
                A.assemble()
            if reuse is not None and reuse.keep(snes_):
                # P unchanged: the PC keeps its factorisation (PETSc refactors on a
                # change of the matrix's state only)
                timings.jacobian_reuses += 1
                return
            t0 = time.perf_counter()
            fem_petsc.assemble_jacobian(snes_, x, P, P, u, J, None, bcs)
            for hook in jacobian_hooks:
                hook(x, P)
            if reuse is not None:
                reuse.assembled()
            timings.jacobian += time.perf_counter() - t0
            timings.jacobian_calls += 1

        snes.setFunction(residual, problem.b)
        snes.setJacobian(jacobian, problem.A, problem.P_mat)

    def residual_blocks(self) -> list[npt.NDArray[np.float64]]:
        """The residual at the current unknowns, one local array (owned and ghost) per block.

        Evaluated as Newton evaluates it (hooks and Dirichlet rows included;
        collective); one array for a single unknown.
        """
        problem = self.problem
        funcs = self.u if isinstance(self.u, Sequence) else [self.u]
        if self._residual_functions is None:
            self._residual_functions = [fem.Function(f.function_space) for f in funcs]
        out = self._residual_functions
        fem_petsc.assign(list(funcs) if len(funcs) > 1 else funcs[0], problem.x)  # type: ignore[arg-type]
        self.snes.computeFunction(problem.x, problem.b)
        fem_petsc.assign(problem.b, out if len(out) > 1 else out[0])  # type: ignore[arg-type]
        for f in out:
            f.x.scatter_forward()
        return [f.x.array.copy() for f in out]

    @property
    def snes(self) -> PETSc.SNES:
        """The PETSc SNES object."""
        return self.problem.solver

    def solve(self) -> NewtonReport:
        """Run Newton from the current ``u``; never raises on divergence.

        With ``reuse_jacobian``, a solve that failed with a kept Jacobian is run
        once more from the same start with Jacobians assembled afresh (the
        report counts the iterations of both).

        Returns:
            the report; on failure ``u`` holds the last iterate (callers restore it).
        """
        reuse = self.reuse
        if reuse is None:
            return self._solve_once()
        funcs = list(self.u) if isinstance(self.u, Sequence) else [self.u]
        start = [f.x.array.copy() for f in funcs]
        reuse.start()
        report = self._solve_once()
        if report.converged:
            return report
        reuse.valid = False
        if not reuse.kept_this_solve:
            return report
        for f, x0 in zip(funcs, start, strict=True):
            f.x.array[:] = x0
        reuse.start()
        retry = self._solve_once()
        reuse.valid = retry.converged
        return NewtonReport(
            retry.converged,
            retry.reason,
            report.iterations + retry.iterations,
            report.linear_iterations + retry.linear_iterations,
            retry.residual_norm,
            (report.jacobians or 0) + (retry.jacobians or 0),
        )

    def _solve_once(self) -> NewtonReport:
        """One SNES solve from the current ``u`` (:meth:`solve`)."""
        snes = self.snes
        ksp_time0 = self.timings.linear_solve
        t0 = time.perf_counter()
        asm0 = self.timings.assembly
        jacobians = None if self.reuse is None else self.reuse
        try:
            self.problem.solve()
        except PETSc.Error:
            return NewtonReport(
                False,
                -100,
                snes.getIterationNumber(),
                0,
                float("nan"),
                None if jacobians is None else jacobians.assembled_this_solve,
            )
        elapsed = time.perf_counter() - t0
        self.timings.linear_solve = ksp_time0 + max(elapsed - (self.timings.assembly - asm0), 0.0)
        self.timings.linear_iterations += int(snes.getLinearSolveIterations())
        reason = int(snes.getConvergedReason())  # type: ignore[call-overload]
        norm = snes.getFunctionNorm()
        converged = reason > 0 and math.isfinite(norm)
        if (
            reason == PETSc.SNES.ConvergedReason.CONVERGED_SNORM_RELATIVE
            and snes.getIterationNumber() == 0
        ):
            # newtonls returns this when the line search of its first step fails (the full
            # Newton step inverts an element: NaN): no step was taken, the iterate is the
            # predictor and its residual the predictor's (a step-norm test needs a step)
            converged = False
        return NewtonReport(
            bool(converged),
            int(reason),
            int(snes.getIterationNumber()),
            int(snes.getLinearSolveIterations()),
            float(norm),
            None if jacobians is None else jacobians.assembled_this_solve,
        )

    def destroy(self) -> None:
        """Free the PETSc objects."""
        self.problem.solver.destroy()
        self.problem.A.destroy()
        self.problem.b.destroy()
        self.problem.x.destroy()


def solve_linear(
    F: ufl.Form | Sequence[ufl.Form],
    u: fem.Function | Sequence[fem.Function],
    bcs: Sequence[fem.DirichletBC],
    spec: SolverSpec,
    *,
    name: str = "linear",
) -> NewtonReport:
    """Solve a residual ``F`` that is affine in ``u`` (one Newton step, checked).

    Used for the consistent initial acceleration M a₀ = −R(u₀, v₀, 0; t₀).
    """
    # one exact Newton step: GMRES on a finite-difference operator would only approximate it
    solver = NewtonSolver(F, u, bcs, dataclasses.replace(spec, jacobian_free=False), name=name)
    solver.snes.setTolerances(max_it=2)
    report = solver.solve()
    solver.destroy()
    return report


def load_norm(form: ufl.Form, bcs: Sequence[fem.DirichletBC] = ()) -> float:
    """Euclidean norm of the assembled load vector of ``form`` off the supports (collective).

    ``form`` is linear in the test function, e.g. the weight ∫ ρ g·w dV (the
    force scale of :meth:`NewtonSolver.set_force_scale`): the result is in N
    (N/m for strips), the units of the Newton residual. Rows of dofs
    constrained by ``bcs`` are left out, as the support reactions are not
    part of the residual Newton drives to zero.
    """
    compiled = fem.form(form, form_compiler_options=FORM_COMPILER_OPTIONS, jit_options=JIT_OPTIONS)
    b: Any = fem_petsc.assemble_vector(compiled)  # type: ignore[arg-type]
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    with b.localForm() as local:
        for bc in bcs:
            dofs, owned = bc.dof_indices()
            local.array[dofs[:owned]] = 0.0
    norm = float(b.norm())
    b.destroy()
    return norm
