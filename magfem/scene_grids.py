"""The bodies of a case's scene as pyvista grids: field sources, iron parts, obstacles, the cargo.

Every body is drawn where it is at t = 0; a body that moves (a source or
iron part on a ``[[field.motions]]`` entry, an obstacle with a ``motion``, a
cargo's ``floor_motion``) also gets a faint copy at the instant of its path
farthest from its start (the keyframe, or the end time, where its points
have moved most), so a picture shows where it goes. Obstacles without an
end are cut to a size around the robot: a half-space is a square patch of
3 × the robot's extent about the robot's foot on the plane, a cylinder is
3 extents long about the robot's foot on its axis, a cone runs from its
apex to one extent past the robot's centre along the axis.

Pure geometry (numpy and pyvista, no MPI): :mod:`magfem.plot` draws the
items on rank 0.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pyvista

from magfem.field.build import trajectory
from magfem.field.placement import frame
from magfem.geometry.sources import Ball, Box, Frustum
from magfem.mechanics.contacts.cargo import CargoSpec
from magfem.mechanics.contacts.obstacle import ObstacleSpec
from magfem.mechanics.contacts.rigid import MotionSpec, box_frame

__all__ = [
    "FAINT",
    "MeshItem",
    "Region",
    "cargo_grids",
    "contact_items",
    "extreme_time",
    "moved_copy",
    "obstacle_grid",
    "source_grids",
    "source_items",
]

Points = npt.NDArray[np.float64]
Mover = Callable[[float, Points], Points]
"""(t, reference points (N, 3)) -> placed points (N, 3), m."""

FAINT = 0.12
"""Opacity of a moving body's copy at the far end of its path."""
_OBSTACLE, _CARGO, _FLOOR = "#2ca02c", "#e6a700", "#8c564b"


class MeshItem(NamedTuple):
    """One dataset to draw: a pyvista grid and how to show it."""

    grid: Any
    label: str = ""
    color: str | None = None
    scalars: str | None = None  # cell-data name coloured categorically
    opacity: float = 1.0
    show_edges: bool = True


class Region(NamedTuple):
    """Where the robot is: the centre (3,) and extent (the bounding-box diagonal) of it, m."""

    center: Points
    extent: float

    @classmethod
    def of_bounds(cls, bounds: Sequence[float]) -> Region:
        """From pyvista bounds (xmin, xmax, ymin, ymax, zmin, zmax)."""
        b = np.asarray(bounds, dtype=float).reshape(3, 2)
        return cls(b.mean(axis=1), float(np.linalg.norm(b[:, 1] - b[:, 0])))


def _unit(v: Sequence[float]) -> Points:
    a = np.asarray(v, dtype=float)
    return a / np.linalg.norm(a)


def _solid_grid(part: Any) -> Any:
    """A pyvista surface of one gmsh primitive of :mod:`magfem.geometry.sources`."""
    if isinstance(part, Ball):
        return pyvista.Sphere(radius=part.radius, center=part.center)
    if isinstance(part, Box):
        a, b, c = (0.5 * v for v in part.size)
        box = pyvista.Box(bounds=(-a, a, -b, b, -c, c))
        box.points = box.points @ np.asarray(part.rotation).T + np.asarray(part.center)
        return box
    if isinstance(part, Frustum):
        base, vec = np.asarray(part.base), np.asarray(part.vector)
        R = frame(vec / np.linalg.norm(vec))
        phi = np.linspace(0, 2 * np.pi, 48, endpoint=False)
        ring = np.column_stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)]) @ R.T
        pts = np.vstack([base + max(part.r0, 1e-9) * ring, base + vec + max(part.r1, 1e-9) * ring])
    else:
        pts = np.asarray(part.corners)
    return pyvista.PolyData(pts).delaunay_3d().extract_surface(algorithm="dataset_surface")


def source_grids(sources: Sequence[Any], iron: Sequence[Any] = ()) -> list[MeshItem]:
    """Solid pictures of the field sources and iron parts of a ``[field]`` table (no MPI).

    Coils and coil pairs are drawn as annular cylinders (their winding
    cross-section), cylinder magnets as cylinders, block magnets as boxes,
    each placed by its ``center`` and ``axis``; iron parts (steel blue) by
    their shapes. Uniform sources have no body. All in the case's placement.
    """
    items: list[MeshItem] = []
    for i, src in enumerate(sources):
        for grid, label, color, opacity in _source_parts(i, src):
            items.append(MeshItem(grid, label, color, opacity=opacity, show_edges=False))
    for k, part in enumerate(iron):
        grid = pyvista.merge([_solid_grid(p) for p in part.body(f"iron_{k + 1}").parts])
        items.append(MeshItem(grid, f"iron {k} ({part.kind})", "#4682b4", show_edges=False))
    return items


