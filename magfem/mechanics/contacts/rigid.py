"""Rigid analytic bodies: signed distances and normals of their shapes, and their keyframed motion.

The geometry of :mod:`magfem.mechanics.contacts.obstacle` (and of the cargo,
:mod:`magfem.mechanics.contacts.cargo`): :func:`signed_distance` gives, for
a shape's table, g(x) (m, positive on the side where the robot may be) and
the unit normal n = ∇g (UFL, of the current position); :class:`MotionSpec`
is a ``motion`` sub-table, whose :meth:`MotionSpec.placement` gives the
rigid placement and its rates at a time. The shapes and formulas are listed
in :mod:`magfem.mechanics.contacts.obstacle`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import ufl

from magfem.config import MISSING, CaseError, vector
from magfem.field.placement import frame, rotation

__all__ = [
    "MotionSpec",
    "ObstaclePlacement",
    "box_frame",
    "describe_motion",
    "describe_shape",
    "signed_distance",
]


class ObstaclePlacement(NamedTuple):
    """An obstacle's placement x = R (y − p) + p + d and its rates at one time (SI).

    Attributes:
        R: rotation (3, 3). pivot: p (3,). offset: d (3,).
        velocity: d' (3,) (m/s). spin: ω (3,) (rad/s).
    """

    R: npt.NDArray[np.float64]
    pivot: npt.NDArray[np.float64]
    offset: npt.NDArray[np.float64]
    velocity: npt.NDArray[np.float64]
    spin: npt.NDArray[np.float64]


@dataclass(frozen=True)
class MotionSpec:
    """Rigid motion of an obstacle: keyframe offsets ``positions`` (m) and ``angles`` (rad)."""

    times: tuple[float, ...] = vector(unit="s", length=None, doc="keyframe times, increasing")
    positions: tuple[tuple[float, ...], ...] = vector(
        (), "m", length=None, doc="offset [x, y, z] of the obstacle at each time"
    )
    angles: tuple[float, ...] = vector(
        (), "rad", length=None, doc="rotation about rotation_axis through pivot at each time"
    )
    rotation_axis: tuple[float, ...] = vector(
        (0.0, 0.0, 1.0), "", nonzero=True, doc="axis of the angles"
    )
    pivot: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m", doc="point the angles turn about")

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        if t.size < 1 or np.any(np.diff(t) <= 0):
            raise CaseError("times", list(self.times), "must be one or more increasing times")
        if not self.positions and not self.angles:
            raise CaseError("positions", MISSING, "give positions and/or angles")
        for key in ("positions", "angles"):
            values = getattr(self, key)
            if values and len(values) != t.size:
                raise CaseError(key, list(values), f"must have one entry per time ({t.size})")
        for i, p in enumerate(self.positions):
            if len(p) != 3 or not all(math.isfinite(float(v)) for v in p):
                raise CaseError(f"positions[{i}]", p, "must be 3 finite numbers (m)")

    @property
    def turns(self) -> bool:
        """Whether the motion rotates the obstacle."""
        return any(a != 0.0 for a in self.angles)

    def placement(self, t: float) -> ObstaclePlacement:
        """The placement at time t; the rates of the segment t lies in (0 outside)."""
        times = np.asarray(self.times, dtype=float)
        n = times.size
        pos = np.asarray(self.positions, dtype=float) if self.positions else np.zeros((n, 3))
        ang = np.asarray(self.angles, dtype=float) if self.angles else np.zeros(n)
        axis = np.asarray(self.rotation_axis, dtype=float)
        axis = axis / np.linalg.norm(axis)
        offset = np.array([np.interp(t, times, pos[:, k]) for k in range(3)])
        angle = float(np.interp(t, times, ang))
        k = int(np.searchsorted(times, t, side="left"))
        velocity, spin = np.zeros(3), np.zeros(3)
        if 0 < k < n:
            span = times[k] - times[k - 1]
            velocity = (pos[k] - pos[k - 1]) / span
            spin = axis * (ang[k] - ang[k - 1]) / span
        return ObstaclePlacement(
            rotation(axis, angle), np.asarray(self.pivot, float), offset, velocity, spin
        )

    def offset(self, t: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(offset m, velocity m/s) at time t; the velocity of the segment t lies in."""
        placed = self.placement(t)
        return placed.offset, placed.velocity


def _unit(v: Any) -> Any:
    return v / ufl.sqrt(ufl.dot(v, v))


