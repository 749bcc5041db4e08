"""gmsh sessions: one model's options must not leak into the next."""

from __future__ import annotations

from magfem.geometry.gmshio import build_mesh


def _square(size: float | None):
    def builder(gmsh):
        if size is not None:
            gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        s = gmsh.model.occ.addRectangle(0, 0, 0, 1.0, 1.0)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [s], name="domain")
        gmsh.model.mesh.generate(2)

    return builder


def _cells(data) -> int:
    tdim = data.mesh.topology.dim
    return data.mesh.topology.index_map(tdim).size_global


def test_options_of_one_model_do_not_leak_into_the_next(comm):
    default = _cells(build_mesh(_square(None), comm, gdim=2, name="a"))
    fine = _cells(build_mesh(_square(0.05), comm, gdim=2, name="b"))
    again = _cells(build_mesh(_square(None), comm, gdim=2, name="c"))
    assert fine > 4 * default  # the option took effect on its own model (946 vs 162)
    assert again == default  # ... and only there
