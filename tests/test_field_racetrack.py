"""The racetrack coil's closed-form field against the thick circular coil, Ampère's law and
finite differences (div B = 0, curl B = 0 outside the winding)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from magfem.config import CaseError, from_table
from magfem.field import analytic as an
from magfem.field.build import build_terms
from magfem.field.placement import frame
from magfem.field.racetrack import racetrack_distance, racetrack_local
from magfem.field.spec import FieldSpec

# the TEAM-13 coil: bore 150 x 150 mm with 25 mm corners, 25 mm deep, 100 mm long, 3000 AT
R1, R2, H, NI = 0.025, 0.05, 0.1, 3000.0
CX, CY = 0.05, 0.03  # an unequal spine (50 x 30 mm half-sides) exercises both bar lengths


def _outside(rng: np.random.Generator, cx: float, cy: float, n: int, d_min: float) -> np.ndarray:
    p = rng.uniform(-0.15, 0.15, (n, 3))
    return p[racetrack_distance(cx, cy, R1, R2, H, p) > d_min]


def test_zero_straight_length_is_the_thick_circular_coil():
    p = _outside(np.random.default_rng(1), 0.0, 0.0, 600, 2e-3)
    B, G = racetrack_local(0.0, 0.0, R1, R2, H, NI, p)
    rho = np.hypot(p[:, 0], p[:, 1])
    B0, G0 = an.axisymmetric_to_cartesian(p, *an.thick_coil_local(R1, R2, H, 1, NI, rho, p[:, 2]))
    # both are 8-node composite Gauss rules with panels <= 2 d (d >= 2 mm here): measured
    # 6.8e-7 (B) and 6.7e-6 (grad B) of the largest value at 2 mm from the winding
    assert np.abs(B - B0).max() < 2e-6 * np.abs(B0).max()
    assert np.abs(G - G0).max() < 2e-5 * np.abs(G0).max()


def test_gradient_matches_finite_differences_and_is_div_and_curl_free():
    p = _outside(np.random.default_rng(2), CX, CY, 150, 5e-3)
    _, G = racetrack_local(CX, CY, R1, R2, H, NI, p)
    Gfd = an.gradient_fd(
        lambda q: racetrack_local(CX, CY, R1, R2, H, NI, q, grad=False)[0], p, 1e-4
    )
    scale = np.abs(G).max()
    # 4th-order differences with h = 0.1 mm at >= 5 mm: truncation ~(h/d)^4 ~ 1e-7, round-off
    # ~1e-16 B/h ~ 1e-10; measured 2.5e-6, the quadrature's own error at 5 mm
    assert np.abs(G - Gfd).max() < 1e-5 * scale
    assert np.abs(np.trace(Gfd, axis1=1, axis2=2)).max() < 1e-5 * scale  # div B = 0
    assert np.abs(Gfd - Gfd.transpose(0, 2, 1)).max() < 1e-5 * scale  # curl B = 0


def test_amperes_law_around_one_bar():
    """∮ B·dl around the +x bar (a 60 x 140 mm rectangle about its section) = µ0 NI."""
    x0, x1, z0, z1 = CX + R1 - 0.015, CX + R2 + 0.015, -H / 2 - 0.02, H / 2 + 0.02
    xg, wg = an._gauss(0.0, 1.0, 16, 16)  # 256 nodes per side: the field is smooth 15 mm away
    total = 0.0
    corners = [(x0, z0), (x0, z1), (x1, z1), (x1, z0)]  # right-handed about +y, the current
    for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
        a, b = np.array([a[0], 0.0, a[1]]), np.array([b[0], 0.0, b[1]])
        pts = a + np.outer(xg, b - a)
        B, _ = racetrack_local(CX, CY, R1, R2, H, NI, pts, grad=False)
        total += float(wg @ (B @ (b - a)))
    # each quadrature sheet or strip of the winding is a closed current carrying its exact
    # share of NI, so Ampère's law holds to round-off whatever the rule (measured 4e-14); the
    # contour's own 256-node rules are converged 15 mm from the winding
    assert total == pytest.approx(an.MU0 * NI, rel=1e-10)


RACETRACK = {
    "kind": "racetrack_coil",
    "inner_size": ["150 mm", "110 mm"],
    "inner_radius": "25 mm",
    "thickness": "25 mm",
    "length": "100 mm",
    "turns": 1000,
    "current": "3 A",
    "axis": [1, 0, 0],
    "center": [0.01, 0.02, 0.03],
    "roll": "30 deg",
}


def test_case_table_places_and_turns_the_racetrack():
    spec = from_table(FieldSpec, {"sources": [RACETRACK]}, "field")
    (term,) = build_terms(spec, MPI.COMM_SELF)
    c = np.array([0.01, 0.02, 0.03])
    # on the axis, at the centre: along +axis (counter-clockwise current); the local frame's
    # roll only turns the bore's sides, so the field on the axis does not depend on it
    b = term.field.flux_density(c[None, :])[0]
    assert b[0] > 0 and abs(b[1]) < 1e-12 and abs(b[2]) < 1e-12
    # the middle of the local +x side's winding (75 + 12.5 mm out) is inside, the bore is not
    Q = frame(np.array([1.0, 0.0, 0.0]), math.radians(30))
    side = c + np.array([[0.0875, 0.0, 0.0], [0.07, 0.0, 0.0], [0.0, 0.05, 0.0]]) @ Q.T
    assert term.field.inside(side).tolist() == [True, False, False]
    # closer than the quadrature's resolution (78.5 mm / 1024 = 0.077 mm): flagged
    near = c + np.array([[0.10005, 0.0, 0.0], [0.101, 0.0, 0.0]]) @ Q.T
    assert term.field.unresolved(near).tolist() == [True, False]


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"inner_radius": "60 mm"}, r"inner_radius = 0\.06: must be <= half the smaller bore"),
        ({"inner_size": ["150 mm"]}, r"inner_size.*must have 2 components"),
        ({"current": -1.0}, r"current = -1\.0: must be > 0"),
        ({"thickness": 0.0}, r"thickness = 0\.0: must be > 0"),
    ],
)
def test_bad_racetrack_input(change, match):
    with pytest.raises(CaseError, match=match):
        from_table(FieldSpec, {"sources": [RACETRACK | change]}, "field")
