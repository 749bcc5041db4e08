"""The rod's midline mesh of a multi-arm robot: arms and hub spokes, tips, the bonded hub."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from magfem.case import load_case
from magfem.geometry.robot_mesh import create_robot_mesh

FIVE_ARM = Path(__file__).parents[1] / "cases" / "five_arm.toml"


def test_star_midlines_meet_at_the_hub(comm):
    """Five 5 mm arms (centre to tip): 25 mm of midline, five tips, a clamped (bonded) hub."""
    case = load_case(FIVE_ARM, overrides=["mesh.model=rod", "mesh.size=0.5mm"])
    robot = create_robot_mesh(case.robot, case.mesh, comm)
    msh = robot.mesh
    length = comm.allreduce(
        fem.assemble_scalar(fem.form(fem.Constant(msh, 1.0) * ufl.dx(msh))), op=MPI.SUM
    )
    assert abs(length - 5 * 5e-3) < 1e-12, length  # straight cells: exact
    tips = [name for name in robot.groups if name.startswith("tip")]
    assert len(tips) == 5, robot.groups
    held = comm.allreduce(len(robot.facet_tags.find(robot.groups["clamp"][1])), op=MPI.SUM)
    x = msh.geometry.x
    centre = np.hypot(x[:, 0] - case.robot.position[0], x[:, 1] - case.robot.position[1])
    assert held >= 1 and comm.allreduce(int(np.sum(centre < 1e-12)), op=MPI.SUM) == 1
