"""The interface of a contact, and the registry of the ``[[contacts]]`` kinds.

A :class:`Contact` acts on the body in one or both of two ways:

* UFL terms: a traction on the model's contact faces
  (:class:`~magfem.mechanics.models.base.Face`), whose virtual work
  :meth:`Contact.work` returns. In dynamic runs the problem evaluates it at
  the end of the step (x_{n+1}, v_{n+1}), which lets a landing body stop
  within the step (docs/mechanics.md, "Ground contact");
* Newton hooks for terms that are not local to a cell (self-contact couples
  distant dofs): :meth:`Contact.attach` registers them on the solver.

The time loop calls :meth:`Contact.before_solve` before each Newton solve,
:meth:`Contact.after_step` after each accepted step, and
:meth:`Contact.observe` for the history; it never knows which contact it
holds.

The ground plane and self-contact are set in ``[contact]``; further contact
kinds are ``[[contacts]]`` tables whose ``kind`` names a spec class
registered in :data:`CONTACTS`, whose ``build(model, material)`` makes it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl

from magfem.field.spec import FieldSpec
from magfem.mechanics.models.base import Face, Model
from magfem.mechanics.solver import NewtonSolver
from magfem.mechanics.spec import EnvironmentSpec, MaterialSpec
from magfem.plugins import Registry, build_registered

__all__ = ["CONTACTS", "Contact", "ContactKindSpec"]


class Contact:
    """A contact of the body with something (module docstring). Subclasses override what applies.

    Attributes:
        name: a word for its history columns.
        surfaces: the model's contact faces it acts on (``[contact] surfaces`` style names).
        nodal: its faces are integrated at the nodes (Gauss–Lobatto,
            :meth:`~magfem.mechanics.models.base.Model.faces`).
        newton_hooks: it adds terms to the displacement's residual and
            Jacobian through :meth:`attach` (Newton then solves for the model's
            unknowns alone, without a mixed pressure).
    """

    name = "contact"
    surfaces: tuple[str, ...] = ("all",)
    nodal: bool = False
    newton_hooks: bool = False

    def work(self, faces: Sequence[Face]) -> list[ufl.Form] | None:
        """Virtual work per unknown of its tractions on ``faces``, or None (no UFL terms)."""
        return None

    def energy(self, model: Model) -> ufl.Form | None:
        """Stored (penalty) energy at the accepted state, for the history, or None."""
        return None

    def attach(self, solver: NewtonSolver) -> None:
        """Register Newton hooks for terms outside the UFL residual (collective)."""

    def before_solve(self) -> None:
        """Refresh data frozen within a step (after the stage is set, collective)."""

    def after_step(self) -> None:
        """Act on the accepted state of a dynamic step (collective)."""

    def step_limit(self) -> float | None:
        """The longest next step (s) from the accepted state, or None (any; collective)."""
        return None

    def breakpoints(self, t0: float, t1: float) -> npt.NDArray[np.float64]:
        """Instants in (t0, t1] (s) where the contact switches (steps land on them), sorted."""
        return np.zeros(0)

    def press(self, model: Model, acceleration: npt.NDArray[np.float64]) -> None:
        """Prepare a quasi-static start under the body acceleration (m/s², gdim)."""

    def columns(self) -> list[str]:
        """History columns of :meth:`observe`."""
        return []

    def observe(self, t: float) -> dict[str, float]:
        """Observables at the accepted state (collective); keys are :meth:`columns`."""
        return {}

    def events(self) -> list[str]:
        """Messages since the last call (touch, release), identical on every rank."""
        return []

    def summary(self) -> dict[str, float]:
        """Scalars over the whole run."""
        return {}


CONTACTS: Registry[type[Any]] = Registry("contact kind")
"""``kind`` of a ``[[contacts]]`` table -> its spec class (frozen dataclass with ``build``)."""


@dataclass(frozen=True)
class ContactKindSpec(ABC):
    """A ``[[contacts]]`` table: validated into the spec class its ``kind`` names.

    The registered spec classes derive from it and build their contact.
    """

    @abstractmethod
    def build(
        self,
        model: Model,
        material: MaterialSpec,
        *,
        environment: EnvironmentSpec | None = None,
        field: FieldSpec | None = None,
    ) -> Contact:
        """The contact this table describes, acting on ``model`` of ``material``
        (``environment``: gravity, for a contact with a body of its own; ``field``: the
        case's ``[field]``, for a contact with its iron parts)."""

    def check_field(self, field: FieldSpec) -> None:
        """Check what the table names in the case's ``[field]``; raise CaseError (key relative
        to the table) if it is not there. Tables that name nothing there pass."""
        return

    def describe(self) -> str:
        """One line for ``magfem check``: what this contact is, in mm."""
        return str(getattr(self, "kind", type(self).__name__))

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> Any:
        return build_registered(CONTACTS, table, where)
