"""Self-contact on the shell (:mod:`magfem.mechanics.contacts.self_contact.shell`), serial and
mpirun -n 2.

Two square plates, L × L = 1 × 1 mm mid-surfaces of thickness H = 0.1 mm, one
above the other (one surface mesh, cell groups ``lower`` and ``upper``, matching
structured quadrilateral meshes), μ = 115 kPa, ρ = 2130 kg/m³: the plates
touch when their mid-surfaces are H apart (gap = mid-surface distance − H),
through the solids' two-pass penalty (k_c = κ_s μ / H):

* Linearisation: the coupled residual in the shell's block system (u, then
  the director angles) against central finite differences, its symmetry and
  action = reaction; the angle rows and columns stay empty (the gap uses the
  displacement only).
* Pressed: the lower plate is clamped, the upper one rests on it under a body
  force G. At rest the contact force equals the upper plate's weight and the
  mid-surfaces are H − δ apart, δ = r⁻¹(p/k_c) under p = ρ G H
  (:func:`reference.penalty_penetration`).
* Bouncing: two free plates fly at each other (ρ∞ = 1, no gravity): they touch
  at the free-flight time, energy is conserved through the impact to second
  order in Δt, and they separate (identical plates: an elastic impact).
* Inelastic (``self_contact_inelastic``): plates flying at v and −v/3 go on
  together at v/3 (momentum), and the kinetic energy the impact loses,
  ½ (m/2)(4v/3)², is what the absorber reports; stopped after the impact and
  resumed, the run goes on as if never stopped.
* A node pushed deeper than the band through the other plate, its vertices clear,
  is left without a master (no force).
* A plate standing on its free edge on the other is pushed out edge-on.
* Paired plates closing fast bound the next step to their gap plus half the band over
  their relative speed.
"""

from __future__ import annotations

import importlib
import itertools
import signal
from typing import Any

import numpy as np
import pytest
import ufl
from dolfinx import fem, la
from dolfinx.fem import petsc as fem_petsc
from dolfinx.mesh import CellType, create_unit_square
from mpi4py import MPI
from petsc4py import PETSc
from scipy.spatial import cKDTree

from magfem.case import parse_case
from magfem.config import CaseError
from magfem.errors import RunInterrupted
from magfem.geometry.robot_mesh import RobotMesh
from magfem.mechanics.checkpoint import Checkpointer, RunControl, read_checkpoint
from magfem.mechanics.contacts.self_contact import geometry
from magfem.mechanics.contacts.self_contact.geometry import (
    ball_pairs,
    inside,
    nearest_facing,
    reach,
)
from magfem.mechanics.contacts.self_contact.law import FACING, INSIDE
from magfem.mechanics.contacts.self_contact.shell import nodal_rule
from magfem.mechanics.simulation import Simulation
from magfem.pipeline import build_simulation
from verification import references as ref
from verification import setups as vc

L, H, CELLS, MU, RHO = 1e-3, 1e-4, 4, 115e3, 2130.0
KAPPA, ONSET = 10.0, 0.05  # [contact] self_contact_penalty and _onset (defaults)


def _plates(comm: MPI.Comm, gap: float) -> RobotMesh:
    """Two L × L plates in planes z = 0 and z = H + ``gap`` (surface mesh, gdim 3)."""

    def builder(gmsh: Any) -> None:
        occ = gmsh.model.occ
        lower = occ.addRectangle(0.0, 0.0, 0.0, L, L)
        upper = occ.addRectangle(0.0, 0.0, H + gap, L, L)
        occ.synchronize()
        for tag in (lower, upper):
            for _, line in gmsh.model.getBoundary([(2, tag)], oriented=False):
                gmsh.model.mesh.setTransfiniteCurve(abs(line), CELLS + 1)
            gmsh.model.mesh.setTransfiniteSurface(tag)
        for name, tag in (("lower", lower), ("upper", upper)):
            gmsh.model.addPhysicalGroup(2, [tag], name=name)
        edges = gmsh.model.getBoundary([(2, lower)], oriented=False)
        gmsh.model.addPhysicalGroup(1, [abs(t) for _, t in edges], name="rim")
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(2)

    return vc.gmsh_robot(
        builder, comm, gdim=3, name="plates", model="surface", thickness=H, area=2 * L * L
    )


