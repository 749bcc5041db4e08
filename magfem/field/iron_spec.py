"""Magnetizable (soft-iron) parts of the ``[[field.iron]]`` array: shapes and B-H laws.

Each entry has a ``kind`` and the keys of that kind (lengths in m)::

    [[field.iron]]
    kind = "tweezers"          # sphere | rod | needle | box | tweezers
    tip = [0, 0, 0.004]        # midpoint between the two tips
    axis = [0, 0, 1]           # from the tips towards the handle
    permeability = 1000        # relative (initial) permeability
    saturation = "1.8 T"       # optional: nonlinear B-H law (below)
    motion = "approach"        # optional: a [[field.motions]] entry

========== ==============================================================
``sphere`` ``center``, ``radius``
``rod``    ``center``, ``axis``, ``radius``, ``length`` (a cylinder)
``needle`` ``tip``, ``axis`` (tip → shank), ``radius``, ``length`` (of the
           cylindrical shank), ``tip_length`` (cone), ``tip_radius``
           (radius of its flat end)
``box``    ``center``, ``axis`` (local z), ``roll``, ``size`` (a plate)
``tweezers`` ``tip``, ``axis``, ``roll`` (local x = the direction the two
           prongs open in), ``length`` (prong), ``width`` (prong width at the
           handle), ``tip_width``, ``thickness``, ``opening`` (gap between the
           tips), ``spread`` (outer width of the handle), ``handle_length``
========== ==============================================================

B-H law (isotropic): linear, B = µ0 µr H, with ``permeability`` = µr; or,
when ``saturation`` J_s is given, B = µ0 H + (2 J_s/π) arctan(π (µr − 1) µ0 H
/ (2 J_s)) along H (initial relative permeability µr, polarisation
saturating at J_s; smooth and odd, so Newton converges and a reversed
source gives the reversed field); or a measured curve, ``bh_h`` (A/m) and
``bh_b`` (T) from (0, 0), interpolated monotonically with the straight
continuation of slope µ0 beyond its last point (:mod:`magfem.field.bh_table`;
``permeability`` is then the µr of the linear solve that starts Newton).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from magfem.config import MISSING, CaseError, build_fields, option, quantity, vector
from magfem.field.bh_table import BHCurve
from magfem.field.placement import frame
from magfem.geometry.sources import (
    Ball,
    Box,
    Frustum,
    HalfDisk,
    IronBody,
    IronProfile,
    Polygon,
    RuledSolid,
)

__all__ = [
    "IRON_KINDS",
    "BoxIronSpec",
    "IronSpec",
    "NeedleIronSpec",
    "RodIronSpec",
    "SphereIronSpec",
    "TweezersIronSpec",
]

IRON_KINDS = ("sphere", "rod", "needle", "box", "tweezers")


def _unit(v: tuple[float, ...]) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    return a / np.linalg.norm(a)


@dataclass(frozen=True, kw_only=True)
class IronSpec(ABC):
    """Base of the ``[[field.iron]]`` entries; ``kind`` selects the subclass."""

    kind: str = option("sphere", IRON_KINDS)
    permeability: float = quantity(1000.0, "", ge=1.0, doc="relative (initial) permeability")
    saturation: float | None = quantity(None, "T", gt=0.0, doc="saturation polarisation J_s")
    bh_h: tuple[float, ...] | None = vector(
        None, "A/m", length=None, doc="B-H table: H values from 0, increasing (with bh_b)"
    )
    bh_b: tuple[float, ...] | None = vector(
        None, "T", length=None, doc="B-H table: B values from 0, increasing (with bh_h)"
    )
    motion: str = option("", doc="name of a [[field.motions]] entry that moves it ('' = fixed)")

    KIND: ClassVar[str] = ""

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> IronSpec:
        classes = {c.KIND: c for c in _IRON_CLASSES}
        kind = table.get("kind", MISSING)
        if not isinstance(kind, str) or kind not in classes:
            raise CaseError(
                f"{where}.kind", kind, "unknown iron kind; must be one of " + ", ".join(IRON_KINDS)
            )
        spec = build_fields(classes[kind], table, where)
        try:
            spec.bh_curve()
        except CaseError as err:
            raise CaseError(f"{where}.{err.key}", err.value, err.problem) from None
        return spec

    @property
    def linear(self) -> bool:
        """True for a linear B-H law (no ``saturation``, no B-H table)."""
        return self.saturation is None and self.bh_h is None

    def bh_curve(self) -> BHCurve | None:
        """The tabulated B-H curve, or None; CaseError naming the key if the table is invalid."""
        if self.bh_h is None and self.bh_b is None:
            return None
        if self.bh_h is None or self.bh_b is None:
            missing = "bh_h" if self.bh_h is None else "bh_b"
            raise CaseError(missing, MISSING, "a B-H table needs both bh_h and bh_b")
        if self.saturation is not None:
            raise CaseError(
                "saturation", self.saturation, "give saturation or a B-H table, not both"
            )
        return BHCurve.from_table(self.bh_h, self.bh_b)

    # -- geometry (reference placement) ----------------------------------------------------
    @abstractmethod
    def inside(self, points: np.ndarray) -> np.ndarray:
        """Mask (N,) of ``points`` (N, 3) inside the part."""

    @abstractmethod
    def body(self, name: str) -> IronBody:
        """The gmsh description of the part as group ``name``."""

    def profile(self, origin: np.ndarray, axis: np.ndarray, name: str) -> IronProfile | None:
        """Meridian (r, z) section about the line (origin, axis), or None if not axisymmetric."""
        return None

    @abstractmethod
    def sample_points(self) -> np.ndarray:
        """Points (N, 3) of the part's surface and volume (overlap checks, view extents)."""

    @abstractmethod
    def min_feature(self) -> float:
        """Smallest dimension, m (default element size at the surface)."""

    def tip_point(self) -> np.ndarray:
        """The point of the part a robot is brought to (3,), m."""
        return np.mean(self.sample_points(), axis=0)


