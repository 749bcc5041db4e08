"""``rectangle``: one rectangular arm along +x from its root edge on x = 0 (centred on y = 0)."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import quantity
from magfem.geometry.beam import BeamOutline, one_arm
from magfem.geometry.shapes.base import ClampedArmShape, UniformWidthShape, register

__all__ = ["RectangleShape"]


@register("rectangle")
@dataclass(frozen=True)
class RectangleShape(UniformWidthShape, ClampedArmShape):
    """One rectangular arm, ``length`` along x, ``width`` along y, root strip clamped.

    Cell group ``arm``, tip face ``tip`` (x = length); uniform width, so it
    also has the ``strip`` model (depth ``width``).
    """

    length: float = quantity("10 mm", "m", gt=0, doc="arm length along x")
    width: float = quantity("2 mm", "m", gt=0, doc="arm width along y")
    clamp_length: float = quantity(
        "1 mm", "m", ge=0, doc="bottom root strip bonded to the substrate; 0 = free"
    )

    feature_keys = ("length", "width")

    def outline(self) -> BeamOutline:
        return one_arm(self.length, self.width, self.width, self.clamp_length)
