"""Field sources of the ``[[field.sources]]`` array and their ``waveform`` sub-tables.

Source kinds and their keys (lengths in m, SI or strings with units):

========================= ==================================================
``uniform``               ``flux_density`` (T), ``direction``
``coil``                  ``center``, ``axis``, ``inner_radius``,
                          ``outer_radius``, ``length`` (axial winding
                          thickness), ``turns``, ``current`` (A) *or*
                          ``flux_density`` (T at the coil centre)
``coil_pair``             as ``coil`` plus ``separation`` (centre-to-centre
                          distance of the two windings) and ``polarity``
                          (``same``: Helmholtz-like uniform field;
                          ``opposite``: Maxwell-like gradient field)
``racetrack_coil``        ``center``, ``axis``, ``roll`` (rotation of the
                          local x side about ``axis``), ``inner_size``
                          (local x, y edges of the bore), ``inner_radius``
                          (bore corner radius), ``thickness`` (winding
                          depth), ``length`` (axial), ``turns``, ``current``
``cylinder_magnet``       ``center``, ``axis`` (magnetisation direction),
                          ``radius``, ``length``, ``remanence`` (T)
``block_magnet``          ``center``, ``axis`` (magnetisation direction =
                          local z), ``size`` (local x, y, z edges), ``roll``
                          (rotation of the local x edge about ``axis``),
                          ``remanence`` (T)
========================= ==================================================

Every placed (non-uniform) source may name a ``motion`` (a ``[[field.motions]]``
entry) that moves it rigidly in time. Every source has a ``waveform``
sub-table (default DC): a dimensionless multiplier in [-1, 1] of the
source's nominal strength (the flux density of a uniform source, the current
of a coil, the remanence of a magnet).

``coil_pair`` defaults are the experiments' electromagnet: each coil 115 mm
in outer diameter, 35 mm thick, 70 mm centre to centre. The inner winding
radius (25 mm) and the number of turns (270) are *assumed*: Wheeler's
multilayer formula L = 31.6 N² r̄² / (6 r̄ + 9 l + 10 c) µH (r̄ mean radius,
l length, c winding depth, all in m; H. A. Wheeler, Proc. IRE 16, 1398
(1928)) gives L = 4.4 mH for N = 270, matching the quoted 4.5 mH, and 1 Ω
then needs ~1.2 mm² copper wire, which fits the 35 × 32.5 mm² winding.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from magfem.config import (
    MISSING,
    CaseError,
    build_fields,
    check_keys,
    integer,
    option,
    quantity,
    vector,
)
from magfem.field.placement import frame
from magfem.field.racetrack import racetrack_distance

__all__ = [
    "SOURCE_KINDS",
    "WAVEFORM_KINDS",
    "BlockMagnetSpec",
    "CoilPairSpec",
    "CoilSpec",
    "CylinderMagnetSpec",
    "RacetrackCoilSpec",
    "SourceSpec",
    "UniformSourceSpec",
    "WaveformSpec",
    "coil_centers",
    "inside_source",
    "inside_winding",
    "magnet_sample_points",
    "unit_vector",
]

SOURCE_KINDS = (
    "uniform",
    "coil",
    "coil_pair",
    "racetrack_coil",
    "cylinder_magnet",
    "block_magnet",
)
WAVEFORM_KINDS = ("dc", "square", "sine", "trigger", "table", "square_rl")

_WAVEFORM_COMMON = ("kind", "start", "amplitude")
_WAVEFORM_KEYS: dict[str, tuple[str, ...]] = {
    "dc": ("duration",),
    "square": ("frequency", "phase", "duty", "bipolar", "duration"),
    "sine": ("frequency", "phase", "duration"),
    "trigger": ("duration",),
    "table": ("times", "values"),
    "square_rl": (
        "frequency",
        "phase",
        "duty",
        "duration",
        "inductance",
        "resistance",
        "voltage",
        "current",
    ),
}


def unit_vector(v: tuple[float, ...] | np.ndarray, key: str) -> np.ndarray:
    """``v`` normalised to length 1 (shape (3,)); CaseError naming ``key`` if zero or not 3-D."""
    a = np.asarray(v, dtype=float)
    n = float(np.linalg.norm(a)) if a.shape == (3,) else 0.0
    if not n > 0.0 or not math.isfinite(n):
        raise CaseError(key, tuple(v), "must be a nonzero 3-vector")
    return a / n


@dataclass(frozen=True)
class WaveformSpec:
    """Time function of a source: a dimensionless multiplier of its nominal strength.

    ``kind``:

    * ``dc``: 1 from ``start`` on (for ``duration`` if given).
    * ``square``: bipolar ±1 (or 0/1 with ``bipolar = false``), +1 during the
      first ``duty`` fraction of each period, shifted by ``phase``.
    * ``sine``: sin(2π f (t − start) + phase).
    * ``trigger``: 1 during [start, start + duration), 0 otherwise.
    * ``table``: piecewise linear through (``times``, ``values``); a repeated
      time makes a jump; held constant outside the table.
    * ``square_rl``: the current of a coil (``inductance`` L, ``resistance``
      R) driven by a bipolar ±``voltage`` supply that regulates the current
      to ±``current`` (the coil's nominal current): after each switch the
      supply saturates at ±V, L di/dt = ±V − R i, until |i| reaches the
      nominal current, which is then held (see
      :class:`magfem.field.waveforms.SquareRL`).

    All kinds are 0 before ``start`` (alias ``delay``) and, where ``duration`` is given, from
    ``start + duration`` on; ``amplitude`` scales the result (|amplitude| <= 1).
    """

    kind: str = option("dc", WAVEFORM_KINDS, doc="waveform kind")
    start: float = quantity(0.0, "s", ge=0.0, doc="switch-on time (delay)")
    amplitude: float = quantity(1.0, "", ge=-1.0, le=1.0, doc="multiplier, |a| <= 1")
    frequency: float | None = quantity(None, "Hz", gt=0.0, doc="square/sine/square_rl")
    phase: float = quantity(0.0, "rad", doc="phase shift (rad, or '90 deg')")
    duty: float = quantity(0.5, "", gt=0.0, lt=1.0, doc="fraction of a period at +1")
    bipolar: bool = True
    duration: float | None = quantity(None, "s", gt=0.0, doc="on-time (trigger)")
    times: tuple[float, ...] | None = vector(None, "s", length=None, doc="table times")
    values: tuple[float, ...] | None = vector(None, "", length=None, doc="table values")
    inductance: float = quantity(4.5e-3, "H", gt=0.0, doc="coil inductance (square_rl)")
    resistance: float = quantity(1.0, "Ohm", gt=0.0, doc="coil resistance (square_rl)")
    voltage: float = quantity(20.0, "V", gt=0.0, doc="supply voltage (square_rl)")
    current: float | None = quantity(None, "A", gt=0.0, doc="nominal current (square_rl)")

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> WaveformSpec:
        kind = table.get("kind", "dc")
        if kind not in WAVEFORM_KINDS:
            raise CaseError(
                f"{where}.kind",
                kind,
                "unknown waveform; must be one of " + ", ".join(WAVEFORM_KINDS),
            )
        if "delay" in table:  # alias of start
            if "start" in table:
                raise CaseError(f"{where}.delay", table["delay"], "give start or delay, not both")
            table = {("start" if k == "delay" else k): v for k, v in table.items()}
        check_keys(table, _WAVEFORM_COMMON + _WAVEFORM_KEYS[kind], where)
        return build_fields(cls, table, where)

    def table_keys(self) -> tuple[str, ...]:
        """Keys that apply to this kind (what :func:`magfem.config.to_table` writes)."""
        return tuple(_WAVEFORM_COMMON) + tuple(_WAVEFORM_KEYS[self.kind])

    def __post_init__(self) -> None:
        k = self.kind
        if k in ("square", "sine", "square_rl") and self.frequency is None:
            raise CaseError("frequency", MISSING, f"required for a {k} waveform (> 0 Hz)")
        if k == "trigger" and self.duration is None:
            raise CaseError("duration", MISSING, "required for a trigger waveform (> 0 s)")
        if k == "table":
            if self.times is None or self.values is None:
                raise CaseError("times", MISSING, "a table waveform needs times and values")
            if len(self.times) != len(self.values) or len(self.times) < 1:
                raise CaseError(
                    "values", self.values, f"must have as many entries as times ({len(self.times)})"
                )
            if any(b < a for a, b in zip(self.times, self.times[1:], strict=False)):
                raise CaseError("times", self.times, "must be non-decreasing")
            if any(
                a == b == c
                for a, b, c in zip(self.times, self.times[1:], self.times[2:], strict=False)
            ):
                raise CaseError("times", self.times, "a time may appear at most twice (one jump)")
            if any(abs(v) > 1.0 for v in self.values):
                raise CaseError("values", self.values, "must lie in [-1, 1] (multiplier)")

    def extremes(self) -> tuple[float, float]:
        """(smallest, largest) value of the multiplier (0 included: all are 0 before start)."""
        a = self.amplitude
        if self.kind == "table":
            values = [a * v for v in self.values or ()]
        elif self.kind in ("sine", "square_rl") or (self.kind == "square" and self.bipolar):
            values = [-abs(a), abs(a)]
        else:  # dc, trigger, unipolar square
            values = [a]
        return min(0.0, *values), max(0.0, *values)


def _waveform_default() -> WaveformSpec:
    return WaveformSpec()


@dataclass(frozen=True)
class SourceSpec:
    """Base of the ``[[field.sources]]`` entries; ``kind`` selects the subclass."""

    kind: str = option("uniform", SOURCE_KINDS)
    waveform: WaveformSpec = field(default_factory=_waveform_default)

    KIND: ClassVar[str] = ""

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> SourceSpec:
        if "kind" not in table:
            raise CaseError(
                f"{where}.kind", MISSING, "missing required key; one of " + ", ".join(SOURCE_KINDS)
            )
        kind = table["kind"]
        classes = {c.KIND: c for c in _SOURCE_CLASSES}
        if not isinstance(kind, str) or kind not in classes:
            raise CaseError(
                f"{where}.kind",
                kind,
                "unknown source kind; must be one of " + ", ".join(SOURCE_KINDS),
            )
        return build_fields(classes[kind], table, where)

    @property
    def is_uniform(self) -> bool:
        """True for a spatially uniform source."""
        return self.kind == "uniform"


@dataclass(frozen=True, kw_only=True)
class UniformSourceSpec(SourceSpec):
    """A spatially uniform flux density ``flux_density * direction * waveform(t)``."""

    kind: str = option("uniform", ("uniform",))
    flux_density: float = quantity(MISSING, "T", ge=0.0, doc="amplitude")
    direction: tuple[float, ...] = vector((0.0, 0.0, 1.0), "", nonzero=True)

    KIND: ClassVar[str] = "uniform"

    @property
    def unit_direction(self) -> np.ndarray:
        """``direction`` normalised, shape (3,)."""
        return unit_vector(self.direction, "direction")


@dataclass(frozen=True, kw_only=True)
class _PlacedSpec(SourceSpec):
    center: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m", doc="centre of the source")
    axis: tuple[float, ...] = vector((0.0, 0.0, 1.0), "", nonzero=True, doc="symmetry axis")
    motion: str = option("", doc="name of a [[field.motions]] entry that moves it ('' = fixed)")

    @property
    def unit_axis(self) -> np.ndarray:
        """``axis`` normalised, shape (3,)."""
        return unit_vector(self.axis, "axis")


@dataclass(frozen=True, kw_only=True)
class CoilSpec(_PlacedSpec):
    """A thick solenoidal coil: rectangular winding cross-section, uniform current density.

    J_φ = turns * current / ((outer_radius − inner_radius) * length), A/m².
    Give ``current`` (A) or ``flux_density`` (T, on-axis field at the centre
    at full waveform; the current is then computed from the closed form).
    """

    kind: str = option("coil", ("coil",))
    inner_radius: float = quantity(25e-3, "m", ge=0.0)
    outer_radius: float = quantity(57.5e-3, "m", gt=0.0)
    length: float = quantity(35e-3, "m", gt=0.0, doc="axial thickness of the winding")
    turns: int = integer(270, ge=1)
    current: float | None = quantity(None, "A", gt=0.0)
    flux_density: float | None = quantity(None, "T", gt=0.0, doc="field at the centre")

    KIND: ClassVar[str] = "coil"

    def __post_init__(self) -> None:
        if not self.inner_radius < self.outer_radius:
            raise CaseError(
                "inner_radius",
                self.inner_radius,
                f"must be < outer_radius ({self.outer_radius:g} m)",
            )
        if (self.current is None) == (self.flux_density is None):
            raise CaseError(
                "current", self.current, "give exactly one of current (A) and flux_density (T)"
            )


@dataclass(frozen=True, kw_only=True)
class CoilPairSpec(CoilSpec):
    """Two identical coaxial coils at ``center ± separation/2 * axis``.

    ``flux_density`` is then the field at the pair's centre.
    """

    kind: str = option("coil_pair", ("coil_pair",))
    separation: float = quantity(70e-3, "m", gt=0.0, doc="centre-to-centre distance")
    polarity: str = option("same", ("same", "opposite"))

    KIND: ClassVar[str] = "coil_pair"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.separation >= self.length:
            raise CaseError(
                "separation",
                self.separation,
                f"windings overlap; must be >= length ({self.length:g} m)",
            )
        if self.polarity == "opposite" and self.flux_density is not None:
            raise CaseError(
                "flux_density",
                self.flux_density,
                "an opposite-polarity pair has B = 0 at its centre; give current",
            )


@dataclass(frozen=True, kw_only=True)
class RacetrackCoilSpec(_PlacedSpec):
    """A racetrack coil: a rounded-rectangle winding of rectangular cross-section.

    The bore is ``inner_size`` (local x, y edges) with corners of radius
    ``inner_radius``; the winding is ``thickness`` deep (outer corners of radius
    inner_radius + thickness) and ``length`` long along ``axis``; ``turns`` ×
    ``current`` ampere-turns flow counter-clockwise about ``axis``, uniformly
    over the cross-section. inner_radius = inner_size / 2 (a square bore) is a
    thick circular coil.
    """

    kind: str = option("racetrack_coil", ("racetrack_coil",))
    roll: float = quantity(0.0, "rad", doc="rotation of the local x side about axis")
    inner_size: tuple[float, ...] = vector(
        (150e-3, 150e-3), "m", length=2, doc="bore edges along local x, y"
    )
    inner_radius: float = quantity(25e-3, "m", gt=0.0, doc="corner radius of the bore")
    thickness: float = quantity(25e-3, "m", gt=0.0, doc="winding depth (outer - inner)")
    length: float = quantity(100e-3, "m", gt=0.0, doc="axial length of the winding")
    turns: int = integer(1000, ge=1, doc="number of turns")
    current: float = quantity(MISSING, "A", gt=0.0, doc="current per turn (ampere-turns / turns)")

    KIND: ClassVar[str] = "racetrack_coil"

    def __post_init__(self) -> None:
        if not 2 * self.inner_radius <= min(self.inner_size):
            raise CaseError(
                "inner_radius",
                self.inner_radius,
                f"must be <= half the smaller bore edge ({min(self.inner_size) / 2:g} m)",
            )

    @property
    def half_sides(self) -> tuple[float, float]:
        """Half-sides (m) of the spine rectangle (the corner arcs' centres)."""
        return (
            self.inner_size[0] / 2 - self.inner_radius,
            self.inner_size[1] / 2 - self.inner_radius,
        )

    @property
    def winding(self) -> tuple[float, float, float, float, float]:
        """(cx, cy, r1, r2, height) (m): the spine's half-sides, the winding's offsets from
        it and its length, the arguments of :mod:`magfem.field.racetrack`."""
        r1 = self.inner_radius
        return (*self.half_sides, r1, r1 + self.thickness, self.length)


@dataclass(frozen=True, kw_only=True)
class CylinderMagnetSpec(_PlacedSpec):
    """Axially magnetised cylinder magnet (remanence ``remanence`` along ``axis``)."""

    kind: str = option("cylinder_magnet", ("cylinder_magnet",))
    radius: float = quantity(5e-3, "m", gt=0.0)
    length: float = quantity(10e-3, "m", gt=0.0)
    remanence: float = quantity(1.3, "T", gt=0.0, le=2.0)

    KIND: ClassVar[str] = "cylinder_magnet"


@dataclass(frozen=True, kw_only=True)
class BlockMagnetSpec(_PlacedSpec):
    """Rectangular block magnet, magnetised along its local z edge (= ``axis``)."""

    kind: str = option("block_magnet", ("block_magnet",))
    size: tuple[float, ...] = vector((10e-3, 10e-3, 5e-3), "m", doc="local x, y, z edges")
    remanence: float = quantity(1.3, "T", gt=0.0, le=2.0)
    roll: float = quantity(0.0, "rad", doc="rotation of the local x edge about axis")

    KIND: ClassVar[str] = "block_magnet"

    def __post_init__(self) -> None:
        if any(not s > 0.0 for s in self.size):
            raise CaseError("size", self.size, "all three edges must be > 0 m")


_SOURCE_CLASSES: tuple[type[SourceSpec], ...] = (
    UniformSourceSpec,
    CoilSpec,
    CoilPairSpec,
    RacetrackCoilSpec,
    CylinderMagnetSpec,
    BlockMagnetSpec,
)


def coil_centers(spec: CoilSpec) -> list[tuple[np.ndarray, float]]:
    """Centres (shape (3,)) and current signs of the windings of a coil or coil pair."""
    c = np.asarray(spec.center, dtype=float)
    if isinstance(spec, CoilPairSpec):
        a = spec.unit_axis * spec.separation / 2
        return [(c - a, 1.0), (c + a, 1.0 if spec.polarity == "same" else -1.0)]
    return [(c, 1.0)]


def inside_winding(spec: CoilSpec, points: np.ndarray) -> np.ndarray:
    """Boolean mask, shape (N,), of ``points`` (N, 3) inside a winding of ``spec``."""
    pts = np.atleast_2d(points)
    axis = spec.unit_axis
    mask = np.zeros(len(pts), dtype=bool)
    for c, _ in coil_centers(spec):
        d = pts - c
        z = d @ axis
        r = np.linalg.norm(d - np.outer(z, axis), axis=1)
        mask |= (np.abs(z) <= spec.length / 2) & (r >= spec.inner_radius) & (r <= spec.outer_radius)
    return mask


def inside_source(spec: SourceSpec, points: np.ndarray) -> np.ndarray:
    """Mask (N,) of ``points`` (N, 3) inside a winding or magnet of ``spec`` (as placed)."""
    pts = np.atleast_2d(points)
    if isinstance(spec, CoilSpec):
        return inside_winding(spec, pts)
    if isinstance(spec, RacetrackCoilSpec):
        loc = (pts - np.asarray(spec.center)) @ frame(spec.unit_axis, spec.roll)
        return racetrack_distance(*spec.winding, loc) <= 0.0
    if isinstance(spec, CylinderMagnetSpec):
        d = pts - np.asarray(spec.center)
        z = d @ spec.unit_axis
        r = np.linalg.norm(d - np.outer(z, spec.unit_axis), axis=1)
        return (np.abs(z) <= spec.length / 2) & (r <= spec.radius)
    if isinstance(spec, BlockMagnetSpec):
        loc = (pts - np.asarray(spec.center)) @ frame(spec.unit_axis, spec.roll)
        return np.all(np.abs(loc) <= np.asarray(spec.size) / 2, axis=1)
    return np.zeros(len(pts), dtype=bool)


def magnet_sample_points(spec: CylinderMagnetSpec | BlockMagnetSpec) -> np.ndarray:
    """Points of a magnet's volume (centre, corners / rim), shape (N, 3), m."""
    c = np.asarray(spec.center, dtype=float)
    if isinstance(spec, BlockMagnetSpec):
        R = frame(spec.unit_axis, spec.roll)
        h = np.asarray(spec.size) / 2
        signs = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])
        return c + (signs * h) @ R.T
    R = frame(spec.unit_axis)
    phi = np.linspace(0, 2 * math.pi, 16, endpoint=False)
    out = [c]
    for z in (-spec.length / 2, 0.0, spec.length / 2):
        for rr in (0.0, spec.radius):
            loc = np.column_stack([rr * np.cos(phi), rr * np.sin(phi), np.full_like(phi, z)])
            out.extend(c + loc @ R.T)
    return np.array(out)