def _case(contact: dict[str, Any], environment: dict[str, Any], time: dict[str, Any]) -> Any:
    return parse_case(
        {
            "name": "plates",
            "robot": {"shape": "membrane", "thickness": H, "length": L, "width": L},
            "mesh": {"size": L / CELLS, "model": "surface"},
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


def _pressed_in(comm: MPI.Comm) -> tuple[Simulation, np.ndarray]:
    """The plates H apart (touching), lower clamped, the upper one's displacement set.

    Upper plate: 2 onsets into the lower one (linear branch of the ramp),
    0.3 element sideways, tilted by 2e-3 over its length and a 1e-7 m random
    wobble on every displacement dof (random angles too), so that gaps and
    pressures differ at every point. The integrator's u_n is half of it.
    """
    case = _case(
        {},
        {"gravity": [0, 0, 0], "clamped": ["lower"]},
        {"end": 1e-3, "step": 1e-4, "rho_inf": 0.5, "scheme": "generalized_alpha"},
    )
    sim = build_simulation(case, comm, robot_mesh=_plates(comm, 0.0))
    u, theta = sim.model.unknowns
    X = u.function_space.tabulate_dof_coordinates()
    upper = X[:, 2] > 0.5 * H
    disp = np.zeros_like(X)
    disp[upper, 0] = 0.3 * L / CELLS
    disp[upper, 2] = -2 * ONSET * H - 2e-3 * (X[upper, 0] - 0.5 * L)
    rng = np.random.default_rng(7 + comm.rank)
    disp += 1e-7 * rng.standard_normal(disp.shape)
    u.x.array[:] = disp.ravel()
    theta.x.array[:] = 1e-2 * rng.standard_normal(theta.x.array.shape)
    for f in (u, theta):
        f.x.scatter_forward()
    sim.integrator.u0.x.array[:] = 0.5 * u.x.array
    for bc in sim.model.displacement_bcs:
        bc.set(u.x.array, alpha=0.0)
        bc.set(sim.integrator.u0.x.array, alpha=0.0)
    bc_dofs = np.concatenate(
        [bc.dof_indices()[0][: bc.dof_indices()[1]] for bc in sim.model.displacement_bcs]
    )
    return sim, bc_dofs


def _flying(
    comm: MPI.Comm,
    gap: float,
    v: float,
    dt: float,
    end: float,
    *,
    upper: float | None = None,
    contact: dict[str, Any] | None = None,
) -> Simulation:
    """The plates ``gap`` apart, free, flying at each other: the lower one up at v, the upper
    one down at v (or at ``upper``, m/s along z), no gravity, ρ∞ = 1."""
    case = _case(
        contact or {},
        {"gravity": [0, 0, 0], "clamped": []},
        {"end": end, "step": dt, "rho_inf": 1.0, "scheme": "generalized_alpha"},
    )
    sim = build_simulation(case, comm, robot_mesh=_plates(comm, gap))
    middle = H + gap / 2  # between the plates' mid-surfaces
    w = -v if upper is None else upper
    sim.integrator.v0.interpolate(
        lambda X: np.vstack([0.0 * X[0], 0.0 * X[0], np.where(X[2] < middle, v, w)])
    )
    return sim


@pytest.mark.parametrize("cell", [CellType.quadrilateral, CellType.triangle])
@pytest.mark.parametrize("degree", [1, 2, 3])
def test_nodal_rule_is_positive_and_integrates_linear_fields(comm, cell, degree):
    """The shell's contact rule at the element's nodes: positive weights summing to the
    reference cell's area, exact for linear fields (any rule with ∫φ_i weights, and the
    symmetric mass-diagonal weights of P2 triangles, whose ∫φ_i vanish at the vertices); on
    quadrilaterals ∫φ_i of the GLL nodes is the Gauss–Lobatto rule: Simpson's 1/6, 4/6, 1/6
    per direction at P2, exact for x³y² at P3 (1/12)."""
    mesh = create_unit_square(MPI.COMM_SELF, 1, 1, cell)
    points, weights = nodal_rule(fem.functionspace(mesh, ("Lagrange", degree, (3,))))
    area = 1.0 if cell == CellType.quadrilateral else 0.5
    assert np.all(weights > 0) and weights.sum() == pytest.approx(area, rel=1e-12)
    exact = area * (1.0 / 2 + 2.0 / 2) if cell == CellType.quadrilateral else 1.0 / 6 + 2.0 / 6
    assert weights @ (points[:, 0] + 2 * points[:, 1]) == pytest.approx(exact, rel=1e-12)
    if cell == CellType.quadrilateral and degree == 2:
        simpson = np.outer([1, 4, 1], [1, 4, 1]).ravel() / 36
        assert sorted(weights) == pytest.approx(sorted(simpson), rel=1e-12)
    if cell == CellType.quadrilateral and degree == 3:
        assert weights @ (points[:, 0] ** 3 * points[:, 1] ** 2) == pytest.approx(1 / 12)


def test_shell_coupled_linearisation_matches_finite_differences(comm):
    sim, bc_dofs = _pressed_in(comm)
    contact = sim.problem.contacts[0]
    contact.before_solve()  # pairing and normals frozen from here on, as within a step
    assert contact.engaged
    problem = sim.solver.problem
    x = problem.x.copy()
    fem_petsc.assign(sim.model.unknowns, x)
    n_u = sim.model.unknowns[0].function_space.dofmap.index_map.size_local * 3
    u_rows = np.zeros(x.getLocalSize(), dtype=bool)  # the displacement block's owned rows
    u_rows[:n_u] = True

    A = problem.A
    d = vc.contact_direction(x, 11 + comm.rank, bc_dofs, n_u)
    # central differences at a 1e-9 m step: truncation O(ε²), no ramp kink crossed (measured
    # 6e-12 serially, 7e-12 on 2 ranks); a wrong row mapping or a missing block gives O(1)
    mismatch, Jd = vc.contact_jacobian_mismatch(contact, A, x, d, bc_dofs)
    assert mismatch < 1e-8, mismatch
    # the angles enter neither the residual nor the Jacobian (the gap uses u only)
    b = vc.contact_residual(contact, x)
    assert comm.allreduce(float(np.abs(b.array[~u_rows]).max(initial=0.0)), op=MPI.MAX) == 0.0
    d.array[:n_u] = 0.0
    A.mult(d, Jd)
    assert Jd.norm() == 0.0
    # the gradient of one energy: symmetric to round-off
    AT = A.transpose(PETSc.Mat())
    AT.axpy(-1.0, A)
    assert AT.norm() < 1e-12 * A.norm()
    # action = reaction: the contact forces on the whole body sum to zero
    total = comm.allreduce(b.array[:n_u].reshape(-1, 3).sum(axis=0))
    assert np.all(np.abs(total) < 1e-12 * b.norm()), total
    assert b.norm() > 0.0


def _lower_clamped(comm: MPI.Comm) -> tuple[Simulation, fem.Function]:
    """The plates touching (mid-surfaces H apart), the lower one clamped, and the
    displacement, for tests that set a displacement and evaluate the contact at it."""
    case = _case(
        {},
        {"gravity": [0, 0, 0], "clamped": ["lower"]},
        {"end": 1e-3, "step": 1e-4, "rho_inf": 0.5, "scheme": "generalized_alpha"},
    )
    sim = build_simulation(case, comm, robot_mesh=_plates(comm, 0.0))
    return sim, sim.model.unknowns[0]


def _contact_at(sim: Simulation, displacement: np.ndarray) -> tuple[Any, np.ndarray]:
    """The contact paired at ``displacement`` ((nodes, 3) m, u and u_n alike) and its
    residual per owned displacement node ((owned, 3) N: minus the contact forces)."""
    u = sim.model.unknowns[0]
    u.x.array[:] = displacement.ravel()
    sim.integrator.u0.x.array[:] = u.x.array  # the stage displacement is u
    contact = sim.problem.contacts[0]
    contact.before_solve()
    x = sim.solver.problem.x.copy()
    fem_petsc.assign(sim.model.unknowns, x)
    b = vc.contact_residual(contact, x)
    owned = u.function_space.dofmap.index_map.size_local
    return contact, b.array[: 3 * owned].reshape(-1, 3)


def _nodal_area(V: fem.FunctionSpace, select: Any) -> float:
    """Σ ∫φ_i dA over the nodes at which ``select`` ((n, 3) positions -> mask) holds, by the
    default (Gauss) rule: an area independent of the contact's nodal rule (collective)."""
    scalar = fem.functionspace(V.mesh, ("Lagrange", V.ufl_element().embedded_superdegree))
    area = fem.assemble_vector(fem.form(ufl.TestFunction(scalar) * ufl.dx))
    area.scatter_reverse(la.InsertMode.add)
    owned = scalar.dofmap.index_map.size_local
    xs = scalar.tabulate_dof_coordinates()[:owned]
    return V.mesh.comm.allreduce(float(area.array[:owned][select(xs)].sum()), op=MPI.SUM)


def _interior_node(comm: MPI.Comm, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cell-interior node of the upper plate nearest (1.3a, 1.3a) at rest, the same on
    every rank, and its local indices in the dof coordinates ``X`` (none, or one)."""
    a = L / CELLS
    off_edges = np.all(np.abs(X[:, :2] / a - np.rint(X[:, :2] / a)) > 1e-6, axis=1)
    pool = np.concatenate(comm.allgather(X[off_edges & (X[:, 2] > 0.5 * H)]))
    target = pool[np.argmin(np.linalg.norm(pool[:, :2] - 1.3 * a, axis=1))]
    return target, np.flatnonzero(np.linalg.norm(X - target, axis=1) < 1e-9 * a)


def test_one_pressed_node_carries_its_own_gap_on_its_own_area(comm):
    """Node-to-surface with the nodal rule: one node of the upper plate pushed 2 onsets
    into the lower one, every other node half a thickness clear of it. The contact
    force is k_c r(δ) ∫φ_i dA on that node, and the reaction on the node facing it,
    and nothing on any other node: a gap is measured at the nodes only. (Interpolated
    between paired nodes and nodes without a master, the gap had spurious negative
    values between them: the 0.5 mm P3 bow tie took a 0.4 N kick at 2 mm from any contact.)
    """
    sim, u = _lower_clamped(comm)
    V = u.function_space
    X = V.tabulate_dof_coordinates()
    a = L / CELLS
    target, node = _interior_node(comm, X)
    facing = np.flatnonzero(np.linalg.norm(X - target * [1, 1, 0], axis=1) < 1e-9 * a)
    delta = 2 * ONSET * H  # on the ramp's linear branch: r = δ − δ0/2
    disp = np.zeros_like(X)
    disp[X[:, 2] > 0.5 * H, 2] = 0.5 * H
    disp[node, 2] = -delta
    _, force = _contact_at(sim, disp)
    owned = V.dofmap.index_map.size_local
    weight = _nodal_area(V, lambda xs: np.linalg.norm(xs - target, axis=1) < 1e-9 * a)
    expected = KAPPA * MU / H * (delta - ONSET * H / 2) * weight  # N
    at = {i for i in node if i < owned} | {i for i in facing if i < owned}
    pushed = comm.allgather([force[i] for i in sorted(at)])
    pushed = [f for part in pushed for f in part]
    assert len(pushed) == 2
    # the upper node pushed up and the lower one down, each by the whole two-pass force
    # (measured to round-off); every other node carries nothing
    assert sorted(f[2] for f in pushed) == pytest.approx([-expected, expected], rel=1e-9)
    rest = np.delete(force, sorted(at), axis=0)
    assert comm.allreduce(float(np.abs(rest).max(initial=0.0)), op=MPI.MAX) < 1e-12 * expected


def test_a_plate_standing_on_its_edge_is_pushed_out_edge_on(comm):
    """A shell touches with its free edge too (a tip striking another arm edge-on): the
    upper plate turned upright, its bottom edge 2 onsets into the lower plate's face. Its
    normal is parallel to the lower plate, so no face faces the other; the edge's nodes
    are paired all the same (a free edge is half a cylinder of radius H/2, a thickness
    from the mid-surface it strikes, like a face). The lower plate pushes the upright one
    up by ½ k_c r(δ) Σ ∫φ_i dA over the bottom edge's nodes and takes the reaction (rel
    1e-9): one pass of the two-pass law (the lower plate's nodes face no face of the
    upright one). Without the edge rule nothing pairs and the edge goes through."""
    sim, u = _lower_clamped(comm)
    V = u.function_space
    X = V.tabulate_dof_coordinates()
    a = L / CELLS
    upper = X[:, 2] > 0.5 * H
    delta = 2 * ONSET * H  # on the ramp's linear branch: r = δ − δ0/2
    # (x, y, H) -> (x, L/2, H − δ + y): upright over the lower plate's mid-line y = L/2
    disp = np.zeros_like(X)
    disp[upper, 1] = 0.5 * L - X[upper, 1]
    disp[upper, 2] = X[upper, 1] - delta
    _, force = _contact_at(sim, disp)
    owned = len(force)
    lift, load = (  # the residual holds minus the contact forces
        -comm.allreduce(float(force[side[:owned], 2].sum()), op=MPI.SUM) for side in (upper, ~upper)
    )
    weight = _nodal_area(V, lambda xs: (xs[:, 2] > 0.5 * H) & (xs[:, 1] < 1e-9 * a))
    expected = 0.5 * KAPPA * MU / H * (delta - ONSET * H / 2) * weight  # N
    assert lift == pytest.approx(expected, rel=1e-9)
    assert load == pytest.approx(-expected, rel=1e-9)


def test_a_node_deeper_than_the_band_is_not_pulled(comm):
    """The band bounds the gap at the vertices, where the pairs are searched; a
    higher-order node between them takes a master node around the vertex's anchor, and may
    lie far deeper than any face (a tightly folded master: the bow tie at 20 Hz saw 1 N
    with no vertex inside). One cell-interior node of the upper plate pushed 2.5
    thicknesses (0.7 of a cell, corner to corner) through the lower one, every vertex half
    a thickness clear: the node is deeper than the band (one thickness on the shell), so
    it is unpaired, as a vertex would be, and no node carries a force (with a cell as the
    limit it stayed paired and the residual carried 0.079 N)."""
    sim, u = _lower_clamped(comm)
    X = u.function_space.tabulate_dof_coordinates()
    _, node = _interior_node(comm, X)
    disp = np.zeros_like(X)
    disp[X[:, 2] > 0.5 * H, 2] = 0.5 * H
    disp[node, 2] = -2.5 * H
    contact, force = _contact_at(sim, disp)
    pairing = contact.pairing
    assert np.all(pairing.vpartner[node] < 0)
    assert comm.allreduce(int(np.count_nonzero(pairing.vpartner >= 0)), op=MPI.SUM) > 0
    assert comm.allreduce(float(np.abs(force).max(initial=0.0)), op=MPI.MAX) == 0.0


@pytest.mark.parametrize(("cells", "pairs"), [(0.8, True), (1.2, False)])
def test_plates_pair_only_within_one_cell(comm, cells, pairs):
    """Faces farther apart than one cell (corner to corner) are no pair: the search runs
    every step, and a far pair measures its gap to a plane that may be far from where the
    surfaces will meet."""
    diagonal = np.hypot(L, L) / CELLS
    case = _case(
        {},
        {"gravity": [0, 0, 0], "clamped": ["lower"]},
        {"end": 1e-4, "step": 1e-4},
    )
    sim = build_simulation(case, comm, robot_mesh=_plates(comm, cells * diagonal))
    contact = sim.problem.contacts[0]
    contact.before_solve()
    paired = comm.allreduce(int(np.count_nonzero(contact.pairing.partner >= 0)), op=MPI.SUM)
    assert (paired > 0) == pairs
    assert contact.pairing.engaged == pairs


@pytest.mark.slow
@pytest.mark.parametrize(("held", "gravity"), [("lower", -100.0), ("upper", 100.0)])
def test_pressed_shell_plates_rest_at_the_penalty_penetration(comm, held, gravity):
    """The free plate pressed onto the held one from above, or from below (the master's
    normal then points away from its mid-surface's orientation: two-sided faces)."""
    G, dt = abs(gravity), 5e-4  # m/s², s
    case = _case(
        {},
        {"gravity": [0, 0, gravity], "clamped": [held]},
        {"end": 2e-2, "step": dt, "rho_inf": 0.5, "scheme": "generalized_alpha"},
    )
    sim = build_simulation(case, comm, robot_mesh=_plates(comm, 0.0))
    h = sim.run(progress=False).history
    weight = RHO * G * H * L * L  # N
    tail = h["self_contact_force"][3 * len(h["time"]) // 4 :]
    # at rest the contact carries the weight (measured to 2e-6 over the last quarter)
    assert np.max(np.abs(tail / weight - 1)) < 1e-3, tail / weight
    expected = ref.penalty_penetration(RHO * G * H, KAPPA * MU / H, ONSET * H)
    u = sim.model.unknowns[0]
    V = u.function_space
    X = V.tabulate_dof_coordinates()
    z = X[:, 2] + u.x.array.reshape(-1, 3)[:, 2]
    owned = np.arange(len(X)) < V.dofmap.index_map.size_local
    free = owned & ((X[:, 2] > 0.5 * H) == (held == "lower"))
    plane = 0.0 if held == "lower" else H  # the held plate's mid-surface
    depth = H - np.abs(np.concatenate(comm.allgather(z[free])) - plane)
    # a uniform pressure on a plate resting on a held flat one: every node sinks by δ
    # (measured 1 + 1.3e-7, the Newton tolerance); 2 % would still catch a gap measured
    # from the faces' wrong side (2H off) or a wrong penalty scale (a factor)
    assert np.all(np.abs(depth / expected - 1) < 0.02), depth / expected
    assert h["self_contact_penetration"][-1] == pytest.approx(expected, rel=0.02)


@pytest.mark.slow
def test_bouncing_shell_plates_conserve_energy_and_touch_on_time(comm):
    """Two free plates fly at each other at ±v across a gap d (no gravity, ρ∞ = 1): they
    touch at the free-flight time d/(2v), kinetic + elastic + penalty energy is conserved
    through the impact (second order in Δt), they separate, and the faces interpenetrate
    by no more than the penalty ramp's static penetration under the impact's pressure."""
    gap, v, dt = 2e-5, 0.1, 1e-6
    sim = _flying(comm, gap, v, dt, 2.5e-4)
    result = sim.run(progress=False)
    h = result.history
    e0 = 2 * 0.5 * RHO * L * L * H * v**2  # J, both plates
    assert h["energy_total"][0] == pytest.approx(e0, rel=1e-9)
    # the gap closes at t = d/(2v) on a step boundary: the first overlapping step is the next
    assert result.summary["first_touch_lower__upper"] == pytest.approx(gap / (2 * v) + dt)
    # measured (1 and 2 ranks, 25 steps in contact) max |ΔE|/E 2.4e-3 during contact and
    # 3.9e-5 after separation, falling 4x and 4.5x at Δt/2 (6.0e-4, 8.7e-6): second order
    drift = np.abs(h["energy_total"] / e0 - 1)
    assert np.max(drift) < 5e-3, np.max(drift)
    assert drift[-1] < 2e-4, drift[-1]
    assert h["self_contact_force"][-1] == 0.0  # separated again
    # the impact's peak pressure (3.6 kPa) penetrates the faces by r⁻¹(p/k_c): the flat plates
    # meet over the whole face at once (measured 1.0000 of it; a missed pass or a wrong
    # penalty scale would be a factor off)
    peak = np.max(h["self_contact_force"]) / (L * L)
    static = ref.penalty_penetration(peak, KAPPA * MU / H, ONSET * H)
    assert np.max(h["self_contact_penetration"]) < 1.05 * static


@pytest.mark.slow
def test_inelastic_plates_conserve_momentum_and_lose_the_impact_energy(comm):
    """With ``self_contact_inelastic`` two free plates of mass m flying at each other at v
    and −v/3 collide perfectly inelastically: they go on together at the momentum's
    velocity v/3, the impact loses ½ (m/2) (4v/3)² of kinetic energy (reported as
    ``self_contact_absorbed``), and kinetic + elastic + penalty + absorbed energy stays the
    initial energy (ρ∞ = 1). The faces meet within a step (at 0.75 of it), so the absorber
    acts on a penetration, not on a touch that lands on a step's end."""
    gap, v, dt = 2.05e-5, 0.1, 1e-6
    sim = _flying(comm, gap, v, dt, 3e-4, upper=-v / 3, contact={"self_contact_inelastic": True})
    result = sim.run(progress=False)
    h = result.history
    m = RHO * L * L * H  # kg, one plate
    e0 = 0.5 * m * v**2 * (1 + 1 / 9)
    lost = 0.5 * (m / 2) * (4 * v / 3) ** 2
    assert h["energy_total"][0] == pytest.approx(e0, rel=1e-9)
    # the plates move rigidly (matched faces meet at once): their nodes' mean velocities
    V = sim.model.unknowns[0].function_space
    X = V.tabulate_dof_coordinates()
    vz = sim.integrator.v0.x.array.reshape(-1, 3)[:, 2]
    owned = np.arange(len(X)) < V.dofmap.index_map.size_local
    middle = H + gap / 2
    speeds = [
        np.mean(np.concatenate(comm.allgather(vz[owned & side])))
        for side in (X[:, 2] < middle, X[:, 2] > middle)
    ]
    # elastic (the penalty alone, as in the bouncing test) they would part at 4v/3; here
    # only the penalty energy stored at the impact comes back, as a parting speed below the
    # absorber's rest velocity (1 mm/s = 0.01 v; measured 0.0052 v)
    assert speeds == pytest.approx([v / 3, v / 3], abs=0.01 * v), speeds
    # the penalty did no work before the impact was absorbed: measured 1 + 2e-14
    assert result.summary["self_contact_absorbed"] == pytest.approx(lost, rel=1e-6)
    assert result.summary["self_contact_impacts"] > 0
    # the stage-point penalty stores the energy of the end-of-step penetration without the
    # kinetic energy paying for it (measured: the excess is 1.01 of it, 1.2e-5 e0); a
    # missed or doubled reset would be off by ~lost = 0.8 e0
    excess = np.max(np.abs(h["energy_total"] + h["self_contact_absorbed"] - e0))
    assert excess < 1.5 * np.max(h["energy_self_contact"]) + 1e-9 * e0


@pytest.mark.slow
def test_inelastic_plates_resume_as_if_never_stopped(comm, shared_tmp):
    """Stopped two steps after the impact (the absorber remembers which nodes are inside, so
    a rebound of a resting pair is told from a new impact) and resumed from the checkpoint:
    the history equals the uninterrupted run's to 1e-12 of each column's largest value. Not
    bit for bit: the Jacobian keeps the nonzeros of every pair it has seen (55080 in the
    uninterrupted run at the step after the stop, 55044 in the resumed one), so the
    factorisation's round-off differs, and the components that are zero up to round-off
    (in-plane velocities ~1e-34 m/s, the rigid plates' elastic energy ~1e-37 J) with it; a
    memory left out of the checkpoint resets the parting pairs again, a change of 1e-3 of
    the velocities."""
    gap, v, dt, end = 2.05e-5, 0.1, 1e-6, 2e-4
    inelastic = {"self_contact_inelastic": True}

    def flying() -> Simulation:
        return _flying(comm, gap, v, dt, end, upper=-v / 3, contact=inelastic)

    full = flying().run(progress=False)
    impact = int(np.argmax(full.history["self_contact_force"] > 0))  # the step of the impact
    calls = itertools.count(1)
    stop = RunControl(
        stop=lambda _: int(signal.SIGINT) if next(calls) == impact + 2 else 0,
        checkpoints=Checkpointer(shared_tmp / "checkpoint", comm),
    )
    with pytest.raises(RunInterrupted):
        flying().run(progress=False, control=stop)
    _, state = read_checkpoint(shared_tmp / "checkpoint", comm)
    resumed = flying().run(progress=False, control=RunControl(resume=state))
    assert resumed.history.keys() == full.history.keys()
    # every physical column of this run is above 1e-10 in its SI unit (penetration 3e-8 m,
    # energies 1e-9 J, forces 1e-6 N): 1e-25 is far below them and far above the noise
    for key, values in full.history.items():
        scale = 1e-12 * np.nanmax(np.abs(values), initial=0.0) + 1e-25
        np.testing.assert_allclose(resumed.history[key], values, rtol=0, atol=scale, err_msg=key)
    assert resumed.summary["self_contact_absorbed"] == full.summary["self_contact_absorbed"]


@pytest.mark.slow
def test_plates_thrown_from_afar_with_long_steps_do_not_pass_through(comm):
    """Two free plates three cells apart fly at each other at ±v with a step that would
    carry them through each other in one step (no pair at its start: the search pairs only
    within a cell). Self-contact bounds the step: the first is (s − a/2)/(2v), s the gap
    between the faces and a the cell (corner to corner), so that no surfaces meet unpaired;
    the plates then touch with the penalty acting and never cross."""
    a = np.hypot(L, L) / CELLS
    gap, v, dt = 3 * a, 0.1, 8e-3  # m, m/s, s: 2 v dt = 1.5 gap
    sim = _flying(comm, gap, v, dt, 2e-2)
    middle = H + gap / 2
    h = sim.run(progress=False).history
    assert h["dt"][1] == pytest.approx((gap - a / 2) / (2 * v), rel=1e-9)
    assert np.max(h["self_contact_force"]) > 0.0  # they met, paired
    # never deeper than the band (half a thickness; the impact's own penetration is
    # a few um), and the upper plate is still above the lower one at the end
    assert np.max(h["self_contact_penetration"]) < 0.5 * H
    u = sim.model.unknowns[0]
    X = u.function_space.tabulate_dof_coordinates()
    z = X[:, 2] + u.x.array.reshape(-1, 3)[:, 2]
    owned = np.arange(len(X)) < u.function_space.dofmap.index_map.size_local
    lower = np.concatenate(comm.allgather(z[owned & (X[:, 2] < middle)]))
    upper = np.concatenate(comm.allgather(z[owned & (X[:, 2] > middle)]))
    assert upper.min() - lower.max() > 0.5 * H


def test_paired_plates_closing_fast_bound_the_step_to_half_the_band(comm):
    """Two free plates a fraction of a cell apart (paired) close at the relative speed
    4v/3 (v and −v/3): self-contact bounds the next step to (g + b/2)/(4v/3), g the gap
    between the faces and b = H the shell's band, so that no step carries a pair more than
    half the band inside, where the search would drop it (the 30 Hz bow tie's arms went a
    whole thickness through each other within a step). Receding, they bound nothing (the
    unpaired approach's bound counts only vertices two cells from the other group at rest,
    none on stacked plates)."""
    gap, v = 2.05e-5, 0.1
    sim = _flying(comm, gap, v, 1e-3, 1e-3, upper=-v / 3)
    contact = sim.problem.contacts[0]
    contact.before_solve()  # pair at u_n = 0
    expected = (gap + 0.5 * H) / (4 * v / 3)
    assert contact.step_limit() == pytest.approx(expected, rel=1e-9)
    sim.integrator.v0.x.array[:] *= -1.0
    assert contact.step_limit() == np.inf


def test_rod_refuses_self_contact(comm):
    """The rod has no surfaces to pair: the case is refused with the key named."""
    case = parse_case(
        {
            "name": "rod",
            "robot": {"shape": "membrane", "thickness": H, "length": 5 * L, "width": L},
            "mesh": {"size": L, "model": "rod"},
            "material": {"shear_modulus": MU, "density": RHO, "remanence": 0.0},
            "contact": {"self_contact": True, "self_contact_groups": ["arm", "clamp"]},
            "time": {"end": 1e-4, "step": 1e-4},
            "output": {"csv": False, "vtx_every": 0, "plot": False},
        }
    )
    with pytest.raises(CaseError, match=r"contact\.self_contact.*surface"):
        build_simulation(case, comm)


def test_shell_self_contact_needs_cell_groups(comm):
    case = _case(
        {"self_contact_groups": ["lower", "rim"]},
        {"gravity": [0, 0, 0], "clamped": ["lower"]},
        {"end": 1e-4, "step": 1e-4},
    )
    with pytest.raises(CaseError, match="not a cell group"):
        build_simulation(case, comm, robot_mesh=_plates(comm, 0.0))


@pytest.mark.parametrize("lift", [0.0, 4.0])
def test_the_reach_filter_pairs_as_the_full_search(comm, monkeypatch, lift):
    """The search skips the facets of slaves beyond every candidate's reach; the pairing
    (masters, gaps, normals, master nodes, x̄) must be the full search's to the last bit. The
    upper plate pressed in and sheared, its right half bent up by ``lift`` times its distance
    from the middle (4: the right edge 2 mm up, beyond any facet's reach) so that the filter
    drops part of the slaves: it examines fewer facets than the full search."""
    search_module = importlib.import_module("magfem.mechanics.contacts.self_contact.search")
    sim, u = _lower_clamped(comm)
    X = u.function_space.tabulate_dof_coordinates()
    upper = X[:, 2] > 0.5 * H
    disp = np.zeros_like(X)
    disp[upper, 0] = 0.3 * L / CELLS
    disp[upper, 2] = -2 * ONSET * H + lift * np.maximum(X[upper, 0] - 0.5 * L, 0.0)
    found, examined = [], []
    for full in (False, True):
        if full:
            monkeypatch.setattr(
                search_module, "reach", lambda gap, v, n, c: np.full(len(v), np.inf)
            )
        seen = [0]

        def counting(point, corners, tolerance, seen=seen):
            seen[0] += point.shape[0]
            return geometry.inside(point, corners, tolerance)

        monkeypatch.setattr(search_module, "inside", counting)
        contact, _ = _contact_at(sim, disp)
        p = contact.pairing
        arrays = (p.partner, p.gap, p.nbar.x.array, p.vpartner, p.xbar.x.array)
        found.append([a.copy() for a in arrays])
        examined.append(comm.allreduce(seen[0], op=MPI.SUM))
    for filtered, everything in zip(*found, strict=True):
        np.testing.assert_array_equal(filtered, everything)
    assert comm.allreduce(int(np.count_nonzero(found[0][0] >= 0)), op=MPI.SUM) > 0
    if lift > 0:
        assert examined[0] < examined[1]


def _touching_points(corners, normal, gap, rng):
    """Points x = foot + s n, |s| <= gap, whose foot on the plane of normal n through the
    corners' centre passes :func:`inside` (a quadrilateral's foot through its projection on
    a corner triangle): at the grown simplices' corners and at random inside them."""
    t, nv = INSIDE * (1 - 1e-9), corners.shape[1]  # on the edge of inside, not over it
    simplices = [(0, 1)] if nv == 2 else list(itertools.combinations(range(nv), 3))
    centre = corners.mean(axis=1)
    out = []
    for simplex in simplices:
        k = len(simplex)
        bary = np.vstack([np.eye(k), rng.dirichlet(np.ones(k), 40)])
        for b in (1 + k * t) * bary - t:  # barycentric >= -t, summing to 1
            q = np.einsum("i,fia->fa", b, corners[:, list(simplex)])
            if nv == 4:  # the foot on the best-fit plane projects onto q along n_T
                a, b1, c = (corners[:, i] for i in simplex)
                n_t = np.cross(b1 - a, c - a)
                n_t /= np.linalg.norm(n_t, axis=1)[:, None]
                lam = -np.einsum("fa,fa->f", q - centre, normal) / np.einsum(
                    "fa,fa->f", n_t, normal
                )
                q = q + lam[:, None] * n_t
            assert inside(q[:, None], corners[:, None], INSIDE).all()
            out += [q + side * gap * normal for side in (-1.0, 0.0, 1.0)]
    return out


@pytest.mark.parametrize(("nv", "warp"), [(2, 0.0), (3, 0.0), (4, 0.0), (4, 0.15)])
def test_reach_bounds_every_point_that_can_touch_a_facet(nv, warp):
    """Points within ``gap`` of a facet's plane whose foot passes :func:`inside` are within
    :func:`reach` of each of its corners: sampled at the grown simplices' extreme corners
    and at random inside them, on stretched segments, triangles and flat and warped
    (corners 0.15 of the size off a plane) quadrilaterals, gap 0 and 0.7."""
    rng = np.random.default_rng(3)
    gdim = 2 if nv == 2 else 3
    if nv == 4:  # convex quadrilaterals: a rectangle's corners jittered, then warped
        square = np.array([[-1.0, -1.0, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]])
        corners = square * [1.0, 3.0, 0.0] + rng.uniform(-0.3, 0.3, (200, 4, 3)) * [1, 1, 0]
        corners[..., 2] = warp * rng.choice([-1.0, 1.0], (200, 4))
        _, _, vt = np.linalg.svd(corners - corners.mean(axis=1, keepdims=True))
        normal = vt[:, -1, :]
    else:
        corners = rng.uniform(-1.0, 1.0, (200, nv, gdim)) * ([1.0, 3.0, 0.1][:gdim])
        edge = corners[:, 1] - corners[:, 0]
        if nv == 2:
            normal = np.stack([-edge[:, 1], edge[:, 0]], axis=1)
        else:
            normal = np.cross(edge, corners[:, 2] - corners[:, 0])
        normal /= np.linalg.norm(normal, axis=1)[:, None]
    for gap in (0.0, 0.7):
        points = _touching_points(corners, normal, gap, rng)
        for v in range(nv):  # each corner as the candidate vertex
            bound = reach(gap, corners[:, v], normal[:, None, :], corners[:, None])
            for x in points:
                assert np.all(np.linalg.norm(x - corners[:, v], axis=1) <= bound)


@pytest.mark.parametrize("two_sided", [False, True])
def test_nodes_pair_with_their_nearest_facing_candidate_within_one_cell(two_sided):
    """:func:`ball_pairs` and :func:`nearest_facing` against a loop over the slave nodes:
    each takes, among the nodes within the radius of its anchor (at rest, an anchor shared by
    many nodes), the nearest (current positions) whose normal is within 60° of opposing its
    n̄, the first of equal distances; on a grid, so that distances tie."""
    rng = np.random.default_rng(5)
    grid = np.stack(np.meshgrid(np.arange(12.0), np.arange(12.0), [0.0]), -1).reshape(-1, 3)
    index = np.arange(len(grid))[::-1].copy()  # candidate numbers are not tree numbers
    tree = cKDTree(grid)
    current = grid + rng.choice([0.0, 0.5], grid.shape)  # positions with exact ties
    normals = rng.normal(size=grid.shape)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    slaves = np.arange(0, 60, 2)
    anchors = grid[rng.integers(0, 8, len(slaves)) * 13]  # few anchors, shared
    here = rng.choice([0.0, 3.0, 6.0], (70, 3))
    nbar = rng.normal(size=(70, 3)) * rng.choice([0.0, 1.0, 2.0], (70, 1))  # some zero
    sizes, c = ball_pairs(tree, index, anchors, 2.5)
    paired, partner = nearest_facing(slaves, sizes, c, nbar, normals, here, current, two_sided)
    got = dict(zip(paired, partner, strict=True))
    expected = {}
    for s, a in zip(slaves, anchors, strict=True):
        patch = index[np.asarray(tree.query_ball_point(a, r=2.5), dtype=np.int64)]
        dots = normals[patch] @ nbar[s]
        bound = -FACING * max(float(np.linalg.norm(nbar[s])), 1e-300)
        patch = patch[(np.abs(dots) if two_sided else dots) > bound]
        if patch.size:
            distance = np.linalg.norm(current[patch] - here[s], axis=1)
            expected[s] = patch[np.argmin(distance)]
    assert got == expected and len(expected) > 5
