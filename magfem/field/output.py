"""Field output: VTX of iron solves, a sampled 3D grid (.vti), CSV of B and ∇B, a pyvista PNG.

All functions are collective (iron reactions are evaluated collectively);
only rank 0 writes CSV/PNG/VTI files. Values are at nominal strength (every
waveform = 1), with the sources placed as at time ``t``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyvista
from dolfinx.io import VTXWriter
from mpi4py import MPI

from magfem.field.build import Term
from magfem.field.models import term_values
from magfem.field.reaction import ReactionField
from magfem.field.source import SourceField, SumField
from magfem.field.spec import FieldSpec

__all__ = [
    "CSV_COLUMNS",
    "inside_mask",
    "plot_field",
    "plot_plane",
    "reactions",
    "sample",
    "write_csv",
    "write_grid",
    "write_vtx",
]

CSV_COLUMNS = ["x", "y", "z", "Bx", "By", "Bz", "Bnorm"] + [
    f"dB{a}_d{b}" for a in "xyz" for b in "xyz"
]


def sample(
    terms: Sequence[Term], points: np.ndarray, t: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Σ over terms of B (N, 3), T, and ∇B (N, 3, 3), T/m, at ``points`` (N, 3), time t."""
    pts = np.atleast_2d(points).reshape(-1, 3)
    B, G = np.zeros((len(pts), 3)), np.zeros((len(pts), 3, 3))
    for term in terms:
        b, g = term_values(term, pts, t)
        B, G = B + b, G + g
    return B, G


def inside_mask(terms: Sequence[Term], pts: np.ndarray, t: float) -> np.ndarray:
    """Mask of points inside a winding, magnet or iron part at time t."""
    mask = np.zeros(len(pts), dtype=bool)
    for term in terms:
        ref = pts if term.trajectory is None else term.trajectory.placement(t).to_reference(pts)
        mask |= term.field.inside(ref)
    return mask


def write_csv(path: Path, points: np.ndarray, B: np.ndarray, G: np.ndarray, comm: MPI.Comm) -> Path:
    """CSV with x, y, z (m), Bx, By, Bz, |B| (T) and dBi/dxj (T/m); rank 0 writes its rows."""
    if comm.rank == 0:
        data = np.column_stack([points, B, np.linalg.norm(B, axis=1), G.reshape(len(points), 9)])
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savetxt(path, data, delimiter=",", header=",".join(CSV_COLUMNS), comments="", fmt="%.9e")
    return path


def reactions(terms: Sequence[Term]) -> list[ReactionField]:
    """The iron reaction fields among the terms."""
    out: list[ReactionField] = []

    def visit(f: SourceField) -> None:
        if isinstance(f, ReactionField):
            out.append(f)
        elif isinstance(f, SumField):
            for g in f.fields:
                visit(g)

    for term in terms:
        visit(term.field)
    return out


def write_vtx(terms: Sequence[Term], outdir: Path) -> list[Path]:
    """One VTX (BP4) file per iron reaction: recovered air B, ∇B and the iron's B (collective).

    Axisymmetric solves are written on their (r, z) mesh (x = r, y = z).
    """
    out = []
    for k, r in enumerate(reactions(terms)):
        path = outdir / f"iron_reaction{k}.bp"
        with VTXWriter(r.mesh.comm, path, [r.recovered], engine="BP4") as w:
            w.write(0.0)
        out.append(path)
    return out


def _extent(spec: FieldSpec) -> tuple[np.ndarray, float]:
    """Centre (3,) and half-width (m) of a view containing the sources, iron and workspace."""
    pts = [
        np.asarray(spec.expansion_point, dtype=float) + spec.workspace_size / 2 * s
        for s in (-np.ones(3), np.ones(3))
    ]
    for s in spec.sources:
        if hasattr(s, "center"):
            pts.append(_source_corners(s))
    for p in spec.iron:
        pts.append(p.sample_points())
    P = np.vstack(pts)
    lo, hi = P.min(axis=0), P.max(axis=0)
    return 0.5 * (lo + hi), 0.6 * float(np.max(hi - lo))


