r"""Material damping of the elastomer: a Kelvin–Voigt viscosity on the strain rates.

The damping force derives from the dissipation potential

.. math::

    R(q, \dot q) = \tfrac12 \int \dot s : \mathbb C_0 : \dot s,\qquad
    \dot s = D s(q)[\dot q],\qquad
    W_d(q, \dot q)[w] = \beta\, \partial_{\dot q} R(q, \dot q)[w]
        = \beta \int \mathbb C_0 \dot s : D s(q)[w],

with s the model's objective strain measures (the Green strain of the
solid and strip; the membrane, bending and shear strains of the shell; the
strain and curvature of the rod), ℂ₀ its small-strain stiffness
(:meth:`~magfem.mechanics.models.base.Model.strain_rate_energy`) and β a
relaxation time (s). A rigid motion has ṡ = 0 at any state, so it is never
damped, and the dissipated power 2βR is never negative. At small strain this
is the Kelvin–Voigt solid σ = ℂ:(ε + β ε̇) (Rayleigh stiffness-proportional
damping): a vibration mode of angular frequency ω decays with the damping
ratio ζ = β ω/2, and a harmonic strain has the loss tangent tan δ = β ω.
``python -m benchmarks.material_damping_effect`` measures it on the two-arm
strip at 20 Hz (docs/physics.md). The case gives β, or a loss tangent at a frequency
(β = tan δ/(2π f)), which a dynamic mechanical analysis of the user's
elastomer provides: the loss tangent of NdFeB-filled PDMS depends on the
filler, the cure and the frequency, and magfem has no default for it.

    [[loads]]
    kind = "material_damping"
    loss_tangent = 0.1
    frequency = "50 Hz"          # or: relaxation_time = "0.3 ms"
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import ufl
from dolfinx import fem

from magfem.config import CaseError, option, quantity
from magfem.mechanics.loads.base import LOADS, Load, LoadSpec
from magfem.mechanics.models.base import Model

__all__ = ["MaterialDamping", "MaterialDampingSpec"]


@LOADS.register("material_damping")
@dataclass(frozen=True, kw_only=True)
class MaterialDampingSpec(LoadSpec):
    """``[[loads]] kind = "material_damping"``: stiffness-proportional (Kelvin–Voigt) damping."""

    kind: str = option("material_damping", ("material_damping",), doc="load kind")
    relaxation_time: float | None = quantity(None, "s", gt=0.0, doc="β: viscosity / stiffness")
    loss_tangent: float | None = quantity(None, "", gt=0.0, lt=1.0, doc="tan δ at frequency")
    frequency: float | None = quantity(None, "Hz", gt=0.0, doc="where loss_tangent is given")

    def __post_init__(self) -> None:
        given = self.relaxation_time is not None
        if given == (self.loss_tangent is not None):
            raise CaseError(
                "relaxation_time", self.relaxation_time, "give relaxation_time or loss_tangent"
            )
        if self.loss_tangent is not None and self.frequency is None:
            raise CaseError("frequency", None, "is required with loss_tangent")

    @property
    def beta(self) -> float:
        """β (s)."""
        if self.relaxation_time is not None:
            return self.relaxation_time
        assert self.loss_tangent is not None and self.frequency is not None
        return self.loss_tangent / (2 * math.pi * self.frequency)

    def build(self, model: Model) -> Load:
        return MaterialDamping(self.beta, model)


class MaterialDamping(Load):
    """The damping force β ∂R/∂q̇ of the module docstring on ``model`` (β in s)."""

    name = "material_damping"

    def __init__(self, beta: float, model: Model):
        self.beta = fem.Constant(model.robot.mesh, float(beta))
        self._state = [fem.Function(u.function_space) for u in model.unknowns]
        self._rates = [fem.Function(u.function_space) for u in model.unknowns]
        potential = model.strain_rate_energy(self._state, self._rates)
        self._forms = [
            ufl.algorithms.expand_derivatives(ufl.derivative(potential, r, w))
            for r, w in zip(self._rates, model.tests, strict=True)
        ]

    def work(self, model: Model, state: Sequence[Any], rates: Sequence[Any]) -> list[ufl.Form]:
        mapping = dict(zip(self._state, state, strict=True))
        mapping |= dict(zip(self._rates, rates, strict=True))
        return [-self.beta * ufl.replace(f, mapping) for f in self._forms]