def signed_distance(spec: Any, x: Any, offset: Any, gdim: int) -> tuple[Any, Any]:
    """(g, n): signed distance (m, positive where the robot may be) and unit normal (UFL).

    Args:
        spec: the obstacle's table (``ObstacleSpec``: shape, side and the shape's keys).
        x: current position, UFL gdim-vector (m).
        offset: the obstacle's translation, UFL gdim-vector (m).
    """

    def vec(v: Sequence[float]) -> Any:
        arr = np.asarray(v, dtype=float)
        return ufl.as_vector((arr if gdim == 3 else arr[::2]).tolist())

    sign = -1.0 if spec.side == "inside" else 1.0
    if spec.shape == "box":
        g, n = _box(spec, x - vec(spec.center) - offset, gdim)
        return sign * g, sign * n
    if spec.shape == "half_space":
        assert spec.point is not None and spec.normal is not None
        n = _unit(vec(spec.normal))
        return ufl.dot(x - vec(spec.point) - offset, n), n
    if spec.shape == "sphere":
        assert spec.center is not None and spec.radius is not None
        d = x - vec(spec.center) - offset
        dist = ufl.sqrt(ufl.dot(d, d) + (1e-9 * spec.radius) ** 2)
        return sign * (dist - spec.radius), sign * d / dist
    assert spec.axis is not None
    a = _unit(vec(spec.axis))
    origin = spec.point if spec.shape == "cylinder" else spec.apex
    assert origin is not None
    d = x - vec(origin) - offset
    along = ufl.dot(d, a)
    radial = d - along * a
    scale = spec.radius if spec.radius is not None else 1e-3
    rho = ufl.sqrt(ufl.dot(radial, radial) + (1e-9 * scale) ** 2)
    e_rho = radial / rho
    if spec.shape == "cylinder":
        assert spec.radius is not None
        return sign * (rho - spec.radius), sign * e_rho
    assert spec.half_angle is not None
    c, s = math.cos(spec.half_angle), math.sin(spec.half_angle)
    return sign * (rho * c - along * s), sign * (c * e_rho - s * a)


def box_frame(spec: Any, gdim: int) -> npt.NDArray[np.float64]:
    """Rotation (gdim, gdim) whose columns are the box's edges in the mesh's coordinates.

    Raises:
        CaseError: a strip (gdim 2) and a box none of whose edges is along y.
    """
    axis = np.asarray(spec.axis if spec.axis is not None else (0.0, 0.0, 1.0), dtype=float)
    Rb = frame(axis / np.linalg.norm(axis), spec.roll or 0.0)
    if gdim == 3:
        return Rb
    if not np.isclose(abs(Rb[1, 1]), 1.0, atol=1e-9):
        raise CaseError(
            f"obstacle '{spec.name}'.axis",
            spec.axis,
            "the strip model (x-z side view) needs the box's y edge along y",
        )
    return Rb[np.ix_([0, 2], [0, 2])]


def _box(spec: Any, d: Any, gdim: int) -> tuple[Any, Any]:
    """Exact signed distance and normal of the box (outside side) at the offsets d (UFL)."""
    Rb = box_frame(spec, gdim)
    half = 0.5 * np.asarray(spec.size, dtype=float)[[0, 1, 2] if gdim == 3 else [0, 2]]
    p = [sum(float(Rb[k, i]) * d[k] for k in range(gdim)) for i in range(gdim)]  # Rbᵀ d
    q = [abs(p[i]) - half[i] for i in range(gdim)]
    out = [ufl.max_value(qi, 0.0) for qi in q]
    length = ufl.sqrt(sum(o * o for o in out) + (1e-9 * float(half.min())) ** 2)
    inner = functools.reduce(ufl.max_value, q)
    outside = ufl.gt(inner, 0.0)
    g = ufl.conditional(outside, length, inner)
    nearest = []  # the face of the largest q_i (first on ties)
    for i in range(gdim):
        first = [ufl.gt(q[i], q[j]) for j in range(i)] + [
            ufl.ge(q[i], q[j]) for j in range(i + 1, gdim)
        ]
        pick = functools.reduce(ufl.And, first)
        nearest.append(ufl.conditional(pick, ufl.sign(p[i]), 0.0))
    local = [
        ufl.conditional(outside, ufl.sign(p[i]) * out[i] / length, nearest[i]) for i in range(gdim)
    ]
    n = ufl.as_vector([sum(float(Rb[i, k]) * local[k] for k in range(gdim)) for i in range(gdim)])
    return g, n


def describe_shape(spec: Any) -> str:
    """``shape, its dimensions (mm)`` of an obstacle or a cargo, for ``magfem check``."""

    def mm(v: Any) -> str:
        if isinstance(v, (tuple, list)):
            return "(" + ", ".join(f"{1e3 * x:.3g}" for x in v) + ") mm"
        return f"{1e3 * v:.3g} mm"

    keys = {
        "half_space": ("point", "normal"),
        "sphere": ("center", "radius"),
        "cylinder": ("point", "axis", "radius"),
        "cone": ("apex", "axis", "half_angle"),
        "box": ("center", "size"),
    }[spec.shape]
    parts = []
    for key in keys:
        v = getattr(spec, key)
        if key in ("normal", "axis"):
            parts.append(f"{key} ({', '.join(f'{x:g}' for x in v)})")
        elif key == "half_angle":
            parts.append(f"half-angle {math.degrees(v):.3g} deg")
        else:
            parts.append(f"{key} {mm(v)}")
    return f"{spec.shape}, " + ", ".join(parts)


def describe_motion(motion: MotionSpec | None) -> str:
    """``, moving (K keyframes to t s)`` or '' for a fixed part."""
    if motion is None:
        return ""
    what = "moving and turning" if motion.turns else "moving"
    return f", {what} ({len(motion.times)} keyframes to {motion.times[-1]:g} s)"
