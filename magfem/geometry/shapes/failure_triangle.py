"""``failure_triangle``: the three triangles of the failure study, chosen by ``type``."""

from __future__ import annotations

from dataclasses import dataclass

from magfem.config import option, quantity
from magfem.geometry.beam import BeamOutline, one_arm
from magfem.geometry.shapes.base import Shape, register

__all__ = ["FAILURE_TRIANGLES", "FailureTriangleShape"]

FAILURE_TRIANGLES: dict[str, tuple[float, float]] = {
    "I": (5e-3, 8e-3),
    "II": (10e-3, 16e-3),
    "III": (20e-3, 32e-3),
}
"""Failure-study triangles of the source paper: type -> (base width, length) in m."""


@register("failure_triangle")
@dataclass(frozen=True)
class FailureTriangleShape(Shape):
    """Triangles of the failure study: type I 5×8, II 10×16, III 20×32 mm² (base × length).

    Placed and grouped as ``triangle``.
    """

    type: str = option("I", choices=tuple(FAILURE_TRIANGLES), doc="I, II or III")
    clamp_length: float = quantity("1 mm", "m", ge=0, doc="clamped root strip; 0 = free")

    def __post_init__(self) -> None:
        self.at_most("clamp_length", self.length, f"the type {self.type} length", strict=True)

    @property
    def root_width(self) -> float:
        """Base width (m)."""
        return FAILURE_TRIANGLES[self.type][0]

    @property
    def length(self) -> float:
        """Base-to-apex length (m)."""
        return FAILURE_TRIANGLES[self.type][1]

    @property
    def min_feature(self) -> float:
        return self.root_width

    def outline(self) -> BeamOutline:
        return one_arm(self.length, self.root_width, 0.0, self.clamp_length)
