r"""Contact between surfaces of one body (arm–arm, petal–petal): two-pass penalty.

Which surfaces.
    The exterior facets of a set of cell groups (``[contact]
    self_contact_groups``, default: the robot's arms). Every group is a
    *slave* towards every other listed group (its *masters*): the contact
    is two-pass and symmetric, each surface being pushed out of the other.
    Points of two groups that lie closer than ``self_contact_exclusion``
    thicknesses apart in the reference configuration never touch (groups
    that meet at the hub), and a surface never contacts itself.

Gap and traction.
    For a slave point x (current position) with master point x̄ and the
    master's outward unit normal n̄ there, the normal gap is
    g = (x − x̄)·n̄ (m; negative when the point is inside the master). Both
    passes together store the penalty energy

    .. math::

        E = \tfrac12 \sum_\text{passes} \int k_c\, R(-g)\, dA,\qquad
        k_c = \kappa_s\,\mu/h,\qquad R(\delta) = \int_0^\delta r ,

    (reported as ``energy_self_contact``; J, J/m for strips) with r the C¹
    ramp of the ground contact (:func:`magfem.mechanics.contact.penalty_ramp`),
    exactly zero for a positive gap, onset δ0 = ``self_contact_onset`` h,
    integrals over the slave's *reference* area. Its gradient is the
    contact force: each pass pushes its slave with ½ k_c r(−g) n̄ per area and
    its master with the opposite (action = reaction), so on two matched faces
    each body carries k_c r(δ) per area. A contact carrying a pressure p
    therefore penetrates by δ = r⁻¹(p/k_c)
    (:func:`magfem.mechanics.reference.penalty_penetration`): p h/(κ_s μ) +
    δ0/2 on the linear branch, sqrt(2 δ0 p/k_c) on the onset. This is the
    interpenetration tolerance (Wriggers, *Computational Contact Mechanics*,
    2nd ed., Springer 2006, §4.1 and §9.2 for two-pass node-to-surface
    penalty contact). A point touching a surface that does not touch back
    (a corner on a face) gets half that stiffness.

Search (closest point, nearest-node form).
    Normals and touching are decided at the vertices of the contact surfaces
    (a P1 vector space): for every slave vertex, the nearest vertex x_m of
    each master group is found with a k-d tree over the *current* positions
    (scipy ``cKDTree``), and of the contact facets around it the one whose
    normal most opposes the slave's gives n̄ (facet normals from the current
    vertices, oriented by the area-weighted nodal normals
    n_m ∝ ∫ J F⁻ᵀ N φ_m dA). Candidates must face each other
    (n_s·n_m < −1/2), the slave's foot on the facet's plane must lie inside
    the facet (barycentric coordinates ≥ −0.1; a point beyond the master's
    edge does not touch it) and less than half a thickness inside
    (a point that went through is not pulled back the wrong way, and where
    two arms meet, the bottom face of one does not see the top face of the
    other through the thickness: with a band of one thickness the 1 mm bow
    tie paired those at g = −h and Newton failed at 1 ms). Then every
    displacement node of the slave surface (vertices and, for P2/P3, edge
    and face nodes) takes the master group of the paired vertices of its
    facets and, in that group, the nearest master *displacement node* on
    the face that n̄ belongs to (its normal within 60° of n̄): x̄ at
    a slave quadrature point is interpolated from those nodes with the
    displacement's own shape functions, so on matching meshes it is the
    master's own surface and the reaction is distributed over the master's
    nodes like the traction over the slave's (with vertices only, the P2
    edge nodes carried half the pressure and the faces rippled). n̄ is
    interpolated linearly from the vertices. The gap to the master's tangent
    plane equals the gap to the surface for a flat master and is off by
    O(d² κ) for a master of curvature κ at lateral offset d ≲ one facet.
    Nodes without a master have x̄ at their own position (no gap there).

When the data are refreshed: implicit coupling.
    The pairing (which master node, n̄) is searched at the start of every
    step (at the integrator's stage displacement, where the residual is
    enforced) and before every observation, and is frozen within the step.
    x̄ is not: inside every Newton iteration it is the *current* stage
    position of the paired master node, x̄ = X_m + u_{n+1−αf}(X_m), so the
    gap is evaluated with the master's current displacement. The step terms
    are non-local (slave rows depend on master dofs), so they are not part
    of the UFL residual: :meth:`SelfContact.attach` registers hooks on the
    Newton solver that add ∂E/∂u to the residual (slave traction assembled
    as a dolfinx form, master reaction scattered to the master nodes' global
    rows) and its consistent linearisation to the Jacobian: the four blocks
    slave/master rows × slave/master columns, assembled as dolfinx forms in
    (u, x̄) and mapped to global dofs, scaled by ∂u_stage/∂u_{n+1} = 1 − αf,
    off the Dirichlet rows and columns, as new nonzeros of the PETSc matrix.
    Within a step the contact is the gradient of E (symmetric Jacobian,
    forces summing to zero); the forms are compiled once.

    Measured (``tests/test_self_contact.py``): the linearisation matches
    central differences to 4e-12; bouncing blocks (k_c β Δt²/(ρH) = 3e-3)
    conserve kinetic + elastic + penalty energy to 5.4e-4 through the
    impact and 1.3e-4 after separation, both falling 4× when Δt halves
    (second order; the former scheme with the master frozen per step gave
    8.8e-3 and 8.1e-4, independent of Δt); blocks pressed together by a body
    force at k_c β Δt²/(ρH) = 1500 (Δt = 0.5 ms, ρ∞ = 0.5) come to rest at
    the weight and the penalty penetration, where the former scheme (stable
    only for a ratio ≲ 1) failed after 11 steps. With ρ∞ = 1 and Δt far
    beyond the contact period (2π sqrt(ρH/k_c) = 54 µs there) the blocks
    keep rattling, as any undamped impact would; ρ∞ < 1 removes that.
    (Re-searching the data at every Newton iteration without the master
    columns, tried with the former scheme, diverged on the first impact:
    both passes resolved the whole gap at once.)

    Scenes (2 ranks): the bow tie and the flower run with self contact at
    their test resolution and for 1 ms at report resolution (bow tie 0.5 mm:
    19 s against 15 s without; flower 1 mm: 44 s against 41 s). On the 1 mm
    bow tie with ground contact the arms clap at 34 ms (the right arm folded
    past 180° meets the rising left one): the contact acts (forces of
    1–40 mN), but impacts penetrate up to half a thickness and Newton cuts
    the step to 1e-6–1e-5 s (progress estimate 1.7–1.9 h for the remaining
    64 ms; the run without self contact, whose arms pass through each
    other, also fails Newton after the reversal at 25 ms). Known artefact: where a slave
    edge node's master node is not on the tangent plane of its vertices'
    master facet, a quadrature point can see a tiny negative gap (flower,
    1 ms: 2e-9 N between petals 4 mm apart, no vertex penetrating; the
    search pairs facing surfaces at any positive gap).

What makes the 1 mm bow tie slow at the clap (measured, serial:
    ``magfem run cases/bow_tie.toml --set mesh.size=1mm --set time.end=36ms
    --set 'solver.petsc_options={snes_monitor=""}'``).
    Every step cut is a Newton failure with DIVERGED_FUNCTION_NANORINF (a
    full Newton step inverts an element; basic line search), 37 cuts up to
    36.2 ms, and the cuts start after the reversal at 25 ms, before any
    contact (27–33 ms, steps down to 45 µs); ``line_search = "bt"`` gives
    DIVERGED_MAX_IT instead and also reaches 1e-6–1e-5 s at the clap. First
    touch at 33.98 ms (0.26 mN). The nodes that touch are the right arm's
    *tip end face* (reference x = 5 mm, its mid-thickness nodes included)
    landing on the top of the hub at x = 0 after the arm curled past 250°,
    at relative normal speeds of 0.1–10 m/s (a whipping tip), penetrating
    10–39 µm (band 40 µm); the largest strain is 0.4–1.2 there (the 1 mm
    elements of the tip are crushed) and the right arm's angle jumps by
    20° within 20 µs. Tried and not kept:
    the contact at the end of the step with the pairing searched at u_n
    (steps 3–9 µs, no better than the stage point's 2–40 µs), and in
    addition an inelastic impact (relative normal velocity of touching
    through-thickness columns removed after each step, half on each side,
    like :class:`magfem.mechanics.contact.ImpactAbsorber`): worse on the bow
    tie (steps ~1 µs, strain > 1, ground force 0.1–0.2 N, kinetic energy
    0.2 → 6 µJ) and the bouncing blocks did not stick (11 % of the kinetic
    energy back, separation after 100 µs). Its first version, without a
    proximity test, kicked columns 4 mm away (an edge node's gap to a far
    master node can be negative, the artefact above) and failed at 16 ms.
    So at 1 mm the clap is an under-resolved tip crushing against the hub
    (and inverted elements), not a time-discretisation defect of the
    contact law.

Parallel.
    Each rank owns the vertices and nodes it owns; their positions, normals,
    groups and reference positions are gathered on every rank
    (``allgather``) and every rank searches for its own (owned and ghost)
    vertices and nodes; the current master node positions are gathered the
    same way at every residual and Jacobian evaluation, and the reaction
    rows a rank computes for a master node owned elsewhere travel through
    PETSc's off-process assembly. Memory and time of the gather grow with
    the number of contact nodes of the whole body (about 10⁴–10⁵ for the
    0.5 mm bow tie, ≲ a few MB): fine for the membranes here, a
    bounding-box-filtered exchange is the next step beyond ~10⁶ surface
    nodes.

Observable (:meth:`SelfContact.observe`): the contact force (N; N/m × width
for strips) per pair of groups, the largest penetration and the pressure
weighted centroid of the touching points, plus touch / release events.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, la
from dolfinx import mesh as dmesh
from mpi4py import MPI
from petsc4py import PETSc
from scipy.spatial import cKDTree

from magfem.config import CaseError
from magfem.geometry.robot_mesh import RobotMesh, locate
from magfem.mechanics.contact import penalty_ramp
from magfem.mechanics.solver import JIT_OPTIONS

if TYPE_CHECKING:
    from magfem.mechanics.integrator import TimeIntegrator
    from magfem.mechanics.solver import NewtonSolver
    from magfem.mechanics.spec import ContactSpec

__all__ = [
    "SelfContact",
    "SelfContactLaw",
    "create_self_contact",
    "penalty_energy",
]

TOUCH = 1e-6
"""A pair touches when its deepest penetration exceeds TOUCH × δ0 (round-off is not a touch)."""

CANDIDATES = 8
"""Nearest master vertices examined per slave vertex and master group."""

ADJACENT = 8
"""Most contact facets kept around one vertex (4 on a structured quadrilateral surface)."""

FACING = -0.5
"""A master facet counts only if its normal is within 60° of opposing the slave's normal."""

