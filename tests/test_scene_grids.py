"""Scene pictures: every obstacle, cargo and moving source is drawn where the case puts it.

The grids are checked against the case numbers with plain numpy geometry: a
surface point of a sphere is at its radius from the centre, of a cylinder at
its radius from the axis, of a cone on the line ρ = s tan α from the apex,
of a plane at distance 0 from it, of a box at ±size/2 in the box's frame.
The grids' points are placed on the exact surfaces (polygons inscribed in
the circles) but stored in single precision by pyvista (relative round-off
6e-8), hence TOL = 1e-8 m: 1e-6 of the 10 mm scenes here.
"""

from __future__ import annotations

import math

import matplotlib.image
import numpy as np
import pytest

from magfem.case import load_case
from magfem.cli import main
from magfem.config import from_table
from magfem.field.placement import rotation
from magfem.field.spec import FieldSpec
from magfem.mechanics.contacts.obstacle import ObstacleSpec
from magfem.scene_grids import (
    FAINT,
    Region,
    contact_items,
    extreme_time,
    moved_copy,
    obstacle_grid,
    source_items,
)

AROUND = Region(np.array([1e-3, 2e-3, 0.5e-3]), 10e-3)
TOL = 1e-8  # m (module docstring)


def _obstacle(**table):
    return from_table(ObstacleSpec, {"kind": "obstacle", "name": "o", **table}, "contacts[0]")


def _points(grid):
    return np.asarray(grid.points, dtype=float)


def test_sphere_points_lie_at_the_radius():
    spec = _obstacle(shape="sphere", center=[0.01, 0, 0.002], radius=0.003)
    pts = _points(obstacle_grid(spec, AROUND))
    r = np.linalg.norm(pts - [0.01, 0, 0.002], axis=1)
    np.testing.assert_allclose(r, 0.003, atol=TOL)
    b = np.array(obstacle_grid(spec, AROUND).bounds).reshape(3, 2)
    np.testing.assert_allclose(b[2], [-0.001, 0.005], atol=TOL)  # poles on the z axis


def test_box_corners_are_at_half_the_edges_in_its_frame():
    spec = _obstacle(
        shape="box", center=[0, 0, 0.001], size=[0.004, 0.002, 0.001], axis=[0, 1, 1], roll=0.3
    )
    pts = _points(obstacle_grid(spec, AROUND))
    # the box frame as ObstacleSpec documents it: z edge along axis, x edge rolled about it
    z = np.array([0, 1, 1]) / math.sqrt(2)
    x0 = np.array([1.0, 0, 0])  # frame(): x from the world x axis, orthogonal to z
    x = rotation(z, 0.3) @ x0
    local = (pts - [0, 0, 0.001]) @ np.column_stack([x, np.cross(z, x), z])
    np.testing.assert_allclose(np.abs(local), [[0.002, 0.001, 0.0005]] * len(pts), atol=TOL)
    assert len(np.unique(np.sign(local).round(), axis=0)) == 8  # all eight corners


def test_half_space_is_a_patch_in_the_plane_around_the_robot():
    normal = np.array([0.0, -math.sin(0.2), math.cos(0.2)])  # a floor tilted 0.2 rad about x
    spec = _obstacle(shape="half_space", point=[0, 0, -0.001], normal=normal.tolist())
    grid = obstacle_grid(spec, AROUND)
    pts = _points(grid)
    np.testing.assert_allclose((pts - [0, 0, -0.001]) @ normal, 0.0, atol=TOL)
    foot = AROUND.center - ((AROUND.center - [0, 0, -0.001]) @ normal) * normal
    np.testing.assert_allclose(pts.mean(axis=0), foot, atol=TOL)  # centred under the robot
    corner = np.linalg.norm(pts - foot, axis=1).max()  # a square of side 3 extents
    assert corner == pytest.approx(1.5 * math.sqrt(2) * AROUND.extent, abs=TOL)
    n = np.asarray(grid.compute_normals(cell_normals=True).cell_data["Normals"])[0]
    np.testing.assert_allclose(abs(n @ normal), 1.0, rtol=1e-6)


def test_cylinder_points_lie_at_the_radius_from_the_axis():
    axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    spec = _obstacle(shape="cylinder", point=[0, 0, 0.004], axis=axis.tolist(), radius=0.002)
    pts = _points(obstacle_grid(spec, AROUND))
    d = pts - [0, 0, 0.004]
    along = d @ axis
    np.testing.assert_allclose(np.linalg.norm(d - np.outer(along, axis), axis=1), 0.002, atol=TOL)
    foot = (AROUND.center - [0, 0, 0.004]) @ axis
    np.testing.assert_allclose([along.min(), along.max()], foot + np.array([-1.5, 1.5]) * 0.01)


