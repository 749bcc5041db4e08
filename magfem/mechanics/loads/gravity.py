"""Gravity: the potential −∫ ρ g·u of a uniform acceleration g on the body's mass."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem

from magfem.mechanics.loads.base import Load
from magfem.mechanics.models.base import Model

__all__ = ["GravityLoad"]


class GravityLoad(Load):
    """Uniform gravity ``acceleration`` (m/s², 3 components; a strip keeps (x, z)).

    Attributes:
        g: the gravity vector Constant (gdim components), scaled in place by
            :meth:`ramp`.
    """

    name = "gravity"

    def __init__(self, acceleration: Sequence[float], model: Model):
        g3 = np.asarray(acceleration, dtype=float)
        self.full = g3 if model.gdim == 3 else g3[::2].copy()
        self.g = fem.Constant(model.robot.mesh, self.full.copy())

    def energy(self, model: Model, state: Sequence[Any]) -> ufl.Form:
        return -model.mass_density * ufl.dot(self.g, model.displacement(state)) * model.dx

    def ramp(self, factor: float) -> bool:
        if not np.any(self.full):
            return False
        self.g.value = factor * self.full  # type: ignore[assignment]
        return True

    def body_acceleration(self) -> npt.NDArray[np.float64]:
        return np.asarray(self.g.value, dtype=float)
