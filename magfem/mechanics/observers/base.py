"""What every observer of a run is: named history columns at the accepted state.

:mod:`.arms` (angles, midline shape), :mod:`.strain` (largest strain,
energy density), :mod:`.energies` and :mod:`.field` observe a run;
contacts observe themselves (:meth:`magfem.mechanics.contacts.base.Contact.observe`).
:mod:`.summary` turns a history into the run's summary scalars.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from dolfinx import fem, geometry
from mpi4py import MPI

__all__ = ["Observer", "PointEvaluator"]


class Observer:
    """Gives history columns (SI units) at the accepted state of a run."""

    def columns(self) -> list[str]:
        """The column names, in the order :meth:`observe` gives them."""
        return []

    def observe(self, t: float) -> dict[str, float]:
        """The values at time t (collective; identical on every rank)."""
        return {}


class PointEvaluator:
    """Evaluate a Function at fixed reference points on every rank (collective).

    Args:
        function_space: space of the functions to evaluate.
        points: (N, 3) reference points (m; strips: (x, z, 0)).

    Raises:
        ValueError: a point lies outside the mesh.
    """

    def __init__(self, function_space: fem.FunctionSpace, points: npt.NDArray[np.float64]):
        domain = function_space.mesh
        self.comm = domain.comm
        self.points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        tree = geometry.bb_tree(domain, domain.topology.dim)
        candidates = geometry.compute_collisions_points(tree, self.points)
        colliding = geometry.compute_colliding_cells(domain, candidates, self.points)
        self.local_index: list[int] = []
        self.cells: list[int] = []
        for i in range(len(self.points)):
            links = colliding.links(i)
            if len(links) > 0:
                self.local_index.append(i)
                self.cells.append(int(links[0]))
        found = np.zeros(len(self.points), dtype=np.int32)
        found[self.local_index] = 1
        total = np.zeros_like(found)
        self.comm.Allreduce(found, total, op=MPI.SUM)
        if np.any(total == 0):
            missing = self.points[total == 0]
            raise ValueError(f"points outside the mesh: {missing.tolist()}")

    def __call__(self, f: fem.Function) -> npt.NDArray[np.float64]:
        """Values (N, value_size) of ``f`` at the points, identical on every rank."""
        size = int(np.prod(f.ufl_shape)) if f.ufl_shape else 1
        local = np.zeros((len(self.points), size))
        have = np.zeros(len(self.points))
        if self.cells:
            vals = f.eval(self.points[self.local_index], np.array(self.cells, dtype=np.int32))
            local[self.local_index] = np.asarray(vals).reshape(len(self.cells), size)
            have[self.local_index] = 1.0
        total = np.zeros_like(local)
        count = np.zeros_like(have)
        self.comm.Allreduce(local, total, op=MPI.SUM)
        self.comm.Allreduce(have, count, op=MPI.SUM)
        return total / count[:, None]  # points on shared cells: identical values, averaged
