"""``disk``: a free circular membrane centred on the origin (e.g. a plate above a magnet)."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import quantity
from magfem.geometry.radial import RadialOutline
from magfem.geometry.shapes.base import Shape, register

__all__ = ["DiskShape"]


@register("disk")
@dataclass(frozen=True)
class DiskShape(Shape):
    """Circular membrane of ``diameter``; a central bottom disk of ``clamp_diameter`` is bonded.

    One cell group ``body``; no arms and no tip groups. ``clamp_diameter = 0``
    (default) is a free plate.
    """

    diameter: float = quantity("10 mm", "m", gt=0, doc="diameter of the disk")
    clamp_diameter: float = quantity(0.0, "m", ge=0, doc="bonded central disk; 0 = free")

    def __post_init__(self) -> None:
        self.at_most("clamp_diameter", self.diameter, "diameter", strict=True)

    @property
    def min_feature(self) -> float:
        # the radius, or the free ring outside the bonded disk
        return 0.5 * (self.diameter - self.clamp_diameter)

    def outline(self) -> RadialOutline:
        r = 0.5 * self.diameter
        return RadialOutline(
            n=0,
            prefix="arm",
            reach=r,
            root_width=0.0,
            tip_width=0.0,
            hub_radius=r,
            clamp_radius=0.5 * self.clamp_diameter,
            rounded=False,
            hub="body",
        )
