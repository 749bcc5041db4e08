"""The applied field at a point of the robot (the drive as the robot sees it)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from magfem.field.model import FieldModel
from magfem.mechanics.observers.base import Observer

__all__ = ["AppliedField"]


class AppliedField(Observer):
    """``Bx``, ``By``, ``Bz`` (T): the applied field at ``point`` (3D, m) at time t.

    The field is taken on the left of a switching instant (the value the
    step that ends there saw).
    """

    def __init__(self, field: FieldModel, point: npt.NDArray[np.float64]):
        self.field = field
        self.point = np.asarray(point, dtype=float).reshape(1, 3)

    def columns(self) -> list[str]:
        return ["Bx", "By", "Bz"]

    def observe(self, t: float) -> dict[str, float]:
        b = self.field.evaluate(self.point, t, side="left")[0]
        return {"Bx": float(b[0]), "By": float(b[1]), "Bz": float(b[2])}
