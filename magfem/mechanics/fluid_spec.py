"""The ``[fluid]`` case table: the fluid around the robot (docs/fluid.md).

The loads it drives are :mod:`magfem.mechanics.loads.fluid` and
:mod:`magfem.mechanics.loads.hydrodynamics`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from magfem.config import (
    MISSING,
    CaseError,
    build_fields,
    option,
    quantity,
    to_table,
    vector,
)

__all__ = ["FLUID_MEDIA", "VACUUM", "FluidSpec"]

VACUUM = "vacuum"
"""``[fluid] medium`` for no fluid at all (the case's ``fluid`` is then None)."""


FLUID_MEDIA = {"water": (998.2, 1.002e-3), "air": (1.204, 1.813e-5)}
"""``[fluid] medium`` -> (density kg/m³, viscosity Pa·s) at 20 °C (and 101.325 kPa for air)."""


@dataclass(frozen=True)
class FluidSpec:
    """``[fluid]``: the fluid around the robot (docs/fluid.md): buoyancy, added mass, drag.

    Give ``medium = "water"`` or ``"air"`` (20 °C), or ``density`` and
    ``viscosity``; either may override a medium's value. ``medium = "vacuum"``
    alone means no fluid: the table then parses to None, so that
    ``--set fluid.medium=vacuum`` switches a case's fluid off. The model's
    coefficients are per unit plate area for a chord b (``chord``, default
    the robot's area over its arms' total length: an arm's mean width) and
    are printed, with their sources and validity, by ``magfem check``.
    """

    medium: str | None = option(
        None, (*FLUID_MEDIA, VACUUM), doc=f'preset fluid at 20 °C; "{VACUUM}": no fluid'
    )
    density: float | None = quantity(None, "kg/m^3", gt=0.0, doc="ρ_f (default: the medium's)")
    viscosity: float | None = quantity(
        None, "Pa*s", gt=0.0, doc="dynamic viscosity μ (default: the medium's)"
    )
    current: tuple[float, ...] = vector(
        (0.0, 0.0, 0.0), "m/s", doc='uniform velocity of the fluid, with units: ["5 mm/s", 0, 0]'
    )
    chord: float | None = quantity(
        None, "m", gt=0.0, doc="b of the added mass and drag (default: area / total arm length)"
    )
    friction_length: float | None = quantity(
        None, "m", gt=0.0, doc="L of the laminar skin friction (default: the chord)"
    )
    frequency: float | None = quantity(
        None,
        "Hz",
        ge=0.0,
        doc="characteristic frequency of the unsteady terms (default: the drive's; 0: steady)",
    )
    added_mass_coefficient: float = quantity(
        1.0, "", ge=0.0, doc="C_m: multiplies the strip value (π/4)ρb (1/E(e) for an ellipse)"
    )
    drag_coefficient: float = quantity(
        1.17, "", ge=0.0, doc="C_D at high Reynolds number (1.17: disk; 1.98: 2D strip)"
    )
    surfaces: tuple[str, ...] = ("all",)
    """Faces the fluid acts on (names as ``[contact] surfaces``); the coefficients are per
    plate, split equally over its two faces."""
    swim_direction: tuple[float, ...] = vector(
        (1.0, 0.0, 0.0), "", nonzero=True, doc="direction of forward speed and thrust"
    )

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> FluidSpec | None:
        if table.get("medium") == VACUUM:
            others = sorted(set(table) - {"medium"})
            if others:
                key = f"{where}.{others[0]}" if where else others[0]
                raise CaseError(key, table[others[0]], f'medium = "{VACUUM}" takes no other key')
            return None
        raw = table.get("current")
        if isinstance(raw, list | tuple):
            for i, item in enumerate(raw):
                if isinstance(item, int | float) and not isinstance(item, bool) and item != 0:
                    raise CaseError(
                        f"{where}.current[{i}]" if where else f"current[{i}]",
                        item,
                        'give the current with its unit, e.g. "5 mm/s" (0 needs none)',
                    )
        return build_fields(cls, table, where)

    def __post_init__(self) -> None:
        if self.medium is None:
            for key in ("density", "viscosity"):
                if getattr(self, key) is None:
                    raise CaseError(
                        key, MISSING, 'missing: give density and viscosity, or medium = "water"'
                    )

    def __to_table__(self) -> dict[str, Any]:
        out = {
            f.name: to_table(getattr(self, f.name))
            for f in dataclasses.fields(self)
            if getattr(self, f.name) is not None
        }
        out["current"] = [f"{v!r} m/s" if v else 0.0 for v in self.current]
        return out

    @property
    def fluid_density(self) -> float:
        """ρ_f (kg/m³)."""
        return self.density if self.density is not None else FLUID_MEDIA[str(self.medium)][0]

    @property
    def fluid_viscosity(self) -> float:
        """μ (Pa·s)."""
        return self.viscosity if self.viscosity is not None else FLUID_MEDIA[str(self.medium)][1]
