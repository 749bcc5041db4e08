"""``flower``: the flower gripper, rounded petals around a bonded centre disk."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import integer, quantity
from magfem.geometry.radial import RadialOutline, min_hub_radius
from magfem.geometry.shapes.base import Shape, register

__all__ = ["FlowerShape"]


@register("flower")
@dataclass(frozen=True)
class FlowerShape(Shape):
    """Flower gripper: ``petals`` rounded petals around a centre disk (Ø ``centre_diameter``).

    Petal i is a strip of ``petal_width`` along angle 2π(i−1)/petals ending in a
    half disk, reaching ``diameter``/2 from the centre. A bottom disk of
    ``clamp_diameter`` is bonded to the glass (0 = free). Cell groups ``hub``,
    ``petal_1``..; tip groups ``tip_petal_i`` (the half-disk ends).
    """

    petals: int = integer(8, ge=3, le=16, doc="number of petals")
    diameter: float = quantity("25 mm", "m", gt=0, doc="tip-to-tip diameter")
    centre_diameter: float = quantity("12 mm", "m", gt=0, doc="diameter of the centre disk")
    petal_width: float = quantity("4 mm", "m", gt=0, doc="petal width")
    clamp_diameter: float = quantity("6 mm", "m", ge=0, doc="bonded centre disk; 0 = free")

    def __post_init__(self) -> None:
        meet = f"the diameter in which {self.petals} petals of this width meet"
        self.at_least("centre_diameter", 2 * min_hub_radius(self.petals, self.petal_width), meet)
        reach = self.centre_diameter + self.petal_width
        self.at_least("diameter", reach, "centre_diameter + petal_width", strict=True)
        self.at_most("clamp_diameter", self.centre_diameter, "centre_diameter")

    @property
    def min_feature(self) -> float:
        return min(self.petal_width, 0.5 * (self.diameter - self.centre_diameter))

    def outline(self) -> RadialOutline:
        return RadialOutline(
            n=self.petals,
            prefix="petal",
            reach=0.5 * self.diameter,
            root_width=self.petal_width,
            tip_width=self.petal_width,
            hub_radius=0.5 * self.centre_diameter,
            clamp_radius=0.5 * self.clamp_diameter,
            rounded=True,
        )
