"""Iron parts as obstacles (``[[contacts]] kind = "iron"``): the tweezers' prongs.

* The UFL signed distance and normal of the default tweezers (tips 2 mm
  apart, 1 mm thick, 1 mm wide at the tips, 4 mm at the handle 40 mm up,
  8 mm spread: each prong's inner and outer faces lean by 0.05, its sides by
  0.0375) at points computed by hand: inside a prong, outside a side face
  (the face region: exact), under a tip face, and beside a tip's edge, where
  the max over the face planes is a lower bound of the distance.
* A plate lying on a prong's face under gravity is stopped there: the prong
  carries its weight, at the penalty law's closed-form penetration (the
  same set-up and model as the plate on a half-space of
  tests/test_mechanics_contacts_obstacle.py).
* The iron's motion is the obstacle's; bad tables give one-line errors.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh

from magfem.case import parse_case
from magfem.config import CaseError, from_table
from magfem.field.build import trajectory
from magfem.field.spec import FieldSpec
from magfem.mechanics.contacts.iron_obstacle import convex_distance, convex_pieces, iron_motion
from magfem.mechanics.contacts.penalty import penalty_penetration
from magfem.pipeline import build_simulation

MM = 1e-3
INNER = math.sqrt(1 + 0.05**2)  # |(1, 0, -0.05)|: a prong's inner and outer faces
SIDE = math.sqrt(1 + 0.0375**2)  # |(0, 1, -0.0375)|: its side faces


def _tweezers(**keys):
    table = {"iron": [{"kind": "tweezers", "tip": [0, 0, 0], "axis": [0, 0, 1], **keys}]}
    return from_table(FieldSpec, table, "field")


# point (mm), g (mm), n: by hand, in the tweezers' frame (x opening, y width, z to the handle)
POINTS = [
    # inside the + prong at z = 20 (x from 2 to 3 there): 0.4 mm from the inner face
    ((2.4, 0, 20), -0.4 / INNER, np.array([-1, 0, 0.05]) / INNER),
    # the same in the - prong (the union picks it): mirrored normal
    ((-2.4, 0, 20), -0.4 / INNER, np.array([1, 0, 0.05]) / INNER),
    # beside a side face (half-width 1.25 at z = 20); its foot (2.5, 1.25, 20.07) is on the face
    ((2.5, 3, 20), 1.75 / SIDE, np.array([0, 1, -0.0375]) / SIDE),
    # under the tip face (x in [1, 2], |y| <= 0.5 at z = 0): exact
    ((1.5, 0, -0.3), 0.3, np.array([0, 0, -1.0])),
]


def _evaluate(comm, pieces, point):
    """(g, n) of convex_distance at ``point`` (m), on every rank (a Constant point)."""
    cube = mesh.create_unit_cube(comm, 2, 2, 2)
    planes = np.array(pieces)
    normals = fem.Constant(cube, planes[:, :, :3].copy())
    offsets = fem.Constant(cube, planes[:, :, 3].copy())
    y = fem.Constant(cube, np.asarray(point, dtype=float))
    g, n = convex_distance(normals, offsets, y)
    expr = fem.Expression(ufl.as_vector([g, *n]), np.array([[0.25, 0.25, 0.25]]))
    cells = np.arange(min(1, cube.topology.index_map(3).size_local), dtype=np.int32)
    values = np.asarray(expr.eval(cube, cells)).reshape(-1, 4)
    return values[0] if len(values) else None


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_prong_distance_and_normal_at_hand_computed_points(comm):
    pieces = convex_pieces(_tweezers().iron[0])
    assert pieces is not None and [len(p) for p in pieces] == [6, 6, 6]  # 2 prongs + handle
    for point, g, n in POINTS:
        got = _evaluate(comm, pieces, np.asarray(point) * MM)
        if got is None:
            continue
        # plane distances in double precision from corners of ~1e-2 m: 1e-15 m
        assert got[0] == pytest.approx(g * MM, abs=1e-15), point
        np.testing.assert_allclose(got[1:], n, atol=1e-14)
    # beside the tip's inner edge (x = 1, z = 0): the tip plane gives 0.3 mm, the inner face
    # 0.185/INNER: g = 0.3 mm, a lower bound of the distance to the edge, sqrt(0.2² + 0.3²)
    got = _evaluate(comm, pieces, np.array([0.8, 0, -0.3]) * MM)
    if got is not None:
        assert got[0] == pytest.approx(0.3 * MM, abs=1e-15)
        assert got[0] < math.hypot(0.2, 0.3) * MM


def test_only_polyhedral_iron_has_pieces():
    assert convex_pieces(_tweezers().iron[0]) is not None
    rod = from_table(FieldSpec, {"iron": [{"kind": "rod"}]}, "field")
    assert convex_pieces(rod.iron[0]) is None


def test_the_obstacle_follows_the_iron_motion():
    field = from_table(
        FieldSpec,
        {
            "motions": [
                {
                    "name": "m",
                    "times": [0, 0.1, 0.2],
                    "offsets": [[0, 0, 0], [0, 0, -0.003], [0.001, 0, 0]],
                    "angles": [0, 0.2, 0.5],
                    "rotation_axis": [0, 1, 0],
                    "pivot": [0, 0, 0.01],
                }
            ]
        },
        "field",
    )
    motion, path = iron_motion(field.motions[0]), trajectory(field.motions[0])
    assert motion is not None and path is not None
    y = np.array([[0.001, 0.002, 0.003]])
    for t in (0.0, 0.05, 0.1, 0.17, 0.3):
        p = motion.placement(t)
        x = (y - p.pivot) @ p.R.T + p.pivot + p.offset
        np.testing.assert_allclose(x, path.placement(t).apply(y), atol=1e-15)


def _prong_case(**contact):
    """The plate of the half-space test lying on the top face of a prong (along x, face z = 0).

    Tweezers along x, turned 90° so that the opening direction is z; spread 4 mm makes the
    prongs parallel (x from 1 to 2 mm in the opening direction from tip to handle), so the +
    prong's outer face is the plane z = 0, 3.25 mm wide or more under the 2 mm plate."""
    return parse_case(
        {
            "name": "prong",
            "robot": {
                "shape": "membrane",
                "thickness": "100 um",
                "length": "4 mm",
                "width": "2 mm",
            },
            "mesh": {"size": "1 mm", "model": "surface"},
            "material": {"shear_modulus": "115 kPa", "density": "2130 kg/m^3"},
            "environment": {"gravity": [0, 0, -9.8], "clamped": []},
            "time": {"end": "4 ms", "step": "0.1 ms", "adaptive": False},
            "field": {
                "iron": [
                    {
                        "kind": "tweezers",
                        "tip": [-0.03, 0, -0.002],
                        "axis": [1, 0, 0],
                        "roll": "90 deg",
                        "spread": "4 mm",
                    }
                ]
            },
            "contacts": [{"kind": "iron", "name": "prong", "part": 0, **contact}],
            "output": {"csv": False, "vtx_every": 0, "plot": False, "animation": False},
        }
    )


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_plate_lying_on_a_prong_is_held_at_the_penalty_penetration(comm):
    sim = build_simulation(_prong_case(), comm)
    history = sim.run(progress=False).history
    rho, t, area = 2130.0, 1e-4, 8e-6
    weight = rho * 9.8 * t * area  # N
    # as on the half-space: the force balances the weight once the landing has died out
    # (measured 2e-7 off), the deepest node at the law's closed-form penetration (1e-7)
    assert history["obstacle_prong_z"][-1] == pytest.approx(weight, rel=1e-3)
    assert abs(history["obstacle_prong_x"][-1]) < 1e-6 * weight
    obstacle = sim.problem.contacts[0]
    expected = penalty_penetration(rho * 9.8 * t, obstacle.law.stiffness, obstacle.law.onset)
    assert -history["obstacle_prong_gap"][-1] == pytest.approx(expected, rel=0.02)


@pytest.mark.parametrize(
    ("field", "message"),
    [
        ({}, r"contacts\[0\]\.part = 0: must name an iron part: the case has no \[\[field"),
        ({"iron": [{"kind": "rod"}]}, r"contacts\[0\]\.part = 0: iron part 0 is a rod"),
    ],
)
def test_bad_iron_obstacles_name_the_key(field, message):
    case = {
        "name": "bad",
        "robot": {"shape": "membrane", "thickness": 1e-4, "length": 4e-3, "width": 2e-3},
        "mesh": {"size": 1e-3, "model": "surface"},
        "material": {"shear_modulus": 115e3, "density": 2130},
        "field": field,
        "contacts": [{"kind": "iron", "name": "prong"}],
    }
    with pytest.raises(CaseError, match=message):
        parse_case(case)
    with pytest.raises(CaseError, match=r"contacts\[0\]\.name"):
        parse_case({**case, "contacts": [{"kind": "iron", "name": "a b"}]})
