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

    def _locate(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Indices of the points found in local cells and one containing cell for each.

        Affine simplex meshes (all meshes built here): bounding-box candidates, then a
        vectorised barycentric test (20× faster than ``compute_colliding_cells``);
        other meshes: dolfinx's exact collision.
        """
        from dolfinx import geometry

        cand = geometry.compute_collisions_points(self._tree, pts)
        geo = self.mesh.geometry
        tdim = self.mesh.topology.dim
        if geo.cmaps[0].degree != 1 or geo.dofmaps[0].shape[1] != tdim + 1:
            coll = geometry.compute_colliding_cells(self.mesh, cand, pts)
            offs = coll.offsets
            found = np.flatnonzero(offs[1:] > offs[:-1])
            return found, coll.array[offs[found]].astype(np.int32)
        offs, cells = cand.offsets, cand.array
        pid = np.repeat(np.arange(len(pts)), np.diff(offs))
        X = geo.x[geo.dofmaps[0][cells]]  # (M, tdim + 1, 3)
        J = np.transpose(X[:, 1:, :] - X[:, :1, :], (0, 2, 1))  # (M, 3, tdim)
        rhs = pts[pid] - X[:, 0, :]
        JtJ = np.einsum("mki,mkj->mij", J, J)
        lam = np.linalg.solve(JtJ, np.einsum("mki,mk->mi", J, rhs)[..., None])[..., 0]
        bary = np.column_stack([1.0 - lam.sum(axis=1), lam])
        # outside the plane of a 2D mesh or of the cell: residual of the least-squares fit
        resid = np.linalg.norm(np.einsum("mki,mi->mk", J, lam) - rhs, axis=1)
        size = np.linalg.norm(J[:, :, 0], axis=1)
        inside = np.all(bary >= -1e-10, axis=1) & (resid <= 1e-10 * size)
        hit = np.flatnonzero(inside)
        found, first = np.unique(pid[hit], return_index=True)
        return found, cells[hit[first]].astype(np.int32)

    def __call__(self, functions: Sequence[Any], points: np.ndarray) -> list[np.ndarray]:
        """Values of ``functions`` at ``points`` (N, 3): list of (N, value_size) arrays.

        Raises:
            OutsideDomainError: on every rank, if any rank's point is outside the mesh.
        """

        pts = np.ascontiguousarray(np.atleast_2d(points).reshape(-1, 3), dtype=np.float64)
        counts = self.comm.allgather(len(pts))
        allpts = np.concatenate(self.comm.allgather(pts)) if sum(counts) else np.zeros((0, 3))
        n = len(allpts)
        sizes = [int(np.prod(f.ufl_shape)) if f.ufl_shape else 1 for f in functions]
        vals = np.zeros((n, sum(sizes)))
        owner = np.full(n, self.comm.size, dtype=np.int32)
        if n:
            found, cells = self._locate(allpts)
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
