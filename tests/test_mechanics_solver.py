"""The Newton solver (magfem.mechanics.solver, solver_options): the direct solver chosen by
size, a Krylov method when the case names another preconditioner, and the kept Jacobian."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

import magfem  # noqa: F401  (MPI before dolfinx)
from magfem.mechanics.solver import JacobianReuse
from magfem.mechanics.solver_options import (
    KRYLOV_DEFAULTS,
    MUMPS_ORDERING,
    PETSC_LU_NONZEROS,
    check_petsc_options,
    choose_linear_solver,
    newton_options,
    reuse_contraction,
)
from magfem.mechanics.spec import SolverSpec
from magfem.pipeline import build_simulation
from verification import setups as vc


def test_auto_picks_petsc_lu_for_small_serial_jacobians():
    auto = SolverSpec()
    assert auto.linear_solver == "auto"
    assert choose_linear_solver(auto, PETSC_LU_NONZEROS, 1) == "petsc"
    assert choose_linear_solver(auto, PETSC_LU_NONZEROS + 1, 1) == "mumps"
    assert choose_linear_solver(auto, 100, 2) == "mumps"  # PETSc's LU is serial only
    for name in ("mumps", "petsc", "superlu_dist"):
        assert choose_linear_solver(SolverSpec(linear_solver=name), 100, 1) == name
    # without a size (the options check), auto is MUMPS; PETSc's LU counts only exact zeros
    assert newton_options(auto)["pc_factor_mat_solver_type"] == "mumps"
    assert newton_options(auto, "petsc")["pc_factor_zeropivot"] == 0.0


def test_a_preconditioner_other_than_lu_gets_krylov_defaults_and_no_lu_options():
    """`petsc_options = { pc_type = "gamg" }` alone must not leave a one-V-cycle "solve"
    (ksp preonly) nor LU options PETSc reports as unused; the case's own Krylov keys win."""
    spec = SolverSpec(petsc_options={"pc_type": "gamg", "ksp_rtol": 1e-10})
    opts = newton_options(spec)
    assert opts["pc_type"] == "gamg"
    assert not any(key.startswith("pc_factor") for key in opts)
    assert opts["ksp_type"] == KRYLOV_DEFAULTS["ksp_type"] == "gmres"
    assert opts["ksp_pc_side"] == "right"  # its tolerance is the true residual's
    assert opts["ksp_rtol"] == 1e-10
    check_petsc_options(spec)  # PETSc uses every option the case set
    assert newton_options(SolverSpec())["ksp_type"] == "preonly"


def _rod_case(linear_solver: str, petsc_options: dict | None, steps: dict, **solver: object):
    return vc.cantilever_case(
        "rod",
        0.5e-3,
        vc.NARROW_WIDTH,
        "strain",
        root="rigid",
        mesh_options={"rod_bending": "beam"},
        field=vc.DRIVE,
        time={"end": 3e-3, "rho_inf": 0.5, **steps},
        solver={"linear_solver": linear_solver, "petsc_options": petsc_options or {}, **solver},
    )


@pytest.mark.parametrize(
    ("linear_solver", "petsc_options", "ordering"),
    [
        ("mumps", {}, MUMPS_ORDERING),
        ("mumps", {"mat_mumps_icntl_7": 0}, 0),  # the case's own ordering wins
        ("auto", {}, None),  # PETSc's LU on one rank: no MUMPS ordering set
    ],
)
def test_mumps_factorises_with_scotch_unless_the_case_orders(
    linear_solver, petsc_options, ordering
):
    """The ordering MUMPS factorised with, read back from MUMPS after a step (its automatic
    choice is 7; SCOTCH is 3). On one rank ``auto`` takes PETSc's LU for the rod, and no
    MUMPS option may then reach the options database (PETSc would report it unused)."""
    sim = build_simulation(
        _rod_case(linear_solver, petsc_options, {"step": 0.25e-3}), MPI.COMM_WORLD
    )
    sim.initialise()
    sim.step(sim.time_spec.start)
    pc = sim.solver.snes.getKSP().getPC()
    if ordering is None and MPI.COMM_WORLD.size > 1:
        ordering = MUMPS_ORDERING  # auto is MUMPS on several ranks
    if ordering is None:
        assert pc.getFactorSolverType() == "petsc"
        assert not PETSc.Options().hasName(sim.solver.prefix + "mat_mumps_icntl_7")
    else:
        assert pc.getFactorSolverType() == "mumps"
        assert pc.getFactorMatrix().getMumpsIcntl(7) == ordering


