"""Closed-form fields of coils and magnets against independent quadratures and limits.

The package evaluates these closed forms instead of an FE solve for sources
in air, so they are checked here against references computed differently
(verification/field_references.py): loop sums, Coulomb integrals over charged faces,
on-axis formulas, finite differences and the dipole far field.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI
from scipy.integrate import quad
from scipy.special import ellipe, ellipk

from magfem.config import from_table
from magfem.field import analytic as an
from magfem.field.build import build_terms, coil_current
from magfem.field.placement import Placement, frame, rotation
from magfem.field.source import BlockMagnetField, CoilField, CylinderMagnetField
from magfem.field.spec import FieldSpec
from verification.field_references import block_by_charges, sheet_by_loops, thick_coil_by_loops

Z = np.array([0.0, 0.0, 1.0])
PAIR = dict(r1=0.025, r2=0.0575, length=0.035, turns=270, current=1.0)


def _pair(polarity: float = 1.0) -> CoilField:
    return CoilField(
        np.zeros(3), Z, 0.025, 0.0575, 0.035, 270, 1.0, [(-0.035, 1.0), (0.035, polarity)]
    )


def test_cel_gives_the_complete_elliptic_integrals():
    k = np.array([0.0, 0.3, 0.8, 0.999])
    kc = np.sqrt(1 - k**2)
    one = np.ones_like(k)
    np.testing.assert_allclose(an.cel(kc, one, one, one), ellipk(k**2), rtol=1e-14)
    np.testing.assert_allclose(an.cel(kc, one, one, kc**2), ellipe(k**2), rtol=1e-14)


def test_loop_reduces_to_its_on_axis_formula():
    z = np.linspace(-0.1, 0.1, 9)
    br, bz = an.loop_field(0.05, 2.0, np.full_like(z, 1e-14), z)
    np.testing.assert_allclose(bz, an.loop_on_axis(0.05, 2.0, z), rtol=1e-13)
    assert np.all(br == 0.0)


def test_current_sheet_against_loop_sum():
    # points inside, outside, near the rim and on the axis of a 5 x 10 mm sheet
    rho = np.array([0.0, 0.001, 0.004, 0.0049, 0.006, 0.02, 0.003])
    z = np.array([0.01, 0.0, 0.007, 0.0051, -0.003, 0.01, 0.0])
    br, bz = an.sheet_field(0.005, 0.005, 1e6, rho, z)
    rr, rz = sheet_by_loops(0.005, 0.005, 1e6, rho, z, n=4096)
    scale = np.abs(rz).max()
    # measured 8e-15; the loop sum converges to ~1e-12 at 4096 loops
    assert np.abs(br - rr).max() < 1e-11 * scale
    assert np.abs(bz - rz).max() < 1e-11 * scale
    zz = np.linspace(-0.02, 0.02, 9)
    np.testing.assert_allclose(
        an.sheet_field(0.005, 0.005, 1.3 / an.MU0, np.zeros_like(zz), zz)[1],
        an.cylinder_magnet_on_axis(0.005, 0.01, 1.3, zz),
        rtol=1e-14,
    )


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_thick_coil_against_loop_sum_and_on_axis_formula():
    rho = np.array([0.0, 0.01, 0.02, 0.06, 0.03, 0.0])
    z = np.array([0.0, 0.005, 0.0, 0.0, 0.025, 0.05])
    br, bz, _ = an.thick_coil_local(0.025, 0.0575, 0.035, 270, 1.0, rho, z)
    rr, rz = thick_coil_by_loops(0.025, 0.0575, 0.035, 270, 1.0, rho, z, n=256)
    # measured 1e-14 (relative to the largest |B|); the 2D loop sum is converged to ~1e-12
    assert np.abs(np.column_stack([br - rr, bz - rz])).max() < 1e-10 * np.abs(rz).max()
    zz = np.linspace(-0.1, 0.1, 11)
    np.testing.assert_allclose(
        an.thick_coil_local(0.025, 0.0575, 0.035, 270, 1.0, np.zeros_like(zz), zz)[1],
        an.thick_coil_on_axis(0.025, 0.0575, 0.035, 270, 1.0, zz),
        rtol=1e-11,  # measured 1.1e-12: the quadrature's round-off on ~30 nodes
    )


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_coil_quadrature_is_converged_down_to_its_resolution():
    # points approaching an end face of the winding, down to coil_resolution
    res = an.coil_resolution(0.025, 0.0575)
    d = np.geomspace(res, 0.02, 12)
    rho, z = np.full_like(d, 0.04), 0.0175 + d  # above the end face at r = 40 mm
    br, bz, _ = an.thick_coil_local(0.025, 0.0575, 0.035, 270, 1.0, rho, z)
    J = 270 / ((0.0575 - 0.025) * 0.035)

    def radial(r: float, zz: float, k: int) -> float:
        def f(a: float) -> float:
            return float(J * an.sheet_field(a, 0.0175, 1.0, np.array(r), np.array(zz))[k])

        return quad(f, 0.025, 0.0575, points=[r], epsabs=0, epsrel=1e-12, limit=200)[0]

    ref = np.array([[radial(r, zz, k) for k in (0, 1)] for r, zz in zip(rho, z, strict=True)])
    # panels <= 2 d: measured <= 2e-9 of |B| at the resolution limit (panel = 2.5 d)
    assert np.abs(np.column_stack([br, bz]) - ref).max() < 1e-8 * np.abs(ref).max()


@pytest.mark.parametrize("kind", ["coil", "cylinder", "block"])
def test_gradients_are_exact_div_and_curl_free(kind):
    rng = np.random.default_rng(3)
    axis = rng.normal(size=3)
    if kind == "coil":
        field = CoilField(np.array([0.01, 0.0, -0.02]), axis, 0.01, 0.02, 0.01, 100, 2.0)
        P = rng.uniform(-0.008, 0.008, (20, 3))
    elif kind == "cylinder":
        field = CylinderMagnetField(np.zeros(3), axis, 0.005, 0.008, 1.3)
        P = rng.uniform(-0.02, 0.02, (20, 3))
    else:
        field = BlockMagnetField(np.zeros(3), axis, np.array([0.01, 0.006, 0.004]), 1.3, roll=0.4)
        P = rng.uniform(-0.02, 0.02, (20, 3))
    P = P[~field.inside(P)]
    _, G = field.field_and_gradient(P)
    Gfd = an.gradient_fd(field.flux_density, P, 1e-6)
    scale = np.abs(G).max()
    # 4th-order differences with h = 1e-6 m: truncation and round-off ~1e-10 of the gradient
    assert np.abs(G - Gfd).max() < 1e-8 * scale
    assert np.abs(np.trace(G, axis1=1, axis2=2)).max() < 1e-10 * scale
    assert np.abs(G - G.transpose(0, 2, 1)).max() < 1e-10 * scale


def test_block_magnet_of_any_size_and_orientation_2_to_20_mm_away():
    """Acceptance: B within 0.1 % and ∇B within 1 % at points 2-20 mm from the block."""
    rng = np.random.default_rng(7)
    for _ in range(3):
        size = rng.uniform(0.002, 0.02, 3)
        axis, roll = rng.normal(size=3), rng.uniform(0, 2 * math.pi)
        field = BlockMagnetField(rng.uniform(-0.01, 0.01, 3), axis, size, 1.3, roll)
        dirs = rng.normal(size=(8, 3))
        dirs /= np.linalg.norm(dirs, axis=1)[:, None]
        # points at 2-20 mm from the block's surface (distance along each ray from its box)
        gap = rng.uniform(0.002, 0.02, (8, 1))
        reach = np.abs(dirs @ frame(axis / np.linalg.norm(axis), roll)) @ (size / 2)
        local = dirs * (reach[:, None] + gap)
        P = field.center + local
        B, G = field.field_and_gradient(P)
        Bq, Gq = block_by_charges(size / 2, 1.3, local @ field.Q, n=32)
        Bq, Gq = Bq @ field.Q.T, np.einsum("ia,nab,jb->nij", field.Q, Gq, field.Q)
        # the quadrature converges like its panel / 2 mm; measured agreement 1e-9 (B), 3e-8 (G)
        assert np.linalg.norm(B - Bq, axis=1).max() < 1e-6 * np.linalg.norm(Bq, axis=1).max()
        assert (
            np.linalg.norm(G - Gq, axis=(1, 2)).max() < 1e-5 * np.linalg.norm(Gq, axis=(1, 2)).max()
        )


def test_coil_pair_gradient_on_its_axis():
    """Acceptance: grad B of the coil pair within 1 % on its axis (here exact to 1e-9)."""
    z = np.linspace(-0.02, 0.02, 9)
    P = np.column_stack([np.zeros_like(z), np.zeros_like(z), z])

    def dbz_on_axis(zz):  # d/dz of the on-axis closed form (differentiated by hand)
        def dterm(x):
            s1, s2 = np.sqrt(PAIR["r1"] ** 2 + x**2), np.sqrt(PAIR["r2"] ** 2 + x**2)
            log = np.log((PAIR["r2"] + s2) / (PAIR["r1"] + s1))
            return log + x * (x / (s2 * (PAIR["r2"] + s2)) - x / (s1 * (PAIR["r1"] + s1)))

        J = PAIR["turns"] * PAIR["current"] / ((PAIR["r2"] - PAIR["r1"]) * PAIR["length"])
        h = PAIR["length"] / 2
        return an.MU0 * J / 2 * (dterm(zz + h) - dterm(zz - h))

    for polarity in (1.0, -1.0):
        _, G = _pair(polarity).field_and_gradient(P)
        ref = dbz_on_axis(z + 0.035) + polarity * dbz_on_axis(z - 0.035)
        scale = np.abs(ref).max()
        assert np.abs(G[:, 2, 2] - ref).max() < 1e-9 * scale
        np.testing.assert_allclose(G[:, 0, 0], -0.5 * G[:, 2, 2], atol=1e-12 * scale)
        assert np.abs(G[:, 2, :2]).max() < 1e-12 * scale  # no transverse terms on the axis


def test_sources_tend_to_their_dipole():
    far = np.array([[0.3, 0.2, 0.5], [1.0, -0.5, 0.2]])
    cyl = CylinderMagnetField(np.zeros(3), Z, 0.005, 0.01, 1.3)
    block = BlockMagnetField(np.zeros(3), Z, np.array([0.01, 0.01, 0.005]), 1.3)
    coil = CoilField(np.zeros(3), Z, 0.01, 0.02, 0.01, 100, 1.0)
    moments = [
        1.3 / an.MU0 * math.pi * 0.005**2 * 0.01,
        1.3 / an.MU0 * 0.01 * 0.01 * 0.005,
        100 * math.pi * (0.02**3 - 0.01**3) / (3 * (0.02 - 0.01)),  # N I <π a²> over the winding
    ]
    for field, m in zip((cyl, block, coil), moments, strict=True):
        # relative deviation ~ (size / distance)² ≤ (0.025 / 0.6)² ≈ 2e-3
        B, G = field.field_and_gradient(far)
        np.testing.assert_allclose(B, an.dipole_field([0, 0, m], far), rtol=3e-3, atol=0)
        Gd = an.dipole_gradient([0, 0, m], far)
        assert np.abs(G - Gd).max() < 5e-3 * np.abs(Gd).max()


def test_rigid_placement_moves_and_turns_the_field():
    size = np.array([0.01, 0.006, 0.004])
    magnet = BlockMagnetField(np.zeros(3), Z, size, 1.0)
    R = rotation(np.array([1.0, 1.0, 0.0]) / math.sqrt(2), 0.7)
    P = Placement(R, np.array([0.01, -0.02, 0.005]))
    moved = BlockMagnetField(P.d, R[:, 2], size, 1.0, roll=0.0)
    # same body placed by (center, axis, roll): the roll that maps its local x onto R's x
    x_loc = moved.Q.T @ R[:, 0]
    moved = BlockMagnetField(P.d, R[:, 2], size, 1.0, roll=math.atan2(x_loc[1], x_loc[0]))
    pts = np.array([[0.03, 0.01, 0.02], [-0.01, -0.04, 0.0]])
    B, G = magnet.field_and_gradient(P.to_reference(pts))
    Bm, Gm = moved.field_and_gradient(pts)
    np.testing.assert_allclose(P.vectors(B), Bm, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(P.tensors(G), Gm, rtol=1e-11, atol=1e-12)


def test_coil_pair_defaults_centre_field_and_uniformity():
    """The experiments' coil pair (defaults): 3.713 mT/A at the centre, |B| within 10 % at 10 mm."""
    spec = from_table(FieldSpec, {"sources": [{"kind": "coil_pair", "flux_density": "10 mT"}]}, "f")
    (term,) = build_terms(spec, MPI.COMM_SELF)
    assert coil_current(spec.sources[0]) == pytest.approx(2.693, abs=5e-4)
    b0 = term.field.flux_density(np.zeros((1, 3)))[0]
    np.testing.assert_allclose(b0, [0, 0, 0.01], atol=1e-15)
    per_amp = 0.01 / coil_current(spec.sources[0])
    assert per_amp == pytest.approx(3.713e-3, abs=5e-7)  # 1.375e-5 T per ampere-turn of one coil
    g = np.linspace(-0.01, 0.01, 5)
    P = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    nb = np.linalg.norm(term.field.flux_density(P), axis=1)
    # |B| varies by 10.15 % over the ±10 mm cube (its corners are 17 mm from the centre)
    assert (nb.max() - nb.min()) / nb[len(P) // 2] == pytest.approx(0.1015, abs=5e-4)
