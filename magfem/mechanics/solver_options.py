"""The Newton solver's PETSc options, and their check before a run.

:func:`newton_options` gives magfem's defaults for a :class:`SolverSpec` (the
direct solver by size, :func:`choose_linear_solver`; Krylov defaults under a
preconditioner that is not a factorisation), then ``petsc_options``.

The Newton solver hands these options (:func:`newton_options`:
magfem's defaults, then ``petsc_options``) to PETSc when it is set up. An
option PETSc does not read (a typo, an option of another solver type) is
ignored without a word, and a malformed value (``snes_rtol = "abc"``)
fails only in the run. :func:`check_petsc_options` sets the same options up
on a throw-away SNES (``PETSC_COMM_SELF``) whose linear solver it sets up
on a 4 × 4 diagonal matrix (the factorization reads the direct solvers'
options such as ``mat_mumps_icntl_14``), and asks PETSc which of the user's
options it did not use.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Mapping
from typing import Any

from petsc4py import PETSc

from magfem.config import CaseError
from magfem.mechanics.spec import FACTORISATIONS, SolverSpec

__all__ = [
    "FACTORISATIONS",
    "JACOBIAN_FREE_CONTRACTION",
    "JACOBIAN_FREE_DEFAULTS",
    "KRYLOV_DEFAULTS",
    "MODIFIED_NEWTON_CONTRACTION",
    "MUMPS_ORDERING",
    "MUMPS_ORDERING_NONZEROS",
    "PETSC_LU_NONZEROS",
    "check_petsc_options",
    "choose_linear_solver",
    "factor_options",
    "newton_options",
    "reuse_contraction",
]

PETSC_LU_NONZEROS = 150_000
"""``linear_solver = "auto"`` factorises Jacobians with at most this many nonzeros
with PETSc's own LU (on one process), larger ones with MUMPS: MUMPS's fixed
cost per factorisation dominates below, its supernodes win above (CPU per
numeric factorisation, ``python -m benchmarks.direct_solvers``: 5x less with
PETSc's LU on a rod's 33 k nonzeros, 1.7x on a shell's 65 k, even at 174 k,
MUMPS 1.3x faster on the default solid's 211 k, 2x on 380 k)."""

MUMPS_ORDERING = 3
"""MUMPS's fill-reducing ordering (``mat_mumps_icntl_7``) for Jacobians of at most
:data:`MUMPS_ORDERING_NONZEROS` nonzeros: SCOTCH. On the default case's 3395-unknown shell
Jacobian on 2 ranks MUMPS's automatic choice factorised in 12.2 ms, SCOTCH in 7.9, and the
whole run took 103 instead of 131 s; on one rank the orderings are within 5 %
(``benchmarks.direct_solvers orderings``, docs/verification.md §8)."""

MUMPS_ORDERING_NONZEROS = 1_000_000
"""Above this many nonzeros MUMPS chooses its ordering: on the failure triangle's 1.6 M
nonzeros (21 k unknowns) its choice was 5 % faster than SCOTCH on 2 ranks, and on 293 k
unknowns 1.37 × faster on 8 ranks (docs/verification.md §8)."""

KRYLOV_DEFAULTS: dict[str, Any] = {
    "ksp_type": "gmres",
    "ksp_pc_side": "right",
    "ksp_rtol": 1e-8,
    "ksp_gmres_restart": 200,
    "ksp_max_it": 1000,
}
"""Krylov options under a preconditioner that is not a factorisation (e.g.
``petsc_options = { pc_type = "gamg" }``), each overridden by ``petsc_options``:
GMRES preconditioned on the right, so its relative tolerance is the true
residual's, 1e-8 of it (Newton's own tolerance is 1e-6 of the predictor's residual)."""


JACOBIAN_FREE_DEFAULTS: dict[str, Any] = {
    "snes_mf_operator": True,
    "ksp_type": "fgmres",
    "ksp_pc_side": "right",
    "ksp_rtol": 0.1,
    "ksp_max_it": 30,
    "ksp_gmres_restart": 30,
}
"""Options of ``[solver] jacobian_free`` (Jacobian-free Newton–Krylov), each overridden by
``petsc_options``: PETSc's finite-difference operator of the residual (``snes_mf_operator``:
the assembled Jacobian is the preconditioner's matrix only), flexible GMRES (right
preconditioning that keeps the preconditioned vectors: with a fixed preconditioner the
iterates of GMRES on the right, without the extra triangular solve that GMRES spends on its
solution; 1.06 × faster on the default case, docs/verification.md §8) under its
factorisation, each Newton step solved to 0.1 of its residual (an inexact Newton step:
the Newton iterations contract by about that much; on the default case 0.1 with
``krylov_iterations = 4`` was as fast as 0.3 with 2 and 1.07 × faster than 0.3 with 3,
1.16 × faster than 0.5, docs/verification.md §8)."""


MODIFIED_NEWTON_CONTRACTION = 0.5
"""``reuse_contraction`` by default: modified Newton's step is the kept Jacobian's, so an
iteration that contracts ‖R‖ less than this asks for a new one."""

JACOBIAN_FREE_CONTRACTION = 0.99
"""``reuse_contraction`` by default under ``jacobian_free``: the Newton step is the exact
Jacobian's (to GMRES's tolerance) whatever the kept factorisation, so a slow contraction is
the problem's nonlinearity (a contact switching within the step), which a new
preconditioner does not cure; a stale one shows as more GMRES iterations
(``krylov_iterations``). The Jacobian is rebuilt only after an iteration that did not
reduce ‖R‖: on the default case 20 % fewer Jacobians and 1.05–1.11 × faster than 0.5, the
first 25 ms unchanged (docs/verification.md §8)."""


def reuse_contraction(spec: SolverSpec) -> float:
    """The contraction below which a kept Jacobian is rebuilt: ``spec.reuse_contraction``,
    else :data:`JACOBIAN_FREE_CONTRACTION` or :data:`MODIFIED_NEWTON_CONTRACTION`."""
    if spec.reuse_contraction is not None:
        return spec.reuse_contraction
    return JACOBIAN_FREE_CONTRACTION if spec.jacobian_free else MODIFIED_NEWTON_CONTRACTION


def choose_linear_solver(spec: SolverSpec, nonzeros: int, ranks: int) -> str:
    """The direct solver (``petsc``, ``mumps``, ``superlu_dist``) of ``spec`` for a Jacobian.

    Args:
        nonzeros: nonzero entries of the Jacobian (all ranks together).
        ranks: processes sharing it (PETSc's own LU is serial only).
    """
    if spec.linear_solver != "auto":
        return spec.linear_solver
    return "petsc" if ranks == 1 and nonzeros <= PETSC_LU_NONZEROS else "mumps"


def factor_options(linear_solver: str) -> dict[str, Any]:
    """Options of the LU factorisation by ``linear_solver``.

    PETSc's own LU does not pivot and calls a pivot zero below an absolute
    1e-12 (``pc_factor_zeropivot``): the rotary inertia of a rod's or shell's
    rotations puts ~1e-18 on the diagonal of the initial acceleration's mass
    matrix, so only an exact zero counts as one here.
    """
    opts: dict[str, Any] = {"pc_factor_mat_solver_type": linear_solver}
    if linear_solver == "petsc":
        opts["pc_factor_zeropivot"] = 0.0
    return opts


def newton_options(spec: SolverSpec, linear_solver: str | None = None) -> dict[str, Any]:
    """PETSc options (without prefix) for a :class:`SolverSpec`.

    ``linear_solver``: the direct solver chosen (:func:`choose_linear_solver`);
    None: ``spec.linear_solver``, with ``auto`` read as ``mumps``. Where
    ``spec.petsc_options`` names a preconditioner other than a factorisation
    (``pc_type``), the LU's options are left out and the Krylov method
    defaults to :data:`KRYLOV_DEFAULTS`; ``spec.jacobian_free`` adds
    :data:`JACOBIAN_FREE_DEFAULTS`.
    """
    if linear_solver is None:
        linear_solver = "mumps" if spec.linear_solver == "auto" else spec.linear_solver
    opts: dict[str, Any] = {
        "snes_type": "newtonls",
        "snes_linesearch_type": spec.line_search,
        "snes_rtol": spec.rtol,
        "snes_atol": spec.atol,
        "snes_stol": spec.stol,
        "snes_max_it": spec.max_iterations,
        "snes_divergence_tolerance": 1e12,
        "snes_max_fail": 0,
        "ksp_type": "preonly",
        "pc_type": "lu",
        "ksp_error_if_not_converged": False,
    }
    if spec.petsc_options.get("pc_type", "lu") in FACTORISATIONS:
        opts |= factor_options(linear_solver)
    else:
        opts |= KRYLOV_DEFAULTS
    if spec.jacobian_free:
        opts |= JACOBIAN_FREE_DEFAULTS
    opts.update(spec.petsc_options)
    return opts


_COUNTER = itertools.count()
_KEY = "solver.petsc_options"


def _set_up(options: Mapping[str, Any]) -> tuple[PETSc.Error | None, list[str]]:
    """(PETSc's error or None, the options it did not use) of a SNES set up with ``options``."""
    prefix = f"magfem_check_{next(_COUNTER)}_"
    db = PETSc.Options()
    n = 4
    A = PETSc.Mat().createAIJ((n, n), nnz=1, comm=PETSc.COMM_SELF)
    for i in range(n):
        A.setValue(i, i, 2.0)
    A.assemble()
    snes = PETSc.SNES().create(PETSc.COMM_SELF)
    snes.setOptionsPrefix(prefix)
    for key, value in options.items():
        db.setValue(prefix + key, value)
    error: PETSc.Error | None = None
    try:
        snes.setFromOptions()
        ksp = snes.getKSP()
        ksp.setOperators(A, A)
        ksp.setUp()
    except PETSc.Error as err:
        error = err
    finally:
        unused = [key for key in options if not db.used(prefix + key)]
        for key in options:
            db.delValue(prefix + key)
        snes.destroy()
        A.destroy()
    return error, unused


def check_petsc_options(spec: SolverSpec) -> None:
    """Raise CaseError for the first option of ``spec.petsc_options`` PETSc cannot use.

    Not collective (every rank may call it; ``PETSC_COMM_SELF``).

    Raises:
        CaseError: ``solver.petsc_options.<key>``: a value PETSc cannot read
            (a malformed number, an unknown type name) or an option it does
            not use with these settings.
    """
    user = dict(spec.petsc_options)
    if not user:
        return
    error, unused = _set_up(newton_options(spec))
    if error is not None:
        # the options one at a time (with magfem's defaults) to name the culprit
        defaults = newton_options(dataclasses.replace(spec, petsc_options={}))
        for key, value in user.items():
            if _set_up(defaults | {key: value})[0] is not None:
                raise CaseError(
                    f"{_KEY}.{key}", value, f"PETSc cannot read this value (error {_code(error)})"
                )
        raise CaseError(_KEY, user, f"PETSc refuses these options (error {_code(error)})")
    for key in user:
        if key in unused:
            raise CaseError(
                f"{_KEY}.{key}",
                user[key],
                "PETSc does not use this option in the Newton solver "
                "(unknown, or an option of another solver type)",
            )


def _code(err: PETSc.Error) -> object:
    """PETSc's error number of ``err``."""
    return getattr(err, "ierr", "?")
