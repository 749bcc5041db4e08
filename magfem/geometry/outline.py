"""The planar outline of a robot: what the gmsh meshing step asks of every shape.

An :class:`Outline` adds its planar pieces to a gmsh OCC model (``build``),
names a piece or a side face from a point of it (``cell_group``,
``tip_group``), says which points are bonded (``in_clamp``), lists its arms
(``arms``) and knows its exact area (``area``, used by the tests).
Everything is in the robot's own frame: the membrane on z = 0 before the
thickness is extruded and ``position`` added. Shared families:
:class:`magfem.geometry.beam.BeamOutline` (arms along ±x) and
:class:`magfem.geometry.radial.RadialOutline` (arms around a disk hub).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

__all__ = ["TIP_ZONE", "Outline", "PlanarArm", "add_polygon"]

TIP_ZONE = 0.1
"""Fraction of a pointed arm's length, ending at the apex, whose side faces form its tip group."""

_REL_TOL = 1e-7
"""Relative tolerance (of the robot size) for classifying gmsh entities by position."""


class PlanarArm(NamedTuple):
    """An arm in the robot's plane: its midline runs ``length`` from ``root`` along ``direction``.

    ``root`` (m) is the point on the arm axis where the arm's cell group
    begins (x = 0 for one-arm shapes and for the two arms of a strip clamped
    in the middle; the hub circle for stars and flowers; the body side for
    fins); ``direction`` is a unit 2-vector; ``tip`` names its tip facet group.
    """

    name: str
    root: tuple[float, float]
    direction: tuple[float, float]
    length: float
    tip: str


class Outline(ABC):
    """Base class: see the module docstring. Subclasses set the attributes below.

    Attributes:
        arms: the arms (possibly none).
        area: exact area of the outline (m²).
        curved: whether the outline has circular arcs.
        clamped: whether part of the bottom face is bonded.
        scale: size of the robot (m), the unit of the position tolerance.
    """

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

    def inset_clamp(self, inset: float) -> Outline:
        """The same outline with the clamp patch's free edges moved ``inset`` (m) into it.

        Raises:
            ValueError: the patch is not longer than ``inset``, or this outline
                has no clamp patch to inset.
        """
        raise ValueError(f"no clamp inset for {type(self).__name__}")

    @property
    def tol(self) -> float:
        """Position tolerance (m) for classifying gmsh entities."""
        return _REL_TOL * self.scale


def add_polygon(occ: Any, points: Sequence[tuple[float, float]]) -> int:
    """OCC plane surface bounded by the closed polygon ``points`` (m, z = 0); returns its tag."""
    tags = [occ.addPoint(x, y, 0.0) for x, y in points]
    lines = [occ.addLine(tags[i], tags[(i + 1) % len(tags)]) for i in range(len(tags))]
    return int(occ.addPlaneSurface([occ.addCurveLoop(lines)]))
