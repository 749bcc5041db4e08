"""Field output: VTX for ParaView, a sampled 3D grid (.vti), CSV of B and ∇B, a pyvista PNG.

All functions are collective (the FE fields are evaluated collectively);
only rank 0 writes CSV/PNG/VTI files. Fields are written at nominal
strength (every waveform = 1): the applied field at time t is the sum of
the sources times their waveform values.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from magfem.field.model import SourceField
from magfem.field.spec import (
    BlockMagnetSpec,
    CoilSpec,
    CylinderMagnetSpec,
    FieldSpec,
    coil_centers,
    frame,
)

__all__ = [
    "plot_field",
    "plot_plane",
    "sample",
    "write_csv",
    "write_grid",
    "write_vtx",
]


def sample(sources: Sequence[SourceField], points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Σ over sources of B (N, 3), T, and ∇B (N, 3, 3), T/m, at ``points`` (N, 3) (collective)."""
    pts = np.atleast_2d(points).reshape(-1, 3)
    B = np.zeros((len(pts), 3))
    G = np.zeros((len(pts), 3, 3))
    for s in sources:
        B += s.flux_density(pts)
        G += s.gradient(pts)
    return B, G


def _superpose(sources: Sequence[SourceField], pts: np.ndarray, comm: MPI.Comm) -> np.ndarray:
    """Σ B on rank 0's ``pts`` (N, 3) (NaN where a source's air region ends); others get (0, 3)."""
    mine = pts if comm.rank == 0 else np.zeros((0, 3))
    B = np.zeros((len(mine), 3))
    for src in sources:
        ok = src.covers(mine)
        B[ok] += src.flux_density(mine[ok])
        B[~ok] = np.nan
    return B


def write_csv(path: Path, points: np.ndarray, B: np.ndarray, G: np.ndarray, comm: MPI.Comm) -> Path:
    """CSV with x, y, z (m), Bx, By, Bz, |B| (T) and dBi/dxj (T/m); rank 0 writes its rows."""
    if comm.rank == 0:
        names = ["x", "y", "z", "Bx", "By", "Bz", "Bnorm"]
        names += [f"dB{a}_d{b}" for a in "xyz" for b in "xyz"]
        data = np.column_stack([points, B, np.linalg.norm(B, axis=1), G.reshape(len(points), 9)])
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.9e")
    return path


def write_vtx(fields: Sequence[SourceField], outdir: Path) -> list[Path]:
    """One VTX (BP4) file per FE source with its potential and recovered B, ∇B (collective).

    Axisymmetric sources are written on their (r, z) mesh (x = r, y = z);
    3D sources on their 3D mesh. ParaView >= 5.10 reads BP4.
    """
    from dolfinx.io import VTXWriter

    from magfem.field.axisymmetric import AxisymmetricField
    from magfem.field.solid import SolidField

    out = []
    for f in fields:
        if isinstance(f, AxisymmetricField):
            funcs = [f.A, *f.B, *f.dB]
        elif isinstance(f, SolidField):
            funcs = [f.phi, *f.H, *f.dH]
        else:
            continue
        path = outdir / f"{f.name}.bp"
        with VTXWriter(funcs[0].function_space.mesh.comm, path, funcs, engine="BP4") as w:
            w.write(0.0)
        out.append(path)
    return out


def _extent(spec: FieldSpec) -> tuple[np.ndarray, float]:
    """Centre (3,) and half-width (m) of a view containing all sources and the workspace."""
    pts = [np.asarray(spec.expansion_point, dtype=float)]
    radii = [spec.workspace_size]
    for s in spec.sources:
        if isinstance(s, CoilSpec):
            for c, _ in coil_centers(s):
                pts.append(c)
                radii.append(float(np.hypot(s.outer_radius, s.length / 2)))
        elif isinstance(s, CylinderMagnetSpec | BlockMagnetSpec):
            pts.append(np.asarray(s.center, dtype=float))
            size = (
                np.hypot(s.radius, s.length / 2)
                if isinstance(s, CylinderMagnetSpec)
                else 0.5 * np.linalg.norm(s.size)
            )
            radii.append(float(size))
    P = np.array(pts)
    lo = np.min(P - np.array(radii)[:, None], axis=0)
    hi = np.max(P + np.array(radii)[:, None], axis=0)
    return 0.5 * (lo + hi), 0.6 * float(np.max(hi - lo))