def _on_line(p: np.ndarray, origin: np.ndarray, axis: np.ndarray, tol: float) -> bool:
    d = p - origin
    return bool(np.linalg.norm(d - (d @ axis) * axis) <= tol)


def _parallel(a: np.ndarray, b: np.ndarray) -> float:
    """+1 or −1 if unit vectors a, b are parallel (to 1e-9), else 0."""
    c = float(a @ b)
    return math.copysign(1.0, c) if abs(abs(c) - 1.0) < 1e-9 else 0.0


@dataclass(frozen=True, kw_only=True)
class SphereIronSpec(IronSpec):
    """An iron sphere."""

    kind: str = option("sphere", ("sphere",))
    center: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m")
    radius: float = quantity(5e-3, "m", gt=0.0)

    KIND: ClassVar[str] = "sphere"

    def inside(self, points: np.ndarray) -> np.ndarray:
        d = np.atleast_2d(points) - np.asarray(self.center)
        return np.linalg.norm(d, axis=1) <= self.radius

    def body(self, name: str) -> IronBody:
        return IronBody(name, (Ball(tuple(self.center), self.radius),))

    def profile(self, origin: np.ndarray, axis: np.ndarray, name: str) -> IronProfile | None:
        c = np.asarray(self.center, dtype=float)
        if not _on_line(c, origin, axis, 1e-9 * self.radius):
            return None
        return IronProfile(name, (HalfDisk(float((c - origin) @ axis), self.radius),))

    def sample_points(self) -> np.ndarray:
        dirs = np.vstack([np.eye(3), -np.eye(3), np.zeros((1, 3))])
        return np.asarray(self.center) + self.radius * dirs

    def min_feature(self) -> float:
        return 2 * self.radius