def test_cone_has_its_apex_and_half_angle_and_reaches_past_the_robot():
    spec = _obstacle(
        shape="cone", side="inside", apex=[0.03, 0, 0], axis=[-1, 0, 0], half_angle=math.radians(5)
    )
    pts = _points(obstacle_grid(spec, AROUND))
    s = 0.03 - pts[:, 0]  # distance from the apex along the axis
    rho = np.hypot(pts[:, 1], pts[:, 2])
    assert np.any(np.all(np.isclose(pts, [0.03, 0, 0], rtol=0, atol=TOL), axis=1))  # the apex
    np.testing.assert_allclose(rho, s * math.tan(math.radians(5)), atol=TOL)
    far = (0.03 - AROUND.center[0]) + AROUND.extent  # one extent past the robot's centre
    assert s.max() == pytest.approx(far, abs=TOL)


def test_a_moving_obstacle_is_drawn_at_its_start_and_faintly_at_its_farthest():
    motion = {
        "times": [0, 0.1, 0.2],
        "positions": [[0, 0, 0], [0.004, 0, 0.001], [0.001, 0, 0]],
        "angles": [0, 0.4, 0.1],
        "rotation_axis": [0, 0, 1],
        "pivot": [0.001, 0, 0],
    }
    spec = _obstacle(shape="box", center=[0.001, 0, 0], size=[0.002] * 3, motion=motion)
    items = contact_items([spec], AROUND, end=0.2)
    assert [i.label for i in items] == ["obstacle o (outside)", "obstacle o (outside) at 100 ms"]
    assert items[1].opacity == FAINT
    ref = _points(obstacle_grid(spec, AROUND))
    np.testing.assert_allclose(_points(items[0].grid), ref, atol=TOL)  # at rest at t = 0
    # t = 0.1 s is the farthest keyframe by the end time 0.2 s: x = R (y - p) + p + d
    R, p, d = rotation(np.array([0.0, 0, 1]), 0.4), np.array([0.001, 0, 0]), [0.004, 0, 0.001]
    np.testing.assert_allclose(_points(items[1].grid), (ref - p) @ R.T + p + d, atol=TOL)
    early = contact_items([spec], AROUND, end=0.05)[1]  # the run ends halfway to it
    assert early.label == "obstacle o (outside) at 50 ms"
    R = rotation(np.array([0.0, 0, 1]), 0.2)
    expected = (ref - p) @ R.T + p + [0.002, 0, 0.0005]
    np.testing.assert_allclose(_points(early.grid), expected, atol=TOL)


def test_extreme_time_picks_the_farthest_instant_and_none_without_motion():
    def move(t, pts):
        return pts + np.array([0.0, 0.0, 0.001 * math.sin(math.pi * t / 0.2)])

    pts = np.zeros((2, 3))
    assert extreme_time(move, pts, [0.0, 0.1, 0.2], end=0.2) == pytest.approx(0.1)
    assert extreme_time(lambda t, x: x, pts, [0.0, 0.1], end=0.1) is None
    item = contact_items([_obstacle(shape="sphere", center=[0, 0, 0], radius=1e-3)], AROUND, 1.0)
    assert len(item) == 1  # no motion: no copy
    copy = moved_copy(item[0], move, 0.1)
    shift = _points(copy.grid) - _points(item[0].grid)
    np.testing.assert_allclose(shift, np.tile([0, 0, 0.001], (len(shift), 1)), atol=TOL)


def test_moving_sources_and_iron_are_drawn_along_their_motion():
    field = from_table(
        FieldSpec,
        {
            "sources": [
                {
                    "kind": "cylinder_magnet",
                    "center": [0, 0, 0.0625],
                    "radius": 0.005,
                    "length": 0.01,
                    "remanence": 1.3,
                    "motion": "approach",
                }
            ],
            "iron": [{"kind": "tweezers", "tip": [0, 0, 0.009], "motion": "approach"}],
            "motions": [
                {
                    "name": "approach",
                    "times": [0, 0.1, 0.2],
                    "offsets": [[0, 0, 0], [0, 0, -0.003], [0, 0, 0]],
                }
            ],
        },
        "field",
    )
    items = source_items(field)  # end: the last keyframe, where they are back at the start
    labels = ["magnet 0", "magnet 0 at 100 ms", "iron 0 (tweezers)", "iron 0 (tweezers) at 100 ms"]
    assert [i.label for i in items] == labels
    for start, far in (items[:2], items[2:]):
        shift = _points(far.grid) - _points(start.grid)
        np.testing.assert_allclose(shift, np.tile([0, 0, -0.003], (len(shift), 1)), atol=TOL)
    assert np.array(items[2].grid.bounds)[4] == pytest.approx(0.009, abs=TOL)  # the tips


@pytest.mark.slow  # over 0.3 s: not in the fast tier
@pytest.mark.parametrize(
    ("command", "case", "size"), [("mesh", "pipette", "1.5mm"), ("field", "gripper", "1.2mm")]
)
def test_cli_pictures_of_the_untethered_scenes(repo, shared_tmp, comm, command, case, size):
    path = repo / "cases" / f"{case}.toml"
    argv = [command, str(path), "--set", f"mesh.size={size}", "--out", str(shared_tmp)]
    assert main(argv) == 0
    png = shared_tmp / (f"{case}.png" if command == "mesh" else "scene.png")
    if comm.rank == 0:
        assert matplotlib.image.imread(png).shape[:2] == (600, 800)
    loaded = load_case(path, [f"mesh.size={size}"])
    assert loaded.contacts  # the picture has something to show beyond the robot
