r"""Self-contact search on a shell: mid-surfaces of thickness h that touch face on face.

The shell (``[mesh] model = "surface"``) is its mid-surface: a group's
contact surface is its cells, and both faces of the membrane, at ±h/2 along
the normal, may touch. For a slave point x (current mid-surface position)
paired with the master's mid-surface point x̄, master normal n̄ oriented
towards the slave's side (the side the slave lies on when the pairing is
searched, at the start of each step), the gap is

.. math::

    g = (\mathbf x - \bar{\mathbf x})\cdot\bar{\mathbf n} - h ,

the distance between the slave's face and the master's face that look at
each other. It is evaluated as (x − x̄')·n̄ with x̄' the master's node lifted
by h along the unit n̄ at that node (:meth:`SurfacePairing.place`), so a
node without a master (x̄' = x) has no gap, wherever n̄ is interpolated from
paired and unpaired vertices. The rest (two-pass penalty, search, coupled Newton terms) is the
solids' (:mod:`.law`, :mod:`.search`, :mod:`.assembly`), with the
mid-surface normals n ∝ ∂φ/∂X₁ × ∂φ/∂X₂ and facing taken up to sign.

Approximation: the faces are offset along the mid-surface normal, not the
director d of the shell's kinematics, so the gap depends on the displacement
only (the angles are not coupled). The director differs from the normal by
the transverse shear angle γ (a few 1e-3 rad in bending, (t/L)² small), which
tilts the face point by h/2·γ along the surface and moves it along the
normal by O(h γ²); for two plates facing each other the gap is exact to
O(rotation²) in the angle between d and n. A point whose mid-surface has
crossed the master's (penetration beyond h) is paired with the other face
at the next search: the penalty is a tolerance of a fraction of h, not a
barrier. A group folded onto itself (``self_contact_within``) touches itself the same
way, its own neighbourhood excluded (:mod:`.law`).

Free edges. A vertex on the membrane's free edge (an edge of one cell: an
arm's tip, a fin's rim) touches a face edge-on as well as face on: it need
not face the master (the facing test is left out for it). The edge is half
a cylinder of radius h/2 around the mid-surface's boundary, so it touches a
mid-surface h/2 + h/2 = h away, the same offset as a face. An edge-on touch
is one pass of the two-pass law (the face's nodes face no face of the edge),
so it is half as stiff as a face-on one. Without it an arm's tip striking
another arm edge-on went through it and crumpled at its corner (the 30 Hz
bow tie).

Nodal rule (node-to-surface): the contact integrals are evaluated at the
displacement's nodes, with weights ∫φ_i dA (:func:`nodal_rule`: Gauss–Lobatto
for the quadrilaterals' GLL-warped P2 and P3 nodes, all positive). Each node's
gap is then its own, (x_i − x̄_i)·n̄_i against its master node (or zero without
one), and a node pressed in by δ carries k_c r(δ) ∫φ_i dA. At Gauss points
the gap would be interpolated between paired nodes and nodes without a
master (x̄ = x), and P2/P3 shape functions, negative over part of the cell,
make it negative between nodes whose gaps are all positive.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import basix
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, la
from dolfinx import mesh as dmesh

from magfem.geometry.robot_mesh import RobotMesh
from magfem.mechanics.contacts.self_contact.law import SelfContactLaw
from magfem.mechanics.contacts.self_contact.search import SurfacePairing

__all__ = ["ShellPairing", "nodal_rule"]


def nodal_rule(V: fem.FunctionSpace) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Quadrature at the nodes of V's element: its reference points and weights ∫φ_i.

    Where some ∫φ_i is not positive (P2 triangles: 0 at the vertices) the
    weights are the diagonal of the mass matrix scaled to the cell's area
    (Hinton, Rock & Zienkiewicz, Earthq. Eng. Struct. Dyn. 4, 245 (1976)).
    """
    element = V.ufl_element()
    scalar = element.sub_elements[0] if element.block_size > 1 else element
    basis = scalar.basix_element
    q, w = (
        np.asarray(a, dtype=np.float64)
        for a in basix.make_quadrature(basis.cell_type, 2 * basis.degree + 2)
    )
    phi = np.asarray(basis.tabulate(0, q)[0, :, :, 0])
    weights: npt.NDArray[np.float64] = w @ phi
    if np.any(weights <= 1e-6 * weights.sum()):
        diagonal = w @ phi**2
        weights = diagonal * w.sum() / diagonal.sum()
    return np.asarray(basis.points, dtype=np.float64), weights