@dataclass(frozen=True, kw_only=True)
class RodIronSpec(IronSpec):
    """An iron cylinder (rod)."""

    kind: str = option("rod", ("rod",))
    center: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m")
    axis: tuple[float, ...] = vector((0.0, 0.0, 1.0), "", nonzero=True)
    radius: float = quantity(1e-3, "m", gt=0.0)
    length: float = quantity(20e-3, "m", gt=0.0)

    KIND: ClassVar[str] = "rod"

    def inside(self, points: np.ndarray) -> np.ndarray:
        d = np.atleast_2d(points) - np.asarray(self.center)
        a = _unit(self.axis)
        z = d @ a
        r = np.linalg.norm(d - np.outer(z, a), axis=1)
        return (np.abs(z) <= self.length / 2) & (r <= self.radius)

    def body(self, name: str) -> IronBody:
        a = _unit(self.axis)
        base = np.asarray(self.center) - a * self.length / 2
        return IronBody(
            name, (Frustum(tuple(base), tuple(a * self.length), self.radius, self.radius),)
        )

    def profile(self, origin: np.ndarray, axis: np.ndarray, name: str) -> IronProfile | None:
        c = np.asarray(self.center, dtype=float)
        if not (
            _parallel(_unit(self.axis), axis) and _on_line(c, origin, axis, 1e-9 * self.length)
        ):
            return None
        zc = float((c - origin) @ axis)
        z0, z1, R = zc - self.length / 2, zc + self.length / 2, self.radius
        return IronProfile(name, (Polygon(((0.0, z0), (R, z0), (R, z1), (0.0, z1))),))

    def sample_points(self) -> np.ndarray:
        a = _unit(self.axis)
        F = frame(a)
        phi = np.linspace(0, 2 * math.pi, 8, endpoint=False)
        ring = self.radius * (np.outer(np.cos(phi), F[:, 0]) + np.outer(np.sin(phi), F[:, 1]))
        zs = np.linspace(-self.length / 2, self.length / 2, 5)
        pts = [np.asarray(self.center) + z * a + ring for z in zs]
        return np.vstack([*pts, np.asarray(self.center) + np.outer(zs, a)])

    def min_feature(self) -> float:
        return min(2 * self.radius, self.length)


@dataclass(frozen=True, kw_only=True)
class NeedleIronSpec(IronSpec):
    """A rod ending in a cone (a magnetic needle or pole tip); ``axis`` points from the tip."""

    kind: str = option("needle", ("needle",))
    tip: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m", doc="centre of the flat tip end")
    axis: tuple[float, ...] = vector((0.0, 0.0, 1.0), "", nonzero=True)
    radius: float = quantity(1e-3, "m", gt=0.0)
    length: float = quantity(20e-3, "m", gt=0.0, doc="cylindrical shank")
    tip_length: float = quantity(3e-3, "m", gt=0.0, doc="cone")
    tip_radius: float = quantity(0.1e-3, "m", gt=0.0, doc="radius of the flat tip end")

    KIND: ClassVar[str] = "needle"

    def __post_init__(self) -> None:
        if not self.tip_radius < self.radius:
            raise CaseError("tip_radius", self.tip_radius, f"must be < radius ({self.radius:g} m)")

    def _zr(self, z: np.ndarray) -> np.ndarray:
        """Outer radius at distance z from the tip along the axis."""
        t = np.clip(z / self.tip_length, 0.0, 1.0)
        return self.tip_radius + (self.radius - self.tip_radius) * t

    def inside(self, points: np.ndarray) -> np.ndarray:
        d = np.atleast_2d(points) - np.asarray(self.tip)
        a = _unit(self.axis)
        z = d @ a
        r = np.linalg.norm(d - np.outer(z, a), axis=1)
        return (z >= 0) & (z <= self.tip_length + self.length) & (r <= self._zr(z))

    def body(self, name: str) -> IronBody:
        a = _unit(self.axis)
        tip = np.asarray(self.tip, dtype=float)
        cone = Frustum(tuple(tip), tuple(a * self.tip_length), self.tip_radius, self.radius)
        shank = Frustum(
            tuple(tip + a * self.tip_length), tuple(a * self.length), self.radius, self.radius
        )
        return IronBody(name, (cone, shank))

    def profile(self, origin: np.ndarray, axis: np.ndarray, name: str) -> IronProfile | None:
        tip = np.asarray(self.tip, dtype=float)
        s = _parallel(_unit(self.axis), axis)
        if not (s and _on_line(tip, origin, axis, 1e-9 * self.length)):
            return None
        z0 = float((tip - origin) @ axis)
        z1, z2 = z0 + s * self.tip_length, z0 + s * (self.tip_length + self.length)
        pts = ((0.0, z0), (self.tip_radius, z0), (self.radius, z1), (self.radius, z2), (0.0, z2))
        return IronProfile(name, (Polygon(pts if s > 0 else pts[::-1]),))

    def sample_points(self) -> np.ndarray:
        a = _unit(self.axis)
        F = frame(a)
        phi = np.linspace(0, 2 * math.pi, 8, endpoint=False)
        zs = np.linspace(0.0, self.tip_length + self.length, 7)
        out = [np.asarray(self.tip) + np.outer(zs, a)]
        for z in zs:
            ring = self._zr(np.array(z)) * (
                np.outer(np.cos(phi), F[:, 0]) + np.outer(np.sin(phi), F[:, 1])
            )
            out.append(np.asarray(self.tip) + z * a + ring)
        return np.vstack(out)

    def min_feature(self) -> float:
        return 2 * self.tip_radius

    def tip_point(self) -> np.ndarray:
        return np.asarray(self.tip, dtype=float)