def _source_parts(i: int, src: Any) -> list[tuple[Any, str, str, float]]:
    """(grid, label, colour, opacity) of the bodies of source ``i`` (none if uniform)."""
    if src.kind == "uniform":
        return []
    center, axis = np.asarray(src.center, dtype=float), np.asarray(src.unit_axis)
    if src.kind in ("coil", "coil_pair"):
        offsets = [0.0] if src.kind == "coil" else [-src.separation / 2, src.separation / 2]
        return [
            (
                pyvista.CylinderStructured(
                    radius=np.linspace(src.inner_radius, src.outer_radius, 2),
                    height=src.length,
                    center=center + off * axis,
                    direction=axis,
                    theta_resolution=64,
                    z_resolution=2,
                ),
                f"{src.kind} {i} winding {k + 1}",
                "#b87333",
                0.35,
            )
            for k, off in enumerate(offsets)
        ]
    if src.kind == "racetrack_coil":
        return [(_racetrack_grid(src), f"racetrack coil {i}", "#b87333", 0.35)]
    if src.kind == "cylinder_magnet":
        grid = pyvista.Cylinder(
            center=center, direction=axis, radius=src.radius, height=src.length, resolution=64
        )
        return [(grid, f"magnet {i}", "#708090", 1.0)]
    rot = tuple(map(tuple, frame(axis, src.roll)))  # block_magnet
    return [
        (_solid_grid(Box(tuple(src.center), tuple(src.size), rot)), f"magnet {i}", "#708090", 1.0)
    ]


def _racetrack_grid(src: Any) -> Any:
    """Structured grid of a racetrack coil's winding (inner and outer outline, two ends)."""
    cx, cy = src.half_sides
    phi = np.linspace(0.0, 0.5 * np.pi, 17)
    corners = ((cx, cy), (-cx, cy), (-cx, -cy), (cx, -cy))
    f = np.concatenate([phi + 0.5 * np.pi * k for k in range(4)])
    ox = np.repeat([c[0] for c in corners], len(phi))
    oy = np.repeat([c[1] for c in corners], len(phi))
    pts = np.zeros((2, len(f), 2, 3))
    for a, s in enumerate((src.inner_radius, src.inner_radius + src.thickness)):
        for b, z in enumerate((-src.length / 2, src.length / 2)):
            pts[a, :, b] = np.column_stack(
                [ox + s * np.cos(f), oy + s * np.sin(f), np.full_like(f, z)]
            )
    world = np.asarray(src.center) + pts @ frame(np.asarray(src.unit_axis), src.roll).T
    return pyvista.StructuredGrid(world[..., 0], world[..., 1], world[..., 2])


def extreme_time(move: Mover, points: Points, times: Sequence[float], end: float) -> float | None:
    """The instant in ``times`` ∪ {end}, within [0, end], where ``points`` are farthest from t = 0.

    Returns None when nothing moves (by more than 1e-9 of the points' extent).
    """
    start = move(0.0, points)
    scale = float(np.ptp(start, axis=0).max()) if len(start) else 0.0
    candidates = sorted({*(t for t in times if 0.0 < t <= end), end} - {0.0})
    best, far = None, 1e-9 * max(scale, 1e-9)
    for t in candidates:
        shift = float(np.linalg.norm(move(t, points) - start, axis=1).max())
        if shift > far:
            best, far = t, shift
    return best


def moved_copy(item: MeshItem, move: Mover, t: float, *, opacity: float = FAINT) -> MeshItem:
    """A faint copy of ``item`` (drawn in its reference placement) placed at time ``t``."""
    grid = item.grid.copy()
    grid.points = move(t, np.asarray(item.grid.points, dtype=float))
    return item._replace(grid=grid, label=f"{item.label} at {1e3 * t:.4g} ms", opacity=opacity)


def _placed(
    item: MeshItem, move: Mover | None, times: Sequence[float], end: float
) -> list[MeshItem]:
    """``item`` at t = 0 and, if it moves, its faint copy at the far end of its path."""
    if move is None:
        return [item]
    pts = np.asarray(item.grid.points, dtype=float)
    first = moved_copy(item, move, 0.0, opacity=item.opacity)._replace(label=item.label)
    far = extreme_time(move, pts, times, end)
    return [first] if far is None else [first, moved_copy(item, move, far)]


def _field_mover(motion: Any) -> Mover:
    traj = trajectory(motion)
    assert traj is not None
    return lambda t, pts: traj.placement(t).apply(pts)


def source_items(field: Any, end: float | None = None) -> list[MeshItem]:
    """The sources and iron parts of ``field`` at t = 0, and where each moving one goes.

    ``end``: the run's end time (s); default the last keyframe of the field's motions.
    """
    last = max((m.times[-1] for m in field.motions), default=0.0)
    end = last if end is None else end
    out: list[MeshItem] = []
    parts = [*field.sources, *field.iron]
    items = source_grids(field.sources, field.iron)
    per_part = [len(_source_parts(i, s)) for i, s in enumerate(field.sources)] + [1] * len(
        field.iron
    )
    k = 0
    for part, count in zip(parts, per_part, strict=True):
        motion = field.motion(getattr(part, "motion", ""))
        move = None if motion is None else _field_mover(motion)
        times = () if motion is None else motion.times
        for item in items[k : k + count]:
            out += _placed(item, move, times, end)
        k += count
    return out