class ShellPairing(SurfacePairing):
    """:class:`SurfacePairing` of mid-surface cell groups of thickness h (collective).

    Args: those of :class:`SurfacePairing`; ``V`` is the shell's displacement
    space; the law's band becomes h (any slave point on its own side of the
    master's mid-surface may touch).
    """

    two_sided = True

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
        self.offset = robot.thickness
        super().__init__(
            robot,
            V,
            groups,
            dataclasses.replace(law, band=robot.thickness),
            quadrature_degree=quadrature_degree,
            key=key,
        )
        # per owned contact vertex, gathered in the search's order: the group and the
        # reference corners of the cells around it
        owned = self.nodes[self.nodes < self.size_local]
        adjacent = self.adjacent[owned]
        has = adjacent >= 0
        label = np.full(adjacent.shape, -1, dtype=np.int32)
        label[has] = self._cell_label[adjacent[has]]
        corners = np.zeros((*adjacent.shape, self.facet_dofs.shape[1], 3))
        corners[has] = self.reference[self.facet_dofs[adjacent[has]]]
        parts = self.comm.allgather((label, corners))
        self._gadjacent_label = np.concatenate([p[0] for p in parts])
        self._gadjacent_corners = np.concatenate([p[1] for p in parts])

    @property
    def edim(self) -> int:
        """The contact entities are the groups' cells (the mid-surface)."""
        return int(self.domain.topology.dim)

    def _label_entities(
        self, cell_label: npt.NDArray[np.int32]
    ) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]:
        """The labelled cells (local, owned and ghost) and their group indices."""
        cells = np.flatnonzero(cell_label >= 0).astype(np.int32)
        return cells, cell_label[cells]

    def _surface_vertices(
        self, facets: npt.NDArray[np.int32], facet_label: npt.NDArray[np.int32]
    ) -> None:
        super()._surface_vertices(facets, facet_label)
        self._cell_label = facet_label
        # the rim: vertices on the membrane's free edges (edges of one cell), on every rank
        topology = self.domain.topology
        tdim = topology.dim
        topology.create_connectivity(tdim - 1, tdim)
        edges = dmesh.exterior_facet_indices(topology)
        flag = fem.Function(self.Vc)
        dofs = fem.locate_dofs_topological(self.Vc, tdim - 1, edges)
        flag.x.array.reshape(-1, self.gdim)[dofs, 0] = 1.0
        flag.x.scatter_reverse(la.InsertMode.add)
        flag.x.scatter_forward()
        self.rim = flag.x.array.reshape(-1, self.gdim)[:, 0] > 0.0

    def _far_in_reference(
        self,
        ref: npt.NDArray[np.float64],
        candidate_ref: npt.NDArray[np.float64],
        candidates: npt.NDArray[np.int64],
        group: int,
        limit: float,
    ) -> npt.NDArray[np.bool_]:
        """Cells of the master group none of whose corners lies within ``limit`` (m) of the
        slave in the reference configuration.

        Where two groups meet along an edge (a fin on the body), a slave point on
        that edge lies in the plane of the other group's cells there (g = −h):
        the candidate vertex is a cell's length away, but the cell itself
        touches the slave, so the distance is taken to every corner of the cell.
        A cell around a shared vertex may belong to the slave's own group: only
        the master group's cells count.
        """
        label = self._gadjacent_label[candidates]  # (slaves, k, ADJACENT)
        corners = self._gadjacent_corners[candidates]  # (slaves, k, ADJACENT, corners, 3)
        distance = np.linalg.norm(corners - ref[:, None, None, None, :], axis=-1).min(axis=-1)
        return (label == group) & (distance >= limit)

    def _quadrature(self, degree: int) -> dict[str, Any]:
        """The nodal rule of the displacement's element (:func:`nodal_rule`)."""
        points, weights = nodal_rule(self.V)
        return {
            "quadrature_rule": "custom",
            "quadrature_points": points,
            "quadrature_weights": weights,
        }

    def _entity_nodes(self, facets: npt.NDArray[np.int32]) -> npt.NDArray[np.int32]:
        """The V nodes of each contact cell, (cells, nodes per cell)."""
        dofs = self.V.dofmap.list
        return np.asarray(dofs[facets], dtype=np.int32).reshape(len(facets), dofs.shape[1])

    def _area_normal(self) -> Any:
        """∂φ/∂X₁ × ∂φ/∂X₂ at u_geom: normal times da/dA of the flat (xy) mid-surface (UFL)."""
        F = ufl.Identity(3) + ufl.grad(self.u_geom)
        return ufl.cross(F[:, 0], F[:, 1])
