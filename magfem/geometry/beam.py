"""Beam-like outlines: arms along ±x whose width varies linearly (polygons).

Used by the one-arm shapes (rectangle, trapezoid, triangles), the two-arm
strips (two-arm rectangle, bow tie) and the free membrane. Each arm is cut
into polygon pieces at the end of its clamp strip and, for a pointed arm,
at the start of its tip zone (:data:`magfem.geometry.outline.TIP_ZONE`).
Exact area: Σ length (root_width + tip_width)/2 (trapezoid formula).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from magfem.geometry.outline import TIP_ZONE, Outline, PlanarArm, add_polygon

__all__ = ["BeamArm", "BeamOutline", "one_arm", "two_arms"]


class BeamArm(NamedTuple):
    """An arm along ``sign``·x starting at x = ``x_root`` with linearly varying width (m).

    ``tip_width = 0`` makes a pointed arm (apex); ``clamp_length`` is the
    bonded strip from the root (0 = none).
    """

    name: str
    x_root: float
    sign: int
    length: float
    root_width: float
    tip_width: float
    clamp_length: float

    @property
    def pointed(self) -> bool:
        return self.tip_width == 0.0

    def half_width(self, s: float) -> float:
        """Half width at distance ``s`` from the root along the arm."""
        return 0.5 * (self.root_width + (self.tip_width - self.root_width) * s / self.length)

    def cuts(self) -> list[float]:
        """Distances from the root where the arm is split into pieces."""
        out = [0.0]
        if self.clamp_length > 0:
            out.append(self.clamp_length)
        if self.pointed:
            out.append((1 - TIP_ZONE) * self.length)
        out.append(self.length)
        return out

    def s_of(self, x: Any) -> Any:
        """Distance from the root along the arm of the abscissa ``x`` (scalar or array)."""
        return self.sign * (x - self.x_root)


def _tip_name(arm: str) -> str:
    return "tip" if arm in ("arm", "body") else f"tip_{arm}"


@dataclass(frozen=True)
class BeamOutline(Outline):
    """Arms along ±x; see :class:`BeamArm`."""

    beams: tuple[BeamArm, ...]

    def __post_init__(self) -> None:
        arms = tuple(
            PlanarArm(b.name, (b.x_root, 0.0), (float(b.sign), 0.0), b.length, _tip_name(b.name))
            for b in self.beams
        )
        object.__setattr__(self, "arms", arms)
        area = sum(0.5 * b.length * (b.root_width + b.tip_width) for b in self.beams)
        object.__setattr__(self, "area", area)
        object.__setattr__(self, "curved", False)
        object.__setattr__(self, "clamped", any(b.clamp_length > 0 for b in self.beams))
        scale = max(max(b.length, b.root_width, b.tip_width) for b in self.beams)
        object.__setattr__(self, "scale", scale)

    def build(self, occ: Any) -> None:
        for b in self.beams:
            for s0, s1 in itertools.pairwise(b.cuts()):
                x0, x1 = b.x_root + b.sign * s0, b.x_root + b.sign * s1
                h0, h1 = b.half_width(s0), b.half_width(s1)
                if h1 == 0.0:
                    pts = [(x0, -h0), (x1, 0.0), (x0, h0)]
                else:
                    pts = [(x0, -h0), (x1, -h1), (x1, h1), (x0, h0)]
                if b.sign < 0:
                    pts = [(x, -y) for x, y in pts]  # keep counter-clockwise orientation
                add_polygon(occ, pts)

    def _beam_at(self, x: float) -> BeamArm:
        return min(self.beams, key=lambda b: abs(b.s_of(x) - 0.5 * b.length))

    def cell_group(self, x: float, y: float) -> str:
        return self._beam_at(x).name

    def tip_group(self, x: float, y: float) -> str | None:
        b = self._beam_at(x)
        s = b.s_of(x)
        if b.pointed:
            return _tip_name(b.name) if s > (1 - TIP_ZONE) * b.length + self.tol else None
        return _tip_name(b.name) if abs(s - b.length) < self.tol else None

    def in_clamp(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Any:
        mask = np.zeros(np.shape(x), dtype=bool)
        for b in self.beams:
            if b.clamp_length > 0:
                s = b.s_of(x)
                mask |= (s >= -self.tol) & (s <= b.clamp_length + self.tol)
        return mask

    def inset_clamp(self, inset: float) -> BeamOutline:
        beams = []
        for b in self.beams:
            if 0 < b.clamp_length <= inset:
                raise ValueError(
                    f"the clamp patch of {b.name} ({b.clamp_length:g} m from its root) is not "
                    f"longer than the clamp inset {inset:g} m"
                )
            beams.append(b._replace(clamp_length=b.clamp_length - (inset if b.clamp_length else 0)))
        return BeamOutline(tuple(beams))

    def strip_breaks(self) -> list[float]:
        """Sorted x positions splitting the side-view strip (arm ends, clamp ends)."""
        xs = {round(b.x_root + b.sign * s, 15) for b in self.beams for s in b.cuts()}
        return sorted(xs)


def one_arm(length: float, root_width: float, tip_width: float, clamp_length: float) -> BeamOutline:
    """One arm ``arm`` from x = 0 along +x (``tip_width = 0``: pointed)."""
    return BeamOutline((BeamArm("arm", 0.0, 1, length, root_width, tip_width, clamp_length),))


def two_arms(length: float, middle_width: float, end_width: float, clamp: float) -> BeamOutline:
    """``arm_left`` and ``arm_right`` meeting at x = 0, ``length`` tip to tip.

    Widths vary linearly from ``middle_width`` at x = 0 to ``end_width`` at
    x = ±length/2; the bonded middle patch is |x| <= ``clamp``/2.
    """
    half, c = 0.5 * length, 0.5 * clamp
    return BeamOutline(
        (
            BeamArm("arm_left", 0.0, -1, half, middle_width, end_width, c),
            BeamArm("arm_right", 0.0, 1, half, middle_width, end_width, c),
        )
    )
