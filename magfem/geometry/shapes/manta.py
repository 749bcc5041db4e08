"""``manta``: a manta ray, rectangular body and two trapezoid fins, centred on the origin."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from magfem.config import quantity
from magfem.geometry.outline import Outline, PlanarArm, add_polygon
from magfem.geometry.shapes.base import Shape, register

__all__ = ["MantaOutline", "MantaShape"]


@register("manta")
@dataclass(frozen=True)
class MantaShape(Shape):
    """Manta ray: rectangular ``body`` (length along x, the swimming direction) and two fins.

    ``fin_left`` (+y) and ``fin_right`` (−y) are trapezoids from the body
    side (chord ``body_length``) to the wing tips at y = ±wingspan/2 (chord
    ``fin_tip_width``, centred on x = 0); tip faces ``tip_fin_left``,
    ``tip_fin_right``. Free robot (no clamp).
    """

    wingspan: float = quantity("20 mm", "m", gt=0, doc="tip-to-tip span along y")
    body_length: float = quantity("10 mm", "m", gt=0, doc="body length along x")
    body_width: float = quantity("4 mm", "m", gt=0, doc="body width along y")
    fin_tip_width: float = quantity("2 mm", "m", gt=0, doc="fin chord at the wing tip")

    def __post_init__(self) -> None:
        self.at_least("wingspan", self.body_width, "body_width", strict=True)
        self.at_most("fin_tip_width", self.body_length, "body_length")

    @property
    def min_feature(self) -> float:
        return min(self.body_width, self.fin_tip_width, 0.5 * (self.wingspan - self.body_width))

    def outline(self) -> MantaOutline:
        return MantaOutline(self.wingspan, self.body_length, self.body_width, self.fin_tip_width)


@dataclass(frozen=True)
class MantaOutline(Outline):
    """Body [−L/2, L/2] × [−w/2, w/2] and trapezoid fins to y = ±span/2 (chord ``fin_tip``)."""

    span: float
    body_length: float
    body_width: float
    fin_tip: float

    def __post_init__(self) -> None:
        w2, reach = 0.5 * self.body_width, 0.5 * (self.span - self.body_width)
        arms = (
            PlanarArm("fin_left", (0.0, w2), (0.0, 1.0), reach, "tip_fin_left"),
            PlanarArm("fin_right", (0.0, -w2), (0.0, -1.0), reach, "tip_fin_right"),
        )
        object.__setattr__(self, "arms", arms)
        fin = reach * 0.5 * (self.body_length + self.fin_tip)
        object.__setattr__(self, "area", self.body_length * self.body_width + 2 * fin)
        object.__setattr__(self, "curved", False)
        object.__setattr__(self, "clamped", False)
        object.__setattr__(self, "scale", max(self.span, self.body_length))

    def build(self, occ: Any) -> None:
        lx, w2 = 0.5 * self.body_length, 0.5 * self.body_width
        s2, t2 = 0.5 * self.span, 0.5 * self.fin_tip
        add_polygon(occ, [(-lx, -w2), (lx, -w2), (lx, w2), (-lx, w2)])
        add_polygon(occ, [(-lx, w2), (lx, w2), (t2, s2), (-t2, s2)])
        add_polygon(occ, [(-lx, -w2), (-t2, -s2), (t2, -s2), (lx, -w2)])

    def cell_group(self, x: float, y: float) -> str:
        if abs(y) < 0.5 * self.body_width:
            return "body"
        return "fin_left" if y > 0 else "fin_right"

    def tip_group(self, x: float, y: float) -> str | None:
        if abs(abs(y) - 0.5 * self.span) < self.tol:
            return "tip_fin_left" if y > 0 else "tip_fin_right"
        return None

    def in_clamp(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Any:
        return np.zeros(np.shape(x), dtype=bool)
