"""Finite-strain dynamics of hard-magnetic membranes.

Modules (one job each): :mod:`~magfem.mechanics.spec` (case tables),
:mod:`~magfem.mechanics.integrator` (time discretisation),
:mod:`~magfem.mechanics.problem` (residual, loads, supports),
:mod:`~magfem.mechanics.solver` (the only module that builds PETSc solvers),
:mod:`~magfem.mechanics.observers` (angles, strains, energies),
:mod:`~magfem.mechanics.output` (CSV/VTX/PNG) and
:mod:`~magfem.mechanics.simulation` (the time loop, :func:`simulate`).

Importing this package is cheap (the case loader imports :mod:`.spec`);
dolfinx is imported when :func:`simulate` or :class:`MembraneSimulation` is
first used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from magfem.mechanics.simulation import MembraneSimulation, SimulationResult, simulate

__all__ = ["MembraneSimulation", "SimulationResult", "simulate"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from magfem.mechanics import simulation

        return getattr(simulation, name)
    raise AttributeError(f"module 'magfem.mechanics' has no attribute {name!r}")
