r"""Iron parts of the field as rigid obstacles (``[[contacts]] kind = "iron"``): tweezers' prongs.

An iron part of ``[[field.iron]]`` that is a union of convex polyhedra — the
``tweezers`` (each prong a hexahedron with planar faces: its width and its
distance from the axis vary linearly from the tip to the handle; and the
handle block) and the ``box`` — is also a rigid body the robot cannot enter.
It follows the iron's ``[[field.motions]]`` entry, so the robot that the
magnetised tips attract meets them instead of passing into them. The
geometry is the iron part's own (:meth:`~magfem.field.iron_spec.IronSpec.body`);
the table only names the part.

Distance. A convex piece k is the intersection of the half-spaces
n_ki · y ≤ c_ki of its faces i (outward unit normals n_ki, reference
placement). With

.. math::

    g_k(\mathbf y) = \max_i (\mathbf n_{ki}\cdot\mathbf y - c_{ki}),\qquad
    g(\mathbf y) = \min_k g_k(\mathbf y),\qquad \mathbf n = \mathbf n_{k^*i^*}

(the face i* of the piece k* that attain them), g is exactly the signed
distance inside a piece (minus the distance to its nearest face) and
outside it where the nearest surface point lies inside a face (the face
regions); near an edge or a corner it is a lower bound (off an edge, at
the distance d from both face planes, g = d where the distance is √2 d).
The penalty acts on penetration (g < 0) only, where g is exact, so the
bound changes only the reported gap of a body beside an edge, never the
force. Where two pieces overlap g is the deeper piece's (the tweezers'
pieces only touch, at the prongs' handle ends). The faces' normals and
offsets are Constants: the compiled form depends only on the numbers of
pieces and faces (every pair of tweezers shares one).

Everything else — the penalty law with friction and dashpot, the motion
(the iron's offsets and angles about its pivot), the history columns
``obstacle_<name>_x``, ``_y``, ``_z`` (force on the robot, N) and ``_gap``
(m) — is the obstacle's (:mod:`magfem.mechanics.contacts.obstacle`). 3D
models only (``surface``, ``solid``).

    [[contacts]]
    kind = "iron"
    name = "prongs"
    part = 0                 # the first [[field.iron]] entry
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem

from magfem.config import CaseError, integer, option, quantity
from magfem.field.spec import FieldSpec
from magfem.field.spec import MotionSpec as FieldMotion
from magfem.geometry.sources import Box, RuledSolid
from magfem.mechanics.contacts.base import CONTACTS, Contact, ContactKindSpec
from magfem.mechanics.contacts.obstacle import Obstacle
from magfem.mechanics.contacts.rigid import MotionSpec
from magfem.mechanics.models.base import Model
from magfem.mechanics.spec import EnvironmentSpec, MaterialSpec

__all__ = [
    "IronObstacle",
    "IronObstacleSpec",
    "convex_distance",
    "convex_pieces",
    "iron_motion",
]

_RULED_FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
"""Faces of a ruled solid (tip quad 0-3, handle quad 4-7), as corner indices."""


def _planes(corners: npt.NDArray[np.float64], faces: Any) -> npt.NDArray[np.float64] | None:
    """Outward planes (F, 4) [n, c] (n·y ≤ c inside) of a convex polyhedron, or None if it is
    not one (a face not planar, or a corner outside a face's plane), to 1e-9 of its size."""
    centre = corners.mean(axis=0)
    tol = 1e-9 * float(np.ptp(corners, axis=0).max())
    rows = []
    for face in faces:
        p = corners[list(face)]
        n = np.cross(p[1] - p[0], p[-1] - p[0])
        n = n / np.linalg.norm(n)
        n = n if n @ (p[0] - centre) > 0 else -n
        c = float(n @ p[0])
        if np.any(np.abs(p @ n - c) > tol) or np.any(corners @ n - c > tol):
            return None
        rows.append([*n, c])
    return np.array(rows)


def convex_pieces(iron: Any) -> list[npt.NDArray[np.float64]] | None:
    """Face planes (F, 4) of each convex piece of an iron part, or None if it has other pieces.

    Boxes and ruled solids (the tweezers' prongs) are the pieces; spheres and
    frustums (``sphere``, ``rod``, ``needle``) are not polyhedra.
    """
    out = []
    for part in iron.body("iron").parts:
        if isinstance(part, Box):
            R, half = np.asarray(part.rotation, dtype=float), 0.5 * np.asarray(part.size)
            signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)])
            corners = np.asarray(part.center) + (signs * half) @ R.T
            planes = _planes(
                corners,
                [
                    (0, 1, 3, 2),
                    (4, 6, 7, 5),
                    (0, 4, 5, 1),
                    (2, 3, 7, 6),
                    (0, 2, 6, 4),
                    (1, 5, 7, 3),
                ],
            )
        elif isinstance(part, RuledSolid):
            planes = _planes(np.asarray(part.corners, dtype=float), _RULED_FACES)
        else:
            return None
        if planes is None:
            return None
        out.append(planes)
    return out


def iron_motion(motion: FieldMotion | None) -> MotionSpec | None:
    """The obstacle motion of a ``[[field.motions]]`` entry (same keyframes and placement)."""
    if motion is None:
        return None
    return MotionSpec(
        times=motion.times,
        positions=motion.offsets,
        angles=motion.angles or (),
        rotation_axis=motion.rotation_axis,
        pivot=motion.pivot,
    )


