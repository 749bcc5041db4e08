"""Collective evaluation of distributed dolfinx Functions at arbitrary points.

Every rank passes its own points (possibly none). dolfinx's
``determine_point_ownership`` sends each point only to the ranks whose
bounding boxes hold it and picks one owning cell; the owners evaluate and
send the values back (``Alltoallv``). The cost per rank thus follows the
points it owns, not the total. Points outside the mesh are reported by a
mask, so the caller can name them in its own coordinates.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from dolfinx import geometry
from mpi4py import MPI

__all__ = ["PointEvaluator"]


class PointEvaluator:
    """Evaluate Functions on ``mesh`` at points given with 3 coordinates (collective).

    Args:
        mesh: dolfinx mesh (any gdim; a 2D mesh lies in the plane z = 0).
    """

    def __init__(self, mesh: Any):
        self.mesh = mesh
        self.comm: MPI.Comm = mesh.comm
        x = mesh.geometry.x
        local = float(np.ptp(x, axis=0).max()) if len(x) else 0.0
        self._padding = 1e-10 * self.comm.allreduce(local, op=MPI.MAX)

    def __call__(
        self, functions: Sequence[Any], points: np.ndarray
    ) -> tuple[list[np.ndarray], np.ndarray]:
        """Values of ``functions`` at ``points`` (N, 3) and the mask (N,) of points found.

        Returns:
            ([(N, value_size) per function], found); values are 0 where not found.
        """
        pts = np.ascontiguousarray(np.atleast_2d(points).reshape(-1, 3), dtype=np.float64)
        sizes = [int(np.prod(f.ufl_shape)) if f.ufl_shape else 1 for f in functions]
        k = sum(sizes)
        data = geometry.determine_point_ownership(self.mesh, pts, self._padding)
        src = np.asarray(data.src_owner, dtype=np.int64)
        dest_owner = np.asarray(data.dest_owner, dtype=np.int64)
        dest_pts = np.asarray(data.dest_points, dtype=np.float64).reshape(-1, 3)
        dest_cells = np.asarray(data.dest_cells, dtype=np.int32)
        vals = np.zeros((len(dest_pts), k))
        if len(dest_pts):
            col = 0
            for f, s in zip(functions, sizes, strict=True):
                vals[:, col : col + s] = f.eval(dest_pts, dest_cells).reshape(len(dest_pts), s)
                col += s
        size = self.comm.size
        send_counts = np.bincount(dest_owner, minlength=size) * k
        recv_counts = np.bincount(src[src >= 0], minlength=size) * k
        recv = np.zeros(int(recv_counts.sum()))
        self.comm.Alltoallv([np.ascontiguousarray(vals.ravel()), send_counts], [recv, recv_counts])
        out = np.zeros((len(pts), k))
        found = src >= 0
        # owners answer in the order of this rank's points, grouped by owner rank
        order = np.argsort(src[found], kind="stable")
        idx = np.flatnonzero(found)[order]
        out[idx] = recv.reshape(-1, k)
        result, col = [], 0
        for s in sizes:
            result.append(out[:, col : col + s])
            col += s
        return result, found
