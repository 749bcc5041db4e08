"""The ``disk`` shape: a free circular membrane, optionally bonded at its centre.

References: the disk's area π R² (and the bonded disk's π c²), with the
chord error of order-1 geometry, 1 − sin θ/θ ≈ θ²/6 for chords that subtend
θ = h/R, converging at rate 2 in the element size h.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import tomli_w
import ufl
from dolfinx import fem
from dolfinx.mesh import entities_to_geometry
from mpi4py import MPI

from magfem.cli import main
from magfem.config import CaseError, from_table
from magfem.geometry.robot_mesh import SHELL_CLAMP_INSET, create_robot_mesh, locate
from magfem.geometry.spec import MeshSpec, RobotSpec, check_mesh_for_robot

T = 1e-4
R = 5e-3  # default diameter 10 mm
Q = 2  # quadrature degree: the integrand is 1 on affine (order-1) cells


def disk(**keys: object) -> RobotSpec:
    return from_table(RobotSpec, {"shape": "disk", "thickness": T, **keys}, "robot")


def integral(rm, measure: str, tag: int | None = None) -> float:
    m = ufl.Measure(
        measure, domain=rm.mesh, subdomain_data=rm.facet_tags, metadata={"quadrature_degree": Q}
    )
    form = fem.form(1.0 * (m if tag is None else m(tag)))
    return rm.mesh.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)


def test_volume_converges_to_pi_r2_t(comm):
    """Order-1 volume / (π R² t) − 1: below the chord bound, at rate 2 (measured 1.77, 2.00)."""
    errors = []
    for n in (2, 4, 8):
        h = R / n
        rm = create_robot_mesh(disk(), MeshSpec(size=h), comm)
        errors.append(integral(rm, "dx") / (math.pi * R * R * T) - 1)
        # inscribed chords lose area; chords of ~h lose ~(h/R)^2/6 (measured 0.80-0.93 of it),
        # 1.2x allows gmsh's edges to exceed h a little
        assert -1.2 * (h / R) ** 2 / 6 < errors[-1] < 0, (n, errors[-1])
    rate = math.log2(errors[1] / errors[2])
    assert 1.7 < rate < 2.3


def test_free_disk_groups(comm):
    """One cell group ``body``; bottom and top faces; no arms, tips or clamp."""
    rm = create_robot_mesh(disk(position=[1e-3, -2e-3, 0.5e-3]), MeshSpec(size=R / 4), comm)
    assert set(rm.groups) == {"body", "bottom", "top"} and rm.arms == ()
    n_body = rm.mesh.topology.index_map(3).size_local
    dim, cells = locate(rm, "body")
    assert dim == 3 and comm.allreduce(int(np.sum(cells < n_body)), op=MPI.SUM) == rm.num_cells
    assert integral(rm, "ds", rm.groups["bottom"][1]) == pytest.approx(
        integral(rm, "ds", rm.groups["top"][1]), rel=1e-12
    )
    # centred on position: every node within R of (px, py), boundary nodes on the circle
    x = rm.mesh.geometry.x
    r = np.hypot(x[:, 0] - 1e-3, x[:, 1] + 2e-3)
    assert comm.allreduce(float(r.max()), op=MPI.MAX) == pytest.approx(R, rel=1e-12)
    zmin = comm.allreduce(float(x[:, 2].min()), op=MPI.MIN)
    assert zmin == pytest.approx(0.5e-3, rel=1e-12)


def test_bonded_centre(comm):
    """``clamp_diameter``: clamp + bottom = top, clamp ≈ π c² (chord bound); shell inset."""
    c = 2e-3
    h = R / 8
    rm = create_robot_mesh(disk(clamp_diameter=2 * c), MeshSpec(size=h), comm)
    assert set(rm.groups) == {"body", "bottom", "clamp", "top"}
    clamp, bottom, top = (integral(rm, "ds", rm.groups[g][1]) for g in ("clamp", "bottom", "top"))
    assert clamp + bottom == pytest.approx(top, rel=1e-12)
    assert -1.2 * (h / c) ** 2 / 6 < clamp / (math.pi * c * c) - 1 < 0
    shell = create_robot_mesh(disk(clamp_diameter=2 * c), MeshSpec(size=h, model="surface"), comm)
    assert set(shell.groups) == {"body", "clamp"}
    dim, edges = locate(shell, "clamp")
    shell.mesh.topology.create_connectivity(dim, 2)
    pts = shell.mesh.geometry.x[entities_to_geometry(shell.mesh, dim, edges)].reshape(-1, 3)
    reach = comm.allreduce(float(np.hypot(pts[:, 0], pts[:, 1]).max(initial=0.0)), op=MPI.MAX)
    assert reach == pytest.approx(c - SHELL_CLAMP_INSET * T, rel=1e-12)  # the rim's node circle


def test_strip_and_size_across_refused():
    with pytest.raises(CaseError, match="uniform-width") as err:
        create_robot_mesh(disk(), MeshSpec(size=R / 4, model="strip"), MPI.COMM_WORLD)
    assert err.value.key == "mesh.model"
    with pytest.raises(CaseError) as err:
        create_robot_mesh(disk(), MeshSpec(size=R / 4, size_across=R / 2), MPI.COMM_WORLD)
    assert err.value.key == "mesh.size_across"


@pytest.mark.parametrize(
    ("keys", "key", "words"),
    [
        ({"diameter": "-1 mm"}, "robot.diameter", "> 0"),
        ({"clamp_diameter": "10 mm"}, "robot.clamp_diameter", "< diameter"),
        ({"clamp_diameter": "-1 mm"}, "robot.clamp_diameter", ">= 0"),
        ({"width": "1 mm"}, "robot.width", "clamp_diameter, diameter, position, shape"),
    ],
)
def test_bad_keys_name_the_key(keys, key, words):
    with pytest.raises(CaseError) as err:
        disk(**keys)
    assert err.value.key == key and words in str(err.value)


def test_mesh_must_fit_the_free_ring():
    """min_feature: the radius, or the ring outside the bonded disk (here 1 mm)."""
    assert disk().min_feature == pytest.approx(R)
    with pytest.raises(CaseError, match=r"\(0\.001 m\)") as err:
        check_mesh_for_robot(disk(clamp_diameter="8 mm"), MeshSpec(size=1.5e-3))
    assert err.value.key == "mesh.size"


def test_cli_one_line_error(shared_tmp, comm, capsys):
    path = shared_tmp / "disk.toml"
    case = {
        "name": "disk",
        "robot": {"shape": "disk", "thickness": "100 um", "clamp_diameter": "12 mm"},
        "mesh": {"size": "1 mm"},
        "material": {"shear_modulus": "115 kPa", "density": "2130 kg/m^3"},
    }
    if comm.rank == 0:
        path.write_text(tomli_w.dumps(case))
    comm.barrier()
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    if comm.rank == 0:
        assert err.count("\n") == 1 and "robot.clamp_diameter = 0.012" in err
