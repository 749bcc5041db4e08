"""A group touching itself (``[contact] self_contact_within``, :mod:`magfem.mechanics.contacts.
self_contact.law`), on the shell, serial and mpirun -n 2.

One cell group ``sheet`` made of two L × L = 1 × 1 mm plates (H = 0.1 mm,
4 × 4 quadrilaterals each, μ = 115 kPa, ρ = 2130 kg/m³) LIFT = 1 mm apart at
rest, more than the group's own exclusion E = 2 × its largest cell
(0.35 mm) = 0.71 mm: the upper plate is brought down onto the lower one by
a rigid translation (no strain) before the run, so ONE group faces itself
across a fold that the mesh does not need to resolve. The tests of the two
groups' contact (test_mechanics_contacts_self_contact_shell.py) are repeated
for it:

* Linearisation: the coupled residual against central finite differences,
  symmetric, action = reaction.
* Pressed: the lower plate held, the upper one rests on it under a body
  force G: the contact carries its weight and the mid-surfaces are H − δ
  apart, δ = r⁻¹(p/k_c) under p = ρ G H (:func:`reference.penalty_penetration`);
  the same for two strip blocks of one group (the faces of the cells).
* Neighbourhood: a flat strip and the strip rolled onto arcs up to 286°
  (one group, its own exclusion the only thing that keeps its neighbours
  apart) pair no neighbour and feel no self-contact force; the shell
  cantilever bent to ~89° by a uniform field runs as without self-contact,
  to round-off.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from magfem.case import parse_case
from magfem.config import CaseError
from magfem.geometry.robot_mesh import RobotMesh
from magfem.mechanics.simulation import Simulation
from magfem.pipeline import build_simulation
from verification import references as ref
from verification import setups as vc

L, H, CELLS, MU, RHO = 1e-3, 1e-4, 4, 115e3, 2130.0
LIFT = 1e-3  # m, the upper plate's height at rest (> the group's own exclusion, 0.71 mm)
KAPPA, ONSET = 10.0, 0.05  # [contact] self_contact_penalty and _onset (defaults)
HELD = {"fixed_point": [L / 2, L / 2, 0.0], "fixed_radius": 0.75 * L}  # the lower plate only


def _sheet(comm: MPI.Comm) -> RobotMesh:
    """Two L × L plates in planes z = 0 and z = LIFT, one cell group ``sheet`` (gdim 3)."""

    def builder(gmsh: Any) -> None:
        occ = gmsh.model.occ
        plates = [occ.addRectangle(0.0, 0.0, z, L, L) for z in (0.0, LIFT)]
        occ.synchronize()
        for tag in plates:
            for _, line in gmsh.model.getBoundary([(2, tag)], oriented=False):
                gmsh.model.mesh.setTransfiniteCurve(abs(line), CELLS + 1)
            gmsh.model.mesh.setTransfiniteSurface(tag)
        gmsh.model.addPhysicalGroup(2, plates, name="sheet")
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(2)

    return vc.gmsh_robot(
        builder, comm, gdim=3, name="sheet", model="surface", thickness=H, area=2 * L * L
    )


def _sheet_simulation(
    comm: MPI.Comm, gravity: float, time: dict[str, Any], depth: float = 0.0
) -> Simulation:
    """The sheet with its upper plate lowered onto the lower one (mid-surfaces H − depth apart),
    as the initial state u_n and the iterate."""
    case = parse_case(
        {
            "name": "sheet",
            "robot": {"shape": "membrane", "thickness": H, "length": L, "width": L},
            "mesh": {"size": L / CELLS, "model": "surface"},
            "material": {"shear_modulus": MU, "density": RHO, "remanence": 0.0},
            "contact": {"self_contact": True, "self_contact_groups": ["sheet"]},
            "environment": {"gravity": [0, 0, gravity], "clamped": [], **HELD},
            "time": {"adaptive": False, **time},
            "output": {"csv": False, "vtx_every": 0, "plot": False},
        }
    )
    sim = build_simulation(case, comm, robot_mesh=_sheet(comm))
    u = sim.model.unknowns[0]
    X = u.function_space.tabulate_dof_coordinates()
    disp = np.zeros_like(X)
    disp[X[:, 2] > 0.5 * LIFT, 2] = -(LIFT - H + depth)
    u.x.array[:] = disp.ravel()
    sim.integrator.u0.x.array[:] = u.x.array
    return sim


def _bc_dofs(sim: Simulation) -> np.ndarray:
    return np.concatenate(
        [bc.dof_indices()[0][: bc.dof_indices()[1]] for bc in sim.model.displacement_bcs]
    )


def test_a_group_pairs_with_itself_only_beyond_its_own_exclusion(comm):
    """At rest nothing is paired (the plates are LIFT apart); lowered onto each other, every
    vertex of both plates is paired with the other plate of its own group."""
    sim = _sheet_simulation(comm, 0.0, {"end": 1e-4, "step": 1e-4}, depth=2 * ONSET * H)
    contact = sim.problem.contacts[0]
    p = contact.pairing
    assert p.own_exclusion[0] == pytest.approx(2 * np.hypot(L, L) / CELLS)
    assert contact.pairs == [(0, 0)]
    p.search(np.zeros_like(sim.model.unknowns[0].x.array))
    assert not p.engaged
    contact.before_solve()
    assert p.engaged
    owned = p.nodes[p.nodes < p.size_local]
    assert np.all(p.partner[owned] == 0)
    # each vertex's master lies on the other plate: z of the anchor differs by LIFT
    z = p.reference[owned, 2]
    assert np.allclose(np.abs(p._anchor[owned, 2] - z), LIFT)
    np.testing.assert_allclose(p.gap[owned], -2 * ONSET * H, rtol=1e-9)


def test_self_paired_linearisation_matches_finite_differences(comm):
    """The coupled residual of a group on itself: Jacobian against central differences,
    symmetric, action = reaction (as for two groups: the same code, one group)."""
    sim = _sheet_simulation(
        comm, 0.0, {"end": 1e-3, "step": 1e-4, "rho_inf": 0.5}, depth=2 * ONSET * H
    )
    u, theta = sim.model.unknowns
    X = u.function_space.tabulate_dof_coordinates()
    upper = X[:, 2] > 0.5 * LIFT
    rng = np.random.default_rng(7 + comm.rank)
    lowered = u.x.array.copy()
    disp = u.x.array.reshape(-1, 3)
    disp[upper, 0] += 0.3 * L / CELLS
    disp[upper, 2] -= 2e-3 * (X[upper, 0] - 0.5 * L)
    disp += 1e-7 * rng.standard_normal(disp.shape)
    theta.x.array[:] = 1e-2 * rng.standard_normal(theta.x.array.shape)
    for f in (u, theta):
        f.x.scatter_forward()
    sim.integrator.u0.x.array[:] = lowered + 0.5 * (u.x.array - lowered)
    for bc in sim.model.displacement_bcs:
        bc.set(u.x.array, alpha=0.0)
        bc.set(sim.integrator.u0.x.array, alpha=0.0)
    bc_dofs = _bc_dofs(sim)
    contact = sim.problem.contacts[0]
    contact.before_solve()
    assert contact.engaged
    problem = sim.solver.problem
    x = problem.x.copy()
    fem_petsc.assign(sim.model.unknowns, x)
    n_u = u.function_space.dofmap.index_map.size_local * 3

    A = problem.A
    d = vc.contact_direction(x, 7 + comm.rank, bc_dofs, n_u)
    # central differences at a 1e-9 m step, as for two groups (measured 6e-12 there)
    mismatch, _ = vc.contact_jacobian_mismatch(contact, A, x, d, bc_dofs)
    assert mismatch < 1e-8, mismatch
    AT = A.transpose(PETSc.Mat())
    AT.axpy(-1.0, A)
    assert AT.norm() < 1e-12 * A.norm()
    b = vc.contact_residual(contact, x)
    total = comm.allreduce(b.array[:n_u].reshape(-1, 3).sum(axis=0))
    assert np.all(np.abs(total) < 1e-12 * b.norm()), total
    assert b.norm() > 0.0


@pytest.mark.slow
def test_sheet_pressed_onto_itself_rests_at_the_penalty_penetration(comm):
    """The upper plate of the group rests on its lower plate (held) under a body force."""
    G, dt = 100.0, 5e-4  # m/s², s
    sim = _sheet_simulation(
        comm, -G, {"end": 2e-2, "step": dt, "rho_inf": 0.5, "scheme": "generalized_alpha"}
    )
    result = sim.run(progress=False)
    h = result.history
    weight = RHO * G * H * L * L  # N
    tail = h["self_contact_force_sheet__sheet"][3 * len(h["time"]) // 4 :]
    # at rest the contact carries the weight (two groups: measured to 2e-6)
    assert np.max(np.abs(tail / weight - 1)) < 1e-3, tail / weight
    assert np.array_equal(h["self_contact_force"], h["self_contact_force_sheet__sheet"])
    expected = ref.penalty_penetration(RHO * G * H, KAPPA * MU / H, ONSET * H)
    u = sim.model.unknowns[0]
    V = u.function_space
    X = V.tabulate_dof_coordinates()
    z = X[:, 2] + u.x.array.reshape(-1, 3)[:, 2]
    owned = np.arange(len(X)) < V.dofmap.index_map.size_local
    free = owned & (X[:, 2] > 0.5 * LIFT)
    depth = H - np.concatenate(comm.allgather(z[free]))
    # every node of the upper plate sinks by δ into the held flat one (2 % as for two groups:
    # a gap measured from the wrong face would be 2H off, a wrong penalty scale a factor)
    assert np.all(np.abs(depth / expected - 1) < 0.02), depth / expected
    assert h["self_contact_penetration"][-1] == pytest.approx(expected, rel=0.02)
    assert result.summary["first_touch_sheet__sheet"] == pytest.approx(dt)


def _bent_arm(comm: MPI.Comm, within: bool, b_max: float) -> dict[str, np.ndarray]:
    """The shell cantilever (0.25 mm wide, 0.5 mm cells) ramped quasi-statically to b_max, its
    arm in contact with itself (``within``) or without any self-contact."""
    case = vc.cantilever_case(
        "surface",
        0.5e-3,
        0.25e-3,
        "strain",
        name="elastica",
        size_across=0.25e-3,
        field={"sources": [vc.field_ramp(b_max)]},
        time={"scheme": "quasi_static", "end": 1.0, "step": 0.25},
        contact={"self_contact": True, "self_contact_groups": ["arm"]} if within else {},
    )
    return build_simulation(case, comm).run(progress=False).history


@pytest.mark.slow
def test_bent_shell_arm_runs_as_without_self_contact(comm):
    """The shell cantilever ramped quasi-statically to 0.4 mT (tip at ~89°, one group ``arm``):
    no self-contact force at any load, tip angles identical to round-off without
    self-contact (the pairing has nothing to do; a pair of neighbours would show)."""
    on = _bent_arm(comm, True, vc.B_MAX)
    off = _bent_arm(comm, False, vc.B_MAX)
    assert np.degrees(on["angle_arm"][-1]) > 80.0, np.degrees(on["angle_arm"])
    assert np.all(on["self_contact_force"] == 0.0)
    assert np.all(on["self_contact_force_arm__arm"] == 0.0)
    np.testing.assert_allclose(on["angle_arm"], off["angle_arm"], rtol=0, atol=1e-12)


STRIP, WIDE, CELL = 6e-3, 0.5e-3, 0.25e-3  # m: a strip of 24 × 2 square cells, one group


def _strip(comm: MPI.Comm) -> RobotMesh:
    """A STRIP × WIDE plate in the plane z = 0, one cell group ``sheet`` (gdim 3)."""

    def builder(gmsh: Any) -> None:
        tag = gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, STRIP, WIDE)
        gmsh.model.occ.synchronize()
        for _, line in gmsh.model.getBoundary([(2, tag)], oriented=False):
            span = gmsh.model.occ.getMass(1, abs(line))
            gmsh.model.mesh.setTransfiniteCurve(abs(line), round(span / CELL) + 1)
        gmsh.model.mesh.setTransfiniteSurface(tag)
        gmsh.model.addPhysicalGroup(2, [tag], name="sheet")
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(2)

    return vc.gmsh_robot(
        builder, comm, gdim=3, name="strip", model="surface", thickness=H, area=STRIP * WIDE
    )


def test_curled_sheet_pairs_none_of_its_neighbours(comm):
    """A strip of one group rolled onto arcs of radius R (the whole strip turned by STRIP/R,
    up to 286°), the shell's state set directly: no pair of negative gap and a zero contact
    residual. One cell apart on the R = 1.2 mm arc, neighbours are 0.25²/(2 × 1.2) = 0.026 mm
    from each other's tangent planes, well inside the thickness (0.1 mm): without an
    exclusion a vertex pairs with the cells around it at g ≈ −t (checked below); the
    group's own exclusion (0.71 mm) keeps them apart."""
    case = parse_case(
        {
            "name": "strip",
            "robot": {"shape": "membrane", "thickness": H, "length": STRIP, "width": WIDE},
            "mesh": {"size": CELL, "model": "surface"},
            "material": {"shear_modulus": MU, "density": RHO, "remanence": 0.0},
            "contact": {"self_contact": True, "self_contact_groups": ["sheet"]},
            "environment": {"gravity": [0, 0, 0], "clamped": [], "fixed_point": [0, 0, 0]},
            "time": {"end": 1e-4, "step": 1e-4, "adaptive": False},
            "output": {"csv": False, "vtx_every": 0, "plot": False},
        }
    )
    sim = build_simulation(case, comm, robot_mesh=_strip(comm))
    contact = sim.problem.contacts[0]
    p = contact.pairing
    u = sim.model.unknowns[0]
    X = u.function_space.tabulate_dof_coordinates()
    x = sim.solver.problem.x

    def curl(radius: float) -> tuple[float, float]:
        """(most negative vertex gap of a pair (m), contact residual norm) on the arc."""
        phi = X[:, 0] / radius
        disp = np.zeros_like(X)
        disp[:, 0] = radius * np.sin(phi) - X[:, 0]
        disp[:, 2] = radius * (1.0 - np.cos(phi))
        u.x.array[:] = disp.ravel()
        sim.integrator.u0.x.array[:] = u.x.array
        contact.before_solve()
        fem_petsc.assign(sim.model.unknowns, x)
        b = x.duplicate()
        b.set(0.0)
        contact.add_residual(x, b)
        owned = p.nodes[p.nodes < p.size_local]
        paired = p.partner[owned] >= 0
        low = float(np.min(p.gap[owned][paired], initial=np.inf))
        return comm.allreduce(low, op=MPI.MIN), b.norm()

    for radius in (np.inf, 6e-3, 3e-3, 1.2e-3):
        low, norm = curl(radius) if np.isfinite(radius) else curl(1e30)
        assert low >= 0.0 and norm == 0.0, (radius, low, norm)
    # the test can fail: without the exclusion the neighbours pair through the thickness
    p.own_exclusion[:] = 0.0
    low, norm = curl(1.2e-3)
    assert low < -0.5 * H and norm > 0.0, (low, norm)


