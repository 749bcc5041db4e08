"""``trapezoid``: one trapezoidal arm along +x from its root edge on x = 0 (centred on y = 0)."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import quantity
from magfem.geometry.beam import BeamOutline, one_arm
from magfem.geometry.shapes.base import ClampedArmShape, register

__all__ = ["TrapezoidShape"]


@register("trapezoid")
@dataclass(frozen=True)
class TrapezoidShape(ClampedArmShape):
    """One trapezoidal arm: width ``root_width`` at x = 0, ``tip_width`` at x = length.

    Cell group ``arm``, tip face ``tip``. A tip wider than the root is allowed.
    """

    length: float = quantity("7.5 mm", "m", gt=0, doc="arm length along x")
    root_width: float = quantity("4 mm", "m", gt=0, doc="width at the root (x = 0)")
    tip_width: float = quantity("2 mm", "m", gt=0, doc="width at the tip (x = length)")
    clamp_length: float = quantity("1 mm", "m", ge=0, doc="clamped root strip; 0 = free")

    feature_keys = ("length", "root_width", "tip_width")

    def outline(self) -> BeamOutline:
        return one_arm(self.length, self.root_width, self.tip_width, self.clamp_length)