def test_mumps_chooses_its_own_ordering_above_the_size(monkeypatch):
    """Above ``MUMPS_ORDERING_NONZEROS`` (here made 0) MUMPS keeps its automatic choice (7)."""
    monkeypatch.setattr("magfem.mechanics.solver.MUMPS_ORDERING_NONZEROS", 0)
    sim = build_simulation(_rod_case("mumps", {}, {"step": 0.25e-3}), MPI.COMM_WORLD)
    sim.initialise()
    sim.step(sim.time_spec.start)
    assert sim.solver.snes.getKSP().getPC().getFactorMatrix().getMumpsIcntl(7) == 7


def _rod_run(
    linear_solver: str,
    petsc_options: dict | None = None,
    fixed_step: float = 0.0,
    **solver: object,
):
    """The rod of benchmarks/pyelastica_comparison.py (0.5 mm P2, 3 ms of the 2 mT drive);
    ``fixed_step`` > 0: that step throughout, else adaptive from 0.25 ms; ``solver``: more
    ``[solver]`` keys. Returns (linear solver, factorisation, history, solver timings)."""
    steps = {"step": fixed_step, "adaptive": False} if fixed_step else {"step": 0.25e-3}
    sim = build_simulation(_rod_case(linear_solver, petsc_options, steps, **solver), MPI.COMM_WORLD)
    pc = sim.solver.snes.getKSP().getPC()
    factor = pc.getFactorSolverType() if pc.getType() == "lu" else None
    result = sim.run(progress=False)
    return sim.solver.linear_solver, factor, result.history, sim.solver.timings, result.effort


@pytest.mark.slow
def test_auto_solver_matches_mumps_on_the_rod():
    """The rod's Jacobian (~200 unknowns, two blocks: u and θ) goes to PETSc's LU serially.

    Its rotations' mass matrix (initial acceleration) has pivots ~1e-18, which
    PETSc's LU would call zero at its default tolerance. Both direct solvers
    solve each Newton system to ~1e-12 relative: the histories agree to round-off
    (1e-9 of the largest angle leaves room for a few ulps in 12 steps, far below
    the 0.1° = 2e-3 rad of the coarsest physics difference the histories resolve).
    """
    chosen, factor, auto, *_ = _rod_run("auto")
    expected = "petsc" if MPI.COMM_WORLD.size == 1 else "mumps"
    assert (chosen, factor) == (expected, expected)
    _, mumps_factor, mumps, *_ = _rod_run("mumps")
    assert mumps_factor == "mumps"
    assert np.array_equal(auto["newton_iterations"], mumps["newton_iterations"])
    angle, reference = auto["angle_arm"], mumps["angle_arm"]
    assert np.max(np.abs(reference)) > 0.5  # the arm rose (rad)
    assert np.max(np.abs(angle - reference)) <= 1e-9 * np.max(np.abs(reference))


def test_krylov_newton_matches_the_direct_solver_on_the_rod():
    """GMRES + GAMG (the case's ``pc_type``) in place of the LU, on the same fixed steps: each
    Newton system is solved to 1e-10 of its residual instead of to round-off. Newton's last
    update is then off by 1e-10 of itself, and that update is already below 1e-6 of the
    step's rotation, so the histories agree far below 1e-9 of the largest angle (measured:
    1.4e-12 rad of 0.95). Without the Krylov defaults (ksp preonly: one V-cycle per Newton
    iteration) the initial-acceleration solve fails."""
    gamg = {"pc_type": "gamg", "ksp_rtol": 1e-10}
    chosen, factor, krylov, *_ = _rod_run("auto", gamg, fixed_step=0.0625e-3)
    assert (chosen, factor) == ("gamg", None)
    _, _, mumps, *_ = _rod_run("mumps", fixed_step=0.0625e-3)
    angle, reference = krylov["angle_arm"], mumps["angle_arm"]
    assert angle.shape == reference.shape
    assert np.max(np.abs(reference)) > 0.5  # the arm rose (rad)
    assert np.max(np.abs(angle - reference)) <= 1e-9 * np.max(np.abs(reference))


