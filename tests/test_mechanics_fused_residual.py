"""One kernel for the block residual of several unknowns (:mod:`magfem.mechanics.fused_residual`).

The fused residual must be the block residual: the same forms summed on the
mixed space, so the same vector to round-off at any state, in Newton's block
layout, on one rank and on two (where the unknowns' ghosts and the mixed
space's differ in numbering).
"""

from __future__ import annotations

import numpy as np
import pytest
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from magfem.pipeline import build_simulation
from verification import setups as vc

GROUND = {
    "environment": {"gravity": [0, 0, "-9.8 m/s^2"], "clamped": ["clamp"]},
    "contact": {"ground": True, "friction": 0.5},
}


def _simulation(model: str, comm):
    case = vc.cantilever_case(
        model, 0.5e-3, 1e-3, "stress", layers=1 if model == "solid" else None, **GROUND
    )
    sim = build_simulation(case, comm)
    sim.initialise()
    return sim


@pytest.mark.parametrize("model", ["surface", "rod", "solid"])
def test_fused_residual_is_the_block_residual(model, comm):
    """At a deformed state (random displacements of 0.1 mm and angles of 0.3 rad, or of
    1 µm and pressures of 3 kPa; pressed into the ground in places), the fused vector equals
    the blocks' to 1e-12 of its norm: the shell's and rod's (u, θ), the solid's (u, p)."""
    sim = _simulation(model, comm)
    solver = sim.solver
    assert solver.fused is not None
    rng = np.random.default_rng(7 + comm.rank)
    scales = (1e-6, 3e3) if model == "solid" else (1e-4, 0.3)  # no inverted hexahedra
    for f, scale in zip(solver.u, scales, strict=True):
        owned = f.function_space.dofmap.index_map.size_local * f.function_space.dofmap.bs
        f.x.array[:owned] = scale * rng.standard_normal(owned)
        f.x.scatter_forward()
    problem = solver.problem
    x = problem.x
    fem_petsc.assign(solver.u, x)
    x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    fused = problem.b.duplicate()
    solver.fused.assemble(x, fused)
    blocks = problem.b
    with blocks.localForm() as local:
        local.set(0.0)
    fem_petsc.assemble_vector(blocks, problem.F)
    blocks.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    norm = blocks.norm()
    assert norm > 0.0
    blocks.axpy(-1.0, fused)
    assert blocks.norm() <= 1e-12 * norm


def test_one_unknown_is_not_fused(comm):
    """The strip (displacement formulation) has one unknown: one form, nothing to fuse."""
    case = vc.cantilever_case("strip", 0.5e-3, 1e-3, "strain", solver={"mixed_pressure": "off"})
    assert build_simulation(case, comm).solver.fused is None
