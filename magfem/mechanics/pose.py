"""The initial state of the body: a rigid placement and a rigid velocity (``[initial]``).

Every robot is meshed flat, its bottom face on z = 0 and its thickness along
+z (:mod:`magfem.geometry.spec`, then translated by ``[robot] position``). The
``[initial]`` table places that reference body rigidly before the run: a
rotation R by ``angle`` about ``axis`` through ``pivot`` p, then a
translation d = ``offset``, and gives it the rigid velocity of a
translation V = ``velocity`` and a spin ω = ``angular_velocity`` about the
placed pivot:

.. math::

    \\mathbf x_0(\\mathbf X) = R(\\mathbf X - \\mathbf p) + \\mathbf p + \\mathbf d,\\qquad
    \\mathbf u_0 = \\mathbf x_0 - \\mathbf X,\\qquad
    \\mathbf v_0 = \\mathbf V + \\boldsymbol\\omega\\times(\\mathbf x_0 - \\mathbf p - \\mathbf d).

The reference configuration (where strains are measured) stays the flat
mesh, so the placed body is unstressed. The shell's directors are measured
from the placed normal R e_z (:mod:`magfem.mechanics.models.shell`), which
keeps an upright robot away from the angles' singularity. The 2D strip
(side view in x–z) can only turn about y. The default pivot is the robot's
``position`` at mid-thickness.

    [initial]
    axis = [1, 0, 0]
    angle = "90 deg"              # stand the robot up
    offset = [0, 0, "3 mm"]
    velocity = [0, 0, 0]
    angular_velocity = [0, 0, 0]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from magfem.config import CaseError, quantity, vector
from magfem.field.placement import rotation

__all__ = ["InitialSpec", "RigidMotion", "initial_motion"]


@dataclass(frozen=True)
class InitialSpec:
    """``[initial]``: the body's placement and rigid velocity at the start (module docstring)."""

    axis: tuple[float, ...] = vector(
        (0.0, 0.0, 1.0), "", nonzero=True, doc="axis of the initial rotation"
    )
    angle: float = quantity(0.0, "rad", doc="initial rotation about axis (right hand)")
    pivot: tuple[float, ...] | None = vector(
        None, "m", doc="point the rotation turns about (default: robot position, mid-thickness)"
    )
    offset: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m", doc="translation after the rotation")
    velocity: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m/s", doc="initial translation velocity")
    angular_velocity: tuple[float, ...] = vector(
        (0.0, 0.0, 0.0), "rad/s", doc="initial spin about the placed pivot"
    )

    def __post_init__(self) -> None:
        for key in ("axis", "offset", "velocity", "angular_velocity"):
            if not all(math.isfinite(v) for v in getattr(self, key)):
                raise CaseError(key, getattr(self, key), "must be finite")
        if not math.isfinite(self.angle):
            raise CaseError("angle", self.angle, "must be finite")

    @property
    def rotation(self) -> npt.NDArray[np.float64]:
        """R (3, 3): the rotation by ``angle`` about ``axis``."""
        axis = np.asarray(self.axis, dtype=float)
        return rotation(axis / np.linalg.norm(axis), self.angle)

    @property
    def moves(self) -> bool:
        """Whether the body starts anywhere but at rest in its meshed placement."""
        return bool(
            self.angle != 0.0
            or any(self.offset)
            or any(self.velocity)
            or any(self.angular_velocity)
        )


class RigidMotion(NamedTuple):
    """A rigid placement and velocity, x = R (X − p) + p + d, v = V + ω × (x − p − d) (SI)."""

    R: npt.NDArray[np.float64]
    pivot: npt.NDArray[np.float64]
    offset: npt.NDArray[np.float64]
    velocity: npt.NDArray[np.float64]
    omega: npt.NDArray[np.float64]

    def position(self, X: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Placed positions (N, 3) of reference points X (N, 3)."""
        return (X - self.pivot) @ self.R.T + self.pivot + self.offset

    def speed(self, X: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Velocities (N, 3) of the placed reference points X (N, 3)."""
        arm = self.position(X) - self.pivot - self.offset
        return self.velocity + np.cross(self.omega, arm)


def initial_motion(spec: InitialSpec, default_pivot: npt.ArrayLike, gdim: int = 3) -> RigidMotion:
    """The rigid motion of ``[initial]``; ``default_pivot`` (3,) m when ``pivot`` is not given.

    Raises:
        CaseError: a 2D strip (``gdim`` 2) turned or spun about an axis other than y.
    """
    R = spec.rotation
    omega = np.asarray(spec.angular_velocity, dtype=float)
    if gdim == 2:
        if spec.angle != 0.0 and not np.allclose(np.abs(R[:, 1]), [0.0, 1.0, 0.0]):
            raise CaseError(
                "initial.axis", spec.axis, "the strip model (x-z side view) can only turn about y"
            )
        if omega[0] != 0.0 or omega[2] != 0.0:
            raise CaseError(
                "initial.angular_velocity",
                spec.angular_velocity,
                "the strip model (x-z side view) can only spin about y",
            )
    pivot = np.asarray(spec.pivot if spec.pivot is not None else default_pivot, dtype=float)
    return RigidMotion(
        R, pivot, np.asarray(spec.offset, dtype=float), np.asarray(spec.velocity, float), omega
    )
