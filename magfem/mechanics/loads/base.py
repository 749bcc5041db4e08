"""The interface of a load on the body, and the registry of the ``[[loads]]`` kinds.

A :class:`Load` contributes to the step residual in one of two ways:

* a conservative load has a potential energy Π_L(state) (:meth:`Load.energy`);
  the residual takes its derivative together with the elastic energy's, and
  the history reports it as ``energy_<name>``;
* a non-conservative load gives its virtual work at the stage point
  (:meth:`Load.work`), e.g. drag, which depends on the velocity;
* a force proportional to the acceleration (the added mass of a fluid)
  is written like the model's inertia (:meth:`Load.inertia`), so that the
  integrator's weights apply to it as to the body's own mass (dynamic
  schemes only).

Time-dependent data (a field's waveform) are Constants or Functions that
:meth:`Load.update` sets in place, so forms are compiled once.

Loads other than the magnetic field (``[field]``) and gravity
(``[environment] gravity``) are listed in the case as ``[[loads]]`` tables
whose ``kind`` names a spec class registered in :data:`LOADS`; the spec's
``build(model)`` makes the load.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl

from magfem.mechanics.models.base import Model
from magfem.plugins import Registry, build_registered

__all__ = ["LOADS", "Load", "LoadSpec"]


class Load:
    """A load on a model's body (module docstring). Subclasses override what applies.

    Attributes:
        name: a word for its history columns (``energy_<name>``).
    """

    name = "load"

    def energy(self, model: Model, state: Sequence[Any]) -> ufl.Form | None:
        """Potential energy at ``state`` (J; J/m for strips), or None if not conservative."""
        return None

    def work(
        self, model: Model, state: Sequence[Any], rates: Sequence[Any]
    ) -> list[ufl.Form] | None:
        """Virtual work per unknown at (state, rates), or None (conservative loads)."""
        return None

    def inertia(
        self, model: Model, state: Sequence[Any], rates: Sequence[Any], accelerations: Sequence[Any]
    ) -> list[ufl.Form] | None:
        """Virtual work of an inertia-like force at the accelerations, per unknown, or None.

        Added to the residual with the model's own inertia (the sign of ρ ü·w):
        an added mass m_a gives +∫ m_a a·w.
        """
        return None

    def update(self, t: float, *, side: str, displacement: Any) -> None:
        """Set time-dependent data to time ``t`` (s) at the given displacement (collective)."""

    def breakpoints(self, t0: float, t1: float) -> npt.NDArray[np.float64]:
        """Instants in (t0, t1] (s) where the load switches (steps land on them), sorted."""
        return np.zeros(0)

    def ramp(self, factor: float) -> bool:
        """Scale a constant load by ``factor`` in [0, 1] (quasi-static load continuation).

        Returns whether this load takes part (False: it is left as it is).
        """
        return False

    def body_acceleration(self) -> npt.NDArray[np.float64] | None:
        """The uniform acceleration this load applies to every mass point (m/s², gdim), or None."""
        return None


LOADS: Registry[type[Any]] = Registry("load")
"""``kind`` of a ``[[loads]]`` table -> its spec class (frozen dataclass with ``build(model)``)."""


@dataclass(frozen=True)
class LoadSpec(ABC):
    """A ``[[loads]]`` table: validated into the spec class its ``kind`` names.

    The registered spec classes derive from it and build their load.
    """

    @abstractmethod
    def build(self, model: Model) -> Load:
        """The load this table describes, on ``model``."""

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> Any:
        return build_registered(LOADS, table, where)