@dataclass(frozen=True, kw_only=True)
class BoxIronSpec(IronSpec):
    """An iron box (a plate or a pole piece)."""

    kind: str = option("box", ("box",))
    center: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m")
    axis: tuple[float, ...] = vector((0.0, 0.0, 1.0), "", nonzero=True, doc="local z")
    roll: float = quantity(0.0, "rad", doc="rotation of the local x edge about axis")
    size: tuple[float, ...] = vector((20e-3, 20e-3, 1e-3), "m", doc="local x, y, z edges")

    KIND: ClassVar[str] = "box"

    def __post_init__(self) -> None:
        if any(not s > 0.0 for s in self.size):
            raise CaseError("size", self.size, "all three edges must be > 0 m")

    def _frame(self) -> np.ndarray:
        return frame(_unit(self.axis), self.roll)

    def inside(self, points: np.ndarray) -> np.ndarray:
        loc = (np.atleast_2d(points) - np.asarray(self.center)) @ self._frame()
        return np.all(np.abs(loc) <= np.asarray(self.size) / 2, axis=1)

    def body(self, name: str) -> IronBody:
        rot = tuple(map(tuple, self._frame()))
        return IronBody(name, (Box(tuple(self.center), tuple(self.size), rot),))

    def sample_points(self) -> np.ndarray:
        g = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])
        return np.asarray(self.center) + (g * np.asarray(self.size) / 2) @ self._frame().T

    def min_feature(self) -> float:
        return float(min(self.size))


