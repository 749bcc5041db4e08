"""The reaction field of iron parts, as solved by :mod:`magfem.field.iron`, evaluated in 3D.

The FE solve gives the reaction potential u (B_reaction = −∇u in air, T) on
a ball (3D) or a half-disk of the (r, z) plane (axisymmetric) and, recovered
over the air by L² projection (:mod:`magfem.field.recovery`), continuous B
and ∇B. At a 3D point inside the air region the recovered values are
evaluated (collective, :class:`~magfem.field.points.PointEvaluator`); for an
axisymmetric solve the point is first taken to (r, z) of the symmetry axis
and the result turned back (:func:`magfem.field.analytic.axisymmetric_to_cartesian`).
Beyond the air region the reaction is the field of the iron's dipole moment
m = ∫_iron (B/µ0 − H) dV, placed at the region's centre (the far field the
Robin condition of the solve is matched to).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

import magfem.field.analytic as an
from magfem.field.iron_spec import IronSpec
from magfem.field.points import PointEvaluator
from magfem.field.source import SourceField

__all__ = ["AxisFrame", "ReactionField"]


class AxisFrame:
    """The symmetry axis of an axisymmetric solve: line through ``origin`` along ``axis``."""

    def __init__(self, origin: np.ndarray, axis: np.ndarray):
        self.origin = np.asarray(origin, dtype=float)
        self.axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
        helper = np.array([1.0, 0.0, 0.0]) if abs(self.axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x = helper - self.axis * (helper @ self.axis)
        x /= np.linalg.norm(x)
        self.Q = np.column_stack([x, np.cross(self.axis, x), self.axis])

    def local(self, points: np.ndarray) -> np.ndarray:
        """Points (N, 3) in the axis frame (local z along the axis)."""
        return (np.atleast_2d(points) - self.origin) @ self.Q

    def meridian(self, points: np.ndarray) -> np.ndarray:
        """(r, z, 0) of ``points`` (N, 3): the coordinates of the (r, z) mesh."""
        p = self.local(points)
        return np.column_stack([np.hypot(p[:, 0], p[:, 1]), p[:, 2], np.zeros(len(p))])


class ReactionField(SourceField):
    """Reaction of the iron parts to one load at nominal strength (collective; module docstring).

    Args:
        recovered: blocked Function on the air mesh: 3D [B (3), ∇B (9, row-major)];
            axisymmetric [B_r, B_z, ∂rB_r, ∂zB_r, ∂rB_z, ∂zB_z], T and T/m.
        iron_field: total B in the iron (DG vector Function; (B_r, B_z) if axisymmetric), T.
        moment: dipole moment of the magnetised iron (3,), A m².
        center: centre of the air region (3,), m; r_air: its radius, m.
        parts: the iron parts (for masks); cell_size: DG0 element size on the mesh, m.
        axis: the symmetry axis of an axisymmetric solve, or None in 3D.
        hessian_step: step (m) of the finite differences of ∇B for ∇∇B.
        info: numbers of the solve (dofs, iterations, timings) for reports.
    """

    collective = True

    def __init__(
        self,
        recovered: Any,
        iron_field: Any,
        *,
        moment: np.ndarray,
        center: np.ndarray,
        r_air: float,
        parts: Sequence[IronSpec],
        cell_size: Any,
        axis: AxisFrame | None,
        hessian_step: float,
        name: str,
        info: dict[str, float],
    ):
        self.recovered, self.iron_field = recovered, iron_field
        self.mesh = recovered.function_space.mesh
        self.moment = np.asarray(moment, dtype=float)
        self.center = np.asarray(center, dtype=float)
        self.r_air = float(r_air)
        self.parts = list(parts)
        self.cell_size = cell_size
        self.axis = axis
        self.hessian_step = float(hessian_step)
        self.name = name
        self.info = info
        self._eval = PointEvaluator(self.mesh)

    def _mesh_points(self, pts: np.ndarray) -> np.ndarray:
        return pts if self.axis is None else self.axis.meridian(pts)

    def field_and_gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pts = np.atleast_2d(points).reshape(-1, 3)
        near = np.linalg.norm(pts - self.center, axis=1) < 0.98 * self.r_air
        (v,), found = self._eval([self.recovered], self._mesh_points(pts[near]))
        use = np.flatnonzero(near)[found]
        v = v[found]
        B = np.zeros((len(pts), 3))
        G = np.zeros((len(pts), 3, 3))
        if self.axis is None:
            B[use], G[use] = v[:, :3], v[:, 3:].reshape(-1, 3, 3)
        else:
            Q = self.axis.Q
            b, g = an.axisymmetric_to_cartesian(
                self.axis.local(pts[use]), v[:, 0], v[:, 1], v[:, 2:]
            )
            B[use], G[use] = b @ Q.T, np.einsum("ia,nab,jb->nij", Q, g, Q)
        far = np.ones(len(pts), dtype=bool)
        far[use] = False
        if np.any(far):
            d = pts[far] - self.center
            B[far] = an.dipole_field(self.moment, d)
            G[far] = an.dipole_gradient(self.moment, d)
        return B, G

    def iron_flux_density(self, points: np.ndarray) -> np.ndarray:
        """Total B (N, 3), T, inside the iron at ``points`` (N, 3) (collective; 0 elsewhere)."""
        pts = np.atleast_2d(points).reshape(-1, 3)
        (v,), found = self._eval([self.iron_field], self._mesh_points(pts))
        if self.axis is None:
            return v * found[:, None]
        p = self.axis.local(pts)
        r = np.hypot(p[:, 0], p[:, 1])
        safe = np.where(r > 0, r, 1.0)
        c, s = np.where(r > 0, p[:, 0] / safe, 1.0), np.where(r > 0, p[:, 1] / safe, 0.0)
        loc = np.column_stack([v[:, 0] * c, v[:, 0] * s, v[:, 1]])
        return (loc @ self.axis.Q.T) * found[:, None]

    def inside(self, points: np.ndarray) -> np.ndarray:
        pts = np.atleast_2d(points).reshape(-1, 3)
        return np.any([p.inside(pts) for p in self.parts], axis=0)

    def unresolved(self, points: np.ndarray) -> np.ndarray:
        """Points within one element (its longest edge) of the iron, where the recovery of ∇B
        is one-sided.

        Collective (the element size is looked up on the distributed mesh).
        """
        pts = np.atleast_2d(points).reshape(-1, 3)
        (h,), found = self._eval([self.cell_size], self._mesh_points(pts))
        h = np.where(found, h[:, 0], 0.0)[:, None]
        steps = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])
        steps = steps / np.maximum(np.linalg.norm(steps, axis=1), 1.0)[:, None]
        return np.any([self.inside(pts + h * s) for s in steps], axis=0)
