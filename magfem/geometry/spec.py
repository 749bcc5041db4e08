"""Case tables of the geometry stage: ``[robot]`` (shape) and ``[mesh]`` (discretisation).

Coordinates (every shape): the membrane lies in the x–y plane, its bottom
face on z = 0 and its thickness along +z; ``position`` then translates the
whole robot. One-arm shapes (``rectangle``, ``trapezoid``, ``triangle``,
``slim_triangle``, ``failure_triangle``) have their root edge on x = 0,
extend along +x and are centred on y = 0. Multi-arm shapes and the free
``membrane`` are centred on the origin.

``[robot]`` is a flat table: the common keys ``shape``, ``thickness``,
``position`` plus the keys of the chosen shape (see :data:`SHAPES`). A key
of another shape is an "unknown key" error that lists the allowed keys.
Internally each shape's keys are validated by a small frozen dataclass
(``RectangleShape`` ...); :class:`RobotSpec` stores the values flat (keys of
other shapes are ``None``), so :func:`magfem.config.to_table` writes back
an equivalent table and :attr:`RobotSpec.params` returns the per-shape object.

Default dimensions are assumptions where the source paper (Wang, Mao et al.,
Commun. Mater. 1, 67 (2020)) gives none; they are listed in docs/geometry.md.

Example::

    [robot]
    shape = "triangle"
    thickness = "80 um"
    length = "7.5 mm"
    root_width = "4 mm"
    clamp_length = "1 mm"

    [mesh]
    size = "0.5 mm"        # everything else defaulted: solid, 1 layer, hex, order 1
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from magfem.config import (
    CaseError,
    build_fields,
    check_keys,
    integer,
    option,
    quantity,
    vector,
)

__all__ = [
    "FAILURE_TRIANGLES",
    "MODELS",
    "SHAPES",
    "STRIP_SHAPES",
    "BowTieShape",
    "FailureTriangleShape",
    "FlowerShape",
    "MantaShape",
    "MembraneShape",
    "MeshSpec",
    "RectangleShape",
    "RobotSpec",
    "SlimTriangleShape",
    "StarShape",
    "TrapezoidShape",
    "TriangleShape",
    "TwoArmRectangleShape",
    "check_mesh_for_robot",
]

FAILURE_TRIANGLES: dict[str, tuple[float, float]] = {
    "I": (5e-3, 8e-3),
    "II": (10e-3, 16e-3),
    "III": (20e-3, 32e-3),
}
"""Failure-study triangles: type -> (base width, length) in m (SCENES.md)."""


def _need(cond: bool, key: str, value: object, problem: str) -> None:
    if not cond:
        raise CaseError(key, value, problem)


def _check_clamp_length(clamp_length: float, length: float) -> None:
    """The bonded root strip must leave part of the arm free."""
    _need(clamp_length < length, "clamp_length", clamp_length, f"must be < length ({length:g} m)")


# --- one-arm shapes (root on x = 0, along +x) --------------------------------------------


@dataclass(frozen=True)
class RectangleShape:
    """One rectangular arm, ``length`` along x, ``width`` along y, root strip clamped."""

    length: float = quantity("10 mm", "m", gt=0, doc="arm length along x")
    width: float = quantity("2 mm", "m", gt=0, doc="arm width along y")
    clamp_length: float = quantity(
        "1 mm", "m", ge=0, doc="bottom root strip bonded to the substrate; 0 = free"
    )

    def __post_init__(self) -> None:
        _check_clamp_length(self.clamp_length, self.length)

    @property
    def min_feature(self) -> float:
        return min(self.length, self.width)


@dataclass(frozen=True)
class TrapezoidShape:
    """One trapezoidal arm: width ``root_width`` at x = 0, ``tip_width`` at x = length."""

    length: float = quantity("7.5 mm", "m", gt=0, doc="arm length along x")
    root_width: float = quantity("4 mm", "m", gt=0, doc="width at the root (x = 0)")
    tip_width: float = quantity("2 mm", "m", gt=0, doc="width at the tip (x = length)")
    clamp_length: float = quantity("1 mm", "m", ge=0, doc="clamped root strip; 0 = free")

    def __post_init__(self) -> None:
        _check_clamp_length(self.clamp_length, self.length)

    @property
    def min_feature(self) -> float:
        return min(self.length, self.root_width, self.tip_width)


@dataclass(frozen=True)
class TriangleShape:
    """One triangular arm: base ``root_width`` on x = 0, apex at (length, 0)."""

    length: float = quantity("7.5 mm", "m", gt=0, doc="root-to-apex length along x")
    root_width: float = quantity("4 mm", "m", gt=0, doc="base width on x = 0")
    clamp_length: float = quantity("1 mm", "m", ge=0, doc="clamped root strip; 0 = free")

    def __post_init__(self) -> None:
        _check_clamp_length(self.clamp_length, self.length)

    @property
    def min_feature(self) -> float:
        # the apex has no width: the base width is what an element must resolve
        return min(self.length, self.root_width)


@dataclass(frozen=True)
class SlimTriangleShape:
    """Free slim triangle (propeller): base ``root_width`` on x = 0, apex at (length, 0)."""

    length: float = quantity("10 mm", "m", gt=0, doc="base-to-apex length along x")
    root_width: float = quantity("2 mm", "m", gt=0, doc="base width on x = 0")

    @property
    def min_feature(self) -> float:
        return min(self.length, self.root_width)


@dataclass(frozen=True)
class FailureTriangleShape:
    """Triangles of the failure study: type I 5×8, II 10×16, III 20×32 mm² (base × length)."""

    type: str = option("I", choices=tuple(FAILURE_TRIANGLES), doc="I, II or III")
    clamp_length: float = quantity("1 mm", "m", ge=0, doc="clamped root strip; 0 = free")

    def __post_init__(self) -> None:
        length = FAILURE_TRIANGLES[self.type][1]
        _need(
            self.clamp_length < length,
            "clamp_length",
            self.clamp_length,
            f"must be < the type {self.type} length ({length:g} m)",
        )

    @property
    def root_width(self) -> float:
        return FAILURE_TRIANGLES[self.type][0]

    @property
    def length(self) -> float:
        return FAILURE_TRIANGLES[self.type][1]

    @property
    def min_feature(self) -> float:
        return self.root_width


# --- multi-arm shapes (centred on the origin) --------------------------------------------


@dataclass(frozen=True)
class TwoArmRectangleShape:
    """Strip of total ``length`` along x, arms ``arm_left`` (x < 0) and ``arm_right`` (x > 0).

    The bottom patch |x| < clamp_length/2 is bonded to the substrate.
    """

    length: float = quantity("6 mm", "m", gt=0, doc="total tip-to-tip length along x")
    width: float = quantity("0.8 mm", "m", gt=0, doc="width along y")
    clamp_length: float = quantity("0.8 mm", "m", ge=0, doc="clamped middle patch; 0 = free")

    def __post_init__(self) -> None:
        _check_clamp_length(self.clamp_length, self.length)

    @property
    def min_feature(self) -> float:
        return min(self.width, self.length / 2)


@dataclass(frozen=True)
class BowTieShape:
    """Two trapezoid arms meeting at x = 0 (``middle_width``), ``end_width`` at x = ±length/2."""

    length: float = quantity("10 mm", "m", gt=0, doc="total tip-to-tip length along x")
    middle_width: float = quantity("1 mm", "m", gt=0, doc="width at x = 0")
    end_width: float = quantity("3 mm", "m", gt=0, doc="width at the arm ends")
    clamp_length: float = quantity("1 mm", "m", ge=0, doc="clamped middle patch; 0 = free")

    def __post_init__(self) -> None:
        _check_clamp_length(self.clamp_length, self.length)

    @property
    def min_feature(self) -> float:
        return min(self.middle_width, self.end_width, self.length / 2)


def _min_hub_radius(n: int, width: float) -> float:
    """Smallest hub radius (m) for which ``n`` arms of ``width`` meet only inside the hub.

    Two straight arms of half-width w/2 whose axes differ by 2π/n have
    crossing edges at distance (w/2)/sin(π/n) from the centre.
    """
    return 0.5 * width / math.sin(math.pi / n)


@dataclass(frozen=True)
class StarShape:
    """``arms`` straight arms (3–6) around a disk hub; arm 1 along +x, then counter-clockwise.

    Arms have width ``arm_width`` (``arm_tip_width`` at the tip: tapered when
    smaller) and reach ``arm_length`` from the centre. A central bottom disk
    of ``clamp_radius`` is bonded (0 = free robot).
    """

    arms: int = integer(5, ge=3, le=6, doc="number of arms")
    arm_length: float = quantity("5 mm", "m", gt=0, doc="centre-to-tip distance")
    arm_width: float = quantity("1.5 mm", "m", gt=0, doc="arm width at the hub")
    arm_tip_width: float | None = quantity(
        None, "m", gt=0, doc="width at the tip (default arm_width)"
    )
    hub_radius: float = quantity("1.5 mm", "m", gt=0, doc="radius of the central disk")
    clamp_radius: float = quantity(0.0, "m", ge=0, doc="bonded central disk; 0 = free")

    def __post_init__(self) -> None:
        rmin = _min_hub_radius(self.arms, max(self.arm_width, self.tip_width))
        _need(
            self.hub_radius >= rmin,
            "hub_radius",
            self.hub_radius,
            f"must be >= {rmin:g} m so that {self.arms} arms of this width meet inside the hub",
        )
        _need(
            self.arm_length > self.hub_radius + 0.5 * self.tip_width,
            "arm_length",
            self.arm_length,
            f"must exceed hub_radius + arm_tip_width/2 "
            f"({self.hub_radius + 0.5 * self.tip_width:g} m)",
        )
        _need(
            self.clamp_radius <= self.hub_radius,
            "clamp_radius",
            self.clamp_radius,
            f"must be <= hub_radius ({self.hub_radius:g} m)",
        )

    @property
    def tip_width(self) -> float:
        return self.arm_width if self.arm_tip_width is None else self.arm_tip_width

    @property
    def min_feature(self) -> float:
        return min(self.arm_width, self.tip_width, self.arm_length - self.hub_radius)


@dataclass(frozen=True)
class FlowerShape:
    """Flower gripper: ``petals`` rounded petals around a centre disk (Ø ``centre_diameter``).

    Petal i is a strip of ``petal_width`` along angle 2π(i−1)/petals ending in a
    half disk, reaching ``diameter``/2 from the centre. A bottom disk of
    ``clamp_diameter`` is bonded to the glass (0 = free).
    """

    petals: int = integer(8, ge=3, le=16, doc="number of petals")
    diameter: float = quantity("25 mm", "m", gt=0, doc="tip-to-tip diameter")
    centre_diameter: float = quantity("12 mm", "m", gt=0, doc="diameter of the centre disk")
    petal_width: float = quantity("4 mm", "m", gt=0, doc="petal width")
    clamp_diameter: float = quantity("6 mm", "m", ge=0, doc="bonded centre disk; 0 = free")

    def __post_init__(self) -> None:
        rc = 0.5 * self.centre_diameter
        rmin = _min_hub_radius(self.petals, self.petal_width)
        _need(
            rc >= rmin,
            "centre_diameter",
            self.centre_diameter,
            f"must be >= {2 * rmin:g} m so that {self.petals} petals of this width "
            "meet inside the centre",
        )
        _need(
            0.5 * self.diameter - 0.5 * self.petal_width > rc,
            "diameter",
            self.diameter,
            "must exceed centre_diameter + petal_width "
            f"({self.centre_diameter + self.petal_width:g} m)",
        )
        _need(
            self.clamp_diameter <= self.centre_diameter,
            "clamp_diameter",
            self.clamp_diameter,
            f"must be <= centre_diameter ({self.centre_diameter:g} m)",
        )

    @property
    def min_feature(self) -> float:
        return min(self.petal_width, 0.5 * (self.diameter - self.centre_diameter))


@dataclass(frozen=True)
class MantaShape:
    """Manta ray: rectangular ``body`` (length along x, the swimming direction) and two fins.

    ``fin_left`` (+y) and ``fin_right`` (−y) are trapezoids from the body
    side (chord ``body_length``) to the wing tips at y = ±wingspan/2 (chord
    ``fin_tip_width``, centred on x = 0). Free robot (no clamp).
    """

    wingspan: float = quantity("20 mm", "m", gt=0, doc="tip-to-tip span along y")
    body_length: float = quantity("10 mm", "m", gt=0, doc="body length along x")
    body_width: float = quantity("4 mm", "m", gt=0, doc="body width along y")
    fin_tip_width: float = quantity("2 mm", "m", gt=0, doc="fin chord at the wing tip")

    def __post_init__(self) -> None:
        _need(
            self.wingspan > self.body_width,
            "wingspan",
            self.wingspan,
            f"must exceed body_width ({self.body_width:g} m)",
        )
        _need(
            self.fin_tip_width <= self.body_length,
            "fin_tip_width",
            self.fin_tip_width,
            f"must be <= body_length ({self.body_length:g} m)",
        )

    @property
    def min_feature(self) -> float:
        return min(self.body_width, self.fin_tip_width, 0.5 * (self.wingspan - self.body_width))


@dataclass(frozen=True)
class MembraneShape:
    """Free rectangle ``length`` (x) × ``width`` (y) centred on the origin (e.g. rect-water)."""

    length: float = quantity("10 mm", "m", gt=0, doc="length along x")
    width: float = quantity("5 mm", "m", gt=0, doc="width along y")

    @property
    def min_feature(self) -> float:
        return min(self.length, self.width)


SHAPES: dict[str, type] = {
    "rectangle": RectangleShape,
    "trapezoid": TrapezoidShape,
    "triangle": TriangleShape,
    "slim_triangle": SlimTriangleShape,
    "failure_triangle": FailureTriangleShape,
    "two_arm_rectangle": TwoArmRectangleShape,
    "bow_tie": BowTieShape,
    "star": StarShape,
    "flower": FlowerShape,
    "manta": MantaShape,
    "membrane": MembraneShape,
}
"""Shape name -> dataclass validating that shape's keys."""

