"""``slim_triangle``: the free slim triangle of the propeller scene (base on x = 0)."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import quantity
from magfem.geometry.beam import BeamOutline, one_arm
from magfem.geometry.shapes.base import Shape, register

__all__ = ["SlimTriangleShape"]


@register("slim_triangle")
@dataclass(frozen=True)
class SlimTriangleShape(Shape):
    """Free slim triangle: base ``root_width`` on x = 0, apex at (length, 0); no clamp.

    Cell group ``arm``, tip group ``tip`` (as ``triangle``).
    """

    length: float = quantity("10 mm", "m", gt=0, doc="base-to-apex length along x")
    root_width: float = quantity("2 mm", "m", gt=0, doc="base width on x = 0")

    feature_keys = ("length", "root_width")

    def outline(self) -> BeamOutline:
        return one_arm(self.length, self.root_width, 0.0, 0.0)
