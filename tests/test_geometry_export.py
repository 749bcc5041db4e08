"""``magfem mesh --format``: the robot mesh with its named groups, read back with meshio.

Reference: the distributed dolfinx mesh of the same case, whose group sizes
(global counts of owned entities) the exported file must reproduce.
"""

from __future__ import annotations

import meshio
import numpy as np
import pytest
import tomli_w
from mpi4py import MPI

from magfem.case import load_case
from magfem.cli import main
from magfem.geometry.robot_mesh import create_robot_mesh, locate


def _case(directory, name: str, robot: dict, mesh: dict, comm):
    path = directory / f"{name}.toml"
    data = {
        "name": name,
        "robot": robot,
        "mesh": mesh,
        "material": {"shear_modulus": "115 kPa", "density": "2130 kg/m^3"},
    }
    if comm.rank == 0:
        path.write_text(tomli_w.dumps(data))
    comm.barrier()
    return path


def _group_sizes(path, comm) -> tuple[dict[str, int], dict[str, int]]:
    """Global entity count and tag of every group of the case's dolfinx mesh."""
    case = load_case(path)
    rm = create_robot_mesh(case.robot, case.mesh, comm)
    out = {}
    for name in rm.groups:
        dim, idx = locate(rm, name)
        rm.mesh.topology.create_entities(dim)
        owned = int(np.sum(idx < rm.mesh.topology.index_map(dim).size_local))
        out[name] = comm.allreduce(owned, op=MPI.SUM)
    return out, {name: tag for name, (_, tag) in rm.groups.items()}


@pytest.mark.parametrize("fmt", ["vtu", "vtk"])
def test_export_keeps_every_group(fmt, shared_tmp, comm, capsys):
    robot = {"shape": "star", "thickness": "100 um", "clamp_radius": "1 mm"}
    path = _case(shared_tmp, f"star_{fmt}", robot, {"size": "0.5 mm", "layers": 2}, comm)
    assert main(["mesh", str(path), "--out", str(shared_tmp), "--format", fmt]) == 0
    out = shared_tmp / f"star_{fmt}.{fmt}"
    assert f"wrote     {out}" in capsys.readouterr().out or comm.rank != 0
    sizes, tags = _group_sizes(path, comm)
    if comm.rank == 0:
        m = meshio.read(out)
        assert {n for n in m.cell_data if n != "group"} == set(sizes)
        group = np.concatenate(m.cell_data["group"])
        for name, size in sizes.items():
            flag = np.concatenate(m.cell_data[name]).astype(bool)
            assert np.count_nonzero(flag) == size, name
            assert np.all(group[flag] == tags[name]), name  # "group" holds the RobotMesh tag
        assert sum(sizes.values()) == len(group)  # every element in exactly one group


def test_strip_is_written_in_the_x_z_plane(shared_tmp, comm):
    robot = {"shape": "rectangle", "thickness": "100 um", "length": "4 mm", "width": "1 mm"}
    mesh = {"size": "0.5 mm", "model": "strip", "layers": 2}
    path = _case(shared_tmp, "strip_export", robot, mesh, comm)
    assert main(["mesh", str(path), "--out", str(shared_tmp), "--format", "vtu"]) == 0
    if comm.rank == 0:
        m = meshio.read(shared_tmp / "strip_export.vtu")
        assert np.all(m.points[:, 1] == 0.0)
        assert m.points[:, 2].min() == 0.0 and m.points[:, 2].max() == pytest.approx(1e-4)
        assert m.points[:, 0].max() == pytest.approx(4e-3)
        quads = sum(len(b.data) for b in m.cells if b.type == "quad")
        assert quads == 8 * 2  # 4 mm at 0.5 mm, 2 layers


def test_unknown_format_is_a_usage_error(shared_tmp, comm, capsys):
    robot = {"shape": "rectangle", "thickness": "100 um"}
    path = _case(shared_tmp, "bad_format", robot, {"size": "1 mm"}, comm)
    with pytest.raises(SystemExit) as err:
        main(["mesh", str(path), "--format", "stl"])
    assert err.value.code == 2
    assert "invalid choice: 'stl'" in capsys.readouterr().err