def test_kept_jacobian_converges_to_the_same_steps_with_fewer_factorisations():
    """``reuse_jacobian`` (modified Newton) on the same fixed steps as full Newton, both to
    ‖R‖ <= 1e-10 of the predictor's: each step's solution then differs by ~1e-10 of the
    step's update, so the histories agree far below 1e-7 of the largest angle (measured:
    2.5e-9 rad of 0.95, with 25 Jacobians against 100). A kept Jacobian that were wrong
    (not refreshed, or refactorised from a stale matrix) would stop Newton short or drive
    it elsewhere, and more factorisations than steps would mean nothing was kept."""
    step, tight = 0.0625e-3, {"rtol": 1e-10, "max_iterations": 40}
    _, _, full, full_t, full_effort = _rod_run("auto", fixed_step=step, **tight)
    _, _, kept, kept_t, effort = _rod_run("auto", fixed_step=step, reuse_jacobian=True, **tight)
    # the run's effort against the history's own count (SNES's iterations per step): every
    # iteration asks for a Jacobian; on fixed steps without a failure the kept one is rebuilt
    # only after slow contraction, besides the run's first iteration
    for history, counts in ((full, full_effort), (kept, effort)):
        assert counts["iterations"] == int(np.sum(history["newton_iterations"]))
    assert full_effort["jacobians"] == full_effort["iterations"]
    assert "rebuilt_start" not in full_effort
    assert effort["rebuilt_start"] == 1 and effort["rebuilt_time_step"] == 0
    assert effort["rebuilt_contraction"] == effort["jacobians"] - 1
    assert full_t.jacobian_reuses == 0
    assert kept_t.jacobian_reuses > 0
    steps = len(kept["time"]) - 1
    assert kept_t.jacobian_calls < 0.5 * full_t.jacobian_calls
    assert kept_t.jacobian_calls < steps
    angle, reference = kept["angle_arm"], full["angle_arm"]
    assert angle.shape == reference.shape
    assert np.max(np.abs(reference)) > 0.5  # the arm rose (rad)
    assert np.max(np.abs(angle - reference)) <= 1e-7 * np.max(np.abs(reference))


def test_jacobian_free_newton_converges_to_the_same_steps_with_fewer_factorisations():
    """``jacobian_free`` (Newton–Krylov: flexible GMRES on finite differences of the
    residual, preconditioned by the kept factorisation) on the fixed steps of full Newton,
    both to ‖R‖ <= 1e-10 of the predictor's: the same solutions, so the histories agree
    below 1e-7 of the largest angle (measured: 8.3e-9 rad of 0.95). Its Newton steps are the
    exact Jacobian's to GMRES's 0.1, so it needs fewer factorisations than modified Newton,
    which rebuilds whenever the kept Jacobian's own step contracts too little (measured on
    the 48 steps: 4 against 15, and 100 with full Newton). A preconditioner rebuilt on every
    iteration would give as many Jacobians as iterations; an operator not assembled at each
    iterate fails the first step (checked). Flexible GMRES applies the factorisation once
    per GMRES iteration, plus the initial acceleration's solve (measured 644 for 643 GMRES
    and 262 Newton iterations; GMRES on the right, applying it once more per Newton
    iteration to form its solution, 907)."""
    step, tight = 0.0625e-3, {"rtol": 1e-10, "max_iterations": 40}
    _, _, full, _, full_effort = _rod_run("auto", fixed_step=step, **tight)
    *_, kept_effort = _rod_run("auto", fixed_step=step, reuse_jacobian=True, **tight)
    PETSc.Log.begin()
    pc_applies = PETSc.Log.Event("PCApply").getPerfInfo()["count"]
    _, _, free, free_t, effort = _rod_run(
        "auto", fixed_step=step, reuse_jacobian=True, jacobian_free=True, **tight
    )
    pc_applies = PETSc.Log.Event("PCApply").getPerfInfo()["count"] - pc_applies
    assert effort["iterations"] == int(np.sum(free["newton_iterations"]))
    # flexible GMRES keeps the preconditioned vectors: one triangular solve per GMRES
    # iteration, besides the initial acceleration's (GMRES on the right applies the
    # preconditioner once more per Newton iteration to form its solution)
    assert pc_applies == effort["gmres_iterations"] + 1
    assert effort["gmres_iterations"] == free_t.linear_iterations > effort["iterations"]
    assert "gmres_iterations" not in kept_effort
    assert effort["rebuilt_start"] == 1 and effort["rebuilt_time_step"] == 0
    assert effort["jacobians"] < 0.5 * kept_effort["jacobians"]
    assert kept_effort["jacobians"] < full_effort["jacobians"]
    angle, reference = free["angle_arm"], full["angle_arm"]
    assert angle.shape == reference.shape
    assert np.max(np.abs(reference)) > 0.5  # the arm rose (rad)
    assert np.max(np.abs(angle - reference)) <= 1e-7 * np.max(np.abs(reference))


