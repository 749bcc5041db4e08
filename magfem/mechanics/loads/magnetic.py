"""The hard-magnetic load: the energy −(F M̃)·B_a(x, t) of the remanent magnetization.

B_a is the applied field at the *current* position x = X + u, a UFL
expression of the field model (:mod:`magfem.field.model`), so the torque
m × B and the gradient force (m·∇)B come out of one energy and are
linearised exactly. How F M̃ is formed is the model's
(:meth:`~magfem.mechanics.models.base.Model.magnetic_energy_density`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl

from magfem.field.model import FieldModel
from magfem.mechanics.loads.base import Load
from magfem.mechanics.models.base import Model

__all__ = ["MagneticLoad"]


class MagneticLoad(Load):
    """The applied field's energy on the magnetized body (binds ``field`` to the model's mesh)."""

    name = "magnetic"

    def __init__(self, field: FieldModel, model: Model):
        self.field = field
        field.bind(model.robot.mesh)

    def energy(self, model: Model, state: Sequence[Any]) -> ufl.Form:
        return model.magnetic_energy_density(state, self.field.flux_density) * model.dx

    def breakpoints(self, t0: float, t1: float) -> npt.NDArray[np.float64]:
        return np.asarray(self.field.breakpoints(t0, t1), dtype=float)

    def update(self, t: float, *, side: str, displacement: Any) -> None:
        self.field.update(t, side=side, u=displacement)
