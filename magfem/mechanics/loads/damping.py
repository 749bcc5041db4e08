r"""Material damping of the elastomer: a viscosity proportional to the elastic stiffness.

The damping force is the elastic tangent applied to the velocity, scaled by
a relaxation time β (s):

.. math::

    W_d(q, \dot q)[w] = \beta\, D_q\big(\delta\Pi_{el}(q)[w]\big)[\dot q],

the directional derivative of the elastic force in the direction of the
velocity, for every model (its elastic energy Π_el). At small strain this is
the Kelvin–Voigt solid σ = C:(ε + β ε̇) (Rayleigh stiffness-proportional
damping): a vibration mode of angular frequency ω decays with the damping
ratio ζ = β ω/2, and a harmonic strain has the loss tangent tan δ = β ω.
Rigid motions of the unstressed body are not damped; those of a stressed
body are, through the geometric part of the tangent, which is indefinite
under compression: at large rotations this force can feed energy instead of
removing it (docs/physics.md: on the two-arm strip at 20 Hz the arm bent
faster with it, and Newton failed; ``python -m
benchmarks.material_damping_effect``). The case gives β, or
a loss tangent at a frequency (β = tan δ/(2π f)), which a dynamic mechanical
analysis of the user's elastomer provides: the loss tangent of
NdFeB-filled PDMS depends on the filler, the cure and the frequency, and
magfem has no default for it.

    [[loads]]
    kind = "material_damping"
    loss_tangent = 0.1
    frequency = "50 Hz"          # or: relaxation_time = "0.3 ms"
"""

from __future__ import annotations

import functools
import math
import operator
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
    """The damping force β K(q) q̇ of the module docstring on ``model`` (β in s)."""

    name = "material_damping"

    def __init__(self, beta: float, model: Model):
        self.beta = fem.Constant(model.robot.mesh, float(beta))
        self._state = [fem.Function(u.function_space) for u in model.unknowns]
        self._rates = [fem.Function(u.function_space) for u in model.unknowns]
        energy = model.elastic_energy(self._state)
        self._forms = []
        for s, w in zip(self._state, model.tests, strict=True):
            force = ufl.derivative(energy, s, w)
            terms = [
                ufl.derivative(force, q, r) for q, r in zip(self._state, self._rates, strict=True)
            ]
            self._forms.append(
                ufl.algorithms.expand_derivatives(functools.reduce(operator.add, terms))
            )

    def work(self, model: Model, state: Sequence[Any], rates: Sequence[Any]) -> list[ufl.Form]:
        mapping = dict(zip(self._state, state, strict=True))
        mapping |= dict(zip(self._rates, rates, strict=True))
        return [-self.beta * ufl.replace(f, mapping) for f in self._forms]
