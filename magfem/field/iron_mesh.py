"""The mesh of an iron solve: which geometry (3D or (r, z)) and the gmsh model of the parts.

A configuration is axisymmetric when every iron part has a meridian section
about one line (:meth:`~magfem.field.iron_spec.IronSpec.profile`) and every
source is a coil, coil pair or cylinder magnet on that line or a uniform
field along it; it is then meshed in the (r, z) half-plane. The air region
is a ball (half-disk) about the parts of radius ``air_factor`` × their
bounding radius, enlarged to hold the robot's workspace, which is meshed at
most at ``workspace_mesh_size``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from mpi4py import MPI

from magfem.field.iron_spec import IronSpec
from magfem.field.reaction import AxisFrame
from magfem.field.source import CoilField, CylinderMagnetField, SourceField, SumField, UniformField
from magfem.field.spec import SolveSpec
from magfem.geometry.gmshio import build_mesh
from magfem.geometry.sources import IronSizing, axisymmetric_builder, solid_builder

__all__ = ["build_iron_mesh", "common_axis", "iron_size"]


def _symmetry(field: SourceField) -> list[tuple[np.ndarray | None, np.ndarray]] | None:
    """(point on the axis or None, axis) of each part of a load; None if not axisymmetric."""
    if isinstance(field, SumField):
        out: list[tuple[np.ndarray | None, np.ndarray]] = []
        for f in field.fields:
            s = _symmetry(f)
            if s is None:
                return None
            out += s
        return out
    if isinstance(field, UniformField):
        n = float(np.linalg.norm(field.vector))
        return [(None, field.vector / n)] if n > 0 else []
    if isinstance(field, CoilField | CylinderMagnetField):
        return [(field.center, field.Q[:, 2])]
    return None


def common_axis(parts: Sequence[IronSpec], loads: Sequence[SourceField]) -> AxisFrame | None:
    """The line about which all iron parts and loads are axisymmetric, or None."""
    lines: list[tuple[np.ndarray | None, np.ndarray]] = []
    for f in loads:
        s = _symmetry(f)
        if s is None:
            return None
        lines += s
    axes = [a for _, a in lines]
    axes += [np.asarray(p.axis, dtype=float) for p in parts if hasattr(p, "axis")]
    points = [o for o, _ in lines if o is not None] + [p.tip_point() for p in parts]
    if not points:
        return None
    frame = AxisFrame(points[0], axes[0] if axes else np.array([0.0, 0.0, 1.0]))
    for o, a in lines:
        if abs(abs(a @ frame.axis) - 1.0) > 1e-9:
            return None
        if o is not None and frame.meridian(o[None, :])[0, 0] > 1e-9 * (1.0 + np.abs(o).max()):
            return None
    if any(p.profile(frame.origin, frame.axis, "x") is None for p in parts):
        return None
    return frame


def iron_size(parts: Sequence[IronSpec]) -> tuple[np.ndarray, float]:
    """Centre (3,) and bounding radius (m) of the iron parts."""
    pts = np.vstack([p.sample_points() for p in parts])
    c = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    return c, float(np.linalg.norm(pts - c, axis=1).max())


def build_iron_mesh(
    parts: Sequence[IronSpec],
    frame: AxisFrame | None,
    solve: SolveSpec,
    comm: MPI.Comm,
    workspace: np.ndarray | None,
) -> tuple[Any, np.ndarray, float, float]:
    """Mesh the iron in its air region: (MeshData, centre (3,), r_air, h_iron)."""
    c, s = iron_size(parts)
    if frame is not None:  # centre the half-disk on the axis
        c = frame.origin + frame.axis * float((c - frame.origin) @ frame.axis)
    r_air = solve.air_factor * s
    box = None
    if workspace is not None:
        lo, hi = np.asarray(workspace, dtype=float)
        corners = np.array(
            [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        )
        r_air = max(r_air, 1.2 * float(np.linalg.norm(corners - c, axis=1).max()))
        box = np.array([lo, hi])
        if frame is not None:
            m = frame.meridian(corners)
            box = np.array([[0.0, m[:, 1].min(), 0.0], [m[:, 0].max(), m[:, 1].max(), 0.0]])
    h_iron = solve.mesh_size or min(
        min(p.min_feature() for p in parts) / 2, s / (20 if frame is not None else 6)
    )
    h_ws = solve.workspace_mesh_size if box is not None else None
    order = 2 if solve.curved else 1
    names = [f"iron_{k + 1}" for k in range(len(parts))]
    sizing = IronSizing(h_iron, solve.grading, box, h_ws, order)
    if frame is None:
        bodies = [p.body(n) for p, n in zip(parts, names, strict=True)]
        builder = solid_builder(bodies, r_air, center=tuple(c), sizing=sizing)
        data = build_mesh(builder, comm, gdim=3, name="iron")
    else:
        z_c = float((c - frame.origin) @ frame.axis)
        profiles = [
            p.profile(frame.origin, frame.axis, n) for p, n in zip(parts, names, strict=True)
        ]
        kept = [q for q in profiles if q is not None]
        builder = axisymmetric_builder(kept, r_air, z_center=z_c, sizing=sizing)
        data = build_mesh(builder, comm, gdim=2, name="iron_rz")
    return data, c, r_air, h_iron
