"""A payload carried by the robot: its mass spread uniformly over a cell group.

The payload of mass m (e.g. the manta's) is glued to the cell group
``group`` and moves with it: per unit of the group's measure (area of a
shell, volume of a solid, area per unit depth of a strip) it adds the mass
density m/|group| to the inertia (:meth:`PayloadLoad.inertia`, weighted by
the integrator like the body's own) and the weight (m − m_f) g, m_f the
mass of the fluid it displaces (its buoyancy; 0 in air or vacuum), as the
potential −∫ (m − m_f)/|group| g·u. The payload's own size, its added mass
in a fluid and the height of its centre of mass above the membrane are not
modelled.

    [[loads]]
    kind = "payload"
    mass = "5 mg"
    group = "body"
    displaced_mass = "2 mg"     # optional: the fluid its volume displaces
    gravity = [0, 0, "-9.8 m/s^2"]   # as [environment] gravity
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from mpi4py import MPI

from magfem.config import CaseError, option, quantity, vector
from magfem.mechanics.forms import compile_form
from magfem.mechanics.loads.base import LOADS, Load, LoadSpec
from magfem.mechanics.models.base import Model

__all__ = ["PayloadLoad", "PayloadSpec"]


@LOADS.register("payload")
@dataclass(frozen=True, kw_only=True)
class PayloadSpec(LoadSpec):
    """``[[loads]] kind = "payload"``: a mass carried on a cell group (weight and inertia)."""

    kind: str = option("payload", ("payload",), doc="load kind")
    mass: float = quantity(unit="kg", gt=0.0, doc="the payload's mass")
    group: str = option(doc="cell group it is glued to (e.g. body)")
    displaced_mass: float = quantity(
        0.0, "kg", ge=0.0, doc="mass of the fluid its volume displaces (its buoyancy)"
    )
    gravity: tuple[float, ...] = vector(
        (0.0, 0.0, -9.8), "m/s^2", doc="acceleration of its weight (as [environment] gravity)"
    )

    def build(self, model: Model) -> Load:
        return PayloadLoad(self, model)


class PayloadLoad(Load):
    """The payload of a :class:`PayloadSpec` on ``model``.

    Raises:
        CaseError: ``group`` is not a cell group of the robot (key ``loads.group``).
    """

    name = "payload"

    def __init__(self, spec: PayloadSpec, model: Model):
        robot = model.robot
        mesh = robot.mesh
        tdim = mesh.topology.dim
        cells = [n for n, (dim, _) in robot.groups.items() if dim == tdim]
        if spec.group not in cells:
            raise CaseError(
                "loads.group", spec.group, "no such cell group; groups are " + ", ".join(cells)
            )
        dx = ufl.Measure(
            "dx",
            domain=mesh,
            subdomain_data=robot.cell_tags,
            metadata={"quadrature_degree": model.quadrature_degree},
        )
        self.dx = dx(robot.groups[spec.group][1])
        one = fem.Constant(mesh, 1.0)
        size = mesh.comm.allreduce(fem.assemble_scalar(compile_form(one * self.dx)), op=MPI.SUM)
        self.density = spec.mass / (size * model.depth)  # per unit of the model's measure
        self.buoyant = spec.displaced_mass / (size * model.depth)
        g3 = np.asarray(spec.gravity, dtype=float)
        self.full = g3 if model.gdim == 3 else g3[::2].copy()
        self.g = fem.Constant(mesh, self.full.copy())

    def energy(self, model: Model, state: Sequence[Any]) -> ufl.Form:
        weight = (self.density - self.buoyant) * self.g
        return -ufl.dot(weight, model.displacement(state)) * self.dx

    def inertia(
        self, model: Model, state: Sequence[Any], rates: Sequence[Any], accelerations: Sequence[Any]
    ) -> list[ufl.Form]:
        w = model.tests[0]
        acceleration = model.displacement(accelerations)
        forms: list[Any] = [self.density * ufl.dot(acceleration, w) * self.dx]
        for test in model.tests[1:]:  # the shell's angles carry no payload inertia
            zero = fem.Constant(model.robot.mesh, np.zeros(ufl.shape(test)))
            forms.append(ufl.inner(zero, test) * self.dx)
        return forms

    def ramp(self, factor: float) -> bool:
        if not np.any(self.full):
            return False
        self.g.value = factor * self.full  # type: ignore[assignment]
        return True

    def body_acceleration(self) -> npt.NDArray[np.float64] | None:
        return None  # carried by one group, not by every mass point