INSIDE = 0.1
"""A slave point touches a master facet only if its foot on the facet's plane lies inside the
facet, up to this fraction of the facet (barycentric coordinates >= -INSIDE): a point beyond
the master's edge does not touch it."""


@dataclass(frozen=True)
class SelfContactLaw:
    """Constants of the self-contact penalty, SI units.

    Attributes:
        stiffness: k_c = κ_s μ / h (Pa/m).
        onset: δ0 > 0, width of the C¹ onset of the ramp (m).
        exclusion: reference distance (m) below which two points never touch.
        band: a slave point deeper than this inside the master (m) is ignored.
    """

    stiffness: float
    onset: float
    exclusion: float
    band: float

    def __post_init__(self) -> None:
        # programming errors only: user input is validated by ContactSpec
        for name in ("stiffness", "onset", "band"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"SelfContactLaw.{name} must be finite and > 0, got {value!r}")
        if not (math.isfinite(self.exclusion) and self.exclusion >= 0):
            raise ValueError(f"SelfContactLaw.exclusion must be >= 0, got {self.exclusion!r}")


def penalty_energy(delta: Any, onset: Any) -> Any:
    """R(δ) = ∫₀^δ r (m²), the potential of the C¹ ramp r of :func:`penalty_ramp` (UFL).

    0 for δ <= 0, δ³/(6δ0) on the onset, δ²/2 − δ0 δ/2 + δ0²/6 beyond.
    """
    return ufl.conditional(
        ufl.le(delta, 0.0),
        0.0,
        ufl.conditional(
            ufl.lt(delta, onset),
            delta**3 / (6.0 * onset),
            delta**2 / 2.0 - onset * delta / 2.0 + onset**2 / 6.0,
        ),
    )


