"""Fields of single sources at nominal strength as numpy functions of 3D points.

:class:`SourceField` is what the field models combine: B (N, 3) in T and
∇B (N, 3, 3) in T/m (``G[n, i, j] = ∂B_i/∂x_j``) at points (N, 3) in m, in
the reference placement of the case file. The closed-form fields here
(:class:`UniformField`, :class:`CoilField`, :class:`RacetrackCoilField`,
:class:`CylinderMagnetField`, :class:`BlockMagnetField`) are exact and local to each rank; the iron
reaction fields (:mod:`magfem.field.reaction`) are collective. ∇∇B
(N, 3, 3, 3), only needed by the ``taylor2`` model, is the 4th-order central
difference of the gradient (exact gradients: error ~1e-10 of ∇∇B with the
default step of 1e-3 × the source size).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence

import numpy as np

import magfem.field.analytic as an
import magfem.field.racetrack as rt
from magfem.field.placement import frame

__all__ = [
    "BlockMagnetField",
    "CoilField",
    "CylinderMagnetField",
    "RacetrackCoilField",
    "SourceField",
    "SumField",
    "UniformField",
    "hessian_from_gradient",
]


def hessian_from_gradient(gradient, points: np.ndarray, step: float) -> np.ndarray:  # type: ignore[no-untyped-def]
    """∇∇B (N, 3, 3, 3) by 4th-order central differences of ``gradient(points) -> (N, 3, 3)``.

    Symmetrised in the two derivative indices; ``step`` in m.
    """
    p = np.atleast_2d(points).reshape(-1, 3)
    H = np.zeros((len(p), 3, 3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = step
        H[..., k] = (
            -gradient(p + 2 * e) + 8 * gradient(p + e) - 8 * gradient(p - e) + gradient(p - 2 * e)
        ) / (12 * step)
    return 0.5 * (H + H.transpose(0, 1, 3, 2))


class SourceField(ABC):
    """The field of one source (or one iron reaction) at nominal strength.

    Attributes:
        name: label for messages.
        uniform: True for a spatially uniform field.
        collective: True when evaluation is collective (every rank calls with its own points).
        hessian_step: step (m) of the finite differences for :meth:`hessian`.
    """

    name: str = "source"
    uniform: bool = False
    collective: bool = False
    hessian_step: float = 1e-5

    @abstractmethod
    def field_and_gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B (N, 3), ∇B (N, 3, 3)) at ``points`` (N, 3)."""

    def flux_density(self, points: np.ndarray) -> np.ndarray:
        """B (N, 3), T, at ``points`` (N, 3), m."""
        return self.field_and_gradient(points)[0]

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """∇B (N, 3, 3), T/m, at ``points`` (N, 3)."""
        return self.field_and_gradient(points)[1]

    def hessian(self, points: np.ndarray) -> np.ndarray:
        """∇∇B (N, 3, 3, 3), T/m², at ``points`` (N, 3)."""
        return hessian_from_gradient(self.gradient, points, self.hessian_step)

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Mask (N,) of ``points`` inside the source's body (field not meant for a robot there)."""
        return np.zeros(len(np.atleast_2d(points)), dtype=bool)

    def unresolved(self, points: np.ndarray) -> np.ndarray:
        """Mask (N,) of ``points`` closer to the source than its field is resolved."""
        return self.inside(points)


class UniformField(SourceField):
    """A spatially uniform flux density ``vector`` (3,), T."""

    uniform = True

    def __init__(self, vector: np.ndarray, name: str = "uniform"):
        self.vector = np.asarray(vector, dtype=float).reshape(3)
        self.name = name

    def field_and_gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = len(np.atleast_2d(points))
        return np.tile(self.vector, (n, 1)), np.zeros((n, 3, 3))

    def hessian(self, points: np.ndarray) -> np.ndarray:
        return np.zeros((len(np.atleast_2d(points)), 3, 3, 3))


