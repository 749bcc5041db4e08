"""What every model builds the same way: the remanent magnetization and the supports.

Supports (``[environment]``): the ``clamped`` groups (facets or cells) are
held (u = 0, and a shell's angles too); ``fixed_point`` pins the nodes
within ``fixed_radius`` of a point (or the nearest node); with neither the
body is free. With ``[mesh] root = "rigid"`` the solid's and the strip's
``clamp`` group (the bonded bottom patch) stands for the cells above it,
through the thickness: the extruded mesh puts them in columns over the
patch's facets.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI
from scipy.spatial import cKDTree

from magfem.config import CaseError
from magfem.geometry.robot_mesh import RobotMesh, locate
from magfem.mechanics.spec import EnvironmentSpec, MaterialSpec

__all__ = [
    "cells_above",
    "clamped_entities",
    "create_magnetization",
    "fixed_point_dofs",
    "is_free",
    "magnetization_vector",
]


def magnetization_vector(direction: str | tuple[float, ...], magnitude: float, gdim: int) -> Any:
    """Remanent magnetization M̃ (A/m) as a numpy vector of length ``gdim``.

    ``"normal"`` is +z (3D) or the second axis of a strip (its z); a vector
    (mx, my, mz) is normalised; strips keep (mx, mz).
    """
    if isinstance(direction, str):
        vec = np.array([0.0, 0.0, -1.0 if direction == "-normal" else 1.0])
    else:
        vec = np.asarray(direction, dtype=float)
        vec = vec / np.linalg.norm(vec)
    vec = magnitude * vec
    return vec if gdim == 3 else np.array([vec[0], vec[2]])


def create_magnetization(spec: MaterialSpec, robot: RobotMesh, components: int) -> fem.Function:
    """DG0 vector field M̃ (A/m) of ``components`` entries: the material's, overridden per region.

    Raises:
        CaseError: a region names a group the robot does not have, or a facet group.
    """
    domain = robot.mesh
    Q = fem.functionspace(domain, ("DG", 0, (components,)))
    M = fem.Function(Q, name="magnetization")
    values = M.x.array.reshape(-1, components)
    values[:] = magnetization_vector(spec.direction, spec.remanence, components)
    for i, region in enumerate(spec.regions):
        key = f"material.regions[{i}].group"
        try:
            dim, cells = locate(robot, region.group)
        except KeyError:
            raise CaseError(
                key, region.group, "no such group; groups are " + ", ".join(sorted(robot.groups))
            ) from None
        if dim != domain.topology.dim:
            raise CaseError(key, region.group, "is not a cell group")
        direction = region.direction if region.direction is not None else spec.direction
        magnitude = region.remanence if region.remanence is not None else spec.remanence
        values[cells] = magnetization_vector(direction, magnitude, components)
    M.x.scatter_forward()
    return M


def clamped_entities(env: EnvironmentSpec, robot: RobotMesh) -> list[tuple[int, Any]]:
    """(dim, local entities) of each ``[environment] clamped`` group the robot has.

    Raises:
        CaseError: a group the robot does not have (``clamp`` is skipped: robots
            with clamp_length = 0 have none, and it is the default).
    """
    out = []
    for i, name in enumerate(env.clamped):
        if name not in robot.groups and name != "robot":
            if name == "clamp":
                continue
            raise CaseError(
                f"environment.clamped[{i}]",
                name,
                "no such group; groups are " + ", ".join(sorted(robot.groups)),
            )
        dim, entities = locate(robot, name)
        if name == "clamp" and robot.root == "rigid" and robot.model in ("solid", "strip"):
            dim, entities = robot.mesh.topology.dim, cells_above(robot.mesh, entities)
        out.append((dim, entities))
    return out


def cells_above(domain: Any, facets: npt.NDArray[np.int32]) -> npt.NDArray[np.int32]:
    """Local cells whose in-plane midpoint is a midpoint of one of ``facets`` (collective).

    For a mesh extruded along its last coordinate (the solid's z, the strip's
    second axis) from a bottom face, these are the columns of cells standing
    on those bottom facets, every layer. The facets' midpoints are gathered
    from every rank, so a column split between ranks is found on each.
    """
    tdim, gdim = domain.topology.dim, domain.geometry.dim
    domain.topology.create_connectivity(tdim - 1, tdim)
    mine = dmesh.compute_midpoints(domain, tdim - 1, facets)[:, : gdim - 1]
    feet = np.vstack([m for m in domain.comm.allgather(mine) if len(m)] or [np.empty((0, 1))])
    imap = domain.topology.index_map(tdim)
    cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    centres = dmesh.compute_midpoints(domain, tdim, cells)[:, : gdim - 1]
    x = domain.geometry.x
    scale = domain.comm.allreduce(float(np.abs(x).max()) if len(x) else 0.0, op=MPI.MAX)
    if len(feet) == 0 or len(cells) == 0:
        return np.empty(0, dtype=np.int32)
    distance, _ = cKDTree(feet).query(centres)
    return cells[distance <= 1e-9 * scale]


def fixed_point_dofs(env: EnvironmentSpec, V: fem.FunctionSpace) -> npt.NDArray[np.int32]:
    """Local nodes of ``V`` held by ``fixed_point``/``fixed_radius`` (collective).

    The nodes within ``fixed_radius`` of the point, or the nearest node(s)
    when none is that close. Strip meshes (gdim 2) use (x, z) of the point.
    """
    if env.fixed_point is None:
        raise ValueError("fixed_point_dofs: the environment has no fixed_point")
    gdim = V.mesh.geometry.dim
    given = np.asarray(env.fixed_point, dtype=float)
    point = np.zeros(3)
    point[:gdim] = given[:gdim] if gdim == 3 else given[::2]
    dist = np.linalg.norm(V.tabulate_dof_coordinates() - point, axis=1)
    nearest = V.mesh.comm.allreduce(dist.min() if dist.size else np.inf, op=MPI.MIN)
    radius = max(env.fixed_radius, nearest * (1 + 1e-9) + 1e-15)
    return np.flatnonzero(dist <= radius).astype(np.int32)


def is_free(bcs: list[fem.DirichletBC], comm: MPI.Comm) -> bool:
    """Whether the conditions hold no dof on any rank (collective)."""
    held = sum(len(bc.dof_indices()[0]) for bc in bcs)
    return comm.allreduce(held, op=MPI.SUM) == 0
