"""``star``: 3–6 straight arms around a disk hub, centred on the origin."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import integer, quantity
from magfem.geometry.radial import RadialOutline, min_hub_radius
from magfem.geometry.shapes.base import Shape, register

__all__ = ["StarShape"]


@register("star")
@dataclass(frozen=True)
class StarShape(Shape):
    """``arms`` straight arms (3–6) around a disk hub; arm 1 along +x, then counter-clockwise.

    Arms have width ``arm_width`` (``arm_tip_width`` at the tip: tapered when
    smaller) and reach ``arm_length`` from the centre. A central bottom disk
    of ``clamp_radius`` is bonded (0 = free robot). Cell groups ``hub``,
    ``arm_1``..``arm_n``; tip faces ``tip_arm_1``..
    """

    arms: int = integer(5, ge=3, le=6, doc="number of arms")
    arm_length: float = quantity("5 mm", "m", gt=0, doc="centre-to-tip distance")
    arm_width: float = quantity("1.5 mm", "m", gt=0, doc="arm width at the hub")
    arm_tip_width: float | None = quantity(
        None, "m", gt=0, doc="width at the tip (default arm_width)"
    )
    hub_radius: float = quantity("1.5 mm", "m", gt=0, doc="radius of the central disk")
    clamp_radius: float = quantity(0.0, "m", ge=0, doc="bonded central disk; 0 = free")

    def __post_init__(self) -> None:
        rmin = min_hub_radius(self.arms, max(self.arm_width, self.tip_width))
        self.at_least(
            "hub_radius", rmin, f"the radius in which {self.arms} arms of this width meet"
        )
        reach = self.hub_radius + 0.5 * self.tip_width
        self.at_least("arm_length", reach, "hub_radius + arm_tip_width/2", strict=True)
        self.at_most("clamp_radius", self.hub_radius, "hub_radius")

    @property
    def tip_width(self) -> float:
        """Arm width at the tip (m)."""
        return self.arm_width if self.arm_tip_width is None else self.arm_tip_width

    @property
    def min_feature(self) -> float:
        return min(self.arm_width, self.tip_width, self.arm_length - self.hub_radius)

    def outline(self) -> RadialOutline:
        return RadialOutline(
            n=self.arms,
            prefix="arm",
            reach=self.arm_length,
            root_width=self.arm_width,
            tip_width=self.tip_width,
            hub_radius=self.hub_radius,
            clamp_radius=self.clamp_radius,
            rounded=False,
        )
