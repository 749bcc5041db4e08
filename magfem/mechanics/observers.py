"""Observables of a membrane run: bending angles, strain, energies, contact force.

Definitions (DESIGN.md, after Wang, Mao et al., Commun. Mater. 1, 67 (2020)):

* **Bending angle** of an arm: angle between the tangent of the deformed
  midline at the tip and the resting plane, seen from the side. With e the
  arm's in-plane direction and n the resting plane's normal (+z; the second
  axis of a strip), and x(s) = X(s) + u(X(s)) the deformed mid-thickness
  midline at arc length s from the root,
  θ = atan2((x(L) − x(L − δ))·n, (x(L) − x(L − δ))·e), δ = 10⁻³ L (a
  one-sided difference inside the last element, exact to O(δ) for the
  tangent of a P2 field). θ is unwrapped in time (:class:`AngleUnwrapper`),
  so it passes 90°, 180° and 270° continuously.
* **Largest nominal strain** ε_a = max over the arm of (λ_max − 1), λ_max
  the largest principal stretch (√ of the largest eigenvalue of C = FᵀF),
  sampled at the vertices of every cell (where bending strains peak) except
  those within one thickness of the clamped facets: the edge where a bonded
  patch ends is a stress singularity, whose FE strain (16.6 % on the default
  case, against a bending strain t/(2R) of ~1 %) measures the mesh, not the
  arm (:class:`StrainProbe`).
* Energy density ρE = 3 μ ε_a²/2 and power density ρW = f ρE
  (:func:`magfem.material.energy_density`), kinetic/elastic/magnetic/gravity
  energy (J; J per m of width for strips) and the resultant ground force (N).

Point evaluation works in parallel: every rank evaluates the points found in
its local cells, rank 0 combines them and broadcasts, so every rank holds
the same values.
"""

from __future__ import annotations

import math
from typing import Any

import basix
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, geometry
from mpi4py import MPI

from magfem.geometry.robot_mesh import Arm

__all__ = [
    "AngleUnwrapper",
    "PointEvaluator",
    "StrainProbe",
    "arm_angle_points",
    "bending_angle",
    "max_over_window",
]

TIP_OFFSET = 1e-3
"""δ/L of the tip-tangent difference (see the module docstring)."""


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


def arm_angle_points(arm: Arm, gdim: int) -> npt.NDArray[np.float64]:
    """The two midline points (2, 3) near the tip of ``arm`` whose chord gives the tangent."""
    root, e = np.asarray(arm.root, dtype=float), np.asarray(arm.direction, dtype=float)
    s1 = arm.length * (1.0 - 1e-9)  # just inside the tip face
    s0 = s1 - TIP_OFFSET * arm.length
    return np.array([root + s0 * e, root + s1 * e])


def bending_angle(
    x0: npt.NDArray[np.float64], x1: npt.NDArray[np.float64], arm: Arm, gdim: int
) -> float:
    """Angle (rad, in (−π, π]) of the chord x0 → x1 (deformed positions) against the rest plane.

    Args:
        x0, x1: deformed positions of the two points of :func:`arm_angle_points`,
            length gdim (m).
        arm: the arm (its in-plane direction e).
    """
    d = np.asarray(x1, dtype=float) - np.asarray(x0, dtype=float)
    e = np.asarray(arm.direction, dtype=float)[:gdim]
    if gdim == 3:
        along, normal = float(d @ e), float(d[2])
    else:
        along, normal = float(d[0] * e[0]), float(d[1])
    return math.atan2(normal, along)


class AngleUnwrapper:
    """Makes a sequence of angles in (−π, π] continuous (adds multiples of 2π)."""

    def __init__(self) -> None:
        self.last: float | None = None
        self.offset = 0.0

    def __call__(self, raw: float) -> float:
        if self.last is not None:
            jump = raw - self.last
            if jump > math.pi:
                self.offset -= 2 * math.pi
            elif jump < -math.pi:
                self.offset += 2 * math.pi
        self.last = raw
        return raw + self.offset


class StrainProbe:
    """Largest nominal strain max(λ_max − 1) at cell vertices away from the supports (collective).

    Args:
        u: displacement (m).
        exclude: (N, 3) reference points (m) of the supports (the vertices of
            the clamped facets), or None.
        radius: vertices within this distance (m) of an excluded point are not
            sampled.

    The bonded patch ends in a re-entrant edge where the strain of the
    continuum is singular (its FE value grows as the mesh is refined and says
    nothing about the arm): on the default case it read 16.6 % while the
    bending strain t/(2R) of the arm is ~1 %. The simulation excludes the
    vertices within one thickness of the clamped facets, so ε_a measures the
    arm (bending plus stretching).
    """

    def __init__(
        self,
        u: fem.Function,
        exclude: npt.NDArray[np.float64] | None = None,
        radius: float = 0.0,
    ):
        domain = u.function_space.mesh
        self.comm = domain.comm
        self.domain = domain
        gdim = domain.geometry.dim
        cell = domain.topology.cell_type
        points = basix.geometry(getattr(basix.CellType, cell.name))
        F = ufl.Identity(gdim) + ufl.grad(u)
        self.gdim = gdim
        self.expr = fem.Expression(F.T * F, points)
        n_local = domain.topology.index_map(domain.topology.dim).size_local
        self.cells = np.arange(n_local, dtype=np.int32)
        nv = len(points)
        # reference coordinates (cells, vertices, 3) of the sampled vertices (P1/P2 geometry:
        # the first nv geometry nodes of a cell are its vertices, in basix order)
        xyz = domain.geometry.x[domain.geometry.dofmaps[0][:n_local, :nv]]
        self.mask = np.ones((n_local, nv), dtype=bool)
        if exclude is not None and len(exclude) and radius > 0 and n_local:
            from scipy.spatial import cKDTree

            tree = cKDTree(np.asarray(exclude, dtype=float).reshape(-1, 3))
            dist, _ = tree.query(xyz.reshape(-1, 3))
            self.mask = (dist >= radius).reshape(n_local, nv)

    def __call__(self) -> float:
        """ε_a (dimensionless), identical on every rank (0 if every vertex is excluded)."""
        local = 0.0
        if self.cells.size and self.mask.any():
            C = np.asarray(self.expr.eval(self.domain, self.cells))
            C = C.reshape(-1, self.gdim, self.gdim)[self.mask.ravel()]
            lam_max = np.sqrt(np.max(np.linalg.eigvalsh(C), axis=1))
            local = float(np.max(lam_max)) - 1.0
        return float(self.comm.allreduce(local, op=MPI.MAX))


def max_over_window(
    times: npt.NDArray[np.float64], values: npt.NDArray[np.float64], t0: float, t1: float
) -> float:
    """max |value| over t0 <= t <= t1 (nan when no sample lies there)."""
    mask = (times >= t0 - 1e-12) & (times <= t1 + 1e-12)
    return float(np.max(np.abs(values[mask]))) if np.any(mask) else float("nan")


def assemble_scalars(forms: list[Any], comm: MPI.Comm) -> list[float]:
    """Assemble compiled scalar forms and sum them over ranks."""
    local = np.array([fem.assemble_scalar(f) for f in forms], dtype=float)
    total = np.zeros_like(local)
    comm.Allreduce(local, total, op=MPI.SUM)
    return total.tolist()
