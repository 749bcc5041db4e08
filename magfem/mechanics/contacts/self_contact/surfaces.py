"""The contact surfaces of cell groups: their vertices, displacement nodes and neighbourhoods.

Static data of :class:`~magfem.mechanics.contacts.self_contact.search.SurfacePairing`,
built once from the reference configuration: the contact entities (exterior facets of
the groups' cells; a shell's cells), per contact vertex (P1 space) its group and the
entities around it, per displacement node its group, and the gathered reference
positions every rank searches. The exclusion of a group's own neighbourhood is
derived in :mod:`.law`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from dolfinx import cpp as _cpp
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI
from scipy.spatial import cKDTree

from magfem.config import CaseError
from magfem.geometry.robot_mesh import RobotMesh, locate
from magfem.mechanics.contacts.self_contact.law import ADJACENT, NEIGHBOURHOOD, SelfContactLaw

__all__ = ["ContactSurfaces"]


class ContactSurfaces:
    """Contact entities, vertices and nodes of cell groups (set up by a subclass).

    Attributes set by the subclass before the methods run: ``domain``, ``gdim``,
    ``comm``, ``law``, ``V``, ``groups``.
    """

    domain: Any
    gdim: int
    comm: MPI.Comm
    law: SelfContactLaw
    V: fem.FunctionSpace
    groups: list[str]

    @property
    def edim(self) -> int:
        """Dimension of the contact entities: the facets of the groups' cells."""
        return int(self.domain.topology.dim) - 1

    def _surface_facets(
        self, robot: RobotMesh, key: str
    ) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]:
        """Exterior facets of the groups (sorted) and the group index of each."""
        domain = self.domain
        tdim = domain.topology.dim
        num_cells = domain.topology.index_map(tdim)
        cell_label = np.full(num_cells.size_local + num_cells.num_ghosts, -1, dtype=np.int32)
        for i, name in enumerate(self.groups):
            try:
                dim, cells = locate(robot, name)
            except KeyError:
                raise CaseError(
                    key, name, "no such group; groups are " + ", ".join(sorted(robot.groups))
                ) from None
            if dim != tdim:
                raise CaseError(key, name, "is not a cell group")
            cell_label[cells] = i
        self._num_cells = len(cell_label)
        return self._label_entities(cell_label)

    def _label_entities(
        self, cell_label: npt.NDArray[np.int32]
    ) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]:
        """The contact entities (exterior facets of labelled cells) and their group indices."""
        topology = self.domain.topology
        tdim = topology.dim
        topology.create_connectivity(tdim - 1, tdim)
        exterior = dmesh.exterior_facet_indices(topology)
        f2c = topology.connectivity(tdim - 1, tdim)
        facet_label = np.array([cell_label[f2c.links(f)[0]] for f in exterior], dtype=np.int32)
        keep = facet_label >= 0
        facets, facet_label = exterior[keep].astype(np.int32), facet_label[keep]
        order = np.argsort(facets)
        return facets[order], facet_label[order]

    def _surface_vertices(
        self, facets: npt.NDArray[np.int32], facet_label: npt.NDArray[np.int32]
    ) -> None:
        """Contact data at the vertices (P1 space Vc): groups, facets, facets around each."""
        domain, gdim = self.domain, self.gdim
        tdim, fdim = domain.topology.dim, self.edim
        self.Vc = Vc = fem.functionspace(domain, ("Lagrange", 1, (gdim,)))
        imap = Vc.dofmap.index_map
        n_nodes = imap.size_local + imap.num_ghosts
        self.size_local = imap.size_local
        self.node_label = np.full(n_nodes, -1, dtype=np.int32)
        for i in range(len(self.groups)):
            nodes = fem.locate_dofs_topological(Vc, fdim, facets[facet_label == i])
            free = nodes[self.node_label[nodes] < 0]
            self.node_label[free] = i
        self.nodes = np.flatnonzero(self.node_label >= 0).astype(np.int32)
        vmap0 = domain.topology.index_map(0)
        vertex_to_dof = np.full(vmap0.size_local + vmap0.num_ghosts, -1, dtype=np.int32)
        domain.topology.create_connectivity(tdim, 0)
        c2v = domain.topology.connectivity(tdim, 0).array.reshape(self._num_cells, -1)
        vertex_to_dof[c2v] = Vc.dofmap.list
        domain.topology.create_connectivity(fdim, 0)
        f2v = domain.topology.connectivity(fdim, 0)
        self.facet_dofs = np.array([vertex_to_dof[f2v.links(f)] for f in facets], dtype=np.int32)
        if self.facet_dofs.size == 0:  # no contact entity on this rank
            vertices = _cpp.mesh.cell_num_vertices(domain.topology.entity_types[fdim][0])
            self.facet_dofs = self.facet_dofs.reshape(0, vertices)
        slot = np.zeros(n_nodes, dtype=np.int32)
        self.adjacent = np.full((n_nodes, ADJACENT), -1, dtype=np.int32)
        for f, dofs in enumerate(self.facet_dofs):
            for d in dofs:
                if slot[d] < ADJACENT:
                    self.adjacent[d, slot[d]] = f
                    slot[d] += 1
        self.reference = Vc.tabulate_dof_coordinates()[:, :gdim].copy()
        self.entity_label = facet_label  # group index per contact entity
        self.partner = np.full(n_nodes, -1, dtype=np.int32)
        self.gap = np.zeros(n_nodes)
        self.rim = np.zeros(n_nodes, dtype=bool)
        """Per contact vertex: it touches edge-on too (a shell's free edge: :mod:`.shell`)."""
        self._normal_c = fem.Function(Vc)  # unit outward nodal normals at the contact vertices

    def _surface_nodes(
        self, facets: npt.NDArray[np.int32], facet_label: npt.NDArray[np.int32]
    ) -> None:
        """The displacement nodes of the surfaces (vertices and higher-order nodes of V)."""
        V, gdim = self.V, self.gdim
        fdim = self.edim
        vmap = V.dofmap.index_map
        self.vlabel = np.full(vmap.size_local + vmap.num_ghosts, -1, dtype=np.int32)
        for i in range(len(self.groups)):
            vn = fem.locate_dofs_topological(V, fdim, facets[facet_label == i])
            self.vlabel[vn[self.vlabel[vn] < 0]] = i
        self.vnodes = np.flatnonzero(self.vlabel >= 0).astype(np.int32)
        self.vreference = V.tabulate_dof_coordinates()[:, :gdim].copy()
        self.facet_vnodes = self._entity_nodes(facets)
        self._normal_v = fem.Function(V)  # nodal normals and n̄, interpolated to the V nodes
        self._nbar_v = fem.Function(V)
        self.vpartner = np.full(self.vlabel.size, -1, dtype=np.int64)
        self._lift = np.zeros((self.vlabel.size, gdim))  # offset × unit n̄ per node (m)
        """Per V node: index of its master node in the gathered contact nodes (-1: none)."""
        # contact nodes owned here, in the order of every gather (search and coupling)
        self._vown = self.vnodes[self.vnodes < vmap.size_local]
        self._gvref = self.gather_nodes(self.vreference)
        self._gvlabel = self.gather_nodes(self.vlabel)

    def gather_nodes(self, values: npt.NDArray[Any]) -> npt.NDArray[Any]:
        """Per-node ``values`` (first axis: local V nodes) at the owned contact nodes of every
        rank, in the order every gather of the search and coupling uses (collective)."""
        return np.concatenate(self.comm.allgather(values[self._vown]))

    def _neighbourhoods(self) -> None:
        """Per group: its largest contact entity (m), a k-d tree of its gathered displacement
        nodes at rest and, with ``within``, its own exclusion E (m) and how many of its contact
        vertices lie within E of one of them at rest (collective; see :mod:`.law`)."""
        ng, gdim = len(self.groups), self.gdim
        self.own_exclusion = np.full(ng, self.law.exclusion)
        self._diameter = np.zeros(ng)
        self._crowd = np.zeros(ng, dtype=np.int64)
        self._node_tree: list[tuple[Any, npt.NDArray[np.int64]]] = []
        corners = self.reference[self.facet_dofs]  # (entities, corners, gdim)
        span = np.linalg.norm(corners[:, :, None, :] - corners[:, None, :, :], axis=-1)
        np.maximum.at(self._diameter, self.entity_label, span.max(axis=(1, 2), initial=0.0))
        self.comm.Allreduce(MPI.IN_PLACE, self._diameter, op=MPI.MAX)
        for j in range(ng):
            index = np.flatnonzero(self._gvlabel == j)
            self._node_tree.append((cKDTree(self._gvref[index].reshape(-1, gdim)), index))
        if not self.law.within:
            return
        self.own_exclusion = np.maximum(self.law.exclusion, NEIGHBOURHOOD * self._diameter)
        owned = self.nodes[self.nodes < self.size_local]
        parts = self.comm.allgather((self.reference[owned], self.node_label[owned]))
        vref = np.concatenate([p[0] for p in parts]).reshape(-1, gdim)
        vlabel = np.concatenate([p[1] for p in parts])
        for j in range(ng):
            pts = vref[vlabel == j]
            if len(pts):
                tree = cKDTree(pts)
                count = tree.query_ball_point(pts, self.own_exclusion[j], return_length=True)
                self._crowd[j] = int(np.max(count))

    def _clearance_ends(self) -> list[tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]]:
        """Per group, in the gathered order of the owned contact vertices: its vertices two
        cells or more from every other group at rest, and the other groups' vertices
        (collective; the reference configuration's part of :meth:`clearance`)."""
        nodes = self.nodes[self.nodes < self.size_local]
        parts = self.comm.allgather((self.node_label[nodes], self.reference[nodes]))
        glabel = np.concatenate([p[0] for p in parts])
        gref = np.concatenate([p[1] for p in parts]).reshape(-1, self.gdim)
        out = []
        for j in range(len(self.groups)):
            mine, others = np.flatnonzero(glabel == j), np.flatnonzero(glabel != j)
            if mine.size and others.size:
                far = cKDTree(gref[others]).query(gref[mine])[0] >= NEIGHBOURHOOD * self.cell_size
                mine = mine[far]
            out.append((mine, others))
        return out

    @property
    def cell_size(self) -> float:
        """a: the smallest of the groups' largest contact cells or facets, corner to corner (m)."""
        return float(self._diameter.min())

    def _entity_nodes(self, facets: npt.NDArray[np.int32]) -> npt.NDArray[np.int32]:
        """The V nodes on each contact facet (closure dofs), (facets, nodes per facet)."""
        domain, V = self.domain, self.V
        tdim, fdim = domain.topology.dim, self.edim
        domain.topology.create_connectivity(tdim, fdim)
        c2f = domain.topology.connectivity(tdim, fdim)
        f2c = domain.topology.connectivity(fdim, tdim)
        layout = V.dofmap.dof_layout
        closure = [
            np.asarray(layout.entity_closure_dofs(fdim, i))
            for i in range(len(c2f.links(0)) if self._num_cells else 0)
        ]
        rows = []
        for f in facets:
            c = f2c.links(f)[0]
            rows.append(V.dofmap.cell_dofs(c)[closure[int(np.flatnonzero(c2f.links(c) == f)[0])]])
        return np.array(rows, dtype=np.int32).reshape(len(facets), -1)
