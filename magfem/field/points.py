"""Collective evaluation of distributed dolfinx Functions at arbitrary points.

Every rank passes its own points (possibly none). The points of all ranks
are gathered, each rank evaluates those that fall into its cells, the lowest
rank that found a point provides its value, and the results are summed over
ranks (``Allreduce``) and returned to their owners. Serial and parallel runs
therefore give the same values up to round-off. Cost: O(total points) per
rank, meant for up to ~10⁵ points (robot nodes, plot grids).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from mpi4py import MPI

__all__ = ["OutsideDomainError", "PointEvaluator"]


class OutsideDomainError(ValueError):
    """Points lie outside the mesh (e.g. outside a field solve's air region)."""


class PointEvaluator:
    """Evaluate Functions on ``mesh`` at points (collective).

    Args:
        mesh: dolfinx mesh (any gdim); points are given with 3 coordinates.
        what: description of the domain for error messages.
    """

    def __init__(self, mesh: Any, what: str = "mesh"):
        from dolfinx import geometry

        self.mesh = mesh
        self.comm: MPI.Comm = mesh.comm
        self.what = what
        tdim = mesh.topology.dim
        self._tree = geometry.bb_tree(mesh, tdim)

    def __call__(self, functions: Sequence[Any], points: np.ndarray) -> list[np.ndarray]:
        """Values of ``functions`` at ``points`` (N, 3): list of (N, value_size) arrays.

        Raises:
            OutsideDomainError: on every rank, if any rank's point is outside the mesh.
        """
        from dolfinx import geometry

        pts = np.ascontiguousarray(np.atleast_2d(points).reshape(-1, 3), dtype=np.float64)
        counts = self.comm.allgather(len(pts))
        allpts = np.concatenate(self.comm.allgather(pts)) if sum(counts) else np.zeros((0, 3))
        n = len(allpts)
        sizes = [int(np.prod(f.ufl_shape)) if f.ufl_shape else 1 for f in functions]
        vals = np.zeros((n, sum(sizes)))
        owner = np.full(n, self.comm.size, dtype=np.int32)
        if n:
            cand = geometry.compute_collisions_points(self._tree, allpts)
            coll = geometry.compute_colliding_cells(self.mesh, cand, allpts)
            offs = coll.offsets
            found = np.flatnonzero(offs[1:] > offs[:-1])
            cells = coll.array[offs[found]].astype(np.int32)
            if len(found):
                owner[found] = self.comm.rank
                col = 0
                for f, s in zip(functions, sizes, strict=True):
                    vals[found, col : col + s] = f.eval(allpts[found], cells).reshape(len(found), s)
                    col += s
        best = np.empty_like(owner)
        self.comm.Allreduce(owner, best, op=MPI.MIN)
        missing = np.flatnonzero(best == self.comm.size)
        if len(missing):
            p = allpts[missing[0]]
            raise OutsideDomainError(
                f"{len(missing)} point(s) outside the {self.what}, e.g. "
                f"({p[0]:.6g}, {p[1]:.6g}, {p[2]:.6g}) m; enlarge the air region "
                "(field.solve.air_factor) or keep the robot inside it"
            )
        vals[best != self.comm.rank] = 0.0
        total = np.empty_like(vals)
        self.comm.Allreduce(vals, total, op=MPI.SUM)
        start = sum(counts[: self.comm.rank])
        mine = total[start : start + len(pts)]
        out, col = [], 0
        for s in sizes:
            out.append(mine[:, col : col + s])
            col += s
        return out