def _source_corners(s: Any) -> np.ndarray:
    """Corners (4, 3) of a box holding a placed source (conservative), m."""
    c = np.asarray(s.center, dtype=float)
    if hasattr(s, "size"):
        r = h = 0.5 * float(np.linalg.norm(s.size))
    elif hasattr(s, "inner_size"):  # racetrack coil: the outer corners of its winding
        r = float(np.hypot(*(np.asarray(s.inner_size) / 2 + s.thickness)))
        h = s.length / 2
    else:
        r = float(getattr(s, "outer_radius", 0.0) or s.radius)
        h = getattr(s, "separation", 0.0) / 2 + s.length / 2
    ends = np.array([c + s.unit_axis * h, c - s.unit_axis * h])
    return np.vstack([ends - r, ends + r])


def _view_plane(spec: FieldSpec) -> tuple[np.ndarray, np.ndarray]:
    """Unit in-plane axes (u, v): v along the first placed source or iron axis (default z);
    u ⊥ v towards the first other centre off that axis, else x (or y)."""
    parts: list[tuple[np.ndarray, np.ndarray | None]] = []
    placed: list[Any] = [s for s in spec.sources if hasattr(s, "center")]
    for s in placed:
        parts.append((np.asarray(s.center, dtype=float), s.unit_axis))
    for p in spec.iron:
        ax = getattr(p, "axis", None)
        parts.append((p.tip_point(), None if ax is None else np.asarray(ax) / np.linalg.norm(ax)))
    v = next((a for _, a in parts if a is not None), np.array([0.0, 0.0, 1.0]))
    u = np.array([1.0, 0.0, 0.0]) if abs(v[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    if parts:
        c0 = parts[0][0]
        for c, _ in [*parts[1:], (np.asarray(spec.expansion_point, dtype=float), None)]:
            d = c - c0 - ((c - c0) @ v) * v
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
    w = np.cross(u, v)
    c = c - ((c - np.asarray(spec.expansion_point)) @ w) * w
    return c, u, v, np.linspace(-half, half, n)


def _superpose(terms: Sequence[Term], pts: np.ndarray, comm: MPI.Comm, t: float) -> np.ndarray:
    """Σ B on rank 0's ``pts`` (N, 3); other ranks get (0, 3) (collective)."""
    mine = pts if comm.rank == 0 else np.zeros((0, 3))
    return sample(terms, mine, t)[0]


def plot_field(
    spec: FieldSpec,
    terms: Sequence[Term],
    path: Path,
    comm: MPI.Comm,
    *,
    robot: np.ndarray | None = None,
    t: float = 0.0,
    n: int = 161,
) -> Path:
    """PNG of |B| (log colour scale) with field lines in the plane through the sources' axis.

    Sources and iron parts are grey with black outlines; the robot (a box (2, 3) or
    points (N, 3), m; default the workspace cube) is outlined in red. Collective.
    """
    c, u, v, s = plot_plane(spec, n)
    S, T = np.meshgrid(s, s, indexing="ij")
    pts = c + S.reshape(-1, 1) * u + T.reshape(-1, 1) * v
    B = _superpose(terms, pts, comm, t)
    if comm.rank != 0:
        return path
    inside = inside_mask(terms, pts, t)
    mm = 1e3
    grid = pyvista.ImageData(
        dimensions=(n, n, 1),
        spacing=(mm * (s[1] - s[0]),) * 2 + (1.0,),
        origin=(mm * s[0], mm * s[0], 0.0),
    )
    order = np.arange(n * n).reshape(n, n).T.ravel()  # ImageData: x (along u) fastest
    nb = np.linalg.norm(B, axis=1)
    nb[inside] = np.nan
    bu, bv = np.where(inside, 0.0, B @ u), np.where(inside, 0.0, B @ v)
    grid.point_data["|B| (mT)"] = 1e3 * nb[order]
    grid.point_data["B"] = np.column_stack([bu[order], bv[order], np.zeros(n * n)])
    grid.point_data["body"] = inside[order].astype(float)
    p: Any = pyvista.Plotter(off_screen=True, window_size=[1000, 900])
    vals = grid.point_data["|B| (mT)"]
    finite = vals[np.isfinite(vals)]
    clim = (max(float(np.percentile(finite, 2)), 1e-6), float(np.percentile(finite, 99)))
    p.add_mesh(
        grid, scalars="|B| (mT)", log_scale=True, clim=clim, cmap="viridis", nan_color="lightgray"
    )
    lines = grid.streamlines_from_source(
        _seeds(s, n, mm), vectors="B", max_steps=4000, initial_step_length=0.2
    )
    if lines.n_points:
        p.add_mesh(lines, color="white", line_width=1.5)
    outline = grid.contour([0.5], scalars="body")
    if outline.n_points:
        p.add_mesh(outline, color="black", line_width=2)
    p.add_mesh(_robot_outline(spec, c, u, v, robot), color="red", line_width=3)
    p.view_xy()
    p.add_text(
        f"|B| (mT) at nominal strength, t = {t * 1e3:g} ms, plane through "
        f"{np.round(1e3 * c, 1)} mm; horizontal {np.round(u, 3)}, vertical "
        f"{np.round(v, 3)}; red: robot",
        font_size=9,
    )
    p.show_bounds(xtitle="u (mm)", ytitle="v (mm)", font_size=9, fmt="%.0f")
    path.parent.mkdir(parents=True, exist_ok=True)
    p.screenshot(str(path))
    p.close()
    return path


def _seeds(s: np.ndarray, n: int, mm: float) -> Any:
    """Field-line seeds: a horizontal and a vertical row through the plot."""
    row = np.column_stack([np.linspace(s[2], s[-3], 24), np.full(24, s[n // 2 + 3]), np.zeros(24)])
    col = np.column_stack([np.full(16, s[n // 2 + 3]), np.linspace(s[2], s[-3], 16), np.zeros(16)])
    return pyvista.PolyData(mm * row).merge(pyvista.PolyData(mm * col))


def _robot_outline(
    spec: FieldSpec, c: np.ndarray, u: np.ndarray, v: np.ndarray, robot: np.ndarray | None
) -> Any:
    """Polyline (plot coordinates, mm) of the robot box projected on the plane."""
    box = robot
    if box is None:
        h = spec.workspace_size / 2
        x0 = np.asarray(spec.expansion_point, dtype=float)
        box = np.array([x0 - h, x0 + h])
    pts = np.atleast_2d(box)
    if pts.shape == (2, 3):
        pts = np.array([[x, y, z] for x in pts[:, 0] for y in pts[:, 1] for z in pts[:, 2]])
    a, b = (pts - c) @ u, (pts - c) @ v
    q = np.array([[a.min(), b.min()], [a.max(), b.min()], [a.max(), b.max()], [a.min(), b.max()]])
    xy = 1e3 * np.column_stack([q, np.zeros(4)])
    return pyvista.lines_from_points(np.vstack([xy, xy[:1]]))


def write_grid(
    spec: FieldSpec, terms: Sequence[Term], path: Path, comm: MPI.Comm, n: int = 41, t: float = 0.0
) -> Path:
    """The superposed B (and |B|) on an n³ grid around the sources, as a .vti (ParaView)."""
    c, half = _extent(spec)
    s = np.linspace(-half, half, n)
    X, Y, Zg = np.meshgrid(s, s, s, indexing="ij")
    pts = c + np.column_stack([a.transpose(2, 1, 0).ravel() for a in (X, Y, Zg)])  # x fastest
    B = _superpose(terms, pts, comm, t)
    if comm.rank == 0:
        B[inside_mask(terms, pts, t)] = np.nan
        grid = pyvista.ImageData(
            dimensions=(n, n, n), spacing=(s[1] - s[0],) * 3, origin=tuple(c - half)
        )
        grid.point_data["B"] = B
        grid.point_data["|B|"] = np.linalg.norm(B, axis=1)
        path.parent.mkdir(parents=True, exist_ok=True)
        grid.save(str(path))
    return path
