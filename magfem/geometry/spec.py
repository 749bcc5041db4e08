"""Case tables of the geometry stage: ``[robot]`` (shape) and ``[mesh]`` (discretisation).

Coordinates (every shape): the membrane lies in the x–y plane, its bottom
face on z = 0 and its thickness along +z; ``position`` then translates the
whole robot. One-arm shapes have their root edge on x = 0, extend along +x
and are centred on y = 0; the others are centred on the origin.

``[robot]`` is a flat table: the common keys ``shape``, ``thickness``,
``position`` plus the keys of the chosen shape. Each shape is a small
frozen dataclass in :mod:`magfem.geometry.shapes` (one module per shape,
registered in :data:`SHAPES`) that validates its own keys; a key of another
shape is an "unknown key" error that lists the allowed keys.
:class:`RobotSpec` holds the common keys and the validated shape object
(``params``); :func:`magfem.config.to_table` writes it back as the same flat
table.

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

from magfem import config
from magfem.config import MISSING, CaseError, integer, option, quantity, vector
from magfem.geometry.shapes import SHAPES, Shape

__all__ = [
    "MODELS",
    "SHAPES",
    "STRIP_SHAPES",
    "MeshSpec",
    "RobotSpec",
    "check_mesh_for_robot",
]

STRIP_SHAPES: tuple[str, ...] = tuple(
    name for name, cls in SHAPES.items() if cls().uniform_width is not None
)
"""Shapes of uniform width, which have a 2D side-view ``strip`` model."""

_COMMON = ("shape", "thickness", "position")


@dataclass(frozen=True)
class RobotSpec:
    """``[robot]``: the robot's shape and size (SI units).

    ``params`` is the validated shape object (its keys, e.g.
    ``params.clamp_length``); reading a key on the spec itself
    (``robot.width``) falls through to ``params``, and raises AttributeError
    when the shape has no such key.
    """

    shape: str = option(choices=tuple(SHAPES), doc="robot shape")
    thickness: float = quantity(unit="m", ge=1e-6, le=5e-3, doc="membrane thickness (1 um..5 mm)")
    position: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m", doc="translation of the robot")
    params: Shape = dataclasses.field(
        kw_only=True, metadata={"doc": "the keys of the shape (flat in the table)"}
    )

    @classmethod
    def __from_table__(cls, table: Mapping[str, Any], where: str) -> RobotSpec:
        key = f"{where}.shape" if where else "shape"
        if "shape" not in table:
            raise CaseError(key, MISSING, "missing required key; shapes are " + ", ".join(SHAPES))
        shape = table["shape"]
        if not isinstance(shape, str) or shape not in SHAPES:
            raise CaseError(key, shape, "unknown shape; shapes are " + ", ".join(SHAPES))
        shape_cls = SHAPES[shape]
        shape_keys = [f.name for f in dataclasses.fields(shape_cls)]  # type: ignore[arg-type]
        config.check_keys(table, [*_COMMON, *shape_keys], where)
        params = config.build_fields(
            shape_cls, {k: v for k, v in table.items() if k in shape_keys}, where
        )
        common = {k: v for k, v in table.items() if k in ("thickness", "position")}
        return config.build_fields(cls, common, where, shape=shape, params=params)

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise CaseError("shape", self.shape, "unknown shape; shapes are " + ", ".join(SHAPES))
        if not isinstance(self.params, SHAPES[self.shape]):
            raise TypeError(
                f"RobotSpec: params is a {type(self.params).__name__}, "
                f"not {SHAPES[self.shape].__name__} (shape '{self.shape}')"
            )
        if not 1e-6 <= self.thickness <= 5e-3:
            raise CaseError("thickness", self.thickness, "must be between 1e-06 and 0.005 m")
        if len(self.position) != 3:
            raise CaseError("position", self.position, "must have 3 components")

    def __getattr__(self, name: str) -> Any:
        # called only when normal lookup fails: a key of the shape (``robot.width``)
        params = self.__dict__.get("params")
        if params is None or name.startswith("__"):
            raise AttributeError(name)
        try:
            return getattr(params, name)
        except AttributeError:
            raise AttributeError(f"shape '{self.shape}' has no key '{name}'") from None

    def __to_table__(self) -> dict[str, Any]:
        """The flat ``[robot]`` table (SI numbers) that :func:`magfem.config.to_table` writes."""
        common = {"shape": self.shape, "thickness": self.thickness, "position": list(self.position)}
        return common | config.to_table(self.params)

    @property
    def min_feature(self) -> float:
        """Smallest in-plane dimension (m) an element must resolve (e.g. the arm width)."""
        return float(self.params.min_feature)

    @property
    def uniform_width(self) -> float | None:
        """Out-of-plane depth (m) of the ``strip`` model, or None for non-uniform shapes."""
        width = self.params.uniform_width
        return None if width is None else float(width)


MODELS = ("solid", "strip", "surface", "rod", "auto")
"""``solid``: 3D extruded membrane; ``strip``: 2D side view (x, z) of a
uniform-width arm (plane stress/strain); ``surface``: 2D mid-surface of the
outline (in 3D space, at z = thickness/2); ``rod``: the arms' midlines (1D in
3D, at z = thickness/2); ``auto``: chosen for the case (:mod:`magfem.accuracy`)."""

ROD_BENDING = ("anticlastic", "beam", "plate")
"""Out-of-plane bending law of the rod's section (:mod:`magfem.mechanics.models.rod_section`)."""