def test_one_group_needs_within(comm):
    """Without self_contact_within one group has nothing to touch: the case names the key."""
    case = parse_case(
        {
            "name": "sheet",
            "robot": {"shape": "membrane", "thickness": H, "length": L, "width": L},
            "mesh": {"size": L / CELLS, "model": "surface"},
            "material": {"shear_modulus": MU, "density": RHO, "remanence": 0.0},
            "contact": {
                "self_contact": True,
                "self_contact_groups": ["sheet"],
                "self_contact_within": False,
            },
            "environment": {"gravity": [0, 0, 0], "clamped": [], **HELD},
            "time": {"end": 1e-4, "step": 1e-4},
            "output": {"csv": False, "vtx_every": 0, "plot": False},
        }
    )
    with pytest.raises(CaseError, match=r"self_contact_groups.*within"):
        build_simulation(case, comm, robot_mesh=_sheet(comm))


BLOCK, BLOCK_H, BLOCK_SIZE, BLOCK_LIFT = 1e-3, 2e-4, 1e-4, 5e-4  # m (strip: side views)


def _blocks(comm: MPI.Comm) -> RobotMesh:
    """Two BLOCK × BLOCK_H blocks of one cell group ``sheet``, BLOCK_LIFT between them at rest
    (more than the group's exclusion, max(2 H, 2 × 0.14 mm) = 0.4 mm), the lower one's base
    line ``clamp`` (strip, gdim 2)."""

    def builder(gmsh: Any) -> None:
        occ = gmsh.model.occ
        lower = occ.addRectangle(0.0, 0.0, 0.0, BLOCK, BLOCK_H)
        upper = occ.addRectangle(0.0, BLOCK_H + BLOCK_LIFT, 0.0, BLOCK, BLOCK_H)
        occ.synchronize()
        base = [
            abs(t)
            for _, t in gmsh.model.getBoundary([(2, lower)], oriented=False)
            if gmsh.model.getBoundingBox(1, abs(t))[4] < 1e-6  # OCC pads boxes by ~1e-7
        ]
        gmsh.model.addPhysicalGroup(2, [lower, upper], name="sheet")
        gmsh.model.addPhysicalGroup(1, base, name="clamp")
        gmsh.option.setNumber("Mesh.MeshSizeMax", BLOCK_SIZE)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(2)

    return vc.gmsh_robot(
        builder,
        comm,
        gdim=2,
        name="blocks",
        model="strip",
        thickness=BLOCK_H,
        area=2 * BLOCK * BLOCK_H,
    )


