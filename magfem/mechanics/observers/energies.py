"""The energies of a run: kinetic, elastic, each load's and contact's, and their total."""

from __future__ import annotations

from collections.abc import Mapping

import ufl
from dolfinx import mesh as dmesh

from magfem.mechanics.forms import ScalarForms
from magfem.mechanics.observers.base import Observer

__all__ = ["Energies"]


class Energies(Observer):
    """``energy_<name>`` of each form and ``energy_total`` (J; strips: J/m × depth), collective.

    Args:
        forms: name -> scalar form at the accepted state (compiled here, once).
        mesh: the mesh of the forms.
        depth: out-of-plane depth of a strip (m; 1 for 3D models).
    """

    def __init__(self, forms: Mapping[str, ufl.Form], mesh: dmesh.Mesh, depth: float = 1.0):
        self.names = list(forms)
        self.forms = ScalarForms(mesh, list(forms.values()))
        self.depth = depth

    def columns(self) -> list[str]:
        return [*(f"energy_{n}" for n in self.names), "energy_total"]

    def observe(self, t: float) -> dict[str, float]:
        values = self.forms.assemble()
        row = {f"energy_{n}": v * self.depth for n, v in zip(self.names, values, strict=True)}
        row["energy_total"] = sum(row[f"energy_{n}"] for n in self.names)
        return row
