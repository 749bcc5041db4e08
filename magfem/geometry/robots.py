"""The planar outline of a robot spec, with the clamp patch optionally inset.

Each shape (:mod:`magfem.geometry.shapes`) gives its own
:class:`~magfem.geometry.outline.Outline`; :func:`outline_of` asks the
validated spec for it. The 3D/2D meshing pipeline lives in
:mod:`magfem.geometry.robot_mesh`.
"""

from __future__ import annotations

from magfem.geometry.outline import TIP_ZONE, Outline, PlanarArm
from magfem.geometry.spec import RobotSpec

__all__ = ["TIP_ZONE", "Outline", "PlanarArm", "outline_of"]


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
    outline = robot.params.outline()
    if clamp_inset == 0.0 or not outline.clamped:
        return outline
    return outline.inset_clamp(clamp_inset)