class SelfContact:
    """Two-pass penalty contact between the surfaces of cell groups of one mesh (collective).

    Args:
        robot: the robot mesh with its named cell groups.
        u: the unknown displacement (m), Lagrange vector space V.
        integrator: the time integrator (its stage weights place the search).
        groups: names of the cell groups that may touch each other (>= 2).
        law: penalty constants.
        quadrature_degree: degree of the contact surface measure.
        key: case key named in errors.

    Attributes:
        measure: ``ds`` over the contact surfaces (explicit quadrature degree).
        xbar: master point (m) per displacement node (a Function of the
            displacement space, moved to the master nodes' current stage
            position at every Newton evaluation).
        nbar: master unit normal per slave vertex (P1 vector Function; 0 where
            no master is near).
        engaged: some slave point of the body has a master (all ranks agree);
            the hooks do nothing otherwise.
        events: touch/release messages not yet handed out (:meth:`pop_events`).
    """

    def __init__(
        self,
        robot: RobotMesh,
        u: fem.Function,
        integrator: TimeIntegrator,
        groups: Sequence[str],
        law: SelfContactLaw,
        *,
        quadrature_degree: int,
        key: str = "contact.self_contact_groups",
    ) -> None:
        domain = robot.mesh
        self.comm: MPI.Comm = domain.comm
        self.domain = domain
        self.gdim = gdim = domain.geometry.dim
        tdim = domain.topology.dim
        fdim = tdim - 1
        self.u = u
        self.integrator = integrator
        self.law = law
        names = list(dict.fromkeys(groups))
        if len(names) < 2:
            raise CaseError(key, list(groups), "name at least two cell groups that may touch")
        self.groups = names
        num_cells = domain.topology.index_map(tdim)
        cell_label = np.full(num_cells.size_local + num_cells.num_ghosts, -1, dtype=np.int32)
        for i, name in enumerate(names):
            try:
                dim, cells = locate(robot, name)
            except KeyError:
                raise CaseError(
                    key, name, "no such group; groups are " + ", ".join(sorted(robot.groups))
                ) from None
            if dim != tdim:
                raise CaseError(key, name, "is not a cell group")
            cell_label[cells] = i
        domain.topology.create_connectivity(fdim, tdim)
        exterior = dmesh.exterior_facet_indices(domain.topology)
        f2c = domain.topology.connectivity(fdim, tdim)
        facet_label = np.array([cell_label[f2c.links(f)[0]] for f in exterior], dtype=np.int32)
        keep = facet_label >= 0
        facets, facet_label = exterior[keep].astype(np.int32), facet_label[keep]
        order = np.argsort(facets)
        facets, facet_label = facets[order], facet_label[order]
        tags = dmesh.meshtags(domain, fdim, facets, facet_label + 1)
        ds = ufl.Measure(
            "ds",
            domain=domain,
            subdomain_data=tags,
            metadata={"quadrature_degree": quadrature_degree},
        )
        self.measure = ds(tuple(range(1, len(names) + 1)))

        # contact data at the vertices of the contact surfaces
        self.Vc = Vc = fem.functionspace(domain, ("Lagrange", 1, (gdim,)))
        imap = Vc.dofmap.index_map
        n_nodes = imap.size_local + imap.num_ghosts
        self.size_local = imap.size_local
        self.node_label = np.full(n_nodes, -1, dtype=np.int32)
        for i in range(len(names)):
            nodes = fem.locate_dofs_topological(Vc, fdim, facets[facet_label == i])
            free = nodes[self.node_label[nodes] < 0]
            self.node_label[free] = i
        self.nodes = np.flatnonzero(self.node_label >= 0).astype(np.int32)
        # facets of the contact surfaces as vertex dofs, and the facets around each contact vertex
        vertex_to_dof = np.full(
            domain.topology.index_map(0).size_local + domain.topology.index_map(0).num_ghosts,
            -1,
            dtype=np.int32,
        )
        domain.topology.create_connectivity(tdim, 0)
        c2v = domain.topology.connectivity(tdim, 0).array.reshape(len(cell_label), -1)
        vertex_to_dof[c2v] = Vc.dofmap.list
        domain.topology.create_connectivity(fdim, 0)
        f2v = domain.topology.connectivity(fdim, 0)
        self.facet_dofs = np.array([vertex_to_dof[f2v.links(f)] for f in facets], dtype=np.int32)
        if self.facet_dofs.size == 0:
            self.facet_dofs = self.facet_dofs.reshape(0, gdim)
        slot = np.zeros(n_nodes, dtype=np.int32)
        self.adjacent = np.full((n_nodes, ADJACENT), -1, dtype=np.int32)
        for f, dofs in enumerate(self.facet_dofs):
            for d in dofs:
                if slot[d] < ADJACENT:
                    self.adjacent[d, slot[d]] = f
                    slot[d] += 1
        self.reference = Vc.tabulate_dof_coordinates()[:, :gdim].copy()
        V = u.function_space
        self.V = V
        self.xbar = fem.Function(V, name="self_contact_point")
        self.nbar = fem.Function(Vc, name="self_contact_normal")
        self.u_geom = fem.Function(V, name="self_contact_displacement")
        self._u1 = fem.Function(Vc)
        self.stiffness = fem.Constant(domain, np.float64(law.stiffness))
        self.onset = fem.Constant(domain, np.float64(law.onset))
        self.partner = np.full(n_nodes, -1, dtype=np.int32)
        self.gap = np.zeros(n_nodes)
        self.engaged = False
        """Some slave point of the whole body has a master (same value on every rank)."""

        # the displacement nodes (blocks of V, vertices and higher-order nodes) of the contact
        # surfaces, the group of each, and the V nodes of each contact facet
        vmap = V.dofmap.index_map
        self._v_global = vmap.local_to_global(
            np.arange(vmap.size_local + vmap.num_ghosts, dtype=np.int32)
        ).astype(np.int64)
        self.vlabel = np.full(vmap.size_local + vmap.num_ghosts, -1, dtype=np.int32)
        for i in range(len(names)):
            vn = fem.locate_dofs_topological(V, fdim, facets[facet_label == i])
            self.vlabel[vn[self.vlabel[vn] < 0]] = i
        self.vnodes = np.flatnonzero(self.vlabel >= 0).astype(np.int32)
        self.vreference = V.tabulate_dof_coordinates()[:, :gdim].copy()
        domain.topology.create_connectivity(tdim, fdim)
        c2f = domain.topology.connectivity(tdim, fdim)
        layout = V.dofmap.dof_layout
        closure = [
            np.asarray(layout.entity_closure_dofs(fdim, i))
            for i in range(len(c2f.links(0)) if len(cell_label) else 0)
        ]
        rows = []
        for f in facets:
            c = f2c.links(f)[0]
            rows.append(V.dofmap.cell_dofs(c)[closure[int(np.flatnonzero(c2f.links(c) == f)[0])]])
        self.facet_vnodes = np.array(rows, dtype=np.int32).reshape(len(facets), -1)
        self._normal_c = fem.Function(Vc)  # unit outward nodal normals at the contact vertices
        self._normal_v = fem.Function(V)  # the same and n̄, interpolated to the V nodes
        self._nbar_v = fem.Function(V)
        self.vpartner = np.full(self.vlabel.size, -1, dtype=np.int64)
        """Per V node: index of its master node in the gathered contact nodes (-1: none)."""
        # contact nodes owned here, in the order of every gather (search and coupling)
        self._vown = self.vnodes[self.vnodes < vmap.size_local]
        self._gvglobal = np.concatenate(self.comm.allgather(self._v_global[self._vown]))
        self._gvref = np.concatenate(self.comm.allgather(self.vreference[self._vown]))
        self._gvlabel = np.concatenate(self.comm.allgather(self.vlabel[self._vown]))
        self._bc_global = np.zeros(0, dtype=np.int64)

        X = ufl.SpatialCoordinate(domain)
        phi = ufl.TestFunction(Vc)
        F = ufl.Identity(gdim) + ufl.grad(self.u_geom)
        cofactor = ufl.det(F) * ufl.inv(F).T
        N = ufl.FacetNormal(domain)
        self._normal_form = fem.form(ufl.inner(cofactor * N, phi) * self.measure)
        # nodal forces at the observed state (u_geom = u_n during observation)
        p = self.pressure(X + self.u_geom)
        self._force_form = fem.form(ufl.inner(p * self.nbar, phi) * self.measure)

        # coupled step terms: the half-pass traction on the slave (test w) and its reaction on
        # the master point x̄ (test ψ, nodal values of x̄ in V), with their derivatives in
        # u_geom (slave columns) and in x̄ (master columns)
        w, psi = ufl.TestFunction(V), ufl.TestFunction(V)
        du, dxbar = ufl.TrialFunction(V), ufl.TrialFunction(V)
        half = 0.5 * self.pressure(X + self.u_geom)
        slave = -half * ufl.inner(self.nbar, w) * self.measure  # ∂E/∂u_s
        master = half * ufl.inner(self.nbar, psi) * self.measure  # ∂E/∂x̄
        jit = JIT_OPTIONS
        self._slave_form = fem.form(slave, jit_options=jit)
        self._master_form = fem.form(master, jit_options=jit)
        self._blocks = []
        for form, var, trial in (
            (slave, self.u_geom, du),
            (slave, self.xbar, dxbar),
            (master, self.u_geom, du),
            (master, self.xbar, dxbar),
        ):
            a = fem.form(ufl.derivative(form, var, trial), jit_options=jit)
            self._blocks.append((a, fem.create_matrix(a, la.BlockMode.expanded)))
        self._active: dict[tuple[int, int], bool] = {}
        self.first_touch: dict[tuple[int, int], float] = {}
        self.max_force = 0.0
        self.max_penetration = 0.0
        self.events: list[str] = []

    # --- UFL --------------------------------------------------------------------------------

    def gap_expression(self, x: Any) -> Any:
        """Normal gap g = (x − x̄)·n̄ (m) of the slave point at current position x (UFL)."""
        return ufl.dot(x - self.xbar, self.nbar)

    def pressure(self, x: Any) -> Any:
        """Contact pressure k_c r(−g) >= 0 (Pa per reference area) at position x (UFL)."""
        r, _ = penalty_ramp(-self.gap_expression(x), self.onset)
        return self.stiffness * r

    def energy(self, x: Any) -> Any:
        """Penalty energy ½ Σ_passes ∫ k_c R(−g) dA (J; J/m for strips), UFL form."""
        delta = -self.gap_expression(x)
        return 0.5 * self.stiffness * penalty_energy(delta, self.onset) * self.measure

    # --- search -----------------------------------------------------------------------------

    def refresh_stage(self) -> None:
        """Search at the integrator's stage displacement (1 − αf) u + αf u_n (collective)."""
        self._stage(self.integrator.u)
        self._search()

    def _stage(self, u: fem.Function) -> None:
        integ = self.integrator
        if integ.dynamic and integ.params is not None:
            af = integ.params.alpha_f
            self.u_geom.x.array[:] = (1.0 - af) * u.x.array + af * integ.u0.x.array
        else:
            self.u_geom.x.array[:] = u.x.array

    def refresh(self, displacement: fem.Function) -> None:
        """Search at the given displacement (m), e.g. u_n before an observation (collective)."""
        self.u_geom.x.array[:] = displacement.x.array
        self._search()

    def _search(self) -> None:
        gdim = self.gdim
        self._u1.interpolate(self.u_geom)
        b = fem.assemble_vector(self._normal_form)
        b.scatter_reverse(la.InsertMode.add)
        b.scatter_forward()
        nodes = self.nodes
        ref = self.reference[nodes]
        x = ref + self._u1.x.array.reshape(-1, gdim)[nodes]
        n = b.array.reshape(-1, gdim)[nodes]
        norm = np.linalg.norm(n, axis=1)
        n = n / np.where(norm > 0, norm, 1.0)[:, None]
        self._normal_c.x.array.reshape(-1, gdim)[nodes] = n
        self._normal_c.x.scatter_forward()
        label = self.node_label[nodes]
        normals, corners = self._facet_normals(n)
        adjacent = normals[nodes]  # (nodes, ADJACENT, gdim)
        around_corners = corners[nodes]  # (nodes, ADJACENT, facet vertices, gdim)
        owned = nodes < self.size_local
        parts = self.comm.allgather(
            (x[owned], adjacent[owned], label[owned], ref[owned], around_corners[owned])
        )
        gx, gn, glabel, gref, gc = (np.concatenate([p[k] for p in parts]) for k in range(5))

        best_dist = np.full(nodes.size, np.inf)
        nbar = np.zeros_like(x)
        partner = np.full(nodes.size, -1, dtype=np.int32)
        gap = np.zeros(nodes.size)
        law = self.law
        for j in range(len(self.groups)):
            in_j = glabel == j
            slaves = np.flatnonzero(label != j)
            if not in_j.any() or slaves.size == 0:
                continue
            mx, mn, mref, mc = gx[in_j], gn[in_j], gref[in_j], gc[in_j]
            k = min(CANDIDATES, len(mx))
            dist, idx = cKDTree(mx).query(x[slaves], k=k)
            dist, idx = dist.reshape(slaves.size, k), idx.reshape(slaves.size, k)
            # every facet around each candidate: facing, gap to its plane, projection inside it
            around = mn[idx]  # (slaves, k, ADJACENT, gdim)
            dots = np.einsum("sa,skja->skj", n[slaves], around)
            dots[np.all(around == 0.0, axis=-1)] = np.inf
            d = x[slaves][:, None, :] - mx[idx]
            g = np.einsum("ska,skja->skj", d, around)
            foot = x[slaves][:, None, None, :] - g[..., None] * around
            far_in_reference = (
                np.linalg.norm(ref[slaves][:, None, :] - mref[idx], axis=-1) >= law.exclusion
            )
            ok = (
                (dots < FACING)
                & (g > -law.band)
                & far_in_reference[..., None]
                & _inside(foot, mc[idx], INSIDE)
            )
            # per candidate, of its valid facets the one that most opposes the slave's normal
            choice = np.argmin(np.where(ok, dots, np.inf), axis=-1)
            valid = ok.any(axis=-1)
            normal = np.take_along_axis(around, choice[..., None, None], axis=2)[:, :, 0, :]
            g = np.take_along_axis(g, choice[..., None], axis=2)[..., 0]
            has = valid.any(axis=1)
            first = np.argmax(valid, axis=1)
            rows = np.arange(slaves.size)
            better = has & (dist[rows, first] < best_dist[slaves])
            s = slaves[better]
            best_dist[s] = dist[rows, first][better]
            nbar[s] = normal[rows, first][better]
            partner[s] = j
            gap[s] = g[rows, first][better]
        self.nbar.x.array.reshape(-1, gdim)[nodes] = nbar
        self.nbar.x.scatter_forward()
        self.partner[nodes] = partner
        self.gap[nodes] = gap
        self._pair_nodes()
        self._place(self.u_geom.x.array)

    def _pair_nodes(self) -> None:
        """Pair every displacement node of the contact surfaces with a master node (collective).

        A node takes the master group of the paired vertices of its facets
        and, in that group, the nearest node of the master's surface (current
        positions, vertices and higher-order nodes alike) whose outward normal
        is within 60° of n̄ there (the face that n̄ belongs to, not the
        opposite face of the membrane a thickness away): on matching meshes a
        slave edge node faces the master's edge node, so x̄ is the master's own
        interpolation of its surface and the reaction is distributed like the
        slave's traction.
        """
        gdim = self.gdim
        disp = self.u_geom.x.array.reshape(-1, gdim)
        own = self._vown
        self._normal_v.interpolate(self._normal_c)
        self._nbar_v.interpolate(self.nbar)
        normal = self._normal_v.x.array.reshape(-1, gdim)
        parts = self.comm.allgather((disp[own], normal[own]))
        position = self._gvref + np.concatenate([p[0] for p in parts])
        mnormal = np.concatenate([p[1] for p in parts])
        mnormal /= np.maximum(np.linalg.norm(mnormal, axis=1), 1e-300)[:, None]
        nbar = self._nbar_v.x.array.reshape(-1, gdim)
        group = np.full(self.vlabel.size, -1, dtype=np.int32)
        if self.facet_vnodes.shape[0]:
            fgroup = self.partner[self.facet_dofs].max(axis=1)
            np.maximum.at(
                group,
                self.facet_vnodes.ravel(),
                np.repeat(fgroup, self.facet_vnodes.shape[1]),
            )
        self.vpartner[:] = -1
        here = self.vreference + disp
        for j in range(len(self.groups)):
            slaves = np.flatnonzero(group == j)
            in_j = np.flatnonzero(self._gvlabel == j)
            if slaves.size == 0 or in_j.size == 0:
                continue
            k = min(CANDIDATES, in_j.size)
            _, idx = cKDTree(position[in_j]).query(here[slaves], k=k)
            idx = in_j[idx.reshape(slaves.size, k)]
            facing = (
                np.einsum("ska,sa->sk", mnormal[idx], nbar[slaves])
                > -FACING * np.maximum(np.linalg.norm(nbar[slaves], axis=1), 1e-300)[:, None]
            )
            has = facing.any(axis=1)
            first = np.argmax(facing, axis=1)
            self.vpartner[slaves[has]] = idx[np.arange(slaves.size), first][has]
        self.engaged = bool(self.comm.allreduce(bool(np.any(self.vpartner >= 0)), op=MPI.LOR))

    def _place(self, displacement: npt.NDArray[Any]) -> npt.NDArray[np.int64]:
        """Move x̄ to the master nodes at ``displacement`` (local V array, m) (collective).

        Returns, per local V node, the global V node whose position x̄ there
        is: its master node, or the node itself where it has none (there
        n̄ = 0 or the node lies at the rim of the contact zone).
        """
        gdim = self.gdim
        disp = displacement.reshape(-1, gdim)
        position = self._gvref + np.concatenate(self.comm.allgather(disp[self._vown]))
        k = self.vpartner
        paired = k >= 0
        xbar = self.vreference + disp
        xbar[paired] = position[k[paired]]
        self.xbar.x.array[:] = xbar.ravel()
        return np.where(paired, self._gvglobal[np.maximum(k, 0)], self._v_global)

    def _facet_normals(
        self, nodal: npt.NDArray[np.float64]
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Unit outward normals and corners of the contact facets around each vertex.

        A facet's normal is the direction of least spread of its current
        vertices (SVD; exact for segments and flat facets, the best-fit plane
        of a warped quadrilateral), oriented along the sum of its vertices'
        area-weighted nodal normals ``nodal`` (contact vertices, (nodes, gdim)).

        Returns:
            normals (n_nodes, ADJACENT, gdim) and the facets' current vertex
            positions (n_nodes, ADJACENT, facet vertices, gdim) (m); zero
            rows pad vertices with fewer facets.
        """
        gdim = self.gdim
        nvf = self.facet_dofs.shape[1]
        out = np.zeros((self.node_label.size, ADJACENT, gdim))
        corners = np.zeros((self.node_label.size, ADJACENT, nvf, gdim))
        if self.facet_dofs.shape[0] == 0:
            return out, corners
        x = self.reference + self._u1.x.array.reshape(-1, gdim)
        pts = x[self.facet_dofs]  # (facets, vertices, gdim)
        _, _, vt = np.linalg.svd(pts - pts.mean(axis=1, keepdims=True))
        normal = vt[:, -1, :]
        full = np.zeros_like(x)
        full[self.nodes] = nodal
        orient = full[self.facet_dofs].sum(axis=1)
        normal *= np.where(np.einsum("fa,fa->f", normal, orient) < 0, -1.0, 1.0)[:, None]
        has = self.adjacent >= 0
        out[has] = normal[self.adjacent[has]]
        corners[has] = pts[self.adjacent[has]]
        return out, corners

    # --- coupled step terms (Newton hooks) ---------------------------------------------------

    def attach(self, solver: NewtonSolver, bcs: Sequence[fem.DirichletBC]) -> None:
        """Add the coupled contact terms to ``solver``'s residual and Jacobian (collective).

        ``bcs`` are the (homogeneous) Dirichlet conditions of ``solver``:
        entries in their rows or columns are left out of the Jacobian.
        """
        bs = self.V.dofmap.index_map_bs
        owned = [np.zeros(0, dtype=np.int64)]
        for bc in bcs:
            dofs, num_owned = bc.dof_indices()
            local = np.asarray(dofs[:num_owned], dtype=np.int64)
            owned.append(bs * self._v_global[local // bs] + local % bs)
        self._bc_global = np.unique(np.concatenate(self.comm.allgather(np.concatenate(owned))))
        solver.residual_hooks.append(self.add_residual)
        solver.jacobian_hooks.append(self.add_jacobian)

    @property
    def stage_weight(self) -> float:
        """∂u_stage/∂u_{n+1}: 1 − αf for the dynamic schemes, 1 quasi-static."""
        integ = self.integrator
        if integ.dynamic and integ.params is not None:
            return 1.0 - integ.params.alpha_f
        return 1.0

    def _state(self, x: Any) -> npt.NDArray[np.int64]:
        """Set u_geom to the stage displacement of the iterate ``x`` and x̄ to the current
        master nodes (collective); returns :meth:`_place`'s global node per local V node."""
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with x.localForm() as local:
            self.u_geom.x.array[:] = local.array_r
        integ = self.integrator
        if integ.dynamic and integ.params is not None:
            af = integ.params.alpha_f
            self.u_geom.x.array[:] = (1.0 - af) * self.u_geom.x.array + af * integ.u0.x.array
        return self._place(self.u_geom.x.array)

    def add_residual(self, x: Any, b: Any) -> None:
        """Residual hook: add ∂E/∂u at the stage point of ``x`` to ``b`` (collective).

        E = ½ Σ_passes ∫ k_c R(−g) dA with g = (x_s − x̄)·n̄ and x̄ following the
        master nodes: the slave gets −½ ∫ k_c r n̄·w dA, the master nodes the
        opposite, weighted by the shape functions of x̄ (action = reaction).
        """
        if not self.engaged:
            return
        gdim = self.gdim
        target = self._state(x)
        slave = fem.assemble_vector(self._slave_form)
        slave.scatter_reverse(la.InsertMode.add)
        n = self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs
        with b.localForm() as local:
            local.array[:n] += slave.array[:n]
        master = fem.assemble_vector(self._master_form).array  # local + ghost nodes, unsummed
        rows = (gdim * target[:, None] + np.arange(gdim)).ravel()
        keep = master != 0.0
        rows, values = rows[keep], master[keep]
        b.setValues(rows.astype(PETSc.IntType), values, addv=PETSc.InsertMode.ADD)
        b.assemblyBegin()
        b.assemblyEnd()

    def add_jacobian(self, x: Any, A: Any) -> None:
        """Jacobian hook: add the consistent linearisation of :meth:`add_residual` (collective).

        The four blocks (slave/master rows × slave/master columns) are
        assembled as dolfinx forms in (u_geom, x̄), mapped to global
        displacement dofs (x̄ of a node → its master node), scaled by
        ∂u_stage/∂u and added to ``A`` off the Dirichlet rows and columns
        (new nonzeros allowed: master–slave couplings are not in the form's
        sparsity).
        """
        if not self.engaged:
            return
        gdim = self.gdim
        target = self._state(x)
        bs = self.V.dofmap.index_map_bs
        v_rows = (bs * self._v_global[:, None] + np.arange(bs)).ravel()
        x_rows = (gdim * target[:, None] + np.arange(gdim)).ravel()
        rows, cols, vals = [], [], []
        for (form, mat), (r_map, c_map) in zip(
            self._blocks,
            ((v_rows, v_rows), (v_rows, x_rows), (x_rows, v_rows), (x_rows, x_rows)),
            strict=True,
        ):
            mat.data[:] = 0.0
            fem.assemble_matrix(mat, form)
            coo = mat.to_scipy(ghosted=True).tocoo()
            keep = coo.data != 0.0
            rows.append(r_map[coo.row[keep]])
            cols.append(c_map[coo.col[keep]])
            vals.append(coo.data[keep])
        row, col, val = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
        keep = ~(np.isin(row, self._bc_global) | np.isin(col, self._bc_global))
        row, col, val = row[keep], col[keep], self.stage_weight * val[keep]
        order = np.lexsort((col, row))
        row, col, val = row[order], col[order], val[order]
        uniq, start = np.unique(row, return_index=True)
        indptr = np.append(start, row.size).astype(PETSc.IntType)
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        if uniq.size:
            A.setValuesIJV(
                indptr,
                col.astype(PETSc.IntType),
                val,
                addv=PETSc.InsertMode.ADD,
                rowmap=uniq.astype(PETSc.IntType),
            )
        A.assemble()

    # --- observation ------------------------------------------------------------------------

    @property
    def pairs(self) -> list[tuple[int, int]]:
        """Unordered pairs (i < j) of group indices."""
        return list(itertools.combinations(range(len(self.groups)), 2))

    def pair_name(self, pair: tuple[int, int]) -> str:
        """``<group_i>__<group_j>``."""
        return f"{self.groups[pair[0]]}__{self.groups[pair[1]]}"

    def columns(self) -> list[str]:
        """CSV columns written by :meth:`observe`."""
        cols = [
            "self_contact_force",
            "self_contact_penetration",
            "self_contact_x",
            "self_contact_y",
            "self_contact_z",
        ]
        return cols + [f"self_contact_force_{self.pair_name(p)}" for p in self.pairs]

    def observe(self, t: float, displacement: fem.Function, width: float = 1.0) -> dict[str, float]:
        """Contact observables at the state ``displacement`` (u_n) (collective).

        Refreshes the search at that state. Returns the :meth:`columns`:
        force (N; strips: N/m × ``width``) summed over pairs and per pair
        (mean of the two passes' resultant magnitudes), the largest
        penetration −g (m, >= 0) and the pressure-weighted centroid of the
        touching vertices (m; strips: (x, 0, z); NaN when nothing touches).
        Records touch/release events in :attr:`events`.
        """
        self.refresh(displacement)
        gdim = self.gdim
        f = fem.assemble_vector(self._force_form)
        f.scatter_reverse(la.InsertMode.add)
        nodes = self.nodes[self.nodes < self.size_local]
        force = f.array.reshape(-1, gdim)[nodes]
        label, partner = self.node_label[nodes], self.partner[nodes]
        x = self.reference[nodes] + self._u1.x.array.reshape(-1, gdim)[nodes]
        pen = np.where(partner >= 0, -self.gap[nodes], 0.0)
        ng = len(self.groups)
        resultant = np.zeros((ng, ng, gdim))  # force on slave group i from master j
        weight = np.zeros((ng, ng))
        moment = np.zeros((ng, ng, gdim))
        deepest = np.zeros((ng, ng))
        touching = partner >= 0
        mag = np.linalg.norm(force, axis=1)
        li, pj = label[touching], partner[touching]
        np.add.at(resultant, (li, pj), force[touching])
        np.add.at(weight, (li, pj), mag[touching])
        np.add.at(moment, (li, pj), mag[touching, None] * x[touching])
        np.maximum.at(deepest, (li, pj), pen[touching])
        resultant, weight, moment = (_sum(a, self.comm) for a in (resultant, weight, moment))
        deepest_all = np.zeros_like(deepest)
        self.comm.Allreduce(deepest, deepest_all, op=MPI.MAX)
        deepest = deepest_all
        row: dict[str, float] = {}
        total, total_w, total_m = 0.0, 0.0, np.zeros(gdim)
        for p in self.pairs:
            i, j = p
            fp = 0.5 * width * (np.linalg.norm(resultant[i, j]) + np.linalg.norm(resultant[j, i]))
            row[f"self_contact_force_{self.pair_name(p)}"] = float(fp)
            w = weight[i, j] + weight[j, i]
            total += fp
            total_w += w
            total_m += moment[i, j] + moment[j, i]
            active = bool(max(deepest[i, j], deepest[j, i]) > TOUCH * self.law.onset)
            was = self._active.get(p, False)
            if active and not was:
                where = (moment[i, j] + moment[j, i]) / w
                self.first_touch.setdefault(p, t)
                self.events.append(
                    f"t = {t:.6g} s: {self.groups[i]} touches {self.groups[j]} at "
                    f"{_mm(where)} mm, force {fp:.3g} N"
                )
            elif was and not active:
                self.events.append(f"t = {t:.6g} s: {self.groups[i]} leaves {self.groups[j]}")
            self._active[p] = active
        centroid = total_m / total_w if total_w > 0 else np.full(gdim, np.nan)
        c3 = centroid if gdim == 3 else np.array([centroid[0], 0.0, centroid[1]])
        penetration = float(np.max(deepest)) if deepest.size else 0.0
        row["self_contact_force"] = total
        row["self_contact_penetration"] = penetration
        row["self_contact_x"], row["self_contact_y"], row["self_contact_z"] = map(float, c3)
        self.max_force = max(self.max_force, total)
        self.max_penetration = max(self.max_penetration, penetration)
        return row

    def pop_events(self) -> list[str]:
        """Touch/release messages since the last call (identical on every rank)."""
        out, self.events = self.events, []
        return out

    def summary(self) -> dict[str, float]:
        """First touch time per pair (s, NaN if never), largest force (N) and penetration (m)."""
        out = {
            f"first_touch_{self.pair_name(p)}": self.first_touch.get(p, float("nan"))
            for p in self.pairs
        }
        out["max_self_contact_force"] = self.max_force
        out["max_self_contact_penetration"] = self.max_penetration
        return out


def _inside(
    point: npt.NDArray[np.float64], corners: npt.NDArray[np.float64], tolerance: float
) -> npt.NDArray[np.bool_]:
    """Whether points lie in the convex hull of facet corners, up to ``tolerance``.

    Args:
        point: (..., gdim) points on the facets' planes (m).
        corners: (..., vertices, gdim) facet corners (m): 2 (segment), 3
            (triangle) or 4 (quadrilateral, any vertex order: the union of the
            four corner triangles is its hull).
        tolerance: slack in barycentric coordinates.

    Padding facets (all corners equal) contain no point.
    """
    nv = corners.shape[-2]
    if nv == 2:
        a, b = corners[..., 0, :], corners[..., 1, :]
        e = b - a
        ee = np.einsum("...a,...a->...", e, e)
        t = np.einsum("...a,...a->...", point - a, e) / np.where(ee > 0, ee, np.inf)
        return (ee > 0) & (t >= -tolerance) & (t <= 1.0 + tolerance)
    inside = np.zeros(point.shape[:-1], dtype=bool)
    for tri in itertools.combinations(range(nv), 3):
        a, b, c = (corners[..., i, :] for i in tri)
        v0, v1, v2 = b - a, c - a, point - a
        d00 = np.einsum("...a,...a->...", v0, v0)
        d01 = np.einsum("...a,...a->...", v0, v1)
        d11 = np.einsum("...a,...a->...", v1, v1)
        d20 = np.einsum("...a,...a->...", v2, v0)
        d21 = np.einsum("...a,...a->...", v2, v1)
        det = d00 * d11 - d01 * d01
        safe = np.where(det > 1e-12 * (d00 * d11), det, np.inf)
        beta = (d11 * d20 - d01 * d21) / safe
        gamma = (d00 * d21 - d01 * d20) / safe
        inside |= (
            np.isfinite(safe)
            & (beta >= -tolerance)
            & (gamma >= -tolerance)
            & (1.0 - beta - gamma >= -tolerance)
        )
    return inside


def _sum(a: npt.NDArray[np.float64], comm: MPI.Comm) -> npt.NDArray[np.float64]:
    out = np.zeros_like(a)
    comm.Allreduce(np.ascontiguousarray(a), out, op=MPI.SUM)
    return out


def _mm(x: npt.NDArray[np.float64]) -> str:
    return "(" + ", ".join(f"{1e3 * v:.3g}" for v in x) + ")"


def create_self_contact(
    spec: ContactSpec,
    robot: RobotMesh,
    u: fem.Function,
    integrator: TimeIntegrator,
    *,
    shear_modulus: float,
    quadrature_degree: int,
) -> SelfContact:
    """The self contact of a ``[contact]`` table (``self_contact = true``) on ``robot``.

    k_c = κ_s μ / h, δ0 = onset × h, exclusion = exclusion × h, band = h/2
    (h = ``robot.thickness``; a point deeper than half a thickness inside a
    membrane is nearer its other face, e.g. through the thickness where two
    arms meet); groups default to the robot's arms.

    Raises:
        CaseError: fewer than two groups, an unknown or non-cell group.
    """
    h = robot.thickness
    groups = spec.self_contact_groups or tuple(arm.name for arm in robot.arms)
    law = SelfContactLaw(
        stiffness=spec.self_contact_penalty * shear_modulus / h,
        onset=spec.self_contact_onset * h,
        exclusion=spec.self_contact_exclusion * h,
        band=0.5 * h,
    )
    return SelfContact(robot, u, integrator, groups, law, quadrature_degree=quadrature_degree)