def _view_plane(spec: FieldSpec) -> tuple[np.ndarray, np.ndarray]:
    """Unit in-plane axes (u, v) of the figure.

    v = the first placed source's axis (default z); u ⊥ v points to the first other
    source centre off that axis (so both appear in the plane), else x (or y).
    """
    v = np.array([0.0, 0.0, 1.0])
    placed: list[Any] = [s for s in spec.sources if hasattr(s, "unit_axis")]
    if placed:
        v = placed[0].unit_axis
    u = np.array([1.0, 0.0, 0.0]) if abs(v[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    if placed:
        c0 = np.asarray(placed[0].center, dtype=float)
        for s in placed[1:]:
            d = np.asarray(s.center, dtype=float) - c0
            d -= (d @ v) * v
            if np.linalg.norm(d) > 1e-9:
                u = d / np.linalg.norm(d)
                break
    u = u - (u @ v) * v
    return u / np.linalg.norm(u), v


def plot_plane(
    spec: FieldSpec, n: int = 161
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Grid of the figure plane: centre (3,), axes u, v (3,), coordinates s (n,) in m."""
    c, half = _extent(spec)
    u, v = _view_plane(spec)
    c = c - ((c - np.asarray(spec.expansion_point)) @ np.cross(u, v)) * np.cross(u, v)
    return c, u, v, np.linspace(-half, half, n)


def plot_field(
    spec: FieldSpec,
    sources: Sequence[SourceField],
    path: Path,
    comm: MPI.Comm,
    *,
    robot: np.ndarray | None = None,
    n: int = 161,
) -> Path:
    """PNG of |B| (log colour scale) with field lines in the plane through the sources' axis.

    Args:
        spec: field table (source outlines, workspace, view plane).
        sources: solved fields at nominal strength.
        path: PNG path (rank 0 writes it).
        comm: communicator (collective: the field is evaluated on all ranks).
        robot: robot position, a box (2, 3) or points (N, 3), m, drawn as an outline
            (default: the workspace cube).
        n: grid points per direction.
    """
    c, u, v, s = plot_plane(spec, n)
    S, T = np.meshgrid(s, s, indexing="ij")
    pts = c + S.reshape(-1, 1) * u + T.reshape(-1, 1) * v
    inside = _inside_sources(spec, pts)
    B = _superpose(sources, pts, comm)
    if comm.rank != 0:
        return path
    import pyvista

    pyvista.OFF_SCREEN = True
    nb = np.linalg.norm(B, axis=1)
    nb[inside] = np.nan
    mm = 1e3  # plot coordinates in mm
    grid = pyvista.ImageData(
        dimensions=(n, n, 1),
        spacing=(mm * (s[1] - s[0]),) * 2 + (1.0,),
        origin=(mm * s[0], mm * s[0], 0.0),
    )
    # ImageData orders points x fastest: (i, j) -> i + n j with x = s_i along u, y = s_j along v
    order = np.arange(n * n).reshape(n, n).T.ravel()
    bu, bv = B @ u, B @ v
    bu[inside], bv[inside] = 0.0, 0.0
    grid.point_data["|B| (mT)"] = 1e3 * nb[order]
    grid.point_data["B"] = np.column_stack([bu[order], bv[order], np.zeros(n * n)])
    seeds = pyvista.PolyData(
        mm
        * np.column_stack([np.linspace(s[2], s[-3], 24), np.full(24, s[n // 2 + 3]), np.zeros(24)])
    )
    seeds = seeds.merge(
        pyvista.PolyData(
            mm
            * np.column_stack(
                [np.full(16, s[n // 2 + 3]), np.linspace(s[2], s[-3], 16), np.zeros(16)]
            )
        )
    )
    lines = grid.streamlines_from_source(
        seeds, vectors="B", max_steps=4000, initial_step_length=0.2
    )
    p: Any = pyvista.Plotter(off_screen=True, window_size=[1000, 900])
    vals = grid.point_data["|B| (mT)"]
    finite = vals[np.isfinite(vals)]
    clim = (max(float(np.percentile(finite, 2)), 1e-6), float(np.percentile(finite, 99)))
    p.add_mesh(
        grid, scalars="|B| (mT)", log_scale=True, clim=clim, cmap="viridis", nan_color="lightgray"
    )
    if lines.n_points:
        p.add_mesh(lines, color="white", line_width=1.5)
    for outline in _outlines(spec, c, u, v, robot):
        p.add_mesh(
            outline,
            color="red" if outline.field_data.get("robot") is not None else "black",
            line_width=3,
        )
    p.view_xy()
    p.add_text(
        f"|B| (mT) at nominal strength, plane through {np.round(1e3 * c, 1)} mm; "
        f"horizontal {np.round(u, 3)}, vertical {np.round(v, 3)}; red: robot",
        font_size=9,
    )
    p.show_bounds(xtitle="u (mm)", ytitle="v (mm)", font_size=9, fmt="%.0f")
    path.parent.mkdir(parents=True, exist_ok=True)
    p.screenshot(str(path))
    p.close()
    return path


def _inside_sources(spec: FieldSpec, pts: np.ndarray) -> np.ndarray:
    """Mask of points inside windings or magnets (the recovered field is not meant there)."""
    from magfem.field.spec import inside_winding

    mask = np.zeros(len(pts), dtype=bool)
    for s in spec.sources:
        if isinstance(s, CoilSpec):
            mask |= inside_winding(s, pts)
        elif isinstance(s, CylinderMagnetSpec):
            d = pts - np.asarray(s.center)
            z = d @ s.unit_axis
            r = np.linalg.norm(d - np.outer(z, s.unit_axis), axis=1)
            mask |= (np.abs(z) <= s.length / 2) & (r <= s.radius)
        elif isinstance(s, BlockMagnetSpec):
            loc = (pts - np.asarray(s.center)) @ frame(s.unit_axis, s.roll)
            mask |= np.all(np.abs(loc) <= np.asarray(s.size) / 2, axis=1)
    return mask


def _outlines(
    spec: FieldSpec, c: np.ndarray, u: np.ndarray, v: np.ndarray, robot: np.ndarray | None
) -> list[Any]:
    """Polylines (in plot coordinates) of the source cross-sections and the robot box."""
    import pyvista

    def poly(corners3d: np.ndarray, tag: str | None = None) -> Any:
        d = corners3d - c
        xy = 1e3 * np.column_stack([d @ u, d @ v, np.zeros(len(d))])
        line = pyvista.lines_from_points(np.vstack([xy, xy[:1]]))
        if tag:
            line.field_data[tag] = [1]
        return line

    out = []
    q: list[Any]
    for s in spec.sources:
        if isinstance(s, CoilSpec):
            for cc, _ in coil_centers(s):
                for side in (-1, 1):
                    r0, r1, h = s.inner_radius, s.outer_radius, s.length / 2
                    radial = _radial(u, v, s.unit_axis) * side
                    q = [
                        cc + radial * r + s.unit_axis * z
                        for r, z in ((r0, -h), (r1, -h), (r1, h), (r0, h))
                    ]
                    out.append(poly(np.array(q)))
        elif isinstance(s, CylinderMagnetSpec):
            radial = _radial(u, v, s.unit_axis)
            h, R = s.length / 2, s.radius
            cc = np.asarray(s.center)
            q = [cc + radial * r + s.unit_axis * z for r, z in ((-R, -h), (R, -h), (R, h), (-R, h))]
            out.append(poly(np.array(q)))
        elif isinstance(s, BlockMagnetSpec):
            Rm = frame(s.unit_axis, s.roll)
            hs = np.asarray(s.size) / 2
            corners = np.array(
                [[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)]
            ) * hs @ Rm.T + np.asarray(s.center)
            d = corners - c
            a, b = d @ u, d @ v
            q = [
                [a.min(), b.min()],
                [a.max(), b.min()],
                [a.max(), b.max()],
                [a.min(), b.max()],
            ]
            out.append(poly(np.array([c + x * u + y * v for x, y in q])))
    box = robot
    if box is None:
        h = spec.workspace_size / 2
        x0 = np.asarray(spec.expansion_point)
        box = np.array([x0 - h, x0 + h])
    pts = np.atleast_2d(box)
    if pts.shape == (2, 3):
        pts = np.array([[x, y, z] for x in pts[:, 0] for y in pts[:, 1] for z in pts[:, 2]])
    d = pts - c
    a, b = d @ u, d @ v
    q = [[a.min(), b.min()], [a.max(), b.min()], [a.max(), b.max()], [a.min(), b.max()]]
    out.append(poly(np.array([c + x * u + y * v for x, y in q]), "robot"))
    return out


def _radial(u: np.ndarray, v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Unit vector in the figure plane perpendicular to ``axis`` (for source cross-sections)."""
    w = u - (u @ axis) * axis
    if np.linalg.norm(w) < 1e-9:
        w = v - (v @ axis) * axis
    return w / np.linalg.norm(w)


def write_grid(
    spec: FieldSpec, sources: Sequence[SourceField], path: Path, comm: MPI.Comm, n: int = 41
) -> Path:
    """The superposed B (and |B|) sampled on an n³ grid around the sources, as a .vti (ParaView)."""
    c, half = _extent(spec)
    s = np.linspace(-half, half, n)
    X, Y, Zg = np.meshgrid(s, s, s, indexing="ij")
    # ImageData: x fastest
    pts = c + np.column_stack(
        [X.transpose(2, 1, 0).ravel(), Y.transpose(2, 1, 0).ravel(), Zg.transpose(2, 1, 0).ravel()]
    )
    inside = _inside_sources(spec, pts)
    B = _superpose(sources, pts, comm)
    if comm.rank == 0:
        import pyvista

        B[inside] = np.nan
        grid = pyvista.ImageData(
            dimensions=(n, n, n), spacing=(s[1] - s[0],) * 3, origin=tuple(c - half)
        )
        grid.point_data["B"] = B
        grid.point_data["|B|"] = np.linalg.norm(B, axis=1)
        path.parent.mkdir(parents=True, exist_ok=True)
        grid.save(str(path))
    return path
