"""``membrane``: a free rectangle centred on the origin (e.g. the rect-water scene)."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import quantity
from magfem.geometry.beam import BeamArm, BeamOutline
from magfem.geometry.shapes.base import UniformWidthShape, register

__all__ = ["MembraneShape"]


@register("membrane")
@dataclass(frozen=True)
class MembraneShape(UniformWidthShape):
    """Free rectangle ``length`` (x) × ``width`` (y) centred on the origin.

    Cell group ``body``, one "arm" from x = −length/2 to its tip face
    ``tip`` at x = +length/2; uniform width, so it has the ``strip`` model.
    """

    length: float = quantity("10 mm", "m", gt=0, doc="length along x")
    width: float = quantity("5 mm", "m", gt=0, doc="width along y")

    feature_keys = ("length", "width")

    def outline(self) -> BeamOutline:
        body = BeamArm("body", -0.5 * self.length, 1, self.length, self.width, self.width, 0.0)
        return BeamOutline((body,))
