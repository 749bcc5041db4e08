"""Rigid obstacles (``[[contacts]] kind = "obstacle"``): geometry and a resting body.

* The UFL signed distance and normal of every shape, on both sides, match
  the distance computed independently with numpy (for the cone, by brute
  force over its generator line) at points around the surface.
* A free plate lying on a horizontal half-space under gravity comes to rest
  carrying its weight at the penalty law's closed-form penetration, on the
  shell and the solid (the same check the ground passes).
* Bad obstacle tables give one-line errors naming the key.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from magfem.case import parse_case
from magfem.config import CaseError, from_table
from magfem.mechanics.contacts.obstacle import ObstacleSpec, signed_distance
from magfem.mechanics.contacts.penalty import penalty_penetration
from magfem.pipeline import build_simulation

ALPHA = math.radians(20.0)
SHAPES = {
    "half_space": {"point": [0, 0, 0.1], "normal": [0.3, -0.2, 1.0]},
    "sphere": {"center": [0.1, 0.0, -0.1], "radius": 0.4},
    "cylinder": {"point": [0.0, 0.1, 0.0], "axis": [1.0, 1.0, 0.5], "radius": 0.3},
    "cone": {"apex": [0.0, 0.0, -1.0], "axis": [0.0, 0.2, 1.0], "half_angle": ALPHA},
}
"""Parameters in m and rad (the box around them spans ±0.6 m)."""


def _exact(shape: str, side: str, x: np.ndarray) -> np.ndarray:
    """Signed distance (positive where the robot may be) by plain geometry."""
    p = SHAPES[shape]
    if shape == "half_space":
        n = np.asarray(p["normal"], float)
        return (x - p["point"]) @ (n / np.linalg.norm(n))
    if shape == "sphere":
        g = np.linalg.norm(x - p["center"], axis=1) - p["radius"]
    elif shape == "cylinder":
        a = np.asarray(p["axis"], float) / np.linalg.norm(p["axis"])
        d = x - p["point"]
        g = np.linalg.norm(d - np.outer(d @ a, a), axis=1) - p["radius"]
    else:  # distance to the generator ray in the (axial, radial) half-plane: nearest point
        a = np.asarray(p["axis"], float) / np.linalg.norm(p["axis"])
        d = x - p["apex"]
        z = d @ a
        rho = np.linalg.norm(d - np.outer(z, a), axis=1)
        s = np.maximum(z * math.cos(ALPHA) + rho * math.sin(ALPHA), 0.0)  # foot on the ray
        dist = np.hypot(z - s * math.cos(ALPHA), rho - s * math.sin(ALPHA))
        g = np.where(rho > z * math.tan(ALPHA), dist, -dist)
    return g if side == "outside" else -g


@pytest.mark.parametrize("side", ["outside", "inside"])
@pytest.mark.parametrize("shape", list(SHAPES))
def test_signed_distance_matches_geometry(comm, shape, side):
    box = mesh.create_box(comm, [[-0.6, -0.6, -0.6], [0.6, 0.6, 0.6]], [6, 6, 6])
    spec = from_table(
        ObstacleSpec,
        {"kind": "obstacle", "name": "o", "shape": shape, "side": side, **SHAPES[shape]},
    )
    x = ufl.SpatialCoordinate(box)
    g, n = signed_distance(spec, x, ufl.as_vector([0.0, 0.0, 0.0]), 3)
    expr = fem.Expression(ufl.as_vector([g, *n]), np.array([[0.25, 0.25, 0.25]]))
    cells = np.arange(box.topology.index_map(3).size_local, dtype=np.int32)
    values = np.asarray(expr.eval(box, cells)).reshape(len(cells), 4)
    points = mesh.compute_midpoints(box, 3, cells)
    exact = _exact(shape, side, points)
    near = np.abs(exact) < 0.3  # away from the cone's apex region and the cylinder's axis
    if shape == "cone":
        near &= (points - SHAPES["cone"]["apex"]) @ np.array([0, 0.2, 1.0]) > 0.3
    # both sides are exact formulas in double precision
    assert np.max(np.abs(values[near, 0] - exact[near]), initial=0.0) < 1e-12
    assert np.allclose(np.linalg.norm(values[:, 1:], axis=1), 1.0, atol=1e-9)
    # n is the gradient of g: a small step along n changes g by the step
    h = 1e-4
    ahead = _exact(shape, side, points[near] + h * values[near, 1:])
    # (curvature of the level sets: h²/(2R) <= 2e-8 for R >= 0.3 away from the axis)
    assert np.max(np.abs(ahead - exact[near] - h), initial=0.0) < 1e-6
    assert comm.allreduce(int(near.sum())) > 20


def _resting_case(model: str):
    return parse_case(
        {
            "name": "rest",
            "robot": {
                "shape": "membrane",
                "thickness": "100 um",
                "length": "4 mm",
                "width": "2 mm",
            },
            "mesh": {"size": "1 mm", "model": model},
            "material": {"shear_modulus": "115 kPa", "density": "2130 kg/m^3"},
            "environment": {"gravity": [0, 0, -9.8], "clamped": []},
            "time": {"end": "4 ms", "step": "0.1 ms", "adaptive": False},
            "contacts": [
                {
                    "kind": "obstacle",
                    "name": "floor",
                    "shape": "half_space",
                    "point": [0, 0, 0],
                    "normal": [0, 0, 1],
                }
            ],
            "output": {"csv": False, "vtx_every": 0, "plot": False, "animation": False},
        }
    )


@pytest.mark.parametrize("model", ["surface", "solid"])
def test_plate_rests_on_a_half_space_at_the_penalty_penetration(comm, model):
    case = _resting_case(model)
    sim = build_simulation(case, comm)
    history = sim.run(progress=False).history
    rho, t, area = 2130.0, 1e-4, 8e-6
    weight = rho * 9.8 * t * area  # N
    # the obstacle's force balances the weight once the landing transient has died out
    assert history["obstacle_floor_z"][-1] == pytest.approx(weight, rel=1e-3)
    assert abs(history["obstacle_floor_x"][-1]) < 1e-6 * weight
    # penetration of the bottom face: the inverse of the penalty law under ρ g t
    obstacle = sim.problem.contacts[0]
    expected = penalty_penetration(rho * 9.8 * t, obstacle.law.stiffness, obstacle.law.onset)
    uz = sim.u.x.array.reshape(-1, 3)[:, 2]  # the plate translates: uz is uniform
    sink = -comm.allreduce(float(uz.max()) if uz.size else -np.inf, op=MPI.MAX)
    assert sink == pytest.approx(expected, rel=0.02)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"shape": "sphere", "center": [0, 0, 0]}, r"contacts\[0\]\.radius: is required"),
        ({"shape": "sphere", "center": [0, 0, 0], "radius": 1e-3, "axis": [0, 0, 1]}, "axis"),
        ({"shape": "cone", "apex": [0, 0, 0], "axis": [0, 0, 1], "half_angle": "95 deg"}, "angle"),
        ({"shape": "half_space", "point": [0, 0, 0], "normal": [0, 0, 0]}, "zero vector"),
        ({"shape": "box"}, r"contacts\[0\]\.shape"),
        ({"shape": "sphere", "center": [0, 0, 0], "radius": 1e-3, "name": "a b"}, "name"),
        (
            {"shape": "sphere", "center": [0, 0, 0], "radius": 1e-3, "motion": {"times": [0, 1]}},
            "positions",
        ),
    ],
)
def test_bad_obstacles_name_the_key(table, message):
    entry = {"kind": "obstacle", "name": "o", **table}
    base = {
        "name": "x",
        "robot": {"shape": "membrane", "thickness": "100 um"},
        "mesh": {"size": "1 mm"},
        "material": {"shear_modulus": 1e5, "density": 2130},
        "contacts": [entry],
    }
    with pytest.raises(CaseError, match=message):
        parse_case(base)


def test_motion_offsets_and_velocity():
    spec = from_table(
        ObstacleSpec,
        {
            "kind": "obstacle",
            "name": "o",
            "shape": "sphere",
            "center": [0, 0, 0],
            "radius": 1e-3,
            "motion": {"times": [0.0, 1.0, 2.0], "positions": [[0, 0, 0], [1, 0, 0], [1, 0, 2]]},
        },
    )
    assert spec.motion is not None
    offset, velocity = spec.motion.offset(0.5)
    assert np.allclose(offset, [0.5, 0, 0]) and np.allclose(velocity, [1, 0, 0])
    offset, velocity = spec.motion.offset(1.5)
    assert np.allclose(offset, [1, 0, 1]) and np.allclose(velocity, [0, 0, 2])
    offset, velocity = spec.motion.offset(3.0)
    assert np.allclose(offset, [1, 0, 2]) and np.allclose(velocity, 0.0)
