"""Planar outlines of the robot shapes: gmsh OCC construction plus exact metadata.

An :class:`Outline` knows, for one :class:`~magfem.geometry.spec.RobotSpec`,
how to add its planar pieces to a gmsh OCC model (``build``), how to name a
piece or a side face from a point of it (``cell_group``, ``tip_group``,
``in_clamp``), where its arms are (``arms``) and its exact area
(``area``, used by the tests). Everything is in the robot's own frame
(bottom face on z = 0, before ``position`` is added). The 3D/2D meshing
pipeline lives in :mod:`magfem.geometry.robot_mesh`.

Families:

* :class:`BeamOutline` — arms along ±x whose width varies linearly
  (rectangle, trapezoid, triangles, two-arm rectangle, bow tie, membrane).
  Pieces are polygons split at the clamp end and, for pointed arms, at the
  start of the tip zone.
* :class:`RadialOutline` — n arms or petals around a disk hub (star,
  flower). Arms are cut by the hub circle, so the hub/arm interfaces are
  circular arcs (curved: use ``mesh.order = 2`` for an accurate area).
* :class:`MantaOutline` — rectangular body and two trapezoid fins.

Tip faces: the end face of a blunt arm; for a pointed arm (triangle apex)
the side faces of the last :data:`TIP_ZONE` fraction of the arm length; for a
rounded petal the faces of its half-disk end.

Exact areas: polygons by the shoelace/trapezoid formula; an arm cut by the hub
circle by the integral over the arm axis s of the arm's cross-width lying
outside the circle, ∫ 2 max(0, h(s) − √(R² − s²)) ds for s < R plus 2h(s) for
s ≥ R (adaptive quadrature, relative error < 1e-12), plus π p²/2 for a
rounded petal end of radius p.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from magfem.geometry.spec import RobotSpec

__all__ = [
    "TIP_ZONE",
    "BeamArm",
    "BeamOutline",
    "MantaOutline",
    "Outline",
    "PlanarArm",
    "RadialOutline",
    "outline_of",
]

TIP_ZONE = 0.1
"""Fraction of a pointed arm's length, ending at the apex, whose side faces form its tip group."""

_REL_TOL = 1e-7
"""Relative tolerance (of the robot size) for classifying gmsh entities by position."""


class PlanarArm(NamedTuple):
    """An arm in the robot's plane: its midline runs ``length`` from ``root`` along ``direction``.

    ``root`` is the point on the arm axis where the arm's cell group begins
    (x = 0 for one-arm shapes and for the two arms of a strip clamped in the
    middle; the hub circle for stars and flowers; the body side for fins).
    """

    name: str
    root: tuple[float, float]
    direction: tuple[float, float]
    length: float
    tip: str


