"""Radial outlines: ``n`` arms or rounded petals around a disk hub (star, flower, disk).

Arm i (1-based) points along angle 2π(i−1)/n; the arms are cut by the hub
circle, so the hub/arm interfaces are circular arcs (curved: use
``mesh.order = 2`` for an accurate area). ``n = 0`` is a plain disk. An
optional central disk of ``clamp_radius`` is bonded.

Exact area: π R² for the hub plus, per arm, the integral over the arm axis
s of the arm's cross-width lying outside the hub circle,
∫ 2 max(0, h(s) − √(R² − s²)) ds for s < R plus 2h(s) for s ≥ R (adaptive
quadrature, relative error < 1e-12), plus π p²/2 for a rounded petal end of
radius p.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.integrate import quad

from magfem.geometry.outline import Outline, PlanarArm, add_polygon

__all__ = ["RadialOutline", "min_hub_radius"]


def min_hub_radius(n: int, width: float) -> float:
    """Smallest hub radius (m) for which ``n`` arms of ``width`` (m) meet only inside the hub.

    Two straight arms of half-width w/2 whose axes differ by 2π/n have
    crossing edges at distance (w/2)/sin(π/n) from the centre.
    """
    return 0.5 * width / math.sin(math.pi / n)


def _outside_circle_area(h: Callable[[float], float], radius: float, length: float) -> float:
    """Area of {(s, t): 0 <= s <= length, |t| <= h(s), s² + t² >= radius²} (m²)."""

    def width(s: float) -> float:
        inner = math.sqrt(max(radius * radius - s * s, 0.0)) if s < radius else 0.0
        return 2.0 * max(0.0, h(s) - inner)

    points = [radius] if radius < length else None
    value, _ = quad(width, 0.0, length, points=points, epsabs=0.0, epsrel=1e-13, limit=200)
    return float(value)


@dataclass(frozen=True)
class RadialOutline(Outline):
    """``n`` arms (star) or rounded petals (flower) around a disk hub of ``hub_radius`` (m).

    Star arms are trapezoids from the centre (width ``root_width``) to
    ``reach`` (width ``tip_width``); petals are strips of ``root_width``
    ending in a half disk, reaching ``reach`` from the centre. Arm cell
    groups are ``<prefix>_<i>``, tips ``tip_<prefix>_<i>``, the hub ``hub``.
    """

    n: int
    prefix: str  # "arm" or "petal"
    reach: float
    root_width: float
    tip_width: float
    hub_radius: float
    clamp_radius: float
    rounded: bool
    hub: str = "hub"

    def __post_init__(self) -> None:
        r = self.hub_radius
        arms = tuple(
            PlanarArm(
                f"{self.prefix}_{i + 1}",
                (r * math.cos(a), r * math.sin(a)),
                (math.cos(a), math.sin(a)),
                self.reach - r,
                f"tip_{self.prefix}_{i + 1}",
            )
            for i, a in enumerate(self._angles())
        )
        object.__setattr__(self, "arms", arms)
        one = 0.0
        if self.n and self.rounded:
            p = 0.5 * self.root_width
            end = self.reach - p
            one = _outside_circle_area(lambda s: p, r, end) + 0.5 * math.pi * p * p
        elif self.n:
            one = _outside_circle_area(self._half_width, r, self.reach)
        object.__setattr__(self, "area", math.pi * r * r + self.n * one)
        object.__setattr__(self, "curved", True)
        object.__setattr__(self, "clamped", self.clamp_radius > 0)
        object.__setattr__(self, "scale", 2 * self.reach)

    def _angles(self) -> list[float]:
        return [2 * math.pi * i / self.n for i in range(self.n)]

    def _half_width(self, s: float) -> float:
        return 0.5 * (self.root_width + (self.tip_width - self.root_width) * s / self.reach)

    def _add_arm(self, occ: Any) -> list[tuple[int, int]]:
        """One arm along +x, from the centre (before the hub is cut out)."""
        if self.rounded:
            p = 0.5 * self.root_width
            end = self.reach - p
            rect = occ.addRectangle(0.0, -p, 0.0, end, 2 * p)
            cap = occ.addDisk(end, 0.0, 0.0, p, p)
            arm, _ = occ.fuse([(2, rect)], [(2, cap)])
            return list(arm)
        h0, h1 = self._half_width(0.0), self._half_width(self.reach)
        return [(2, add_polygon(occ, [(0.0, -h0), (self.reach, -h1), (self.reach, h1), (0.0, h0)]))]

    def build(self, occ: Any) -> None:
        hub = occ.addDisk(0.0, 0.0, 0.0, self.hub_radius, self.hub_radius)
        for a in self._angles():
            arm = self._add_arm(occ)
            occ.rotate(arm, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, a)
            occ.cut(arm, [(2, hub)], removeObject=True, removeTool=False)
        if 0 < self.clamp_radius < self.hub_radius:
            occ.addDisk(0.0, 0.0, 0.0, self.clamp_radius, self.clamp_radius)

    def _arm_index(self, x: float, y: float) -> int:
        return round(math.atan2(y, x) / (2 * math.pi / self.n)) % self.n

    def cell_group(self, x: float, y: float) -> str:
        if not self.n or math.hypot(x, y) < self.hub_radius:
            return self.hub
        return f"{self.prefix}_{self._arm_index(x, y) + 1}"

    def tip_group(self, x: float, y: float) -> str | None:
        if not self.n:
            return None
        i = self._arm_index(x, y)
        name = f"tip_{self.prefix}_{i + 1}"
        if self.rounded:
            start = self.reach - 0.5 * self.root_width
            return name if math.hypot(x, y) > start + self.tol else None
        a = 2 * math.pi * i / self.n
        s = x * math.cos(a) + y * math.sin(a)
        return name if abs(s - self.reach) < self.tol else None

    def in_clamp(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Any:
        if self.clamp_radius <= 0:
            return np.zeros(np.shape(x), dtype=bool)
        return np.hypot(x, y) <= self.clamp_radius + self.tol

    def inset_clamp(self, inset: float) -> RadialOutline:
        if self.clamp_radius <= inset:
            raise ValueError(
                f"the bonded disk (radius {self.clamp_radius:g} m) is not larger than the "
                f"clamp inset {inset:g} m"
            )
        return dataclasses.replace(self, clamp_radius=self.clamp_radius - inset)
