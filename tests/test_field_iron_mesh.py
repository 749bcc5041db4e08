"""The iron mesh: touching iron parts share their interface (one conforming iron region)."""

from __future__ import annotations

import numpy as np
from dolfinx import mesh

from magfem.config import from_table
from magfem.field.iron_mesh import build_iron_mesh
from magfem.field.iron_spec import IronSpec
from magfem.field.spec import SolveSpec


def test_touching_boxes_are_one_conforming_iron_region(comm):
    """An L of two boxes (a TEAM-13 channel's corner): the contact face is interior facets
    between the two parts' cells, none of it a boundary of the mesh; the potential is thus
    continuous across it and the parts act as one iron body."""
    top = {"kind": "box", "center": [0.0, 0.0, 0.0116], "size": [0.02, 0.01, 0.0032]}
    side = {"kind": "box", "center": [0.0084, 0.0, 0.0], "size": [0.0032, 0.01, 0.02]}
    parts = [from_table(IronSpec, t, "iron") for t in (top, side)]
    solve = from_table(SolveSpec, {"geometry": "3d", "mesh_size": "2 mm", "curved": False}, "s")
    data, *_ = build_iron_mesh(parts, None, solve, comm, None)
    msh, tags = data.mesh, data.cell_tags
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    owner = np.full(
        msh.topology.index_map(tdim).size_local + msh.topology.index_map(tdim).num_ghosts, 0
    )
    for k in (1, 2):
        owner[tags.find(data.physical_groups[f"iron_{k}"][1])] = k
    n_facets = msh.topology.index_map(tdim - 1).size_local
    shared = [f for f in range(n_facets) if sorted(owner[f2c.links(f)]) == [1, 2]]
    mid = mesh.compute_midpoints(msh, tdim - 1, np.array(shared, dtype=np.int32))
    # the contact face z = 10 mm, 6.8 <= x <= 10 mm, |y| <= 5 mm: 32 mm² in 2 mm triangles
    # (measured 22 on one rank); every shared facet lies on it
    total = comm.allreduce(len(shared))
    assert total >= 8
    if len(shared):
        assert np.allclose(mid[:, 2], 0.01, atol=1e-9)
        assert np.all((mid[:, 0] > 0.0068 - 1e-9) & (mid[:, 0] < 0.01 + 1e-9))
    boundary = mesh.exterior_facet_indices(msh.topology)
    bmid = mesh.compute_midpoints(msh, tdim - 1, boundary)
    on_face = np.isclose(bmid[:, 2], 0.01) & (bmid[:, 0] > 0.0068) & (np.abs(bmid[:, 1]) < 0.005)
    assert comm.allreduce(int(on_face.sum())) == 0