@pytest.mark.slow
def test_strip_block_pressed_onto_its_own_group_rests_at_the_penalty_penetration(comm):
    """The strip (faces of the cells, one-sided normals): the upper block of the group,
    lowered onto the lower one (clamped at its base), rests on it under a body force."""
    G, dt = 100.0, 5e-4  # m/s², s
    case = parse_case(
        {
            "name": "blocks",
            "robot": {"shape": "membrane", "thickness": BLOCK_H, "length": BLOCK, "width": 1e-3},
            "mesh": {"size": BLOCK_SIZE, "model": "strip"},
            "material": {"shear_modulus": MU, "density": RHO, "remanence": 0.0},
            "contact": {"self_contact": True, "self_contact_groups": ["sheet"]},
            "environment": {"gravity": [0, 0, -G], "clamped": ["clamp"]},
            "time": {"adaptive": False, "end": 2e-2, "step": dt, "rho_inf": 0.5},
            "output": {"csv": False, "vtx_every": 0, "plot": False},
        }
    )
    sim = build_simulation(case, comm, robot_mesh=_blocks(comm))
    X = sim.u.function_space.tabulate_dof_coordinates()
    disp = np.zeros((len(X), 2))
    disp[X[:, 1] > BLOCK_H + 0.5 * BLOCK_LIFT, 1] = -BLOCK_LIFT
    sim.u.x.array[:] = disp.ravel()
    sim.integrator.u0.x.array[:] = sim.u.x.array
    h = sim.run(progress=False).history
    weight = RHO * G * BLOCK_H * BLOCK * 1e-3  # N
    tail = h["self_contact_force_sheet__sheet"][3 * len(h["time"]) // 4 :]
    # at rest the contact carries the weight (two groups: measured to 8e-6)
    assert np.max(np.abs(tail / weight - 1)) < 1e-3, tail / weight
    # the elastic blocks carry the pressure unevenly (two groups: every node within 8 % of δ,
    # the largest 1.02 δ); a gap from the wrong face would be 2H off, a wrong scale a factor
    expected = ref.penalty_penetration(RHO * G * BLOCK_H, KAPPA * MU / BLOCK_H, ONSET * BLOCK_H)
    assert h["self_contact_penetration"][-1] == pytest.approx(expected, rel=0.08)
