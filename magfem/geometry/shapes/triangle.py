"""``triangle``: one triangular arm, base on x = 0 (centred on y = 0), apex at (length, 0)."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import quantity
from magfem.geometry.beam import BeamOutline, one_arm
from magfem.geometry.shapes.base import ClampedArmShape, register

__all__ = ["TriangleShape"]


@register("triangle")
@dataclass(frozen=True)
class TriangleShape(ClampedArmShape):
    """One triangular arm: base ``root_width`` on x = 0, apex at (length, 0).

    Cell group ``arm``; its tip group ``tip`` is the side faces of the last
    10 % of the length (:data:`magfem.geometry.outline.TIP_ZONE`).
    """

    length: float = quantity("7.5 mm", "m", gt=0, doc="root-to-apex length along x")
    root_width: float = quantity("4 mm", "m", gt=0, doc="base width on x = 0")
    clamp_length: float = quantity("1 mm", "m", ge=0, doc="clamped root strip; 0 = free")

    # the apex has no width: the base width is what an element must resolve
    feature_keys = ("length", "root_width")

    def outline(self) -> BeamOutline:
        return one_arm(self.length, self.root_width, 0.0, self.clamp_length)