def test_jacobian_free_options_and_their_checks():
    """The finite-difference operator, flexible GMRES (on the right: its tolerance is the
    true residual's) under the factorisation, the case's own Krylov keys winning; the spec refuses
    it without a kept Jacobian or with a preconditioner that is not a factorisation."""
    from magfem.config import CaseError

    opts = newton_options(
        SolverSpec(reuse_jacobian=True, jacobian_free=True, petsc_options={"ksp_rtol": 0.1})
    )
    assert opts["snes_mf_operator"] is True
    assert (opts["ksp_type"], opts["ksp_pc_side"], opts["pc_type"]) == ("fgmres", "right", "lu")
    assert opts["ksp_rtol"] == 0.1
    assert "snes_mf_operator" not in newton_options(SolverSpec(reuse_jacobian=True))
    check_petsc_options(SolverSpec(reuse_jacobian=True, jacobian_free=True))
    with pytest.raises(CaseError, match=r"jacobian_free.*needs reuse_jacobian = true"):
        SolverSpec(jacobian_free=True)
    with pytest.raises(CaseError, match=r"jacobian_free.*not petsc_options\.pc_type = 'gamg'"):
        SolverSpec(reuse_jacobian=True, jacobian_free=True, petsc_options={"pc_type": "gamg"})


class _Ksp:
    def __init__(self) -> None:
        self.iterations = 0

    def getIterationNumber(self) -> int:
        return self.iterations


class _Snes:
    """What :class:`JacobianReuse` reads of SNES: the residual norm of the iterate and the
    GMRES iterations of the last linear solve."""

    def __init__(self) -> None:
        self.norm = 1.0
        self.ksp = _Ksp()

    def getFunctionNorm(self) -> float:
        return self.norm

    def getKSP(self) -> _Ksp:
        return self.ksp


def test_jacobian_reuse_with_krylov_rebuilds_after_a_long_gmres_solve():
    reuse = JacobianReuse(0.5, [], krylov_iterations=3)
    snes = _Snes()
    reuse.start()
    assert not reuse.keep(snes)
    reuse.assembled()
    snes.norm, snes.ksp.iterations = 0.1, 3  # contracted, GMRES within the limit: keep
    assert reuse.keep(snes)
    snes.norm, snes.ksp.iterations = 0.01, 4  # contracted, but GMRES took too long: rebuild
    assert not reuse.keep(snes)
    reuse.assembled()
    snes.norm, snes.ksp.iterations = 0.001, 1
    assert reuse.keep(snes)
    assert reuse.rebuilds == {"contraction": 0, "krylov": 1, "time_step": 0, "start": 1}
    plain = JacobianReuse(0.5, [])  # modified Newton never asks GMRES
    plain.start()
    plain.keep(snes)
    plain.assembled()
    snes.ksp.iterations = 100
    plain.start()  # the next step's first iteration: no contraction to judge yet
    assert plain.keep(snes)


def test_jacobian_reuse_refreshes_on_a_new_step_size_slow_contraction_or_failure():
    from dolfinx import fem, mesh

    domain = mesh.create_unit_interval(MPI.COMM_SELF, 1)
    dt = fem.Constant(domain, 1e-4)
    contraction = reuse_contraction(SolverSpec(reuse_jacobian=True))
    assert contraction == 0.5
    free = SolverSpec(reuse_jacobian=True, jacobian_free=True)
    assert reuse_contraction(free) == 0.99  # a new preconditioner does not cure nonlinearity
    assert reuse_contraction(dataclasses.replace(free, reuse_contraction=0.3)) == 0.3
    reuse = JacobianReuse(contraction, [dt])
    snes = _Snes()
    reuse.start()
    assert not reuse.keep(snes)  # nothing assembled yet
    reuse.assembled()
    snes.norm = 0.1 * contraction  # contracted enough: keep
    assert reuse.keep(snes)
    snes.norm *= 1.01 * contraction  # contracted too little: refresh
    assert not reuse.keep(snes)
    reuse.assembled()
    reuse.start()  # the next step: its first iteration keeps the Jacobian
    assert reuse.keep(snes)
    assert reuse.kept_this_solve == 1
    dt.value = 5e-5  # the inertia term changed: refresh
    reuse.start()
    assert not reuse.keep(snes)
    reuse.assembled()
    reuse.start()
    assert reuse.keep(snes)
    reuse.valid = False  # what a failed solve sets
    reuse.start()
    assert not reuse.keep(snes)
    assert reuse.rebuilds == {"contraction": 1, "krylov": 0, "time_step": 1, "start": 2}
