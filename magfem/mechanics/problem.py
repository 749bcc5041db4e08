"""The step residual of a model under its loads and contacts, in continuous time.

Total Lagrangian balance of momentum, weak form: for all test functions w
vanishing on the supports,

    R(q, q̇, q̈; t)[w] = inertia(q̈)[w] + Σ_loads I_L(q, q̇, q̈)[w] + δΠ(q)[w]
                       − Σ_loads W_L(q, q̇)[w] − Σ_contacts W_C[w] = 0,
    Π(q) = elastic energy(q) + Σ_conservative loads Π_L(q),

with q the model's unknowns (:class:`~magfem.mechanics.models.base.Model`)
and I_L the inertia-like work of a load (a fluid's added mass,
:meth:`~magfem.mechanics.loads.base.Load.inertia`), taken at the stage
acceleration like the body's own inertia.
δΠ is ``ufl.derivative`` of the potential with respect to generic unknowns
that are then replaced by the integrator's stage values, so the
integrator's weights multiply the inertia and the internal force
consistently (a derivative taken through the stage value itself would carry
a spurious factor 1 − αf). At ρ∞ = 1 the integrator asks for δΠ averaged
over the step (``potential_points``, the average vector field that makes
the scheme conserve energy, :mod:`magfem.mechanics.integrator`): the same
forms summed over a few states between u_n and u_{n+1}. In dynamic runs the
contacts' UFL terms act at the end of the step (x_{n+1}, v_{n+1}), elsewhere at the stage point.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import ufl
from dolfinx import fem

from magfem.config import CaseError
from magfem.mechanics.contacts.base import Contact
from magfem.mechanics.loads.base import Load
from magfem.mechanics.models.base import Model
from magfem.mechanics.models.pressure import MixedPressure

__all__ = ["Problem", "build_problem"]


@dataclass
class Problem:
    """A model, its loads and contacts, and the forms of one step (not yet compiled).

    Attributes:
        model, loads, contacts: the parts.
        residual: the step residual: one form, or the list of block forms of
            several unknowns.
        unknowns: what Newton solves for: the model's unknowns, and the
            pressure of :class:`~magfem.mechanics.models.pressure.MixedPressure`
            where the model has one.
        pressure: that pressure, or None (the displacement formulation).
        energy_forms: name -> scalar form at the accepted state (J; J/m for
            strips): ``kinetic``, ``elastic``, each conservative load's and
            each contact's stored energy.
    """

    model: Model
    loads: list[Load]
    contacts: list[Contact]
    residual: Any
    energy_forms: dict[str, ufl.Form]
    unknowns: list[fem.Function] = field(default_factory=list)
    pressure: MixedPressure | None = None
    _internal: list[Any] = field(repr=False, default_factory=list)
    _generic: list[fem.Function] = field(repr=False, default_factory=list)
    _step_internal: list[Any] | None = field(repr=False, default=None)

    def continuous_residual(
        self, states: Sequence[Any], rates: Sequence[Any], accelerations: Sequence[Any]
    ) -> Any:
        """R(q, q̇, q̈) with every contact at (q, q̇), as the solver takes it.

        Used for the consistent initial acceleration M q̈₀ = −R(q₀, q̇₀, 0).
        """
        forms = self._balance(states, rates, accelerations)
        forms = self._minus_contacts(forms, states, rates)
        return self.model.residual_form(forms)

    def _balance(
        self,
        states: Sequence[Any],
        rates: Sequence[Any],
        accelerations: Sequence[Any],
        potential: Sequence[tuple[float, Sequence[Any]]] | None = None,
        internal: list[Any] | None = None,
    ) -> list[Any]:
        """Inertia + δΠ − non-conservative load work, per unknown (no contacts).

        ``potential``: (weight, state) points where δΠ is evaluated and summed
        (the integrator's average vector field); default δΠ at ``states``.
        ``internal``: δΠ's forms of the generic unknowns; default the whole potential's.
        """
        model = self.model
        forms: list[Any] = []
        internal = self._internal if internal is None else internal
        for weight, point in potential or [(1.0, states)]:
            mapping = dict(zip(self._generic, point, strict=True))
            terms = [ufl.replace(f, mapping) for f in internal]
            if weight != 1.0:
                terms = [weight * f for f in terms]
            forms = [a + b for a, b in zip(forms, terms, strict=True)] if forms else terms
        if model.integrator.dynamic:
            inertia = model.inertia_at(states, rates, accelerations)
            forms = [f + i for f, i in zip(forms, inertia, strict=True)]
            for load in self.loads:
                added = load.inertia(model, states, rates, accelerations)
                if added is not None:
                    forms = [f + a for f, a in zip(forms, added, strict=True)]
        for load in self.loads:
            work = load.work(model, states, rates)
            if work is not None:
                forms = [f - w for f, w in zip(forms, work, strict=True)]
        return forms

    def _minus_contacts(
        self, forms: list[Any], states: Sequence[Any], rates: Sequence[Any]
    ) -> list[Any]:
        for contact in self.contacts:
            faces = self.model.faces(states, rates, contact.surfaces, nodal=contact.nodal)
            work = contact.work(faces)
            if work is not None:
                forms = [f - w for f, w in zip(forms, work, strict=True)]
        return forms


def build_problem(model: Model, loads: Sequence[Load], contacts: Sequence[Contact]) -> Problem:
    """The step residual and energies of ``model`` under ``loads`` and ``contacts``.

    Raises:
        CaseError: a free body (nothing holds it) with the quasi-static scheme.
    """
    if model.free_body and not model.integrator.dynamic:
        raise CaseError(
            "time.scheme",
            "quasi_static",
            "a free body (no clamped group, no fixed_point) needs a dynamic scheme",
        )
    generic = [fem.Function(u.function_space) for u in model.unknowns]
    internal = _internal_forms(model, loads, generic, model.elastic_energy)
    problem = Problem(model, list(loads), list(contacts), None, {}, list(model.unknowns))
    problem._internal, problem._generic = internal, generic
    states, rates, accelerations = model.stage()
    dynamic = model.integrator.dynamic
    averaged = model.integrator.potential_points(model.free_body) if dynamic else None
    points = averaged or [(1.0, states)]
    if not any(c.newton_hooks for c in contacts):
        problem.pressure = model.mixed_pressure(len(points))
    pressure = problem.pressure
    if pressure is not None:
        problem._step_internal = _internal_forms(model, loads, generic, pressure.other_energy)
    forms = problem._balance(states, rates, accelerations, averaged, problem._step_internal)
    if model.integrator.dynamic:
        forms = problem._minus_contacts(forms, *model.end_of_step())
    else:
        forms = problem._minus_contacts(forms, states, rates)
    if pressure is not None:
        work, constraint = pressure.residuals(
            generic[0], model.tests[0], [(w, point[0]) for w, point in points]
        )
        forms = [forms[0] + work, *forms[1:], constraint]
        problem.unknowns.append(pressure.p)
    problem.residual = forms if len(forms) > 1 else forms[0]
    problem.energy_forms = _energy_forms(model, loads, contacts)
    return problem


def _internal_forms(
    model: Model,
    loads: Sequence[Load],
    generic: list[fem.Function],
    elastic: Callable[[Sequence[Any]], Any],
) -> list[Any]:
    """δΠ of the generic unknowns per unknown, Π = ``elastic`` + the loads' energies."""
    potential = elastic(generic)
    for load in loads:
        energy = load.energy(model, generic)
        if energy is not None:
            potential = potential + energy
    return [
        ufl.algorithms.expand_derivatives(ufl.derivative(potential, g, w))
        for g, w in zip(generic, model.tests, strict=True)
    ]


def _energy_forms(
    model: Model, loads: Sequence[Load], contacts: Sequence[Contact]
) -> dict[str, ufl.Form]:
    state, rates = model.accepted()
    out = {"kinetic": model.kinetic_energy(rates), "elastic": model.elastic_energy(state)}
    for load in loads:
        energy = load.energy(model, state)
        if energy is not None:
            out[load.name] = energy
    for contact in contacts:
        energy = contact.energy(model)
        if energy is not None:
            out[contact.name] = energy
    return out
