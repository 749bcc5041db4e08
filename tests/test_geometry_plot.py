"""Pictures of robots: every cell of a distributed mesh reaches the picture."""

from __future__ import annotations

import numpy as np

from magfem.config import from_table
from magfem.geometry.robot_mesh import create_robot_mesh
from magfem.geometry.spec import MeshSpec, RobotSpec
from magfem.plot import plot_robot, robot_grid


def test_plot_robot_gathers_all_cells(shared_tmp, comm):
    """The picture shows every cell: the grid gathered on rank 0 has the global cell count."""
    r = from_table(RobotSpec, {"shape": "star", "thickness": 1e-4}, "robot")
    rm = create_robot_mesh(r, MeshSpec(size=0.75e-3), comm)
    grid = robot_grid(rm)
    out = plot_robot(rm, shared_tmp / "star.png", comm=comm)
    if comm.rank == 0:
        assert grid.n_cells == rm.num_cells
        assert set(grid.field_data["groups"]) == {"hub", *(a.name for a in rm.arms)}
        assert np.all(grid.cell_data["group"] >= 0)
        assert out is not None and out.stat().st_size > 10_000
    else:
        assert grid is None and out is None
