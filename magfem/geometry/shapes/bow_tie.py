"""``bow_tie``: two trapezoid arms meeting at x = 0 (centred on the origin), middle bonded."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import quantity
from magfem.geometry.beam import BeamOutline, two_arms
from magfem.geometry.shapes.base import ClampedArmShape, register

__all__ = ["BowTieShape"]


@register("bow_tie")
@dataclass(frozen=True)
class BowTieShape(ClampedArmShape):
    """Two trapezoid arms meeting at x = 0 (``middle_width``), ``end_width`` at x = ±length/2.

    Cell groups ``arm_left``, ``arm_right``; bonded middle patch
    |x| < clamp_length/2.
    """

    length: float = quantity("10 mm", "m", gt=0, doc="total tip-to-tip length along x")
    middle_width: float = quantity("1 mm", "m", gt=0, doc="width at x = 0")
    end_width: float = quantity("3 mm", "m", gt=0, doc="width at the arm ends")
    clamp_length: float = quantity("1 mm", "m", ge=0, doc="clamped middle patch; 0 = free")

    @property
    def min_feature(self) -> float:
        return min(self.middle_width, self.end_width, self.length / 2)

    def outline(self) -> BeamOutline:
        return two_arms(self.length, self.middle_width, self.end_width, self.clamp_length)
