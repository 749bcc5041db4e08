"""The Newton solver's direct solver chosen by size (magfem.mechanics.solver)."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

import magfem  # noqa: F401  (MPI before dolfinx)
from magfem.mechanics.solver import PETSC_LU_NONZEROS, choose_linear_solver, newton_options
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


def _rod_run(linear_solver: str):
    """The rod of benchmarks/pyelastica_comparison.py (0.5 mm P2, 3 ms of the 2 mT drive)."""
    case = vc.cantilever_case(
        "rod",
        0.5e-3,
        vc.NARROW_WIDTH,
        "strain",
        root="rigid",
        mesh_options={"rod_bending": "beam"},
        field=vc.DRIVE,
        time={"end": 3e-3, "step": 0.25e-3, "rho_inf": 0.5},
        solver={"linear_solver": linear_solver},
    )
    sim = build_simulation(case, MPI.COMM_WORLD)
    factor = sim.solver.snes.getKSP().getPC().getFactorSolverType()
    return sim.solver.linear_solver, factor, sim.run(progress=False).history


@pytest.mark.slow
def test_auto_solver_matches_mumps_on_the_rod():
    """The rod's Jacobian (~200 unknowns, two blocks: u and θ) goes to PETSc's LU serially.

    Its rotations' mass matrix (initial acceleration) has pivots ~1e-18, which
    PETSc's LU would call zero at its default tolerance. Both direct solvers
    solve each Newton system to ~1e-12 relative: the histories agree to round-off
    (1e-9 of the largest angle leaves room for a few ulps in 12 steps, far below
    the 0.1° = 2e-3 rad of the coarsest physics difference the histories resolve).
    """
    chosen, factor, auto = _rod_run("auto")
    expected = "petsc" if MPI.COMM_WORLD.size == 1 else "mumps"
    assert (chosen, factor) == (expected, expected)
    _, mumps_factor, mumps = _rod_run("mumps")
    assert mumps_factor == "mumps"
    assert np.array_equal(auto["newton_iterations"], mumps["newton_iterations"])
    angle, reference = auto["angle_arm"], mumps["angle_arm"]
    assert np.max(np.abs(reference)) > 0.5  # the arm rose (rad)
    assert np.max(np.abs(angle - reference)) <= 1e-9 * np.max(np.abs(reference))
