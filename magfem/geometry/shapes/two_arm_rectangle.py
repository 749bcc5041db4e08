"""``two_arm_rectangle``: a strip centred on the origin, arms to −x and +x, middle bonded."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import quantity
from magfem.geometry.beam import BeamOutline, two_arms
from magfem.geometry.shapes.base import ClampedArmShape, UniformWidthShape, register

__all__ = ["TwoArmRectangleShape"]


@register("two_arm_rectangle")
@dataclass(frozen=True)
class TwoArmRectangleShape(UniformWidthShape, ClampedArmShape):
    """Strip of total ``length`` along x, arms ``arm_left`` (x < 0) and ``arm_right`` (x > 0).

    The bottom patch |x| < clamp_length/2 is bonded to the substrate (flat:
    a curved substrate is not modelled). Tip faces ``tip_arm_left``,
    ``tip_arm_right``; uniform width, so it has the ``strip`` model.
    """

    length: float = quantity("6 mm", "m", gt=0, doc="total tip-to-tip length along x")
    width: float = quantity("0.8 mm", "m", gt=0, doc="width along y")
    clamp_length: float = quantity("0.8 mm", "m", ge=0, doc="clamped middle patch; 0 = free")

    @property
    def min_feature(self) -> float:
        return min(self.width, self.length / 2)

    def outline(self) -> BeamOutline:
        return two_arms(self.length, self.width, self.width, self.clamp_length)
