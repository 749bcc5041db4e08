r"""Self-contact search: the contact surfaces of cell groups and their pairing.

Search (closest point, nearest-node form).
    Normals and touching are decided at the vertices of the contact surfaces
    (a P1 vector space): for every slave vertex, the nearest vertex x_m of
    each master group is found with a k-d tree over the *current* positions
    (scipy ``cKDTree``), and of the contact facets around it the one whose
    normal most opposes the slave's gives n̄ (facet normals from the current
    vertices, oriented by the area-weighted nodal normals
    n_m ∝ ∫ J F⁻ᵀ N φ_m dA). Candidates must face each other
    (n_s·n_m < −1/2; a shell's free edge need not, :mod:`.shell`), the
    slave's foot on the facet's plane must lie inside the facet
    (barycentric coordinates ≥ −0.1; a point beyond the master's edge does
    not touch it) and less than half a thickness inside
    (a point that went through is not pulled back the wrong way, and where
    two arms meet, the bottom face of one does not see the top face of the
    other through the thickness: with a band of one thickness the 1 mm bow
    tie paired those at g = −h and Newton failed at 1 ms) and less than one
    cell (corner to corner) outside: the search is refreshed every step, and
    a pair farther apart measures its gap to a tangent plane that may be far
    from where the surfaces will meet. Then every
    displacement node of the slave surface (vertices and, for P2/P3, edge
    and face nodes) takes the master group of the paired vertices of its
    facets and the master vertex one of them found, and, among that group's
    *displacement nodes* within one cell of that vertex at rest, the nearest
    one (current positions) on the face that n̄ belongs to (its normal
    within 60° of n̄): x̄ at a slave node is that node's position, and
    between nodes it is interpolated with the displacement's own shape
    functions (the shell evaluates the contact at the nodes only,
    :mod:`.shell`), so on matching meshes x̄ is the master's own surface and
    the reaction goes to the master's nodes like the traction to the slave's
    (with vertices only, the P2 edge nodes carried half the pressure and
    the faces rippled; the nearest facing node of the whole group is, on a
    curled master, often far from the facet found). n̄ is interpolated linearly from the
    vertices. The gap to the master's tangent plane equals the gap to the
    surface for a flat master and is off by O(d² κ) for a master of
    curvature κ at lateral offset d ≲ one facet. A node deeper inside its
    master node than the band is left without one, as a vertex would be.
    Nodes without a master have x̄ at their own position (no gap there).
    With ``within`` a group is also searched against itself: candidates
    closer at rest than its own exclusion are skipped before the nearest
    CANDIDATES are examined (:mod:`.law`). A slave beyond every candidate's
    reach (:func:`.geometry.reach`) has none: its facets are not examined.

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
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, la
from dolfinx import mesh as dmesh
from mpi4py import MPI
from scipy.spatial import cKDTree

from magfem.config import CaseError
from magfem.geometry.robot_mesh import RobotMesh
from magfem.mechanics.contacts.penalty import penalty_energy, penalty_ramp
from magfem.mechanics.contacts.self_contact.geometry import (
    ball_pairs,
    facet_normals,
    facing,
    inside,
    nearest_facing,
    reach,
)
from magfem.mechanics.contacts.self_contact.law import (
    ADJACENT,
    CANDIDATES,
    FACING,
    INSIDE,
    SelfContactLaw,
)
from magfem.mechanics.contacts.self_contact.surfaces import ContactSurfaces
from magfem.parallel import JIT_WAIT

__all__ = ["SurfacePairing"]


class SurfacePairing(ContactSurfaces):
    """The contact surfaces of cell groups, paired slave to master (collective).

    Args:
        robot: the robot mesh with its named cell groups.
        V: the displacement space.
        groups: names of the cell groups that may touch each other (>= 2).
        law: penalty constants.
        quadrature_degree: degree of the contact surface measure.
        key: case key named in errors.

    Attributes:
        measure: ``ds`` over the contact surfaces (explicit quadrature degree).
        u_geom: the displacement the pairing and the gap are evaluated at.
        xbar: master point (m) per displacement node (moved to the master
            nodes' current position by :meth:`place`).
        nbar: master unit normal per slave vertex (P1 vector Function; 0 where
            no master is near).
        partner, gap: per contact vertex, its master group (-1: none) and gap (m).
        engaged: some slave point of the body has a master (all ranks agree).
    """

    def __init__(
        self,
        robot: RobotMesh,
        V: fem.FunctionSpace,
        groups: Sequence[str],
        law: SelfContactLaw,
        *,
        quadrature_degree: int,
        key: str = "contact.self_contact_groups",
    ) -> None:
        domain = robot.mesh
        self.comm: MPI.Comm = domain.comm
        self.domain = domain
        self.gdim = domain.geometry.dim
        self.law = law
        self.V = V
        names = list(dict.fromkeys(groups))
        if len(names) < (1 if law.within else 2):
            raise CaseError(
                key,
                list(groups),
                "name at least one cell group (two without self_contact_within)",
            )
        self.groups = names
        facets, facet_label = self._surface_facets(robot, key)
        tags = dmesh.meshtags(domain, self.edim, facets, facet_label + 1)
        measure = ufl.Measure(
            "ds" if self.edim < domain.topology.dim else "dx",
            domain=domain,
            subdomain_data=tags,
            metadata=self._quadrature(quadrature_degree),
        )
        self.measure = measure(tuple(range(1, len(names) + 1)))
        self._surface_vertices(facets, facet_label)
        self._surface_nodes(facets, facet_label)
        self._neighbourhoods()
        self.xbar = fem.Function(V, name="self_contact_point")
        self.nbar = fem.Function(self.Vc, name="self_contact_normal")
        self.u_geom = fem.Function(V, name="self_contact_displacement")
        self._anchor = np.full(self.reference.shape, np.nan)
        """Per paired contact vertex: its master vertex at rest (m)."""
        self.vertex_displacement = fem.Function(self.Vc)
        self._clearance_u = fem.Function(V)
        self._ends = self._clearance_ends()
        self.stiffness = fem.Constant(domain, np.float64(law.stiffness))
        self.onset = fem.Constant(domain, np.float64(law.onset))
        self.engaged = False
        phi = ufl.TestFunction(self.Vc)
        self._normal_form = fem.form(
            ufl.inner(self._area_normal(), phi) * self.measure, jit_options=JIT_WAIT
        )
        bs = V.dofmap.index_map_bs
        self.number_rows(bs * int(V.dofmap.index_map.local_range[0]))  # V alone

    def _quadrature(self, degree: int) -> dict[str, Any]:
        """Metadata of the contact measure: a Gauss rule of ``degree``."""
        return {"quadrature_degree": degree}

    def _area_normal(self) -> Any:
        """Outward normal times the area ratio da/dA of the surface at u_geom (UFL, Nanson)."""
        F = ufl.Identity(self.gdim) + ufl.grad(self.u_geom)
        return ufl.det(F) * ufl.inv(F).T * ufl.FacetNormal(self.domain)

    def number_rows(self, first_row: int) -> None:
        """Number the displacement dofs as the Newton system does (collective).

        ``first_row``: global index, in the Newton system, of this rank's
        first owned displacement dof. The displacement's owned dofs come first
        on every rank (one unknown, or the first block of several unknowns
        stacked per rank), so node k owned here has row first_row + bs k of
        its first component; ghost nodes get their owner's row. Sets ``row``
        (per local V node) and the rows of the gathered contact nodes.
        """
        V = self.V
        bs = V.dofmap.index_map_bs
        owned = V.dofmap.index_map.size_local * bs
        numbering = fem.Function(V)
        numbering.x.array[:owned] = first_row + np.arange(owned, dtype=np.float64)
        numbering.x.scatter_forward()  # exact in float64 below 2**53 dofs
        self.row = np.rint(numbering.x.array[::bs]).astype(np.int64)
        """Per local V node: global row of its first component in the Newton system."""
        self._gvrow = self.gather_nodes(self.row)

    # --- the law at a point (UFL) ------------------------------------------------------------

    offset = 0.0
    """Distance (m) between the points x of two surfaces that just touch (0: faces); x̄ is the
    master's point lifted by it along n̄ (towards the slave)."""

    two_sided = False
    """Surfaces without an outside (a shell's mid-surface): n̄ points at the slave's side."""

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

    # --- search ------------------------------------------------------------------------------

    def search(self, displacement: npt.NDArray[Any]) -> None:
        """Pair the surfaces at a displacement (local array of V, m), place x̄ (collective)."""
        self.u_geom.x.array[:] = displacement
        gdim = self.gdim
        self.vertex_displacement.interpolate(self.u_geom)
        b = fem.assemble_vector(self._normal_form)
        b.scatter_reverse(la.InsertMode.add)
        b.scatter_forward()
        nodes = self.nodes
        ref = self.reference[nodes]
        x = ref + self.vertex_displacement.x.array.reshape(-1, gdim)[nodes]
        n = b.array.reshape(-1, gdim)[nodes]
        norm = np.linalg.norm(n, axis=1)
        n = n / np.where(norm > 0, norm, 1.0)[:, None]
        self._normal_c.x.array.reshape(-1, gdim)[nodes] = n
        self._normal_c.x.scatter_forward()
        label = self.node_label[nodes]
        full = np.zeros_like(self.reference)
        full[nodes] = n
        normals, corners = facet_normals(
            self.reference + self.vertex_displacement.x.array.reshape(-1, gdim),
            self.facet_dofs,
            full,
            self.adjacent,
        )
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
        anchor = np.zeros(nodes.size, dtype=np.int64)
        # a pair has -band < g < its master group's largest cell: each vertex's reach
        bound = np.maximum(abs(self.offset - self.law.band), self._diameter + self.offset)
        master = (gx, gn, glabel, gref, gc, reach(bound[glabel], gx, gn, gc))
        for j in range(len(self.groups)):
            for own in (False, True):
                slaves = np.flatnonzero((label == j) == own)
                if slaves.size == 0 or not (glabel == j).any() or (own and not self.law.within):
                    continue
                dist, normal, g, m = self._match(
                    x[slaves], n[slaves], ref[slaves], self.rim[nodes[slaves]], master, j, own
                )
                better = dist < best_dist[slaves]
                s = slaves[better]
                best_dist[s] = dist[better]
                nbar[s] = normal[better]
                partner[s] = j
                gap[s] = g[better]
                anchor[s] = m[better]
        self.nbar.x.array.reshape(-1, gdim)[nodes] = nbar
        self.nbar.x.scatter_forward()
        self.partner[nodes] = partner
        self.gap[nodes] = gap
        self._anchor[nodes] = np.where((partner >= 0)[:, None], gref[anchor], np.nan)
        self._pair_nodes()
        self.place(self.u_geom.x.array)

    def clearance(self, displacement: npt.NDArray[Any]) -> float:
        """Smallest distance (m) from a contact vertex to the vertices of the other groups at
        ``displacement`` (local V array), less the offset (collective; inf: none).

        Only vertices at least two cells (:attr:`cell_size`) from every other
        group at rest count as the nearer end (:meth:`_clearance_ends`): where
        groups meet (a fin on the body) the neighbours across the seam are
        always a cell apart.
        """
        gdim = self.gdim
        self._clearance_u.x.array[:] = displacement
        self.vertex_displacement.interpolate(self._clearance_u)
        nodes = self.nodes[self.nodes < self.size_local]
        x = self.reference[nodes] + self.vertex_displacement.x.array.reshape(-1, gdim)[nodes]
        gx = np.concatenate(self.comm.allgather(x)).reshape(-1, gdim)
        nearest = np.inf
        for ends, others in self._ends:
            if ends.size and others.size:
                nearest = min(nearest, float(cKDTree(gx[others]).query(gx[ends])[0].min()))
        return nearest - self.offset

    def _match(
        self,
        x: npt.NDArray[Any],
        n: npt.NDArray[Any],
        ref: npt.NDArray[Any],
        rim: npt.NDArray[np.bool_],
        master: tuple[npt.NDArray[Any], ...],
        j: int,
        own: bool,
    ) -> tuple[npt.NDArray[Any], ...]:
        """The facet of master group j that each slave vertex touches.

        Args:
            x, n, ref: (slaves, gdim) current positions, unit normals, reference positions.
            rim: (slaves,) the slave touches edge-on too: it need not face the master.
            master: the gathered vertices (positions, normals of the facets around,
                groups, reference positions, corners of the facets around, reach).
            j: the master group.
            own: the slaves belong to group j (its own neighbourhood is excluded).

        Returns:
            per slave the distance to the paired master vertex (m; inf: none), n̄, the gap
            and the master vertex (index in the gathered vertices).
        """
        gx, gn, glabel, gref, gc, greach = master
        in_j = np.flatnonzero(glabel == j)
        mx, mn, mref, mc = gx[in_j], gn[in_j], gref[in_j], gc[in_j]
        law = self.law
        limit = self.own_exclusion[j] if own else law.exclusion
        k = min(CANDIDATES + (self._crowd[j] if own else 0), len(mx))
        dist, idx = cKDTree(mx).query(x, k=k)
        dist, idx = dist.reshape(len(x), k), idx.reshape(len(x), k)
        far = np.ones(idx.shape, dtype=bool)
        if own:  # the nearest CANDIDATES outside the slave's own neighbourhood
            far = np.linalg.norm(ref[:, None, :] - mref[idx], axis=-1) >= limit
            keep = np.argsort(~far, axis=1, kind="stable")[:, : min(CANDIDATES, k)]
            dist, idx, far = (np.take_along_axis(a, keep, axis=1) for a in (dist, idx, far))
        # a slave beyond every candidate's reach has no master: skip its facets (exact, and
        # most of the search where the surfaces are apart)
        active = np.flatnonzero((dist <= greach[in_j][idx]).any(axis=1))
        best = np.full(len(x), np.inf)
        normal_out, g_out = np.zeros_like(x), np.zeros(len(x))
        anchor = np.zeros(len(x), dtype=np.int64)
        if active.size == 0:
            return best, normal_out, g_out, anchor
        x, n, ref, rim, far = x[active], n[active], ref[active], rim[active], far[active]
        dist, idx = dist[active], idx[active]
        # every facet around each candidate: facing, gap to its plane, projection inside it
        around = mn[idx]  # (slaves, k, ADJACENT, gdim)
        d = x[:, None, :] - mx[idx]
        dots, g, around = facing(n, d, around, self.offset, self.two_sided)
        foot = x[:, None, None, :] - (g + self.offset)[..., None] * around
        ok = (
            far[..., None]
            & ((dots < FACING) | (rim[:, None, None] & np.isfinite(dots)))
            & (g > -law.band)
            & self._far_in_reference(ref, mref[idx], in_j[idx], j, limit)
            & inside(foot, mc[idx], INSIDE)
        )
        ok &= g < self._diameter[j]  # only surfaces that may close the gap within about a step
        # per candidate, of its valid facets the one that most opposes the slave's normal
        choice = np.argmin(np.where(ok, dots, np.inf), axis=-1)
        valid = ok.any(axis=-1)
        normal = np.take_along_axis(around, choice[..., None, None], axis=2)[:, :, 0, :]
        g = np.take_along_axis(g, choice[..., None], axis=2)[..., 0]
        rows, first = np.arange(len(x)), np.argmax(valid, axis=1)
        best[active] = np.where(valid.any(axis=1), dist[rows, first], np.inf)
        normal_out[active], g_out[active] = normal[rows, first], g[rows, first]
        anchor[active] = in_j[idx[rows, first]]
        return best, normal_out, g_out, anchor

    def _far_in_reference(
        self,
        ref: npt.NDArray[np.float64],
        candidate_ref: npt.NDArray[np.float64],
        candidates: npt.NDArray[np.int64],
        group: int,
        limit: float,
    ) -> npt.NDArray[np.bool_]:
        """Whether slave points may touch the facets around candidate master vertices.

        Args:
            ref: (slaves, gdim) the slaves' reference positions (m).
            candidate_ref: (slaves, k, gdim) the candidates' reference positions (m).
            candidates: (slaves, k) the candidates' indices in the gathered vertices.
            group: the master group.
            limit: the exclusion distance (m).

        Returns:
            (slaves, k, ADJACENT): the candidate lies at least ``limit`` from the
            slave in the reference configuration.
        """
        far = np.linalg.norm(ref[:, None, :] - candidate_ref, axis=-1) >= limit
        return np.repeat(far[..., None], ADJACENT, axis=-1)

    def _pair_nodes(self) -> None:
        """Pair every displacement node of the contact surfaces with a master node (collective).

        A node takes the master group of the paired vertices of its facets
        and the master vertex one of them found (:meth:`_node_anchors`) and,
        among that group's nodes within one cell of the vertex at rest, the
        nearest (current positions, vertices and higher-order nodes alike)
        whose outward normal is within 60° of n̄ there (the face that n̄
        belongs to, not the opposite face of the membrane a thickness away):
        on matching meshes a slave edge node faces the master's edge node, so
        x̄ is the master's own surface and the reaction is distributed like the
        slave's traction. A node deeper inside its master than the band is
        left without one, as a vertex is (on a tightly folded master a node
        may find one millimetres inside; docs/verification.md, "Inelastic
        self-contact").
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
        group, anchor = self._node_anchors()
        self.vpartner[:] = -1
        unit = np.linalg.norm(nbar, axis=1)
        self._lift = self.offset * nbar / np.where(unit > 0, unit, 1.0)[:, None]
        here = self.vreference + disp
        for j in range(len(self.groups)):
            slaves = np.flatnonzero(group == j)
            tree, index = self._node_tree[j]
            if slaves.size == 0 or index.size == 0:
                continue
            sizes, c = ball_pairs(tree, index, anchor[slaves], self._diameter[j])
            node, master = nearest_facing(
                slaves, sizes, c, nbar, mnormal, here, position, self.two_sided
            )
            self.vpartner[node] = master
        # a node deeper than the band has gone through its master, or faces the wrong part
        paired = np.flatnonzero(self.vpartner >= 0)
        n_hat = nbar[paired] / np.maximum(np.linalg.norm(nbar[paired], axis=1), 1e-300)[:, None]
        lifted = position[self.vpartner[paired]] + self._lift[paired]
        gap = np.einsum("ij,ij->i", here[paired] - lifted, n_hat)
        self.vpartner[paired[gap < -self.law.band]] = -1
        self.engaged = bool(self.comm.allreduce(bool(np.any(self.vpartner >= 0)), op=MPI.LOR))

    def _node_anchors(self) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.float64]]:
        """Per local V node: the master group of its facets (the largest paired with; -1:
        none) and the master vertex at rest (m; NaN: none) that a vertex of such a facet
        found."""
        group = np.full(self.vlabel.size, -1, dtype=np.int32)
        anchor = np.full((self.vlabel.size, self.gdim), np.nan)
        if self.facet_vnodes.shape[0] == 0:
            return group, anchor
        vertex_group = self.partner[self.facet_dofs]  # (facets, vertices)
        fgroup = vertex_group.max(axis=1)
        first = np.argmax(vertex_group == fgroup[:, None], axis=1)
        fanchor = self._anchor[self.facet_dofs[np.arange(len(first)), first]]
        per = self.facet_vnodes.shape[1]
        node, node_group = self.facet_vnodes.ravel(), np.repeat(fgroup, per)
        # every node takes the facet of the largest group around it
        order = np.lexsort((node_group, node))
        last = order[np.r_[np.flatnonzero(np.diff(node[order])), node.size - 1]]
        group[node[last]] = node_group[last]
        anchor[node[last]] = np.repeat(fanchor, per, axis=0)[last]
        group[~np.isfinite(anchor[:, 0])] = -1
        return group, anchor

    def place(self, displacement: npt.NDArray[Any]) -> npt.NDArray[np.int64]:
        """Move x̄ to the master nodes at ``displacement`` (local V array, m) (collective).

        Returns, per local V node, the Newton row (:meth:`number_rows`) of the
        first component of the node whose position x̄ there is: its master
        node, or the node itself where it has none (there n̄ = 0 or the node
        lies at the rim of the contact zone).
        """
        gdim = self.gdim
        disp = displacement.reshape(-1, gdim)
        position = self._gvref + self.gather_nodes(disp)
        k = self.vpartner
        paired = k >= 0
        xbar = self.vreference + disp
        xbar[paired] = position[k[paired]] + self._lift[paired]
        self.xbar.x.array[:] = xbar.ravel()
        return np.where(paired, self._gvrow[np.maximum(k, 0)], self.row)
