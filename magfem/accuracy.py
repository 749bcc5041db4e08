"""Which mechanics model suits a case: the rod's adequacy and ``[mesh] model = "auto"``.

The rod (:mod:`magfem.mechanics.models.rod`) holds one section per point of
an arm's midline: the section stays straight across the width (bent only by
the anticlastic law of :mod:`magfem.mechanics.models.rod_section`, exact for
a curvature that is uniform along the arm). That asks for

* a slender arm: length >= SLENDERNESS × its widest section, so that the
  root and tip regions, where a plate's bending is not that of a strip,
  are a small part of it;
* a width small against the length over which the bending changes: the
  magnetoelastic length ℓ (:func:`magfem.material.magnetoelastic_length`,
  at the field amplitude bound), widest section <= WIDTH_PER_BEND_LENGTH ℓ.
  A wider arm meets curvatures that vary across its width (the bend of a
  2 mm arm in the default drive spans ~ℓ = 0.86 mm), which one section
  cannot hold.

Measured (docs/verification.md §6b, §6e), 7.5 mm arms in 2 mT (ℓ = 0.86 mm),
rod − shell while the arm rises: 0.25 mm wide (b/ℓ = 0.29) within 0.15°,
0.5 mm (0.58) 0.04°, 1 mm (1.16) 0.49°, 2 mm (2.3) 1.56°. ``auto`` picks the
rod where it is adequate and the shell (``surface``) elsewhere.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from magfem import material
from magfem.case import Case
from magfem.config import CaseError
from magfem.geometry.robot_mesh import SHELL_CLAMP_INSET
from magfem.geometry.robots import outline_of
from magfem.geometry.rod_mesh import arm_widths, rod_layout
from magfem.geometry.spec import check_mesh_for_robot

__all__ = [
    "SLENDERNESS",
    "WIDTH_PER_BEND_LENGTH",
    "RodAdequacy",
    "resolve_model",
    "rod_adequacy",
]

SLENDERNESS = 4.0
"""Least arm length / widest section of an arm the rod models."""
WIDTH_PER_BEND_LENGTH = 0.5
"""Largest widest-section / magnetoelastic length of an arm the rod models."""


@dataclass(frozen=True)
class RodAdequacy:
    """Whether the rod model suits a case, and the one-line reason."""

    adequate: bool
    reason: str


def _bend_length(case: Case) -> float | None:
    """ℓ (m) at the sum of the sources' nominal flux densities; None without a field."""
    flux = sum(getattr(s, "flux_density", None) or 0.0 for s in case.field.sources)
    mat = case.material
    if flux <= 0.0 or mat.remanence <= 0.0:
        return None
    return material.magnetoelastic_length(
        mat.shear_modulus, mat.bulk, case.robot.thickness, mat.remanence, flux
    )


def rod_adequacy(case: Case) -> RodAdequacy:
    """The rod's adequacy for ``case``'s robot and field (module docstring)."""
    robot = case.robot
    try:
        layout = rod_layout(
            outline_of(robot),
            robot,
            root=case.mesh.root,
            inset=SHELL_CLAMP_INSET * robot.thickness,
        )
    except CaseError as err:
        return RodAdequacy(False, err.problem)
    lengths = {b.group: b.length for b in layout.branches if not b.rigid}
    widths = {name: max(w) for name, w in arm_widths(layout).items()}
    name = min(widths, key=lambda g: lengths[g] / widths[g])
    slender = lengths[name] / widths[name]
    ell = _bend_length(case)
    facts = f"{name}: length/width {slender:.3g}"
    if ell is not None:
        facts += f", width/magnetoelastic length {widths[name] / ell:.2g}"
    if slender < SLENDERNESS:
        return RodAdequacy(False, f"{facts}: not slender (< {SLENDERNESS:g})")
    widest = max(widths.values())
    if ell is not None and widest > WIDTH_PER_BEND_LENGTH * ell:
        return RodAdequacy(
            False,
            f"{facts}: wider than {WIDTH_PER_BEND_LENGTH:g} x the magnetoelastic length "
            f"{ell * 1e3:.3g} mm (the bend varies across the width)",
        )
    return RodAdequacy(True, f"{facts}: slender, narrow against the bend")


def resolve_model(case: Case) -> tuple[Case, str | None]:
    """(case with ``mesh.model`` chosen, the line saying why) for ``auto``; else (case, None).

    Raises:
        CaseError: the mesh does not suit the chosen model (``check_mesh_for_robot``).
    """
    if case.mesh.model != "auto":
        return case, None
    verdict = rod_adequacy(case)
    chosen = "rod" if verdict.adequate else "surface"
    mesh = dataclasses.replace(case.mesh, model=chosen)
    check_mesh_for_robot(case.robot, mesh)
    line = f"mesh.model = auto: {chosen} ({'rod adequate' if verdict.adequate else 'no rod'}: "
    return dataclasses.replace(case, mesh=mesh), line + verdict.reason + ")"