def _motion_mover(motion: MotionSpec) -> Mover:
    def move(t: float, pts: Points) -> Points:
        p = motion.placement(t)
        return (pts - p.pivot) @ p.R.T + p.pivot + p.offset

    return move


def _fan(apex: Points, ring: Points) -> Any:
    """A cone's mantle: triangles from ``apex`` (3,) to the closed polygon ``ring`` (N, 3)."""
    n = len(ring)
    faces = np.column_stack(
        [np.full(n, 3), np.zeros(n), 1 + np.arange(n), 1 + (np.arange(n) + 1) % n]
    )
    return pyvista.PolyData(np.vstack([apex, ring]), faces.astype(np.int64).ravel())


def obstacle_grid(spec: ObstacleSpec, around: Region) -> Any:
    """An obstacle's surface in its table's placement (m); unbounded shapes cut to ``around``."""
    size = 3.0 * around.extent
    if spec.shape == "sphere":
        assert spec.center is not None and spec.radius is not None
        return pyvista.Sphere(
            radius=spec.radius, center=spec.center, theta_resolution=48, phi_resolution=24
        )
    if spec.shape == "box":
        assert spec.center is not None and spec.size is not None
        rot = tuple(map(tuple, box_frame(spec, 3)))
        return _solid_grid(Box(tuple(spec.center), tuple(spec.size), rot))
    if spec.shape == "half_space":
        assert spec.point is not None and spec.normal is not None
        n, p = _unit(spec.normal), np.asarray(spec.point, dtype=float)
        foot = around.center - ((around.center - p) @ n) * n
        return pyvista.Plane(center=foot, direction=n, i_size=size, j_size=size)
    assert spec.axis is not None
    a = _unit(spec.axis)
    if spec.shape == "cylinder":
        assert spec.point is not None and spec.radius is not None
        p = np.asarray(spec.point, dtype=float)
        foot = p + ((around.center - p) @ a) * a
        return pyvista.Cylinder(
            center=foot, direction=a, radius=spec.radius, height=size, resolution=64, capping=False
        )
    assert spec.apex is not None and spec.half_angle is not None
    apex = np.asarray(spec.apex, dtype=float)
    length = max((around.center - apex) @ a + around.extent, around.extent)
    R = frame(a)
    phi = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    ring = np.column_stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)]) @ R.T
    return _fan(apex, apex + length * a + length * np.tan(spec.half_angle) * ring)


def cargo_grids(spec: CargoSpec) -> list[MeshItem]:
    """The cargo at its start and its floor (a square of 3 × the cargo's size under it)."""
    if spec.shape == "box":
        assert spec.size is not None
        rot = tuple(map(tuple, box_frame(spec, 3)))
        body = _solid_grid(Box(tuple(spec.center), tuple(spec.size), rot))
        span = float(max(spec.size))
    else:
        assert spec.radius is not None
        body = pyvista.Sphere(radius=spec.radius, center=spec.center)
        span = 2.0 * spec.radius
    items = [MeshItem(body, f"cargo {spec.name}", _CARGO, opacity=0.6, show_edges=False)]
    if spec.floor is not None:
        c = np.asarray(spec.center, dtype=float)
        plane = pyvista.Plane(
            center=(c[0], c[1], spec.floor), direction=(0, 0, 1), i_size=3 * span, j_size=3 * span
        )
        items.append(
            MeshItem(plane, f"floor of {spec.name}", _FLOOR, opacity=0.35, show_edges=False)
        )
    return items


def contact_items(contacts: Sequence[Any], around: Region, end: float) -> list[MeshItem]:
    """The obstacles and cargos at t = 0, and where the moving ones are by ``end`` (s)."""
    out: list[MeshItem] = []
    for spec in contacts:
        if isinstance(spec, ObstacleSpec):
            item = MeshItem(
                obstacle_grid(spec, around),
                f"obstacle {spec.name} ({spec.side})",
                _OBSTACLE,
                opacity=0.3,
                show_edges=False,
            )
            move = None if spec.motion is None else _motion_mover(spec.motion)
            times = () if spec.motion is None else spec.motion.times
            out += _placed(item, move, times, end)
        elif isinstance(spec, CargoSpec):
            body, *floor = cargo_grids(spec)
            out.append(body)
            fm = spec.floor_motion
            for item in floor:
                out += _placed(
                    item,
                    None if fm is None else _motion_mover(fm),
                    () if fm is None else fm.times,
                    end,
                )
    return out