STRIP_SHAPES = ("rectangle", "two_arm_rectangle", "membrane")
"""Shapes of uniform width, which have a 2D side-view ``strip`` model."""

_COMMON = ("shape", "thickness", "position")


@dataclass(frozen=True)
class RobotSpec:
    """``[robot]``: the robot's shape and size (SI units, flat keys).

    Only the keys of ``shape`` are set; the others are ``None``. Use
    :attr:`params` for the validated per-shape object.
    """

    shape: str = option(choices=tuple(SHAPES), doc="robot shape")
    thickness: float = quantity(unit="m", ge=1e-6, le=5e-3, doc="membrane thickness (1 um..5 mm)")
    position: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m", doc="translation of the robot")
    # shape parameters (flat; None = not a key of this shape)
    length: float | None = quantity(None, "m")
    width: float | None = quantity(None, "m")
    root_width: float | None = quantity(None, "m")
    tip_width: float | None = quantity(None, "m")
    clamp_length: float | None = quantity(None, "m")
    type: str | None = option(None)
    middle_width: float | None = quantity(None, "m")
    end_width: float | None = quantity(None, "m")
    arms: int | None = integer(None)
    arm_length: float | None = quantity(None, "m")
    arm_width: float | None = quantity(None, "m")
    arm_tip_width: float | None = quantity(None, "m")
    hub_radius: float | None = quantity(None, "m")
    clamp_radius: float | None = quantity(None, "m")
    petals: int | None = integer(None)
    diameter: float | None = quantity(None, "m")
    centre_diameter: float | None = quantity(None, "m")
    petal_width: float | None = quantity(None, "m")
    clamp_diameter: float | None = quantity(None, "m")
    wingspan: float | None = quantity(None, "m")
    body_length: float | None = quantity(None, "m")
    body_width: float | None = quantity(None, "m")
    fin_tip_width: float | None = quantity(None, "m")

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> RobotSpec:
        key = f"{where}.shape" if where else "shape"
        if "shape" not in table:
            raise CaseError(
                key, dataclasses.MISSING, "missing required key; shapes are " + ", ".join(SHAPES)
            )
        shape = table["shape"]
        if not isinstance(shape, str) or shape not in SHAPES:
            raise CaseError(key, shape, "unknown shape; shapes are " + ", ".join(SHAPES))
        shape_cls = SHAPES[shape]
        shape_keys = [f.name for f in dataclasses.fields(shape_cls)]
        check_keys(table, [*_COMMON, *shape_keys], where)
        params: Any = build_fields(
            shape_cls, {k: v for k, v in table.items() if k in shape_keys}, where
        )
        common = build_fields(
            _CommonKeys, {k: v for k, v in table.items() if k in ("thickness", "position")}, where
        )
        return cls(
            shape=shape,
            thickness=common.thickness,
            position=common.position,
            **dataclasses.asdict(params),
        )

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise CaseError("shape", self.shape, "unknown shape; shapes are " + ", ".join(SHAPES))
        if not 1e-6 <= self.thickness <= 5e-3:
            raise CaseError("thickness", self.thickness, "must be between 1e-06 and 0.005 m")
        if len(self.position) != 3:
            raise CaseError("position", self.position, "must have 3 components")
        own = {f.name for f in dataclasses.fields(SHAPES[self.shape])}
        for f in dataclasses.fields(self):
            if f.name in _COMMON or f.name in own:
                continue
            if getattr(self, f.name) is not None:
                raise CaseError(
                    f.name,
                    getattr(self, f.name),
                    f"is not a key of shape '{self.shape}'; its keys are " + ", ".join(sorted(own)),
                )
        self.params  # noqa: B018  (validates the shape's keys and cross-checks)

    @property
    def params(self) -> Any:
        """The validated per-shape dataclass (``RectangleShape``, ``StarShape``, ...)."""
        shape_cls = SHAPES[self.shape]
        values = {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(shape_cls)
            if getattr(self, f.name) is not None
        }
        return shape_cls(**values)

    @property
    def min_feature(self) -> float:
        """Smallest in-plane dimension (m) an element must resolve (e.g. the arm width)."""
        return float(self.params.min_feature)

    @property
    def uniform_width(self) -> float | None:
        """Out-of-plane depth (m) of the ``strip`` model, or None for non-uniform shapes."""
        if self.shape not in STRIP_SHAPES:
            return None
        return float(self.params.width)