ROOTS = ("bonded", "rigid")
"""``[mesh] root``: how the bonded patch holds the membrane (:class:`MeshSpec`)."""


@dataclass(frozen=True)
class MeshSpec:
    """``[mesh]``: how the robot is discretised. Only ``size`` is required (and not even it
    when ``[solver] accuracy`` chooses it).

    ``element = "hex"`` (default) recombines the outline into quadrilaterals
    (gmsh blossom full-quad) and extrudes them into hexahedra
    (quadrilaterals for ``strip`` and ``surface``); ``"wedge"`` keeps
    triangles (``strip`` and ``surface`` only: dolfinx 0.11 cannot tag the
    facets of prism meshes, so wedge solids are rejected). ``order = 2``
    gives second-order (curved) geometry, which represents the round hubs
    and petals of ``star`` and ``flower`` far better. ``tip_size`` refines the
    in-plane size towards the arm tips, ``root_size`` towards the free edges of
    the clamp patch, where the arms leave it and fold tightest when they wrap
    round it (both grow to ``size`` over a quarter of the shortest arm).
    ``size_across`` sets a different element size across arms that run along x
    (the beam-like shapes), whose bending varies along the arm:
    ``size = 0.25mm, size_across = 1mm`` resolves the bending like a 0.25 mm
    mesh with a quarter of its elements.

    ``root`` says how the bonded patch (the ``clamp`` group) holds the
    membrane. ``bonded`` (default) is the experiments' glued bottom face: the
    solid and strip hold that face only, so the membrane above it is as
    compliant as it is; the shell, which has no bottom face, clamps the patch
    less 0.41 thicknesses at its free edges, the measured compliance of the
    bonded root (docs/verification.md). ``rigid`` holds the whole patch
    through the thickness up to its edge: the textbook clamp of beam theory.

    The ``rod`` model meshes the arms' midlines with elements of ``size``
    along them; ``rod_bending`` chooses its section law, and ``root`` holds
    it like the shell: ``bonded`` less 0.41 thicknesses inside the patch's
    free edges, ``rigid`` at the edge (docs/mechanics.md, "Rod"). ``auto``
    picks the model for the case (the rod where it is adequate, else the
    shell; ``magfem check`` says which and why); the keys the chosen model does
    not use (the rod: ``tip_size``, ``root_size``, ``size_across``,
    ``turn_axis``; the shell: ``layers``) go back to their defaults, and that
    line names them.
    """

    size: float = quantity(
        unit="m", gt=0, doc="in-plane element size (required unless solver.accuracy is set)"
    )
    model: str = option("solid", choices=MODELS, doc="solid, strip, surface, rod or auto")
    layers: int = integer(1, ge=1, le=64, doc="elements through the thickness (solid, strip)")
    element: str = option("hex", choices=("hex", "wedge"), doc="hex (quads) or wedge (triangles)")
    order: int = integer(1, ge=1, le=2, doc="geometry order")
    tip_size: float | None = quantity(None, "m", gt=0, doc="element size at the arm tips")
    root_size: float | None = quantity(
        None, "m", gt=0, doc="element size where the arms leave the clamp patch (their roots)"
    )
    size_across: float | None = quantity(
        None, "m", gt=0, doc="element size across arms along x (default size)"
    )
    rod_bending: str = option(
        "anticlastic",
        ROD_BENDING,
        doc="rod model: bending about the width axis; anticlastic (beam at small curvature, "
        "plate at large, Ashwell), beam (E I) or plate (E I/(1 - nu^2))",
    )
    root: str = option(
        "bonded",
        ROOTS,
        doc="how the clamp patch holds the membrane: bonded (its bottom face glued) or rigid "
        "(held through the thickness up to the patch's edge)",
    )
    turn_axis: tuple[float, ...] | None = vector(
        None,
        "",
        nonzero=True,
        doc="surface model: the in-plane axis [x, y, 0] about which the director turns without "
        "limit (default: each arm's cross axis, so arms bend past 270 deg); the angles are "
        "singular for a turn of 90 deg about the in-plane axis across it",
    )

    def __post_init__(self) -> None:
        for key in ("tip_size", "root_size"):
            value = getattr(self, key)
            if value is not None and value > self.size:
                raise CaseError(key, value, f"must be <= size ({self.size:g} m)")
            if value is not None and self.model == "rod":
                raise CaseError(key, value, "the rod model meshes its midlines uniformly")
        if self.size_across is not None and self.model in ("strip", "rod"):
            raise CaseError(
                "size_across", self.size_across, f"the {self.model} model has no across direction"
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
        if self.turn_axis is not None:
            if self.model != "surface":
                raise CaseError("turn_axis", list(self.turn_axis), "is a surface-model key")
            if abs(self.turn_axis[2]) > 1e-12 * math.hypot(*self.turn_axis):
                raise CaseError("turn_axis", list(self.turn_axis), "must lie in the x-y plane")


def check_mesh_for_robot(robot: RobotSpec, mesh: MeshSpec) -> None:
    """Cross-table checks between ``[robot]`` and ``[mesh]`` (keys named ``mesh.*``).

    Raises:
        CaseError: ``mesh.size`` or ``size_across`` larger than the smallest feature (the
            shortest arm for the rod), a ``strip`` model for a shape without uniform width,
            or ``root_size`` for a robot without a clamp patch.
    """
    if mesh.model == "auto":  # checked again for the model chosen (magfem.accuracy)
        return
    if mesh.model == "rod":
        lengths = [a.length for a in robot.params.outline().arms]
        if lengths and mesh.size > min(lengths):
            raise CaseError(
                "mesh.size", mesh.size, f"must be <= the shortest arm ({min(lengths):g} m) for rods"
            )
        return
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
    if mesh.model == "strip" and robot.uniform_width is None:
        raise CaseError(
            "mesh.model",
            mesh.model,
            f"'strip' needs a uniform-width shape ({', '.join(STRIP_SHAPES)}), not '{robot.shape}'",
        )
    if mesh.root_size is not None and not robot.params.outline().clamped:
        raise CaseError(
            "mesh.root_size",
            mesh.root_size,
            f"refines where the arms leave the clamp patch, and '{robot.shape}' has none",
        )
