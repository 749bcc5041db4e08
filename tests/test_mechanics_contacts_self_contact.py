"""Arm–arm (self) contact through the full time loop, serial and mpirun -n 2.

Two blocks, L × H = 1 × 0.2 mm side views (plane-strain strips, one mesh,
cell groups ``lower`` and ``upper``), μ = 115 kPa, ρ = 2130 kg/m³, touch
through the two-pass penalty of :mod:`magfem.mechanics.contacts.self_contact`
(k_c = κ_s μ / H, the gap follows the master's current displacement inside
Newton):

* Linearisation: the coupled residual (slave traction and master reaction)
  against central finite differences, its symmetry (it is the gradient of
  the penalty energy) and action = reaction (the contact forces of the
  whole body sum to zero).
* Pressed: the lower block is clamped at its base, the upper one rests on
  it under a body force G, at a step 1500 times beyond the stability limit
  of the former staggered coupling. At rest the contact force equals the
  upper block's weight and the faces interpenetrate by the static
  penetration of the penalty ramp under the pressure p = ρ G H,
  δ = r⁻¹(p/k_c) (:func:`reference.penalty_penetration`).
* Bouncing: the free blocks fly towards each other at ±v across a gap d
  (no gravity, no friction, ρ∞ = 1). The observable reports the first
  touch at the free-flight time d/(2v); kinetic + elastic + penalty energy
  is conserved through the impact and the blocks separate with their
  speeds reversed (identical blocks: elastic impact).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from magfem.case import parse_case
from magfem.config import CaseError
from magfem.geometry.robot_mesh import RobotMesh
from magfem.mechanics.simulation import Simulation
from magfem.pipeline import build_simulation
from verification import references as ref
from verification import setups as vc

L, H, SIZE, MU, RHO, WIDTH = 1e-3, 2e-4, 1e-4, 115e3, 2130.0, 1e-3


def _blocks(comm: MPI.Comm, gap: float) -> RobotMesh:
    """Two L × H quadrilateral blocks, one above the other ``gap`` apart (strip, gdim 2)."""

    def builder(gmsh: Any) -> None:
        occ = gmsh.model.occ
        lower = occ.addRectangle(0.0, 0.0, 0.0, L, H)
        upper = occ.addRectangle(0.0, H + gap, 0.0, L, H)
        occ.synchronize()

        def horizontal(block: int, height: float) -> int:
            for _, tag in gmsh.model.getBoundary([(2, block)], oriented=False):
                _, y0, _, _, y1, _ = gmsh.model.getBoundingBox(1, tag)  # OCC pads by ~1e-7
                if y1 - y0 < 1e-6 and abs(0.5 * (y0 + y1) - height) < 1e-6:
                    return int(tag)
            raise RuntimeError(f"no horizontal side at {height}")

        lines = {
            "clamp": horizontal(lower, 0.0),
            "lower_top": horizontal(lower, H),
            "upper_bottom": horizontal(upper, H + gap),
        }
        for name, tag in (("lower", lower), ("upper", upper)):
            gmsh.model.addPhysicalGroup(2, [tag], name=name)
        for name, tag in lines.items():
            gmsh.model.addPhysicalGroup(1, [tag], name=name)
        gmsh.option.setNumber("Mesh.MeshSizeMax", SIZE)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(2)

    robot = vc.gmsh_robot(
        builder, comm, gdim=2, name="blocks", model="strip", thickness=H, area=2 * L * H
    )
    assert {"clamp", "lower_top", "upper_bottom"} <= set(robot.groups)
    return robot


def _case(contact: dict[str, Any], environment: dict[str, Any], time: dict[str, Any]) -> Any:
    return parse_case(
        {
            "name": "blocks",
            "robot": {"shape": "membrane", "thickness": H, "length": L, "width": WIDTH},
            "mesh": {"size": SIZE, "model": "strip"},
            "material": {"shear_modulus": MU, "density": RHO, "remanence": 0.0},
            "contact": {
                "self_contact": True,
                "self_contact_groups": ["lower", "upper"],
                "self_contact_exclusion": 0.0,
                **contact,
            },
            "environment": environment,
            "time": {"adaptive": False, **time},
            "output": {"csv": False, "vtx_every": 0, "plot": False},
        }
    )


@pytest.mark.slow
def test_bouncing_blocks_conserve_energy_and_touch_on_time(comm):
    gap, v, dt = 2e-5, 0.1, 1e-6
    case = _case(
        {},
        {"gravity": [0, 0, 0], "clamped": []},
        {"end": 2.5e-4, "step": dt, "rho_inf": 1.0, "scheme": "generalized_alpha"},
    )
    sim = build_simulation(case, comm, robot_mesh=_blocks(comm, gap))
    middle = H + gap / 2
    sim.integrator.v0.interpolate(
        lambda X: np.vstack([np.zeros(X.shape[1]), np.where(X[1] < middle, v, -v)])
    )
    result = sim.run(progress=False)
    h = result.history
    e0 = 2 * 0.5 * RHO * L * H * WIDTH * v**2  # J, both blocks
    assert h["energy_total"][0] == pytest.approx(e0, rel=1e-9)
    touch = result.summary["first_touch_lower__upper"]
    # free flight closes the gap at t = d/(2v) exactly on a step boundary: the first step that
    # ends with the faces overlapping is the next one
    assert touch == pytest.approx(gap / (2 * v) + dt, rel=1e-6)
    # kinetic + elastic + penalty energy through the impact (ρ∞ = 1, 56 steps in contact):
    # measured max |ΔE|/E = 5.4e-4 during contact and 1.3e-4 after separation, both falling
    # 4x at Δt/2 (1.35e-4, 3.3e-5: the integrator's second order; with the former frozen
    # master data 8.8e-3 and 8.1e-4, unchanged at Δt/2)
    drift = np.abs(h["energy_total"] / e0 - 1)
    assert np.max(drift) < 2e-3, np.max(drift)
    assert drift[-1] < 5e-4, drift[-1]
    assert h["self_contact_force"][-1] == 0.0  # separated again
    # interpenetration stays within the penalty's tolerance: the impact pressure of the
    # blocks (measured peak force 3.2 mN over 1 mm², 3.2 kPa) penetrates by
    # r⁻¹(p/k_c) = 3.3e-6 m; the largest nodal penetration measured 3.5e-6 m (the pressure
    # of an impact is not uniform over the face)
    k_c = 10.0 * MU / H
    peak = h["self_contact_force"].max() / (L * WIDTH)
    expected = ref.penalty_penetration(peak, k_c, 0.05 * H)
    assert h["self_contact_penetration"].max() == pytest.approx(expected, rel=0.1)
    assert h["self_contact_penetration"].max() < 0.05 * H


def _pressed_in(comm) -> tuple[Simulation, np.ndarray]:
    """The blocks touching (gap 0), lower clamped, the upper one's displacement set.

    Upper block: 2 onsets into the lower one (linear branch of the ramp),
    0.3 element sideways, tilted by 1e-5 over its length and a 1e-6 m random
    wobble on every dof, so that gaps and pressures differ at every point.
    The integrator's u_n is half of it (a stage point between them).
    """
    case = _case(
        {},
        {"gravity": [0, 0, 0], "clamped": ["clamp"]},
        {"end": 1e-3, "step": 1e-4, "rho_inf": 0.5, "scheme": "generalized_alpha"},
    )
    sim = build_simulation(case, comm, robot_mesh=_blocks(comm, 0.0))
    V = sim.u.function_space
    X = V.tabulate_dof_coordinates()[:, :2]
    upper = X[:, 1] > H * (1 + 1e-9)
    disp = np.zeros_like(X)
    disp[upper, 0] = 0.3 * SIZE
    disp[upper, 1] = -1e-5 * (2.0 + X[upper, 0] / L - 0.5)
    disp += 1e-6 * np.random.default_rng(7 + comm.rank).standard_normal(disp.shape)
    sim.u.x.array[:] = disp.ravel()
    sim.u.x.scatter_forward()
    sim.integrator.u0.x.array[:] = 0.5 * sim.u.x.array
    for bc in sim.model.bcs:
        bc.set(sim.u.x.array, alpha=0.0)
        bc.set(sim.integrator.u0.x.array, alpha=0.0)
    bc_dofs = np.concatenate([bc.dof_indices()[0][: bc.dof_indices()[1]] for bc in sim.model.bcs])
    return sim, bc_dofs


def test_coupled_linearisation_matches_finite_differences(comm):
    sim, bc_dofs = _pressed_in(comm)
    contact = sim.problem.contacts[0]
    assert contact is not None
    contact.before_solve()  # pairing and normals frozen from here on, as within a step
    assert contact.engaged
    x = sim.u.x.petsc_vec.copy()

    A = sim.solver.problem.A
    d = vc.contact_direction(x, 11 + comm.rank, bc_dofs)
    # central differences at a 1e-9 m perturbation: truncation O(ε²) and no ramp kink crossed
    # (measured 4e-12 serial, 2e-11 on 2 ranks; 1e-4 at 1e-8 m, where kinks are crossed)
    mismatch, Jd = vc.contact_jacobian_mismatch(contact, A, x, d, bc_dofs)
    assert mismatch < 1e-8, mismatch
    # the upper block's rows depend on the lower block's displacement (master columns)
    robot = sim.model.robot
    V = sim.u.function_space
    lower_blocks = fem.locate_dofs_topological(V, 2, robot.cell_tags.find(robot.groups["lower"][1]))
    lower = np.zeros(d.getLocalSize() // 2, dtype=bool)
    lower[lower_blocks[lower_blocks < lower.size]] = True
    lower = np.repeat(lower, 2)
    d.array[~lower] = 0.0
    A.mult(d, Jd)
    on_upper = comm.allreduce(float(np.linalg.norm(Jd.array[~lower])) ** 2)
    assert on_upper > 1e-2 * Jd.norm() ** 2
    # the gradient of one energy: symmetric to round-off
    AT = A.transpose(PETSc.Mat())
    AT.axpy(-1.0, A)
    assert AT.norm() < 1e-12 * A.norm()
    # action = reaction: the contact forces on the whole body sum to zero
    b = vc.contact_residual(contact, x)
    total = comm.allreduce(b.array.reshape(-1, 2).sum(axis=0))
    assert np.all(np.abs(total) < 1e-12 * b.norm()), total


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_pressed_blocks_rest_at_the_penalty_penetration(comm):
    G, dt = 100.0, 5e-4  # m/s², s
    case = _case(
        {},
        {"gravity": [0, 0, -G], "clamped": ["clamp"]},
        {"end": 2e-2, "step": dt, "rho_inf": 0.5, "scheme": "generalized_alpha"},
    )
    robot = _blocks(comm, 0.0)
    sim = build_simulation(case, comm, robot_mesh=robot)
    k_c = 10.0 * MU / H
    beta = sim.integrator.params.beta
    # k_c β Δt²/(ρH) = 1500: the former staggered coupling (master frozen per step) needed
    # this ≲ 1 and failed here at t = 5.5 ms (Newton NaN; at ρ∞ = 0 it rocked at 3x the weight)
    assert k_c * beta * dt**2 / (RHO * H) > 1e3
    h = sim.run(progress=False).history
    weight = RHO * G * H * L * WIDTH  # N
    # at rest the contact carries the weight (measured to 8e-6 over the last quarter)
    tail = h["self_contact_force"][3 * len(h["time"]) // 4 :]
    assert np.max(np.abs(tail / weight - 1)) < 1e-3
    expected = ref.penalty_penetration(RHO * G * H, k_c, 0.05 * H)  # 3.85e-7 m

    V = sim.u.function_space
    X = V.tabulate_dof_coordinates()[:, :2]
    x = X + sim.u.x.array.reshape(-1, 2)
    owned = V.dofmap.index_map.size_local

    def gathered(rows: np.ndarray) -> np.ndarray:
        rows = rows[rows < owned]
        data = np.vstack(comm.allgather(np.hstack([X[rows], x[rows]])))
        return data[np.argsort(data[:, 0])]

    def face(name: str) -> np.ndarray:
        dim, tag = robot.groups[name]
        return gathered(fem.locate_dofs_topological(V, dim, robot.facet_tags.find(tag)))

    top, bottom = face("lower_top"), face("upper_bottom")
    assert np.allclose(top[:, 0], bottom[:, 0])  # the meshes of the faces match node by node
    depth = top[:, 3] - bottom[:, 3]
    # the pressure is the weight per area on average; the elastic blocks carry it unevenly
    # towards their free ends (measured depth 0.94-1.02 δ, i.e. pressure 0.88-1.04 p on the
    # quadratic branch), so every node is within 8 % of δ and the face average within 3 %
    assert np.all(np.abs(depth / expected - 1) < 0.08), depth / expected
    assert abs(np.mean(depth) / expected - 1) < 0.03
    assert h["self_contact_penetration"][-1] == pytest.approx(expected, rel=0.08)
    # no node of the upper block lies below the lower block's top face by more than that
    upper_cells = robot.cell_tags.find(robot.groups["upper"][1])
    body = gathered(fem.locate_dofs_topological(V, 2, upper_cells))
    assert np.max(top[:, 3]) - np.min(body[:, 3]) < 1.08 * expected


def test_self_contact_needs_two_cell_groups(comm):
    case = _case(
        {"self_contact_groups": ["lower", "clamp"]},
        {"gravity": [0, 0, 0]},
        {"end": 1e-4, "step": 1e-4},
    )
    with pytest.raises(CaseError, match="not a cell group"):
        build_simulation(case, comm, robot_mesh=_blocks(comm, 0.0))
