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
rod where it is adequate and the shell (``surface``) elsewhere; the
``[mesh]`` keys the chosen model does not use (:data:`NOT_USED_BY`: the
shell's sizes for the rod, the layers for the shell) go back to their
defaults, and the line that says what was chosen names them.

**The accuracy target** (``[solver] accuracy = "1 deg"``,
:func:`resolve_accuracy`) chooses the model (the ``auto`` rule above unless
the case names one), then, from that model's table (:data:`TABLES`), the
cheapest measured configuration whose tip-angle error was at most the target
(at most half of it where the case's ℓ or τ is not the table's, :data:`TRANSFER_MARGIN`):
the element degree, the elements per magnetoelastic length ℓ along the arm
(``mesh.size``) and across it (``size_across``, shell and solid), the layers
through the thickness (strip, solid) and the time step. The rows are
measurements on the default drive (80 µm, 2 mT square wave, ℓ = 0.86 mm,
τ = 2.54 ms, the largest tip-angle error over the first half period against
a converged run; docs/verification.md §4a, §4c (solid, shell), §6c (rod) and
§8 (strip)); a row is carried to another case at the same elements per ℓ
and steps per τ (:func:`magfem.material.magnetoelastic_time`), the two
scales of a field-driven bend. The step is chosen rather than ``[time]
tolerance``: the error estimate does not see the violent start after a field
switch, and its error fell slowly with the tolerance (docs/verification.md
§7). Keys the case sets itself win over the table; every choice is one line
of the run's log and of ``magfem check``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from magfem import material
from magfem.case import Case
from magfem.config import CaseError
from magfem.geometry.beam import BeamOutline
from magfem.geometry.robot_mesh import SHELL_CLAMP_INSET
from magfem.geometry.robots import outline_of
from magfem.geometry.rod_mesh import arm_widths, rod_layout
from magfem.geometry.spec import MeshSpec, check_mesh_for_robot
from magfem.units import parse_angle

__all__ = [
    "BEND_LENGTH",
    "BEND_TIME",
    "NOT_USED_BY",
    "SAME_SCALE",
    "SLENDERNESS",
    "TABLES",
    "TRANSFER_MARGIN",
    "WIDTH_PER_BEND_LENGTH",
    "Measured",
    "RodAdequacy",
    "resolve_accuracy",
    "resolve_case",
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
    """ℓ (m) at the sources' amplitude bound (FieldSpec.nominal_flux_bound); None without one."""
    flux = case.field.nominal_flux_bound()
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
    mesh, dropped = _for_model(case.mesh, chosen)
    check_mesh_for_robot(case.robot, mesh)
    line = f"mesh.model = auto: {chosen} ({'rod adequate' if verdict.adequate else 'no rod'}: "
    line += verdict.reason + ")"
    if dropped:
        line += f"; not used by the {chosen}: " + ", ".join(dropped)
    return dataclasses.replace(case, mesh=mesh), line


NOT_USED_BY = {
    "rod": ("tip_size", "root_size", "size_across", "turn_axis"),
    "surface": ("layers",),
}
"""``[mesh]`` keys that ``auto`` resets to their defaults when it picks the model: a case
that leaves the model open may set them for the other one."""


def _for_model(mesh: MeshSpec, chosen: str) -> tuple[MeshSpec, list[str]]:
    """(``mesh`` with model ``chosen`` and its unused keys at their defaults, ``key = value``
    of each key reset)."""
    defaults: dict[str, Any] = {f.name: f.default for f in dataclasses.fields(MeshSpec)}
    dropped = {
        key: getattr(mesh, key)
        for key in NOT_USED_BY[chosen]
        if getattr(mesh, key) != defaults[key]
    }
    reset = {key: defaults[key] for key in dropped}
    shown = [_show(f"mesh.{key}", value) for key, value in dropped.items()]
    return dataclasses.replace(mesh, model=chosen, **reset), shown


# --- the accuracy target ([solver] accuracy) ---------------------------------------------------

BEND_LENGTH = material.magnetoelastic_length(115e3, 11.5e6, 80e-6, 123e3, 2e-3)
"""ℓ (m) of the measurements in :data:`TABLES`: the default case (80 µm, 2 mT), 0.863 mm."""
BEND_TIME = material.magnetoelastic_time(115e3, 11.5e6, 80e-6, 2130.0, 123e3, 2e-3)
"""τ (s) of the measurements in :data:`TABLES`, 2.54 ms."""


SAME_SCALE = 0.05
"""ℓ and τ within this fraction of the tables': a row's measured error holds as it is."""
TRANSFER_MARGIN = 2.0
"""Elsewhere a row counts as TRANSFER_MARGIN × its measured error: carried to another ℓ and τ
the rows gave 1.05-1.8 × their error (docs/verification.md §8)."""


@dataclass(frozen=True)
class Measured:
    """One measured configuration of a model in the default drive (ℓ = BEND_LENGTH, τ = BEND_TIME).

    ``error``: largest tip-angle error over the first half period (deg);
    ``size``, ``across``: element sizes along and across the arm (m; across
    None: as along); ``layers`` through the thickness; ``step`` (s); ``where``:
    the measurement (docs/verification.md section, run).
    """

    error: float
    degree: int
    size: float
    across: float | None
    layers: int
    step: float
    where: str


TABLES: dict[str, tuple[Measured, ...]] = {
    "surface": (
        Measured(10.7, 2, 0.5e-3, None, 1, 0.2e-3, "§4c, shell P2 0.5 mm, dt 0.2 ms"),
        Measured(1.92, 2, 0.25e-3, 0.5e-3, 1, 0.2e-3, "§4c, shell P2 0.25 x 0.5 mm, dt 0.2 ms"),
        Measured(1.73, 2, 0.25e-3, 0.5e-3, 1, 0.1e-3, "§4c, shell P2 0.25 x 0.5 mm, dt 0.1 ms"),
        Measured(0.71, 3, 0.5e-3, 1e-3, 1, 0.05e-3, "§4c, shell P3 0.5 x 1 mm, dt 0.05 ms"),
        Measured(0.58, 2, 0.125e-3, 0.5e-3, 1, 0.05e-3, "§4c, shell P2 0.125 x 0.5 mm, dt 0.05 ms"),
    ),
    # the solid's rows add its mesh error at dt 0.2 ms (§4a) and the step's share (§4a, §4c)
    "solid": (
        Measured(6.5, 2, 0.5e-3, None, 1, 0.2e-3, "§4a, solid P2 0.5 mm: 5.0 deg mesh + 1.45 step"),
        Measured(1.3, 2, 0.25e-3, 0.5e-3, 1, 0.05e-3, "§4a/4c, solid 0.25 x 0.5 mm: 0.7 + 0.6"),
    ),
    "rod": (
        Measured(9.17, 2, 1e-3, None, 1, 0.5e-3, "§6c, rod P2 1 mm, dt 0.5 ms"),
        Measured(7.02, 2, 0.5e-3, None, 1, 0.25e-3, "§6c, rod P2 0.5 mm, dt 0.25 ms"),
        Measured(3.44, 2, 0.5e-3, None, 1, 0.125e-3, "§6c, rod P2 0.5 mm, dt 0.125 ms"),
        Measured(0.55, 3, 0.5e-3, None, 1, 31.25e-6, "§6c, rod P3 0.5 mm, dt 31.25 us"),
    ),
    "strip": (
        Measured(23.5, 2, 1e-3, None, 1, 0.2e-3, "§8, strip P2 1 mm, dt 0.2 ms"),
        Measured(4.78, 2, 0.5e-3, None, 1, 0.2e-3, "§8, strip P2 0.5 mm, dt 0.2 ms"),
        Measured(0.81, 2, 0.25e-3, None, 1, 0.2e-3, "§8, strip P2 0.25 mm, dt 0.2 ms"),
        Measured(0.69, 2, 0.25e-3, None, 2, 0.2e-3, "§8, strip P2 0.25 mm, 2 layers, dt 0.2 ms"),
        Measured(0.45, 2, 0.125e-3, None, 1, 0.1e-3, "§8, strip P2 0.125 mm, dt 0.1 ms"),
        Measured(0.33, 2, 0.125e-3, None, 2, 0.1e-3, "§8, strip P2 0.125 mm, 2 layers, dt 0.1 ms"),
    ),
}
"""Per model, measured configurations, cheapest first (module docstring)."""


def resolve_case(case: Case) -> tuple[Case, list[str]]:
    """(case with the accuracy target and ``mesh.model = auto`` resolved, the lines saying why).

    Raises:
        CaseError: the target cannot be met or the chosen mesh does not suit the robot.
    """
    case, lines = resolve_accuracy(case)
    case, line = resolve_model(case)
    return case, lines + ([line] if line is not None else [])


def resolve_accuracy(case: Case) -> tuple[Case, list[str]]:
    """(case with the choices of ``[solver] accuracy`` made, one line per choice).

    Unchanged, no lines, without a target or when the case is already resolved
    (``case.given`` None). The resolved case has ``given`` None.

    Raises:
        CaseError: (``solver.accuracy``) no field scale, no table for the model, or a
            target below the table's best; a chosen value the case's other keys refuse.
    """
    target = case.solver.accuracy
    if target is None or case.given is None:
        return case, []
    wanted = math.degrees(parse_angle(target))
    given = case.given
    ell = _bend_length(case)
    if ell is None:
        raise CaseError(
            "solver.accuracy",
            target,
            "needs material.remanence > 0 and a source with a flux_density: the tables are "
            "in magnetoelastic lengths",
        )
    mat = case.material
    flux = case.field.nominal_flux_bound()
    tau = material.magnetoelastic_time(
        mat.shear_modulus, mat.bulk, case.robot.thickness, mat.density, mat.remanence, flux
    )
    case, model_line = _target_model(case, given)
    model = case.mesh.model
    scales = (ell / BEND_LENGTH, tau / BEND_TIME)
    margin = 1.0 if all(abs(x - 1.0) <= SAME_SCALE for x in scales) else TRANSFER_MARGIN
    degree = case.solver.degree if "solver.degree" in given else None
    row = _pick_row(model, wanted, degree, target, margin)
    choices = _choices(case, row, *scales)
    head = (
        f"accuracy  {target}: ell = {ell * 1e3:.3g} mm, tau = {tau * 1e3:.3g} ms; {model} row "
        f"{row.where}: {row.error:g} deg measured"
        + ("" if margin == 1.0 else f", x {margin:g} for another ell, tau")
    )
    lines = [head, f"accuracy  {model_line}"]
    values: dict[str, object] = {}
    for key, (value, why) in choices.items():
        table, name = key.split(".")
        if key in given:
            mine = getattr(getattr(case, table), name)
            values[key] = mine
            theirs = _show(key, value).split(" = ")[1]
            same = _show(key, mine) == _show(key, value)
            said = "as the target" if same else f"wins over {theirs}"
            lines.append(f"accuracy  {_show(key, mine)} set in the case {said} ({why})")
        else:
            values[key] = value
            lines.append(f"accuracy  {_show(key, value)}: {why}")
    return _apply(case, values), lines


def _target_model(case: Case, given: frozenset[str]) -> tuple[Case, str]:
    """(case with a concrete model, the line): the case's own model, else the ``auto`` rule."""
    if "mesh.model" in given and case.mesh.model != "auto":
        return case, f"mesh.model = {case.mesh.model} set in the case wins"
    auto = dataclasses.replace(case, mesh=dataclasses.replace(case.mesh, model="auto"))
    resolved, line = resolve_model(auto)
    return resolved, f"{line} (the auto rule)"


def _pick_row(
    model: str, wanted: float, degree: int | None, target: str, margin: float
) -> Measured:
    """The cheapest row of ``model`` within ``wanted`` / ``margin`` deg (of ``degree`` if the
    case sets it)."""
    rows = TABLES.get(model)
    if not rows:
        raise CaseError("solver.accuracy", target, f"no measured table for mesh.model = {model}")
    within = [r for r in rows if r.error * margin <= wanted]
    if not within:
        best = min(rows, key=lambda r: r.error)
        moved = "" if margin == 1.0 else f" x {margin:g} away from the measured ell and tau"
        raise CaseError(
            "solver.accuracy",
            target,
            f"below what the {model} table reaches ({best.error:g} deg{moved}; {best.where}); "
            f"ask for >= {best.error * margin:.3g} deg"
            + ("" if model == "surface" else " or another mesh.model"),
        )
    same = [r for r in within if r.degree == degree]
    return (same or within)[0]


def _choices(
    case: Case, row: Measured, length_scale: float, time_scale: float
) -> dict[str, tuple[object, str]]:
    """``table.key`` -> (value the row gives, why), for the keys that apply to the model."""
    model = case.mesh.model
    per_ell = f"{BEND_LENGTH / row.size:.3g} per ell"
    size = row.size * length_scale
    out: dict[str, tuple[object, str]] = {"solver.degree": (row.degree, f"P{row.degree}")}
    if model == "rod":
        shortest = min(a.length for a in case.robot.params.outline().arms)
        out["mesh.size"] = (min(size, shortest), f"{per_ell} along the arm")
    else:
        across = (row.across or row.size) * length_scale
        feature = case.robot.min_feature
        if model != "strip" and across != size and isinstance(outline_of(case.robot), BeamOutline):
            out["mesh.size"] = (size, f"{per_ell} along the arm")
            why = f"{BEND_LENGTH / (row.across or row.size):.3g} per ell across"
            out["mesh.size_across"] = (min(across, feature), why)
        else:
            out["mesh.size"] = (min(size, across, feature), f"{per_ell}")
    if model in ("strip", "solid"):
        out["mesh.layers"] = (row.layers, "through the thickness")
    if case.time.scheme != "quasi_static":
        step = min(row.step * time_scale, case.time.end - case.time.start)
        out["time.step"] = (step, f"tau / {BEND_TIME / row.step:.3g}")
    return out


def _show(key: str, value: object) -> str:
    if isinstance(value, float) and key.startswith("mesh."):
        return f"{key} = {value * 1e3:.4g} mm"
    if isinstance(value, float) and key.startswith("time."):
        return f"{key} = {value * 1e6:.4g} us"
    return f"{key} = {value}"


def _apply(case: Case, values: dict[str, object]) -> Case:
    """The case with ``values`` (``table.key`` -> value) set, checked, marked resolved."""
    tables: dict[str, dict[str, object]] = {}
    for key, value in values.items():
        table, name = key.split(".")
        tables.setdefault(table, {})[name] = value
    changed = {}
    for table, fields in tables.items():
        try:
            changed[table] = dataclasses.replace(getattr(case, table), **fields)
        except CaseError as err:
            raise CaseError(f"{table}.{err.key}", err.value, err.problem) from None
    resolved = dataclasses.replace(case, **changed, given=None)
    check_mesh_for_robot(resolved.robot, resolved.mesh)
    return resolved
