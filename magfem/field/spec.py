"""Case table ``[field]``: sources, iron parts, motions, the field model and FE settings.

A case without ``[field]`` has no applied field::

    [field]
    model = "auto"                 # auto | uniform | taylor1 | taylor2 | nodal (= fe)
    expansion_point = [0, 0, 0]    # m, Taylor expansion point = workspace centre
    workspace_size = "20 mm"       # edge of the cubic robot workspace
    tolerance = 0.01               # auto: error allowed in B and in ∇B over the workspace

    [[field.sources]]              # coils and magnets: magfem.field.source_spec
    kind = "cylinder_magnet"
    center = [0, 0, -0.02]
    motion = "approach"

    [[field.iron]]                 # magnetizable parts: magfem.field.iron_spec
    kind = "needle"
    tip = [0, 0, 0.01]

    [[field.motions]]              # rigid keyframed motions, referred to by name
    name = "approach"
    times = ["0 ms", "50 ms", "100 ms"]
    offsets = [[0, 0, 0], [0, 0, "5 mm"], [0, 0, 0]]
    angles = ["0 deg", "0 deg", "30 deg"]   # optional, about rotation_axis through pivot

    [field.solve]                  # FE settings of the iron solve (only with [[field.iron]])
    degree = 2

Rules checked here (each a :class:`~magfem.config.CaseError` naming the key):
magnets may not overlap windings nor iron; all iron parts move together, and
every coil or magnet moves with them (a source moving relative to the iron
would change its magnetisation in time); a uniform source may act on iron
only if the iron is fixed; with nonlinear iron (``saturation``) all sources
share one waveform taking only the values −1, 0, 1, because the iron's
response is then not proportional to the sources' strength.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from magfem.config import MISSING, CaseError, build_fields, integer, option, quantity, vector
from magfem.field.iron_spec import IronSpec
from magfem.field.source_spec import (
    BlockMagnetSpec,
    CoilSpec,
    CylinderMagnetSpec,
    SourceSpec,
    UniformSourceSpec,
    inside_source,
    inside_winding,
    magnet_sample_points,
)
from magfem.units import UnitError, parse_quantity

__all__ = ["MODELS", "FieldSpec", "IronSpec", "MotionSpec", "SolveSpec"]

MODELS = ("auto", "uniform", "taylor1", "taylor2", "nodal", "nodal2", "fe")


@dataclass(frozen=True)
class MotionSpec:
    """``[[field.motions]]``: a rigid keyframed motion (piecewise linear, held outside).

    The parts naming it move by ``offsets`` (m) and turn by ``angles`` (rad)
    about ``rotation_axis`` through ``pivot`` (a point of the case's
    placement), both interpolated linearly between the keyframe ``times``.
    """

    name: str = option(MISSING, doc="referred to by the parts' motion keys")
    times: tuple[float, ...] = vector(MISSING, "s", length=None, doc="keyframe times")
    offsets: tuple[tuple[float, ...], ...] = ()
    angles: tuple[float, ...] | None = vector(None, "rad", length=None, doc="keyframe angles")
    rotation_axis: tuple[float, ...] = vector((0.0, 0.0, 1.0), "", nonzero=True)
    pivot: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m")

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> MotionSpec:
        raw = table.get("offsets", None)
        rest = {k: v for k, v in table.items() if k != "offsets"}
        offsets: tuple[tuple[float, ...], ...] = ()
        if raw is not None:
            offsets = _offsets(raw, f"{where}.offsets")
        return build_fields(cls, rest, where, offsets=offsets)

    def __post_init__(self) -> None:
        if not self.name:
            raise CaseError("name", self.name, "must be a non-empty string")
        t = self.times
        if len(t) < 1 or any(b <= a for a, b in itertools.pairwise(t)):
            raise CaseError("times", t, "must be one or more strictly increasing times")
        for key, vals in (("offsets", self.offsets), ("angles", self.angles)):
            if vals and len(vals) != len(t):
                raise CaseError(key, vals, f"must have one entry per time ({len(t)})")
        if not self.offsets and not self.angles:
            raise CaseError("offsets", MISSING, "give offsets and/or angles")


def _offsets(raw: Any, key: str) -> tuple[tuple[float, ...], ...]:
    """Parse a list of 3-vectors of lengths (numbers in m or strings with units)."""
    if not isinstance(raw, list | tuple) or not all(
        isinstance(v, list | tuple) and len(v) == 3 for v in raw
    ):
        raise CaseError(key, raw, "must be a list of [x, y, z] offsets")
    try:
        return tuple(tuple(parse_quantity(c, "m") for c in v) for v in raw)
    except UnitError as err:
        raise CaseError(key, raw, str(err)) from None


@dataclass(frozen=True)
class SolveSpec:
    """``[field.solve]``: the finite-element solve of the iron parts' reaction field.

    The air region is a ball (or, axisymmetric, a half-disk) of radius
    ``air_factor`` × the iron's bounding radius, enlarged to hold the workspace.
    """

    degree: int | None = integer(None, ge=1, le=3, doc="potential degree (3 in (r, z), 2 in 3D)")
    mesh_size: float | None = quantity(None, "m", gt=0.0, doc="element size on the iron surface")
    workspace_mesh_size: float | None = quantity(None, "m", gt=0.0, doc="size cap in the workspace")
    grading: float = quantity(0.2, "", gt=0.0, le=1.0, doc="size growth per distance from iron")
    air_factor: float = quantity(10.0, "", ge=3.0, doc="air radius / iron size")
    hessian_step: float | None = quantity(None, "m", gt=0.0, doc="step for the FE ∇∇B (taylor2)")
    open_boundary: str = option("robin", ("robin", "dirichlet"), doc="outer boundary condition")
    geometry: str = option("auto", ("auto", "axisymmetric", "3d"), doc="FE geometry")
    curved: bool = True


def _solve_default() -> SolveSpec:
    return SolveSpec()


@dataclass(frozen=True)
class FieldSpec:
    """``[field]``: applied-field sources and how the mechanics sees them.

    ``model``: ``uniform`` (B(t) at ``expansion_point``, no gradient),
    ``taylor1``/``taylor2`` (B, ∇B (, ∇∇B) at ``expansion_point``),
    ``nodal`` (the field at the robot's nodes, re-expanded every time step;
    ``fe`` is its former name), ``nodal2`` (also ∇∇B at the nodes: the
    gradient force follows a free body within a step) or ``auto``: the
    cheapest of ``uniform``, ``taylor1``, ``taylor2``, ``nodal`` whose
    errors over the workspace (cube of edge ``workspace_size`` about
    ``expansion_point``) are within ``tolerance`` (:mod:`magfem.field.model`).
    """

    model: str = option("auto", MODELS)
    expansion_point: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m")
    workspace_size: float = quantity(20e-3, "m", gt=0.0, doc="edge of the robot workspace cube")
    tolerance: float = quantity(0.01, "", gt=0.0, lt=1.0, doc="auto: relative error allowed")
    sources: tuple[SourceSpec, ...] = ()
    iron: tuple[IronSpec, ...] = ()
    motions: tuple[MotionSpec, ...] = ()
    solve: SolveSpec = field(default_factory=_solve_default)

    def __post_init__(self) -> None:
        _check_motions(self)
        _check_overlaps(self)
        if self.iron:
            _check_iron_groups(self)

    @property
    def all_uniform(self) -> bool:
        """True when every source is spatially uniform (or there is none) and there is no iron."""
        return all(s.is_uniform for s in self.sources) and not self.iron

    def nominal_flux_bound(self) -> float:
        """Largest |B| (T) the sources' nominal flux densities add up to at one instant.

        Only sources on at the same instant add: the bound is the largest over the
        instants where a source switches on (each set of sources on together is on at
        the latest of their starts), so a trigger and a drive that follows it do not
        add. Uniform sources add as vectors, each scaled by any value in its
        waveform's range (:meth:`WaveformSpec.extremes`); |Σ| is convex, so the
        largest is at a corner of the ranges: exact for square waves, at most
        √n too large for n sines in quadrature. A coil's nominal (centre) flux
        density adds its magnitude times its waveform's; sources without one
        add nothing.
        """
        windows = []
        for spec in self.sources:
            wave = spec.waveform
            end = math.inf if wave.duration is None else wave.start + wave.duration
            windows.append((wave.start, end))
        best = 0.0
        for t, _ in windows:
            on = [s for s, (a, b) in zip(self.sources, windows, strict=True) if a <= t < b]
            best = max(best, _flux_bound(on))
        return best

    def motion(self, name: str) -> MotionSpec | None:
        """The motion called ``name`` ('' → None)."""
        return next((m for m in self.motions if m.name == name), None) if name else None


def _flux_bound(sources: Sequence[Any]) -> float:
    """Largest |B| (T) of ``sources`` all on (:meth:`FieldSpec.nominal_flux_bound`)."""
    vectors, ranges, rest = [], [], 0.0
    for spec in sources:
        lo, hi = spec.waveform.extremes()
        if isinstance(spec, UniformSourceSpec):
            vectors.append(spec.flux_density * spec.unit_direction)
            ranges.append((lo, hi))
        else:
            rest += float(getattr(spec, "flux_density", None) or 0.0) * max(-lo, hi)
    best = 0.0
    for corner in itertools.product(*ranges):
        total = sum((c * v for c, v in zip(corner, vectors, strict=True)), np.zeros(3))
        best = max(best, float(np.linalg.norm(total)))
    return best + rest


def _check_motions(spec: FieldSpec) -> None:
    names = [m.name for m in spec.motions]
    for i, n in enumerate(names):
        if n in names[:i]:
            raise CaseError(f"motions[{i}].name", n, "motion names must be unique")
    parts: list[tuple[str, Any]] = [(f"sources[{i}]", s) for i, s in enumerate(spec.sources)]
    parts += [(f"iron[{i}]", p) for i, p in enumerate(spec.iron)]
    for key, part in parts:
        name = getattr(part, "motion", "")
        if name and name not in names:
            allowed = ", ".join(names) if names else "none defined in [[field.motions]]"
            raise CaseError(f"{key}.motion", name, f"unknown motion; defined: {allowed}")


def _check_overlaps(spec: FieldSpec) -> None:
    coils = [(i, s) for i, s in enumerate(spec.sources) if isinstance(s, CoilSpec)]
    for i, s in enumerate(spec.sources):
        if not isinstance(s, CylinderMagnetSpec | BlockMagnetSpec):
            continue
        pts = magnet_sample_points(s)
        for j, c in coils:
            if np.any(inside_winding(c, pts)):
                raise CaseError(
                    f"sources[{i}].center",
                    s.center,
                    f"magnet overlaps the winding of the coil sources[{j}]; "
                    "move it into the bore or outside",
                )
    for k, part in enumerate(spec.iron):
        pts = part.sample_points()
        for i, s in enumerate(spec.sources):
            other = (
                magnet_sample_points(s)
                if isinstance(s, CylinderMagnetSpec | BlockMagnetSpec)
                else None
            )
            if np.any(inside_source(s, pts)) or (other is not None and np.any(part.inside(other))):
                raise CaseError(
                    f"iron[{k}]", part.kind, f"overlaps the source sources[{i}] ({s.kind})"
                )


def _check_iron_groups(spec: FieldSpec) -> None:
    tables = [(k, (p.bh_h, p.bh_b)) for k, p in enumerate(spec.iron) if p.bh_h is not None]
    for k, t in tables[1:]:
        if t != tables[0][1]:
            i = 0 if t[0] != tables[0][1][0] else 1
            raise CaseError(
                f"iron[{k}].{('bh_h', 'bh_b')[i]}",
                t[i],
                f"all iron parts with a B-H table share one table (that of iron[{tables[0][0]}])",
            )
    group = spec.iron[0].motion
    for k, part in enumerate(spec.iron):
        if part.motion != group:
            raise CaseError(
                f"iron[{k}].motion",
                part.motion,
                f"all iron parts move together (iron[0] has motion '{group}')",
            )
    for i, s in enumerate(spec.sources):
        if isinstance(s, UniformSourceSpec):
            if group:
                raise CaseError(
                    f"sources[{i}].kind",
                    s.kind,
                    "a uniform source acting on moving iron is not supported",
                )
        elif getattr(s, "motion", "") != group:
            raise CaseError(
                f"sources[{i}].motion",
                getattr(s, "motion", ""),
                f"the iron moves with motion '{group}'; a source moving relative to it would "
                "change its magnetisation in time: give the source the same motion",
            )
    if all(p.linear for p in spec.iron):
        return
    w0 = spec.sources[0].waveform if spec.sources else None
    for i, s in enumerate(spec.sources):
        w = s.waveform
        if w != w0 or w.kind not in ("dc", "square", "trigger") or abs(w.amplitude) != 1.0:
            raise CaseError(
                f"sources[{i}].waveform",
                w.kind,
                "nonlinear iron (saturation or a B-H table) needs all sources on one waveform "
                "taking only the values -1, 0, 1 (dc, square or trigger, amplitude 1); "
                "otherwise give the iron a linear permeability only",
            )
