"""From a source table to its FE field: geometry in the source frame, mesh sizes, solve.

Default resolution (``[field.solve]`` keys left unset), chosen from the
measurements in docs/field.md so that B is within 0.1 % and ∇B within 1 %
over the workspace at degree 3:

* ``mesh_size`` = s / 15, s = radius of the source's bounding sphere;
* ``workspace_mesh_size`` = workspace edge / 10;
* air radius = ``air_factor`` × s (default 20: truncation error ~1e-4 of B
  at the centre of the coil pair).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from mpi4py import MPI

from magfem.field.analytic import thick_coil_on_axis
from magfem.field.axisymmetric import AxisymmetricSource, solve_axisymmetric
from magfem.field.model import SourceField
from magfem.field.spec import (
    BlockMagnetSpec,
    CoilPairSpec,
    CoilSpec,
    CylinderMagnetSpec,
    SolveSpec,
    SourceSpec,
    frame,
)
from magfem.geometry.sources import RectRegion

__all__ = ["coil_current", "solve_source", "source_frame_box"]


def coil_current(spec: CoilSpec) -> float:
    """Nominal current of a coil / pair, A: ``current`` or the one giving ``flux_density``.

    ``flux_density`` is the on-axis field at the centre (closed form).
    """
    if spec.current is not None:
        return spec.current
    assert spec.flux_density is not None  # validated: exactly one of the two
    per_amp = 0.0
    offsets = [0.0]
    if isinstance(spec, CoilPairSpec):
        offsets = [-spec.separation / 2, spec.separation / 2]
    for dz in offsets:
        per_amp += float(
            thick_coil_on_axis(
                spec.inner_radius, spec.outer_radius, spec.length, spec.turns, 1.0, np.array(dz)
            )
        )
    return spec.flux_density / per_amp


def source_frame_box(box: np.ndarray, center: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(r, z) box [[0, z_min], [r_max, z_max]] in a source frame covering a 3D box (2, 3)."""
    lo, hi = np.asarray(box, dtype=float)
    corners = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    loc = (corners - center) @ frame(axis)
    r = np.hypot(loc[:, 0], loc[:, 1])
    return np.array([[0.0, loc[:, 2].min()], [r.max(), loc[:, 2].max()]])


def _regions(spec: SourceSpec) -> tuple[list[AxisymmetricSource], float]:
    """Axisymmetric regions of a coil / pair / cylinder and the nominal current (A, or 0)."""
    if isinstance(spec, CoilSpec):
        current = coil_current(spec)
        J = spec.turns * current / ((spec.outer_radius - spec.inner_radius) * spec.length)
        centres = [(0.0, 1.0)]
        if isinstance(spec, CoilPairSpec):
            sign = 1.0 if spec.polarity == "same" else -1.0
            centres = [(-spec.separation / 2, 1.0), (spec.separation / 2, sign)]
        out = [
            AxisymmetricSource(
                RectRegion(
                    f"coil_{k + 1}",
                    spec.inner_radius,
                    spec.outer_radius,
                    zc - spec.length / 2,
                    zc + spec.length / 2,
                ),
                current_density=s * J,
            )
            for k, (zc, s) in enumerate(centres)
        ]
        return out, current
    if isinstance(spec, CylinderMagnetSpec):
        reg = RectRegion("magnet", 0.0, spec.radius, -spec.length / 2, spec.length / 2)
        return [AxisymmetricSource(reg, magnetization=spec.remanence / (4e-7 * math.pi))], 0.0
    raise TypeError(f"source kind {spec.kind} is not axisymmetric")


def solve_source(
    spec: SourceSpec,
    solve: SolveSpec,
    comm: MPI.Comm,
    *,
    workspace: np.ndarray | None = None,
    name: str = "source",
) -> tuple[SourceField, float | None]:
    """FE field of one non-uniform source at nominal strength (collective).

    Args:
        spec: a coil, coil pair, cylinder or block magnet table.
        solve: FE settings.
        comm: communicator.
        workspace: robot workspace box (2, 3), m (refined; sets default sizes).
        name: label.

    Returns:
        (field, nominal current in A for coils, else None).
    """
    placed: Any = spec  # every non-uniform kind has center and axis
    center = np.array(placed.center, dtype=float)
    axis = np.asarray(placed.unit_axis)
    ws = 20e-3
    if workspace is not None:
        ws = float(np.max(workspace[1] - workspace[0]))
    hessian_step = solve.hessian_step or ws / 10
    if isinstance(spec, BlockMagnetSpec):
        from magfem.field.solid import solve_block_magnets

        return solve_block_magnets([spec], solve, comm, workspace=workspace, name=name), None
    regions, current = _regions(spec)
    s = max(math.hypot(g.region.r1, max(abs(g.region.z0), abs(g.region.z1))) for g in regions)
    r_air = solve.air_factor * s
    box_rz = None
    if workspace is not None:
        box_rz = source_frame_box(workspace, center, axis)
        reach = float(np.max(np.linalg.norm(box_rz, axis=1)))
        r_air = max(r_air, 2.0 * reach)
    field = solve_axisymmetric(
        regions,
        comm,
        degree=solve.degree,
        h_source=solve.mesh_size or s / 15,
        r_air=r_air,
        center=center,
        axis=axis,
        workspace=box_rz,
        h_workspace=solve.workspace_mesh_size or ws / 10,
        hessian_step=hessian_step,
        open_boundary=solve.open_boundary,
        name=name,
    )
    return field, (current if isinstance(spec, CoilSpec) else None)
