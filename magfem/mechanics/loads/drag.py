"""Linear viscous drag: a traction −c (v − v_f) per reference area on the body's faces.

The low-Reynolds-number (Stokes) limit of a fluid's resistance, as a dashpot
of coefficient c (Pa·s/m) between each face and a surrounding fluid moving
uniformly at v_f. Its virtual work at the stage point is
−∫ c (v − v_f)·δx dA over the faces named by ``surfaces`` (the shell's two
faces, the solid's boundary facet groups), linearised exactly through the
integrator's velocity. A free plate of mass ρt per area moving normal to
itself with both faces exposed slows as v(t) = v₀ exp(−2c t/(ρ t)).

    [[loads]]
    kind = "drag"
    coefficient = "0.1 Pa*s/m"
    flow = [0, 0, 0]            # velocity of the fluid, m/s (optional)
    surfaces = ["all"]          # faces it acts on, as [contact] surfaces
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import ufl
from dolfinx import fem

from magfem.config import option, quantity, vector
from magfem.mechanics.loads.base import LOADS, Load, LoadSpec
from magfem.mechanics.models.base import Model, sum_work

__all__ = ["DragLoad", "DragSpec"]


@LOADS.register("drag")
@dataclass(frozen=True, kw_only=True)
class DragSpec(LoadSpec):
    """``[[loads]] kind = "drag"``: linear viscous drag on the body's faces."""

    kind: str = option("drag", ("drag",), doc="load kind")
    coefficient: float = quantity(
        unit="Pa*s/m", gt=0.0, doc="c: traction per unit relative velocity on each face"
    )
    flow: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m/s", doc="velocity of the fluid")
    surfaces: tuple[str, ...] = ("all",)
    """Faces it acts on (names as ``[contact] surfaces``)."""

    def build(self, model: Model) -> Load:
        return DragLoad(self, model)


class DragLoad(Load):
    """The drag of a :class:`DragSpec` on ``model``'s faces."""

    name = "drag"

    def __init__(self, spec: DragSpec, model: Model):
        mesh = model.robot.mesh
        flow = np.asarray(spec.flow, dtype=float)
        self.coefficient = fem.Constant(mesh, spec.coefficient)
        self.flow = fem.Constant(mesh, flow if model.gdim == 3 else flow[::2].copy())
        self.surfaces = tuple(spec.surfaces)
        model.faces(*model.accepted(), self.surfaces)  # unknown face names fail here

    def work(self, model: Model, state: Sequence[Any], rates: Sequence[Any]) -> list[ufl.Form]:
        faces = model.faces(state, rates, self.surfaces)
        tractions = [-self.coefficient * (f.velocity - self.flow) for f in faces]
        return sum_work(faces, tractions)