@dataclass(frozen=True, kw_only=True)
class TweezersIronSpec(IronSpec):
    """Tweezers: two tapered flat prongs joined by a handle block (module docstring).

    Local frame: z = ``axis`` from the tips (at ``tip``) to the handle, x the
    opening direction, y across the prongs' width.
    """

    kind: str = option("tweezers", ("tweezers",))
    tip: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m", doc="midpoint between the tips")
    axis: tuple[float, ...] = vector((0.0, 0.0, 1.0), "", nonzero=True)
    roll: float = quantity(0.0, "rad", doc="rotation of the opening direction about axis")
    length: float = quantity(40e-3, "m", gt=0.0, doc="prong length")
    width: float = quantity(4e-3, "m", gt=0.0, doc="prong width at the handle")
    tip_width: float = quantity(1e-3, "m", gt=0.0, doc="prong width at the tip")
    thickness: float = quantity(1e-3, "m", gt=0.0, doc="prong thickness")
    opening: float = quantity(2e-3, "m", gt=0.0, doc="gap between the tips")
    spread: float = quantity(8e-3, "m", gt=0.0, doc="outer width of the handle")
    handle_length: float = quantity(8e-3, "m", gt=0.0)

    KIND: ClassVar[str] = "tweezers"

    def __post_init__(self) -> None:
        if not self.spread >= 2 * self.thickness:
            raise CaseError(
                "spread", self.spread, f"must be >= 2 thickness ({2 * self.thickness:g} m)"
            )
        if not self.tip_width <= self.width:
            raise CaseError("tip_width", self.tip_width, f"must be <= width ({self.width:g} m)")

    def _frame(self) -> np.ndarray:
        return frame(_unit(self.axis), self.roll)

    def _local(self, points: np.ndarray) -> np.ndarray:
        return (np.atleast_2d(points) - np.asarray(self.tip)) @ self._frame()

    def _prong_corners(self, sign: float) -> np.ndarray:
        """Corners (8, 3) of one prong in the local frame: tip quad, then handle quad."""
        o, t, L = self.opening / 2, self.thickness, self.length
        h0, h1 = self.tip_width / 2, self.width / 2
        x_tip, x_handle = (o, o + t), (self.spread / 2 - t, self.spread / 2)
        quads = []
        for (xa, xb), z, hw in ((x_tip, 0.0, h0), (x_handle, L, h1)):
            quads.append(
                [[sign * xa, -hw, z], [sign * xb, -hw, z], [sign * xb, hw, z], [sign * xa, hw, z]]
            )
        return np.array(quads).reshape(8, 3)

    def inside(self, points: np.ndarray) -> np.ndarray:
        p = self._local(points)
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        L, o, t = self.length, self.opening / 2, self.thickness
        s = np.clip(z / L, 0.0, 1.0)
        x_in = o + (self.spread / 2 - t - o) * s
        half_w = self.tip_width / 2 + (self.width - self.tip_width) / 2 * s
        prong = (z >= 0) & (z <= L) & (np.abs(x) >= x_in) & (np.abs(x) <= x_in + t)
        prong &= np.abs(y) <= half_w
        handle = (z >= L) & (z <= L + self.handle_length) & (np.abs(x) <= self.spread / 2)
        return prong | (handle & (np.abs(y) <= self.width / 2))

    def body(self, name: str) -> IronBody:
        F, tip = self._frame(), np.asarray(self.tip, dtype=float)
        parts: list[Any] = []
        for sign in (1.0, -1.0):
            c = tip + self._prong_corners(sign) @ F.T
            parts.append(RuledSolid(tuple(map(tuple, c))))
        hc = tip + F @ np.array([0.0, 0.0, self.length + self.handle_length / 2])
        size = (self.spread, self.width, self.handle_length)
        parts.append(Box(tuple(hc), size, tuple(map(tuple, F))))
        return IronBody(name, tuple(parts))

    def sample_points(self) -> np.ndarray:
        F, tip = self._frame(), np.asarray(self.tip, dtype=float)
        loc = [self._prong_corners(s) for s in (1.0, -1.0)]
        L, H = self.length, self.handle_length
        g = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (0, 1)], dtype=float)
        loc.append(g * [self.spread / 2, self.width / 2, H] + [0, 0, L])
        return tip + np.vstack(loc) @ F.T

    def min_feature(self) -> float:
        return min(self.thickness, self.tip_width, self.opening)

    def tip_point(self) -> np.ndarray:
        return np.asarray(self.tip, dtype=float)


_IRON_CLASSES: tuple[type[IronSpec], ...] = (
    SphereIronSpec,
    RodIronSpec,
    NeedleIronSpec,
    BoxIronSpec,
    TweezersIronSpec,
)
