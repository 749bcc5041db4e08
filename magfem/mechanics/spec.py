"""Case tables of the mechanics stage: material, time, solver, contact, environment, output.

Each table maps one-to-one onto a frozen dataclass below (see
:mod:`magfem.config`). Every table except ``[material]`` is fully defaulted,
so a case only states what differs from the defaults. Values are SI.

``[material]`` (hard-magnetic neo-Hookean, :mod:`magfem.material`)::

    [material]
    shear_modulus = "115 kPa"
    density = "2130 kg/m^3"
    remanence = "123 kA/m"          # |M| of the remanent magnetization
    direction = "normal"            # "normal", "-normal" or a vector [mx, my, mz]
    [[material.regions]]            # optional per-cell-group overrides
    group = "arm_left"
    direction = "-normal"

``direction = "normal"`` is the membrane normal of the reference
configuration, +z (robots lie in the x-y plane, thickness along +z; for 2D
strips, side views in (x, z), it is the second in-plane axis).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from magfem.config import (
    CaseError,
    build_fields,
    flag,
    integer,
    option,
    quantity,
    vector,
)
from magfem.units import UnitError, parse_angle, parse_quantity

__all__ = [
    "FACTORISATIONS",
    "ContactSpec",
    "EnvironmentSpec",
    "MagnetRegionSpec",
    "MaterialSpec",
    "OutputSpec",
    "SolverSpec",
    "TimeSpec",
    "parse_direction",
]

Direction = str | tuple[float, ...]
"""``"normal"``, ``"-normal"`` or a 3-vector (any length, normalised on use)."""

_NORMAL_WORDS = ("normal", "+normal", "-normal")


def parse_direction(raw: Any, key: str) -> Direction:
    """Validate a magnetization direction: ``"normal"``, ``"-normal"`` or a nonzero 3-vector.

    Returns ``"normal"``/``"-normal"`` or a tuple of three floats (not normalised).

    Raises:
        CaseError: naming ``key`` for anything else.
    """
    allowed = 'must be "normal", "-normal" or a nonzero vector [mx, my, mz]'
    if isinstance(raw, str):
        word = raw.strip()
        if word not in _NORMAL_WORDS:
            raise CaseError(key, raw, allowed)
        return "-normal" if word == "-normal" else "normal"
    if isinstance(raw, list | tuple) and len(raw) == 3:
        try:
            vec = tuple(parse_quantity(v, "") for v in raw)
        except UnitError:
            raise CaseError(key, raw, allowed) from None
        if not any(vec) or not all(math.isfinite(v) for v in vec):
            raise CaseError(key, raw, allowed)
        return vec
    raise CaseError(key, raw, allowed)


def _build_with_direction[T](cls: type[T], table: Mapping[str, Any], where: str) -> T:
    """``build_fields`` with the ``direction`` key parsed by :func:`parse_direction`."""
    fixed: dict[str, Any] = {}
    if "direction" in table:
        fixed["direction"] = parse_direction(table["direction"], f"{where}.direction")
    rest = {k: v for k, v in table.items() if k != "direction"}
    return build_fields(cls, rest, where, **fixed)


@dataclass(frozen=True)
class MagnetRegionSpec:
    """Remanent magnetization of one named cell group, overriding ``[material]``."""

    group: str = option(doc="name of a cell group of the robot mesh (e.g. arm_left)")
    remanence: float | None = quantity(None, "A/m", ge=0.0, doc="|M| in A/m (default: material's)")
    direction: Direction | None = field(
        default=None, metadata={"doc": 'direction ("normal", "-normal" or a vector)'}
    )

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> MagnetRegionSpec:
        return _build_with_direction(cls, table, where)


@dataclass(frozen=True)
class MaterialSpec:
    """``[material]``: hard-magnetic neo-Hookean solid (see :mod:`magfem.material`).

    ψ = μ/2 (J^(-2/3) tr C − 3) + K/2 (J − 1)² − (F M̃)·B_a(x, t).
    """

    shear_modulus: float = quantity(unit="Pa", gt=0.0, doc="μ (Pa)")
    density: float = quantity(unit="kg/m^3", gt=0.0, doc="ρ in the reference configuration")
    bulk_modulus: float | None = quantity(None, "Pa", gt=0.0, doc="K (Pa); default 100 μ")
    remanence: float = quantity(0.0, "A/m", ge=0.0, doc="|M̃| of the remanent magnetization")
    direction: Direction = field(
        default="normal", metadata={"doc": 'direction of M̃: "normal", "-normal" or a vector'}
    )
    regions: tuple[MagnetRegionSpec, ...] = ()
    plane: str = option(
        "strain",
        ("strain", "stress"),
        doc="2D strip models only: plane strain (wide arm, plate-like) or plane stress",
    )

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> MaterialSpec:
        return _build_with_direction(cls, table, where)

    def __post_init__(self) -> None:
        seen: set[str] = set()
        for i, region in enumerate(self.regions):
            if region.group in seen:
                raise CaseError(f"regions[{i}].group", region.group, "group listed twice")
            seen.add(region.group)
        if self.bulk_modulus is not None and self.bulk_modulus < self.shear_modulus:
            raise CaseError(
                "bulk_modulus",
                self.bulk_modulus,
                "must be >= shear_modulus (a nearly incompressible elastomer has K >> μ)",
            )

    @property
    def bulk(self) -> float:
        """K in Pa (default 100 μ)."""
        return self.bulk_modulus if self.bulk_modulus is not None else 100.0 * self.shear_modulus


SCHEMES = ("generalized_alpha", "hht", "newmark", "quasi_static")
MAX_STEP_RATIO = 10.0
"""Default ``max_step`` / ``step`` under error control (``tolerance``)."""


@dataclass(frozen=True)
class TimeSpec:
    """``[time]``: time span, integrator and adaptive stepping.

    Schemes: ``generalized_alpha`` (Chung–Hulbert, spectral radius ``rho_inf``;
    at ``rho_inf = 1`` energy conserving), ``hht`` (Hilber–Hughes–Taylor,
    ``rho_inf`` in [0.5, 1]), ``newmark`` (average acceleration, β = 1/4,
    γ = 1/2), ``quasi_static`` (no inertia; the load follows the field's time
    history).

    Steps: from Newton's cost (cut after failures and slow solves, grown
    after easy ones), or, with ``tolerance``, from the integrator's local
    error estimate (:mod:`magfem.mechanics.stepping`).
    """

    end: float = quantity(0.1, "s", gt=0.0, doc="end time")
    start: float = quantity(0.0, "s", ge=0.0, doc="start time")
    step: float = quantity(2.5e-4, "s", gt=0.0, doc="initial (nominal) time step")
    min_step: float | None = quantity(None, "s", gt=0.0, doc="smallest step (default step/1024)")
    max_step: float | None = quantity(
        None, "s", gt=0.0, doc="largest step (default step; with tolerance 10 × step)"
    )
    scheme: str = option("generalized_alpha", SCHEMES)
    rho_inf: float = quantity(0.5, "", ge=0.0, le=1.0, doc="spectral radius at infinite frequency")
    adaptive: bool = True
    average_forces: str = option(
        "auto",
        ("auto", "on", "off"),
        doc="rho_inf = 1: on averages the potential's forces over the step (energy conserved, "
        "also when the step changes), off keeps them at the midpoint (momentum and angular "
        "momentum conserved, smaller phase error in fast rotations); auto: off for a free "
        "body, on otherwise",
    )
    cut_factor: float = quantity(0.5, "", gt=0.0, lt=1.0, doc="step multiplier after a failure")
    grow_factor: float = quantity(1.5, "", ge=1.0, le=4.0, doc="step multiplier after easy steps")
    easy_iterations: int = integer(4, ge=0, doc="Newton iterations <= this: a step is easy")
    slow_iterations: int = integer(
        10, ge=1, doc="Newton iterations at or above which the next step is cut"
    )
    max_cuts: int = integer(12, ge=0, doc="consecutive step cuts before giving up")
    tolerance: float | None = quantity(
        None,
        "",
        gt=0.0,
        lt=1.0,
        doc="error control: local displacement error per step / body size (default off)",
    )

    def __post_init__(self) -> None:
        if self.end <= self.start:
            raise CaseError("end", self.end, f"must be > start ({self.start:g} s)")
        if self.min_step is not None and self.min_step > self.step:
            raise CaseError("min_step", self.min_step, f"must be <= step ({self.step:g} s)")
        if self.max_step is not None and self.max_step < self.step:
            raise CaseError("max_step", self.max_step, f"must be >= step ({self.step:g} s)")
        if self.scheme == "hht" and self.rho_inf < 0.5:
            raise CaseError("rho_inf", self.rho_inf, "HHT-α needs rho_inf in [0.5, 1]")
        if self.tolerance is not None and self.scheme == "quasi_static":
            raise CaseError(
                "tolerance", self.tolerance, "needs a dynamic scheme (quasi_static has no error)"
            )
        if self.tolerance is not None and not self.adaptive:
            raise CaseError("tolerance", self.tolerance, "needs adaptive = true")
        if self.easy_iterations >= self.slow_iterations:
            raise CaseError(
                "easy_iterations",
                self.easy_iterations,
                f"must be < slow_iterations ({self.slow_iterations})",
            )

    @property
    def smallest_step(self) -> float:
        """Lower bound of the adaptive step (s)."""
        return self.min_step if self.min_step is not None else self.step / 1024.0

    @property
    def largest_step(self) -> float:
        """Upper bound of the adaptive step (s)."""
        if self.max_step is not None:
            return self.max_step
        return self.step if self.tolerance is None else MAX_STEP_RATIO * self.step


FACTORISATIONS = ("lu", "cholesky")
"""Preconditioners (``petsc_options.pc_type``) that are direct factorisations."""


@dataclass(frozen=True)
class SolverSpec:
    """``[solver]``: Newton (PETSc SNES) and linear solver; extra PETSc options pass through.

    ``petsc_options`` entries are given without prefix, e.g.
    ``petsc_options = { snes_monitor = "" , mat_mumps_icntl_14 = 200 }``,
    and override the options derived from the other keys. A ``pc_type``
    other than ``lu``/``cholesky`` (e.g. ``"gamg"``) replaces the direct
    solve by right-preconditioned GMRES to 1e-8 of the residual
    (:data:`magfem.mechanics.solver_options.KRYLOV_DEFAULTS`).

    Newton converges when the residual norm ‖R‖ (the Euclidean norm of the
    nodal force vector, N; N/m for strips) drops below ``rtol`` × its value
    at the predictor, below ``atol``, or below ``force_tolerance`` × F_ref,
    where F_ref is the norm of the robot's weight load vector ∫ ρ g₀·w dV under
    standard gravity on the same mesh (:func:`magfem.mechanics.solver.load_norm`;
    the time loop passes it to
    :meth:`~magfem.mechanics.solver.NewtonSolver.set_force_scale`).
    The relative criterion alone measures the residual against the
    predictor's, which the inertia term M Δu/(β Δt²) dominates (~1700 × the
    weight vector's norm on the default case), and so asks for ~2e-3 of the
    weight. ``force_tolerance = 0.1`` stops one Newton iteration earlier on
    most steps but moves the default case's tip angle by up to 0.16° through
    a different adaptive step sequence, hence off (0) by default
    (``docs/mechanics.md``, "Newton convergence").
    """

    linear_solver: str = option(
        "auto",
        ("auto", "mumps", "superlu_dist", "petsc"),
        doc="direct solver; auto: PETSc's LU for small Jacobians on one process, else MUMPS",
    )
    line_search: str = option("basic", ("basic", "bt", "l2", "cp"))
    rtol: float = quantity(1e-6, "", gt=0.0, lt=1.0, doc="Newton relative residual tolerance")
    atol: float = quantity(1e-12, "N", ge=0.0, doc="Newton absolute residual tolerance (N)")
    force_tolerance: float = quantity(
        0.0,
        "",
        ge=0.0,
        lt=1.0,
        doc="Newton also stops when ‖R‖ <= this × ‖weight load vector‖ (0: off)",
    )
    stol: float = quantity(1e-10, "", ge=0.0, lt=1.0, doc="Newton relative step tolerance")
    max_iterations: int = integer(15, ge=1, doc="Newton iterations before a step counts as failed")
    reuse_jacobian: bool = flag(
        False,
        doc="keep the factorised Jacobian across Newton iterations and steps while each "
        "iteration reduces the residual norm to reuse_contraction of the previous one or less "
        "(modified Newton); rebuilt when the step changes and after a failed solve",
    )
    reuse_contraction: float | None = quantity(
        None,
        "",
        gt=0.0,
        lt=1.0,
        doc="reuse_jacobian: rebuild the Jacobian after an iteration that left the residual "
        "norm above this fraction of the previous one (default 0.5; 0.99 with jacobian_free)",
    )
    jacobian_free: bool = flag(
        False,
        doc="with reuse_jacobian: each Newton step solves with the exact Jacobian, applied "
        "by finite differences of the residual, by GMRES preconditioned by the kept factorised "
        "Jacobian (Jacobian-free Newton-Krylov); the kept one is rebuilt after a GMRES solve "
        "of more than krylov_iterations iterations",
    )
    krylov_iterations: int = integer(
        4,
        ge=1,
        doc="jacobian_free: rebuild the kept Jacobian after a linear solve that took more "
        "GMRES iterations than this",
    )
    degree: int = integer(2, ge=1, le=3, doc="Lagrange degree of the displacement (P2 default)")
    quadrature_degree: int | None = integer(
        None, ge=1, le=12, doc="quadrature degree (default 2 × degree)"
    )
    volumetric_quadrature_degree: int | None = integer(
        None, ge=0, le=12, doc="degree for K/2 (J−1)² (default reduced: 2 × (degree − 1))"
    )
    mixed_pressure: str = option(
        "auto",
        ("auto", "on", "off"),
        doc="Newton also solves for the pressure K (J−1) at the volumetric quadrature points "
        "(quadrilaterals/hexahedra; same solution); auto: on for the solid, off for the strip",
    )
    petsc_options: dict[str, Any] = field(default_factory=dict)
    accuracy: str | None = option(
        None,
        doc='target tip-angle error, e.g. "1 deg": chooses mesh.model, mesh.size, '
        "size_across, layers, solver.degree and time.step from measured tables (keys the "
        "case sets win; magfem check prints the choices); absent: the case's own settings",
    )

    def __post_init__(self) -> None:
        try:
            parse_angle(self.accuracy, largest=math.pi / 2) if self.accuracy else None
        except UnitError as err:
            raise CaseError("accuracy", self.accuracy, str(err)) from None
        for key, value in self.petsc_options.items():
            if not isinstance(value, str | int | float | bool):
                raise CaseError(f"petsc_options.{key}", value, "must be a string or number")
        if self.jacobian_free and not self.reuse_jacobian:
            raise CaseError(
                "jacobian_free",
                self.jacobian_free,
                "needs reuse_jacobian = true (the kept factorised Jacobian preconditions GMRES)",
            )
        pc_type = self.petsc_options.get("pc_type", "lu")
        if self.jacobian_free and pc_type not in FACTORISATIONS:
            raise CaseError(
                "jacobian_free",
                self.jacobian_free,
                f"needs a factorisation as preconditioner, not petsc_options.pc_type = {pc_type!r}",
            )


@dataclass(frozen=True)
class ContactSpec:
    """``[contact]``: ground plane contact (penalty, regularised Coulomb friction).

    The laws: :mod:`magfem.mechanics.contacts.penalty` (ground) and
    :mod:`magfem.mechanics.contacts.self_contact`.
    """

    ground: bool = False
    ground_height: float = quantity(0.0, "m", doc="z of the ground plane (second axis for strips)")
    friction: float = quantity(0.5, "", ge=0.0, doc="Coulomb friction coefficient μ_f")
    penalty: float = quantity(10.0, "", gt=0.0, doc="κ: contact stiffness k_n = κ μ / thickness")
    penalty_onset: float = quantity(
        0.05, "", gt=0.0, doc="width of the C¹ onset of the penalty ramp, in thicknesses"
    )
    damping: float = quantity(1.0, "", ge=0.0, doc="contact dashpot, fraction of critical")
    regularization_velocity: float = quantity(
        1e-3, "m/s", gt=0.0, doc="v_ε of the regularised Coulomb friction"
    )
    slip_length: float = quantity(
        0.01,
        "",
        ge=0.0,
        doc="ℓ, in thicknesses: friction also regularised by ℓ/Δt (soft stick on tiny steps)",
    )
    surfaces: tuple[str, ...] = ("all",)
    """Facet groups that may touch the ground (``"all"``: the whole boundary).

    The traction is exactly zero off the ground, so a smaller set changes
    nothing but the cost as long as it holds every face that reaches the
    ground: ``["bottom", "clamp"]`` saves ~12 % of the Jacobian assembly on the
    default case but is wrong there, because the arm flips over past 180° after
    the field reverses and lands on its ``top`` face."""
    self_contact: bool = False
    """Contact between cell groups of the robot (arm–arm),
    :mod:`magfem.mechanics.contacts.self_contact`."""
    self_contact_groups: tuple[str, ...] = ()
    """Cell groups that may touch each other, and themselves with ``self_contact_within``
    (default: the robot's arms/petals)."""
    self_contact_penalty: float = quantity(
        10.0, "", gt=0.0, doc="κ_s: self-contact stiffness k_c = κ_s μ / thickness"
    )
    self_contact_onset: float = quantity(
        0.05, "", gt=0.0, doc="width of the C¹ onset of the self-contact ramp, in thicknesses"
    )
    self_contact_exclusion: float = quantity(
        2.0, "", ge=0.0, doc="points closer than this (in thicknesses) at rest never touch"
    )
    self_contact_inelastic: bool = False
    """Impacts between the groups are perfectly inelastic in the normal direction, as on the
    ground: after each step, points that have just met lose their relative normal velocity
    (the bow tie's clap, a fin striking the body). The energy lost is in the history
    (``self_contact_absorbed``)."""
    self_contact_within: bool = True
    """Each group also touches itself (an arm curling past 180°, a membrane folded over):
    two of its points touch only when farther apart at rest than the exclusion and than
    twice the group's largest cell, so a flat or smoothly bent membrane feels nothing."""


@dataclass(frozen=True)
class EnvironmentSpec:
    """``[environment]``: gravity and supports.

    ``clamped`` lists named groups (facets or cells) whose displacement is
    zero (the ``clamp`` patch bonded to the substrate); an empty list and no
    ``fixed_point`` makes a free body. ``fixed_point`` pins the mesh nodes
    within ``fixed_radius`` of a reference point (robots fixed at their middle).
    """

    gravity: tuple[float, ...] = vector((0.0, 0.0, -9.8), "m/s^2")
    clamped: tuple[str, ...] = ("clamp",)
    fixed_point: tuple[float, ...] | None = vector(None, "m")
    fixed_radius: float = quantity(
        0.0, "m", ge=0.0, doc="pin nodes within this distance of fixed_point (0: nearest node)"
    )


@dataclass(frozen=True)
class OutputSpec:
    """``[output]``: what is written while the run goes."""

    csv: bool = True
    history_interval: float = quantity(
        0.0,
        "s",
        ge=0.0,
        doc="keep a history row (CSV, plots, summary) at the first step at or after each "
        "multiple of this interval from time.start, at the last step and where the animation "
        "takes a frame (0: every step); contacts and observers with memory still see every step",
    )
    midline_spacing: float = quantity(
        0.0,
        "m",
        ge=0.0,
        doc="largest spacing of the arm midline's samples, from which the active length, "
        "folds, curvature and spread are read (0: 81 samples per arm, L/80 apart)",
    )
    vtx_every: int = integer(
        10, ge=0, doc="write the displacement to VTX every N steps and at the end (0: never)"
    )
    vtu_every: int = integer(
        10,
        ge=0,
        doc="write the P1 displacement as a VTU/PVD series (pyvista, ParaView) every N steps "
        "and at the end (0: never)",
    )
    checkpoint_every: int = integer(
        0, ge=0, doc="write a checkpoint every N steps (0: not by steps)"
    )
    checkpoint_interval: float = quantity(
        "10 min",
        "s",
        ge=0.0,
        doc="write a checkpoint when this much wall time has passed since the last "
        "(0: not by time)",
    )
    plot: bool = True
    animation: bool = True
    """GIF of the motion (``motion.gif``, :func:`magfem.mechanics.animation.write_animation`)."""
    animation_frames: int = integer(
        60, ge=2, le=1000, doc="snapshots of the boundary surface over the run (GIF frames)"
    )