@CONTACTS.register("iron")
@dataclass(frozen=True, kw_only=True)
class IronObstacleSpec(ContactKindSpec):
    """``[[contacts]] kind = "iron"``: a ``[[field.iron]]`` part as a rigid, moving obstacle."""

    kind: str = option("iron", ("iron",), doc="contact kind")
    name: str = option(doc="a word for the history columns (letters, digits, _)")
    part: int = integer(0, ge=0, doc="index of the [[field.iron]] entry (0: the first)")
    friction: float = quantity(0.5, "", ge=0.0, doc="Coulomb friction coefficient")
    penalty: float = quantity(10.0, "", gt=0.0, doc="κ: stiffness k_n = κ μ / thickness")
    penalty_onset: float = quantity(0.05, "", gt=0.0, doc="onset of the ramp, in thicknesses")
    damping: float = quantity(1.0, "", ge=0.0, doc="contact dashpot, fraction of critical")
    regularization_velocity: float = quantity(1e-3, "m/s", gt=0.0, doc="friction's v_ε")
    slip_length: float = quantity(0.01, "", ge=0.0, doc="friction's ℓ, in thicknesses")

    shape = "iron"
    side = "outside"
    motion = None  # the iron's, from the field (build)

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise CaseError("name", self.name, "must be letters, digits and _ (a column name)")

    def check_field(self, field: FieldSpec) -> None:
        if self.part >= len(field.iron):
            have = (
                f"{len(field.iron)} [[field.iron]] entries" if field.iron else "no [[field.iron]]"
            )
            raise CaseError("part", self.part, f"must name an iron part: the case has {have}")
        iron = field.iron[self.part]
        if convex_pieces(iron) is None:
            raise CaseError(
                "part",
                self.part,
                f"iron part {self.part} is a {iron.kind}: only box and tweezers iron (convex "
                "polyhedra) are obstacles; use an obstacle of shape sphere or cylinder for it",
            )

    def describe(self) -> str:
        return (
            f"obstacle '{self.name}': the surface of iron part {self.part}, moving with it, "
            "robot outside"
        )

    def build(
        self,
        model: Model,
        material: MaterialSpec,
        *,
        environment: EnvironmentSpec | None = None,
        field: FieldSpec | None = None,
    ) -> Contact:
        if field is None:
            raise CaseError(f"obstacle '{self.name}'.part", self.part, "needs the case's [field]")
        self.check_field(field)
        iron = field.iron[self.part]
        pieces = convex_pieces(iron) or []
        return IronObstacle(
            self,
            model,
            pieces,
            shear_modulus=material.shear_modulus,
            density=material.density,
            motion=iron_motion(field.motion(iron.motion)),
        )


class IronObstacle(Obstacle):
    """The contact of the robot's faces with the convex pieces of an iron part (module docstring).

    Args:
        spec: the table.
        model: the body (3D).
        pieces: face planes (F, 4) [n, c] of each piece, reference placement (m).
        shear_modulus, density: of the membrane (Pa, kg/m³), which scale the law.
        motion: the iron part's motion.
    """

    def __init__(
        self,
        spec: IronObstacleSpec,
        model: Model,
        pieces: list[npt.NDArray[np.float64]],
        *,
        shear_modulus: float,
        density: float,
        motion: MotionSpec | None,
    ):
        if model.gdim != 3:
            raise CaseError(
                f"obstacle '{spec.name}'", "(a 2D strip)", "an iron obstacle needs a 3D model"
            )
        mesh = model.robot.mesh
        count = max(len(p) for p in pieces)
        padded = [np.vstack([p, np.tile(p[:1], (count - len(p), 1))]) for p in pieces]
        planes = np.array(padded)  # (pieces, faces, 4); a piece repeats its first face
        self.normals = fem.Constant(mesh, planes[:, :, :3].copy())
        self.offsets = fem.Constant(mesh, planes[:, :, 3].copy())
        super().__init__(spec, model, shear_modulus=shear_modulus, density=density, motion=motion)

    def distance(self, x: Any, offset: Any) -> tuple[Any, Any]:
        return convex_distance(self.normals, self.offsets, x - offset)


def convex_distance(normals: Any, offsets: Any, y: Any) -> tuple[Any, Any]:
    """(g, n) at the point y (UFL 3-vector, m) of a union of convex pieces (module docstring).

    Args:
        normals: outward unit normals, shape (pieces, faces, 3) (a UFL tensor or Constant).
        offsets: c of the planes n·y = c, shape (pieces, faces) (m).
    """
    n_pieces, n_faces = normals.ufl_shape[:2]
    per_piece = []
    for k in range(n_pieces):
        ns = [ufl.as_vector([normals[k, i, j] for j in range(3)]) for i in range(n_faces)]
        faces = [(ufl.dot(n, y) - offsets[k, i], n) for i, n in enumerate(ns)]
        per_piece.append(functools.reduce(functools.partial(_pick, larger=True), faces))
    return functools.reduce(functools.partial(_pick, larger=False), per_piece)


def _pick(a: tuple[Any, Any], b: tuple[Any, Any], *, larger: bool) -> tuple[Any, Any]:
    """(value, vector) of the larger (or smaller) value of a and b; a on ties (UFL)."""
    take_b = ufl.gt(b[0], a[0]) if larger else ufl.lt(b[0], a[0])
    value = ufl.conditional(take_b, b[0], a[0])
    return value, ufl.as_vector([ufl.conditional(take_b, b[1][j], a[1][j]) for j in range(3)])