class _Placed(SourceField):
    """A field given in a local frame (z = ``axis``) placed at ``center`` (3,), m."""

    def __init__(self, center: np.ndarray, axis: np.ndarray, roll: float, size: float, name: str):
        self.center = np.asarray(center, dtype=float)
        self.Q = frame(np.asarray(axis, dtype=float) / np.linalg.norm(axis), roll)
        self.size = float(size)
        self.hessian_step = 1e-3 * self.size
        self.name = name

    def _local(self, points: np.ndarray) -> np.ndarray:
        return (np.atleast_2d(points).reshape(-1, 3) - self.center) @ self.Q

    @abstractmethod
    def _local_field(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B, ∇B) in the local frame at local points p (N, 3)."""

    def field_and_gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        B, G = self._local_field(self._local(points))
        return B @ self.Q.T, np.einsum("ia,nab,jb->nij", self.Q, G, self.Q)


class CoilField(_Placed):
    """Thick coil(s) on one axis: windings (offset along the axis (m), current sign).

    Args:
        center, axis: placement (3,), m and direction.
        r1, r2, length: winding inner, outer radius and axial length, m.
        turns, current: turns per winding and current, A.
        windings: (offset, sign) of each winding; one centred winding by default.
    """

    def __init__(
        self,
        center: np.ndarray,
        axis: np.ndarray,
        r1: float,
        r2: float,
        length: float,
        turns: int,
        current: float,
        windings: Sequence[tuple[float, float]] = ((0.0, 1.0),),
        name: str = "coil",
    ):
        reach = max(abs(o) for o, _ in windings) + length / 2
        super().__init__(center, axis, 0.0, float(np.hypot(r2, reach)), name)
        self.r1, self.r2, self.length = r1, r2, length
        self.turns, self.current = turns, current
        self.windings = list(windings)

    def _local_field(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rho = np.hypot(p[:, 0], p[:, 1])
        B, G = np.zeros((len(p), 3)), np.zeros((len(p), 3, 3))
        for off, sign in self.windings:
            br, bz, d = an.thick_coil_local(
                self.r1, self.r2, self.length, self.turns, sign * self.current, rho, p[:, 2] - off
            )
            b, g = an.axisymmetric_to_cartesian(p, br, bz, d)
            B += b
            G += g
        return B, G

    def _winding_distance(self, points: np.ndarray) -> np.ndarray:
        p = self._local(points)
        rho = np.hypot(p[:, 0], p[:, 1])
        d = [
            an.winding_distance(self.r1, self.r2, self.length, rho, p[:, 2] - o)
            for o, _ in self.windings
        ]
        return np.min(d, axis=0)

    def inside(self, points: np.ndarray) -> np.ndarray:
        return self._winding_distance(points) <= 0.0

    def unresolved(self, points: np.ndarray) -> np.ndarray:
        return self._winding_distance(points) < an.coil_resolution(self.r1, self.r2)


class RacetrackCoilField(_Placed):
    """Racetrack coil (:mod:`magfem.field.racetrack`): winding offsets r1 < r2 from the spine
    rectangle of half-sides (cx, cy) in the local x-y plane, axial ``height``, all m;
    ``ampere_turns`` (A) counter-clockwise about ``axis``; ``roll`` turns the local x side."""

    def __init__(
        self,
        center: np.ndarray,
        axis: np.ndarray,
        half_sides: tuple[float, float],
        r1: float,
        r2: float,
        height: float,
        ampere_turns: float,
        roll: float = 0.0,
        name: str = "coil",
    ):
        self.cx, self.cy = (float(v) for v in half_sides)
        size = float(np.linalg.norm([self.cx + r2, self.cy + r2, height / 2]))
        super().__init__(center, axis, roll, size, name)
        self.r1, self.r2, self.height, self.ampere_turns = r1, r2, height, ampere_turns

    def _args(self) -> tuple[float, float, float, float, float]:
        return self.cx, self.cy, self.r1, self.r2, self.height

    def _local_field(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return rt.racetrack_local(*self._args(), self.ampere_turns, p)

    def flux_density(self, points: np.ndarray) -> np.ndarray:
        B, _ = rt.racetrack_local(*self._args(), self.ampere_turns, self._local(points), grad=False)
        return B @ self.Q.T

    def inside(self, points: np.ndarray) -> np.ndarray:
        return rt.racetrack_distance(*self._args(), self._local(points)) <= 0.0

    def unresolved(self, points: np.ndarray) -> np.ndarray:
        d = rt.racetrack_distance(*self._args(), self._local(points))
        return d < rt.racetrack_resolution(self.r1, self.r2)


class CylinderMagnetField(_Placed):
    """Axially magnetised cylinder magnet (radius, length in m; remanence in T)."""

    def __init__(
        self,
        center: np.ndarray,
        axis: np.ndarray,
        radius: float,
        length: float,
        remanence: float,
        name: str = "magnet",
    ):
        super().__init__(center, axis, 0.0, float(np.hypot(radius, length / 2)), name)
        self.radius, self.length, self.remanence = radius, length, remanence

    def _local_field(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rho = np.hypot(p[:, 0], p[:, 1])
        br, bz, d = an.cylinder_magnet_local(self.radius, self.length, self.remanence, rho, p[:, 2])
        return an.axisymmetric_to_cartesian(p, br, bz, d)

    def inside(self, points: np.ndarray) -> np.ndarray:
        p = self._local(points)
        return (np.hypot(p[:, 0], p[:, 1]) <= self.radius) & (np.abs(p[:, 2]) <= self.length / 2)


class BlockMagnetField(_Placed):
    """Block magnet (edges ``size`` (3,) along local x, y, z; magnetised along local z)."""

    def __init__(
        self,
        center: np.ndarray,
        axis: np.ndarray,
        size: np.ndarray,
        remanence: float,
        roll: float = 0.0,
        name: str = "magnet",
    ):
        self.half = np.asarray(size, dtype=float) / 2
        super().__init__(center, axis, roll, float(np.linalg.norm(self.half)), name)
        self.remanence = remanence

    def _local_field(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return an.block_magnet_local(self.half, self.remanence, p)

    def inside(self, points: np.ndarray) -> np.ndarray:
        return np.all(np.abs(self._local(points)) <= self.half, axis=1)


class SumField(SourceField):
    """The sum of ``fields`` (e.g. a magnet and the iron's reaction to it)."""

    def __init__(self, fields: Sequence[SourceField], name: str):
        self.fields = list(fields)
        self.name = name
        self.uniform = all(f.uniform for f in self.fields)
        self.collective = any(f.collective for f in self.fields)
        self.hessian_step = min(f.hessian_step for f in self.fields)

    def field_and_gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pts = np.atleast_2d(points).reshape(-1, 3)
        B, G = np.zeros((len(pts), 3)), np.zeros((len(pts), 3, 3))
        for f in self.fields:
            b, g = f.field_and_gradient(pts)
            B += b
            G += g
        return B, G

    def hessian(self, points: np.ndarray) -> np.ndarray:
        return sum(
            (f.hessian(points) for f in self.fields),
            np.zeros((len(np.atleast_2d(points)), 3, 3, 3)),
        )

    def inside(self, points: np.ndarray) -> np.ndarray:
        return np.any([f.inside(points) for f in self.fields], axis=0)

    def unresolved(self, points: np.ndarray) -> np.ndarray:
        return np.any([f.unresolved(points) for f in self.fields], axis=0)