class Outline(ABC):
    """Base class: see the module docstring. Subclasses fill the attributes below."""

    arms: tuple[PlanarArm, ...]
    area: float
    curved: bool
    clamped: bool
    scale: float

    @abstractmethod
    def build(self, occ: Any) -> None:
        """Add the planar pieces (surfaces on z = 0) to the OCC model of rank 0."""

    @abstractmethod
    def cell_group(self, x: float, y: float) -> str:
        """Cell group name of the piece whose centre of mass is (x, y) (m)."""

    @abstractmethod
    def tip_group(self, x: float, y: float) -> str | None:
        """Tip group of a side face (or strip/surface edge) centred at (x, y), or None."""

    @abstractmethod
    def in_clamp(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Any:
        """Vectorised: which points (m, robot frame) lie in the clamp patch (boolean array)."""

    @property
    def tol(self) -> float:
        return _REL_TOL * self.scale


def _polygon(occ: Any, points: Sequence[tuple[float, float]]) -> int:
    """OCC plane surface bounded by the closed polygon ``points`` (z = 0); returns its tag."""
    tags = [occ.addPoint(x, y, 0.0) for x, y in points]
    lines = [occ.addLine(tags[i], tags[(i + 1) % len(tags)]) for i in range(len(tags))]
    return int(occ.addPlaneSurface([occ.addCurveLoop(lines)]))


# --- beams: arms along ±x -----------------------------------------------------------------


class BeamArm(NamedTuple):
    """An arm along ``sign``·x starting at x = ``x_root`` with linearly varying width (m)."""

    name: str
    x_root: float
    sign: int
    length: float
    root_width: float
    tip_width: float
    clamp_length: float

    @property
    def pointed(self) -> bool:
        return self.tip_width == 0.0

    def half_width(self, s: float) -> float:
        """Half width at distance ``s`` from the root along the arm."""
        return 0.5 * (self.root_width + (self.tip_width - self.root_width) * s / self.length)

    def cuts(self) -> list[float]:
        """Distances from the root where the arm is split into pieces."""
        out = [0.0]
        if self.clamp_length > 0:
            out.append(self.clamp_length)
        if self.pointed:
            out.append((1 - TIP_ZONE) * self.length)
        out.append(self.length)
        return out

    def s_of(self, x: Any) -> Any:
        return self.sign * (x - self.x_root)


@dataclass(frozen=True)
class BeamOutline(Outline):
    """Arms along ±x; see :class:`BeamArm`."""

    beams: tuple[BeamArm, ...]

    def __post_init__(self) -> None:
        object.__setattr__(
            self,
            "arms",
            tuple(
                PlanarArm(
                    b.name, (b.x_root, 0.0), (float(b.sign), 0.0), b.length, _tip_name(b.name)
                )
                for b in self.beams
            ),
        )
        object.__setattr__(
            self, "area", sum(0.5 * b.length * (b.root_width + b.tip_width) for b in self.beams)
        )
        object.__setattr__(self, "curved", False)
        object.__setattr__(self, "clamped", any(b.clamp_length > 0 for b in self.beams))
        object.__setattr__(
            self, "scale", max(max(b.length, b.root_width, b.tip_width) for b in self.beams)
        )

    def build(self, occ: Any) -> None:
        for b in self.beams:
            cuts = b.cuts()
            for s0, s1 in itertools.pairwise(cuts):
                x0, x1 = b.x_root + b.sign * s0, b.x_root + b.sign * s1
                h0, h1 = b.half_width(s0), b.half_width(s1)
                if h1 == 0.0:
                    pts = [(x0, -h0), (x1, 0.0), (x0, h0)]
                else:
                    pts = [(x0, -h0), (x1, -h1), (x1, h1), (x0, h0)]
                if b.sign < 0:
                    pts = [(x, -y) for x, y in pts]  # keep counter-clockwise orientation
                _polygon(occ, pts)

    def _beam_at(self, x: float) -> BeamArm:
        best = min(self.beams, key=lambda b: abs(b.s_of(x) - 0.5 * b.length))
        return best

    def cell_group(self, x: float, y: float) -> str:
        return self._beam_at(x).name

    def tip_group(self, x: float, y: float) -> str | None:
        b = self._beam_at(x)
        s = b.s_of(x)
        if b.pointed:
            return _tip_name(b.name) if s > (1 - TIP_ZONE) * b.length + self.tol else None
        return _tip_name(b.name) if abs(s - b.length) < self.tol else None

    def in_clamp(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Any:
        mask = np.zeros(np.shape(x), dtype=bool)
        for b in self.beams:
            if b.clamp_length > 0:
                s = b.s_of(x)
                mask |= (s >= -self.tol) & (s <= b.clamp_length + self.tol)
        return mask

    def strip_breaks(self) -> list[float]:
        """Sorted x positions splitting the side-view strip (arm ends, clamp ends)."""
        xs = {round(b.x_root + b.sign * s, 15) for b in self.beams for s in b.cuts()}
        return sorted(xs)


def _tip_name(arm: str) -> str:
    return "tip" if arm in ("arm", "body") else f"tip_{arm}"


# --- radial: star and flower ----------------------------------------------------------------


def _outside_circle_area(h: Callable[[float], float], radius: float, length: float) -> float:
    """Area of {(s, t): 0 <= s <= length, |t| <= h(s), s² + t² >= radius²} (m²)."""
    from scipy.integrate import quad

    def width(s: float) -> float:
        inner = math.sqrt(max(radius * radius - s * s, 0.0)) if s < radius else 0.0
        return 2.0 * max(0.0, h(s) - inner)

    points = [radius] if radius < length else None
    value, _ = quad(width, 0.0, length, points=points, epsabs=0.0, epsrel=1e-13, limit=200)
    return float(value)


@dataclass(frozen=True)
class RadialOutline(Outline):
    """``n`` arms (star) or rounded petals (flower) around a disk hub of ``hub_radius``.

    Arm i (1-based) points along angle 2π(i−1)/n. Star arms are trapezoids
    from the centre (width ``root_width``) to ``reach`` (width
    ``tip_width``); petals are strips of ``root_width`` ending in a half
    disk, reaching ``reach`` from the centre.
    """

    n: int
    prefix: str  # "arm" or "petal"
    reach: float
    root_width: float
    tip_width: float
    hub_radius: float
    clamp_radius: float
    rounded: bool

    def __post_init__(self) -> None:
        r = self.hub_radius
        axis_end = self.reach - 0.5 * self.root_width if self.rounded else self.reach
        arms = tuple(
            PlanarArm(
                f"{self.prefix}_{i + 1}",
                (r * math.cos(a), r * math.sin(a)),
                (math.cos(a), math.sin(a)),
                self.reach - r,
                f"tip_{self.prefix}_{i + 1}",
            )
            for i, a in enumerate(self._angles())
        )
        object.__setattr__(self, "arms", arms)
        if self.rounded:
            p = 0.5 * self.root_width
            one = _outside_circle_area(lambda s: p, r, axis_end) + 0.5 * math.pi * p * p
        else:
            one = _outside_circle_area(self._half_width, r, self.reach)
        object.__setattr__(self, "area", math.pi * r * r + self.n * one)
        object.__setattr__(self, "curved", True)
        object.__setattr__(self, "clamped", self.clamp_radius > 0)
        object.__setattr__(self, "scale", 2 * self.reach)

    def _angles(self) -> list[float]:
        return [2 * math.pi * i / self.n for i in range(self.n)]

    def _half_width(self, s: float) -> float:
        return 0.5 * (self.root_width + (self.tip_width - self.root_width) * s / self.reach)

    def build(self, occ: Any) -> None:
        hub = occ.addDisk(0.0, 0.0, 0.0, self.hub_radius, self.hub_radius)
        for a in self._angles():
            if self.rounded:
                p = 0.5 * self.root_width
                end = self.reach - p
                rect = occ.addRectangle(0.0, -p, 0.0, end, 2 * p)
                cap = occ.addDisk(end, 0.0, 0.0, p, p)
                arm, _ = occ.fuse([(2, rect)], [(2, cap)])
            else:
                h0, h1 = self._half_width(0.0), self._half_width(self.reach)
                arm = [
                    (2, _polygon(occ, [(0.0, -h0), (self.reach, -h1), (self.reach, h1), (0.0, h0)]))
                ]
            occ.rotate(arm, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, a)
            occ.cut(arm, [(2, hub)], removeObject=True, removeTool=False)
        if 0 < self.clamp_radius < self.hub_radius:
            occ.addDisk(0.0, 0.0, 0.0, self.clamp_radius, self.clamp_radius)

    def _arm_index(self, x: float, y: float) -> int:
        return round(math.atan2(y, x) / (2 * math.pi / self.n)) % self.n

    def cell_group(self, x: float, y: float) -> str:
        if math.hypot(x, y) < self.hub_radius:
            return "hub"
        return f"{self.prefix}_{self._arm_index(x, y) + 1}"

    def tip_group(self, x: float, y: float) -> str | None:
        i = self._arm_index(x, y)
        name = f"tip_{self.prefix}_{i + 1}"
        if self.rounded:
            start = self.reach - 0.5 * self.root_width
            return name if math.hypot(x, y) > start + self.tol else None
        a = 2 * math.pi * i / self.n
        s = x * math.cos(a) + y * math.sin(a)
        return name if abs(s - self.reach) < self.tol else None

    def in_clamp(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Any:
        if self.clamp_radius <= 0:
            return np.zeros(np.shape(x), dtype=bool)
        return np.hypot(x, y) <= self.clamp_radius + self.tol


# --- manta ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class MantaOutline(Outline):
    """Body [−L/2, L/2] × [−w/2, w/2] and trapezoid fins to y = ±span/2 (chord ``fin_tip``)."""

    span: float
    body_length: float
    body_width: float
    fin_tip: float

    def __post_init__(self) -> None:
        w2, reach = 0.5 * self.body_width, 0.5 * (self.span - self.body_width)
        arms = (
            PlanarArm("fin_left", (0.0, w2), (0.0, 1.0), reach, "tip_fin_left"),
            PlanarArm("fin_right", (0.0, -w2), (0.0, -1.0), reach, "tip_fin_right"),
        )
        object.__setattr__(self, "arms", arms)
        fin = reach * 0.5 * (self.body_length + self.fin_tip)
        object.__setattr__(self, "area", self.body_length * self.body_width + 2 * fin)
        object.__setattr__(self, "curved", False)
        object.__setattr__(self, "clamped", False)
        object.__setattr__(self, "scale", max(self.span, self.body_length))

    def build(self, occ: Any) -> None:
        lx, w2, s2, t2 = (
            0.5 * self.body_length,
            0.5 * self.body_width,
            0.5 * self.span,
            0.5 * self.fin_tip,
        )
        _polygon(occ, [(-lx, -w2), (lx, -w2), (lx, w2), (-lx, w2)])
        _polygon(occ, [(-lx, w2), (lx, w2), (t2, s2), (-t2, s2)])
        _polygon(occ, [(-lx, -w2), (-t2, -s2), (t2, -s2), (lx, -w2)])

    def cell_group(self, x: float, y: float) -> str:
        if abs(y) < 0.5 * self.body_width:
            return "body"
        return "fin_left" if y > 0 else "fin_right"

    def tip_group(self, x: float, y: float) -> str | None:
        if abs(abs(y) - 0.5 * self.span) < self.tol:
            return "tip_fin_left" if y > 0 else "tip_fin_right"
        return None

    def in_clamp(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Any:
        return np.zeros(np.shape(x), dtype=bool)


# --- dispatch -------------------------------------------------------------------------------


def outline_of(robot: RobotSpec, *, clamp_inset: float = 0.0) -> Outline:
    """The :class:`Outline` of a validated robot spec (robot frame, SI units).

    ``clamp_inset`` (m) moves the edges of the clamp patch where the free
    membrane leaves it that far into the patch (the root strip's free end,
    the middle patch's two ends, the bonded disk's rim); the robot's own
    outline is unchanged. The shell model clamps this smaller patch to stand
    for the root compliance of a bonded membrane
    (:data:`magfem.geometry.robot_mesh.SHELL_CLAMP_INSET`).

    Raises:
        ValueError: ``clamp_inset`` < 0 or not shorter than the patch (the
            caller names the case entry).
    """
    if clamp_inset < 0:
        raise ValueError(f"clamp_inset {clamp_inset:g} m must be >= 0")
    outline = _outline_of(robot)
    if clamp_inset == 0.0 or not outline.clamped:
        return outline
    if isinstance(outline, BeamOutline):
        beams = []
        for b in outline.beams:
            if b.clamp_length > 0 and b.clamp_length <= clamp_inset:
                raise ValueError(
                    f"the clamp patch of {b.name} ({b.clamp_length:g} m from its root) is not "
                    f"longer than the clamp inset {clamp_inset:g} m"
                )
            inset = clamp_inset if b.clamp_length > 0 else 0.0
            beams.append(b._replace(clamp_length=b.clamp_length - inset))
        return BeamOutline(tuple(beams))
    if isinstance(outline, RadialOutline):
        if outline.clamp_radius <= clamp_inset:
            raise ValueError(
                f"the bonded disk (radius {outline.clamp_radius:g} m) is not larger than the "
                f"clamp inset {clamp_inset:g} m"
            )
        return dataclasses.replace(outline, clamp_radius=outline.clamp_radius - clamp_inset)
    raise ValueError(f"outline_of: no clamp inset for {type(outline).__name__}")


def _outline_of(robot: RobotSpec) -> Outline:
    p = robot.params
    shape = robot.shape
    if shape == "rectangle":
        return BeamOutline((BeamArm("arm", 0.0, 1, p.length, p.width, p.width, p.clamp_length),))
    if shape == "trapezoid":
        arm = BeamArm("arm", 0.0, 1, p.length, p.root_width, p.tip_width, p.clamp_length)
        return BeamOutline((arm,))
    if shape in ("triangle", "failure_triangle"):
        arm = BeamArm("arm", 0.0, 1, p.length, p.root_width, 0.0, p.clamp_length)
        return BeamOutline((arm,))
    if shape == "slim_triangle":
        return BeamOutline((BeamArm("arm", 0.0, 1, p.length, p.root_width, 0.0, 0.0),))
    if shape == "membrane":
        return BeamOutline((BeamArm("body", -0.5 * p.length, 1, p.length, p.width, p.width, 0.0),))
    if shape in ("two_arm_rectangle", "bow_tie"):
        w0, w1 = (
            (p.width, p.width) if shape == "two_arm_rectangle" else (p.middle_width, p.end_width)
        )
        half, c = 0.5 * p.length, 0.5 * p.clamp_length
        return BeamOutline(
            (
                BeamArm("arm_left", 0.0, -1, half, w0, w1, c),
                BeamArm("arm_right", 0.0, 1, half, w0, w1, c),
            )
        )
    if shape == "star":
        return RadialOutline(
            p.arms,
            "arm",
            p.arm_length,
            p.arm_width,
            p.tip_width,
            p.hub_radius,
            p.clamp_radius,
            False,
        )
    if shape == "flower":
        return RadialOutline(
            p.petals,
            "petal",
            0.5 * p.diameter,
            p.petal_width,
            p.petal_width,
            0.5 * p.centre_diameter,
            0.5 * p.clamp_diameter,
            True,
        )
    if shape == "manta":
        return MantaOutline(p.wingspan, p.body_length, p.body_width, p.fin_tip_width)
    raise ValueError(f"outline_of: no outline for shape {shape!r}")  # spec validation prevents this