@dataclass(frozen=True)
class _CommonKeys:
    thickness: float = quantity(unit="m", ge=1e-6, le=5e-3)
    position: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m")


MODELS = ("solid", "strip", "surface")
"""``solid``: 3D extruded membrane; ``strip``: 2D side view (x, z) of a
uniform-width arm (plane stress/strain); ``surface``: 2D mid-surface of the
outline (in 3D space, at z = thickness/2)."""


@dataclass(frozen=True)
class MeshSpec:
    """``[mesh]``: how the robot is discretised. Only ``size`` is required.

    ``element = "hex"`` (default) recombines the outline into quadrilaterals
    (gmsh blossom full-quad) and extrudes them into hexahedra
    (quadrilaterals for ``strip`` and ``surface``); ``"wedge"`` keeps
    triangles (``strip`` and ``surface`` only: dolfinx 0.11 cannot tag the
    facets of prism meshes, so wedge solids are rejected). ``order = 2``
    gives second-order (curved) geometry, which represents the round hubs
    and petals of ``star`` and ``flower`` far better. ``tip_size`` refines the
    in-plane size towards the arm tips. ``size_across`` sets a different
    element size across arms that run along x (the beam-like shapes), whose
    bending varies along the arm: ``size = 0.25mm, size_across = 1mm`` resolves
    the bending like a 0.25 mm mesh with a quarter of its elements.
    """

    size: float = quantity(unit="m", gt=0, doc="in-plane element size")
    model: str = option("solid", choices=MODELS, doc="solid, strip or surface")
    layers: int = integer(1, ge=1, le=64, doc="elements through the thickness")
    element: str = option("hex", choices=("hex", "wedge"), doc="hex (quads) or wedge (triangles)")
    order: int = integer(1, ge=1, le=2, doc="geometry order")
    tip_size: float | None = quantity(None, "m", gt=0, doc="element size at the arm tips")
    size_across: float | None = quantity(
        None, "m", gt=0, doc="element size across arms along x (default size)"
    )

    def __post_init__(self) -> None:
        if self.tip_size is not None and self.tip_size > self.size:
            raise CaseError("tip_size", self.tip_size, f"must be <= size ({self.size:g} m)")
        if self.size_across is not None and self.model == "strip":
            raise CaseError(
                "size_across", self.size_across, "the strip model has no across direction"
            )
        if self.model == "solid" and self.element == "wedge":
            # dolfinx 0.11's gmsh reader raises "Unsupported facet tag for type prism"
            raise CaseError(
                "element",
                self.element,
                "wedge (prism) solids cannot carry facet groups in dolfinx 0.11; use hex "
                "(wedge gives triangles for the strip and surface models)",
            )
        if self.model == "surface" and self.layers != 1:
            raise CaseError("layers", self.layers, "must be 1 for the surface model")


def check_mesh_for_robot(robot: RobotSpec, mesh: MeshSpec) -> None:
    """Cross-table checks between ``[robot]`` and ``[mesh]`` (keys named ``mesh.*``).

    Raises:
        CaseError: ``mesh.size`` or ``size_across`` larger than the smallest feature, or a
            ``strip`` model for a shape without uniform width.
    """
    feature = robot.min_feature
    # with size_across, size runs along the arms and size_across is what meets the width
    checked = [("mesh.size_across", mesh.size_across)]
    if mesh.size_across is None:
        checked.append(("mesh.size", mesh.size))
    for key, value in checked:
        if value is not None and value > feature:
            raise CaseError(
                key, value, f"must be <= the robot's smallest in-plane dimension ({feature:g} m)"
            )
    if mesh.model == "strip" and robot.shape not in STRIP_SHAPES:
        raise CaseError(
            "mesh.model",
            mesh.model,
            f"'strip' needs a uniform-width shape ({', '.join(STRIP_SHAPES)}), not '{robot.shape}'",
        )
