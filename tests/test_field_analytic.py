"""Closed-form references checked against each other, against quadrature and the dipole limit.

These references are what the FE tests compare with, so they are checked
independently of the FE code first.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.field import analytic as an

Z = np.array([0.0, 0.0, 1.0])


def test_loop_off_axis_formula_reduces_to_on_axis():
    z = np.linspace(-0.1, 0.1, 9)
    br, bz = an.loop_field(0.05, 2.0, np.full_like(z, 1e-14), z)
    np.testing.assert_allclose(bz, an.loop_on_axis(0.05, 2.0, z), rtol=1e-13)
    assert np.all(br == 0.0)


def test_loop_is_divergence_and_curl_free():
    loop = an.place(
        lambda p: np.column_stack(_cyl_to_cart(p, *an.loop_field(0.03, 1.0, *_cyl(p)))),
        np.zeros(3),
        Z,
    )
    P = np.array([[0.01, 0.004, 0.02], [0.05, -0.02, -0.01]])
    G = an.gradient_fd(loop, P, 1e-5)
    scale = np.abs(G).max()
    assert np.abs(np.trace(G, axis1=1, axis2=2)).max() < 1e-8 * scale
    assert np.abs(G - G.transpose(0, 2, 1)).max() < 1e-8 * scale


def _cyl(p):
    return np.hypot(p[:, 0], p[:, 1]), p[:, 2]


def _cyl_to_cart(p, br, bz):
    r = np.hypot(p[:, 0], p[:, 1])
    return br * p[:, 0] / r, br * p[:, 1] / r, bz


def test_thick_coil_quadrature_matches_on_axis_closed_form():
    z = np.linspace(-0.1, 0.1, 11)
    _br, bz = an.thick_coil_field(0.025, 0.0575, 0.035, 270, 1.0, np.zeros_like(z), z)
    ref = an.thick_coil_on_axis(0.025, 0.0575, 0.035, 270, 1.0, z)
    np.testing.assert_allclose(bz, ref, rtol=1e-12)
    # long thin solenoid limit: B = mu0 N I / L at its centre
    b = an.thick_coil_on_axis(0.01, 0.0101, 10.0, 1000, 1.0, np.zeros(1))
    assert b[0] == pytest.approx(an.MU0 * 1000 / 10.0, rel=1e-5)


def test_off_axis_quadrature_converged():
    rho, z = np.array([0.01, 0.03, 0.08]), np.array([0.02, -0.04, 0.01])
    a = np.array(an.thick_coil_field(0.025, 0.0575, 0.035, 270, 1.0, rho, z))
    b = np.array(an.thick_coil_field(0.025, 0.0575, 0.035, 270, 1.0, rho, z, n=32, pieces=8))
    assert np.abs(a - b).max() < 1e-12 * np.abs(b).max()
    a = np.array(an.cylinder_magnet_field(0.005, 0.01, 1.3, rho / 3, z / 3))
    b = np.array(an.cylinder_magnet_field(0.005, 0.01, 1.3, rho / 3, z / 3, n=48, pieces=16))
    assert np.abs(a - b).max() < 1e-11 * np.abs(b).max()


def test_cylinder_magnet_on_axis_and_dipole_limit():
    z = np.array([0.0, 0.006, 0.02, -0.05])
    _br, bz = an.cylinder_magnet_field(0.005, 0.01, 1.3, np.zeros_like(z), z)
    np.testing.assert_allclose(bz, an.cylinder_magnet_on_axis(0.005, 0.01, 1.3, z), rtol=1e-11)
    far = np.array([[0.3, 0.2, 0.5], [1.0, -0.5, 0.2]])
    m = 1.3 / an.MU0 * math.pi * 0.005**2 * 0.01
    B = an.cylinder_field(np.zeros(3), Z, 0.005, 0.01, 1.3)(far)
    # relative deviation from the dipole ~ (size / distance)^2 = (0.007 / 0.6)^2 ~ 1e-4
    np.testing.assert_allclose(B, an.dipole_field([0, 0, m], far), rtol=2e-4, atol=0)


def test_block_magnet_against_charge_sheet_quadrature_and_dipole():
    size = np.array([0.01, 0.01, 0.005])
    block = an.block_magnet_field(np.zeros(3), Z, size, 1.3)
    P = np.array([[0.003, 0.008, 0.006], [-0.012, 0.002, -0.004], [0.02, 0.03, 0.01]])
    # brute-force quadrature of the two charge sheets sigma = +-M on z = +-c
    xs, ws = np.polynomial.legendre.leggauss(40)
    xs, ws = np.concatenate([xs / 8 + k / 4 - 3 / 8 for k in range(4)]), np.tile(ws / 8, 4)
    X, Y = np.meshgrid(xs * 0.01, xs * 0.01, indexing="ij")
    W = np.outer(ws, ws) * 0.01**2
    ref = np.zeros((len(P), 3))
    for z0, sign in ((0.0025, 1.0), (-0.0025, -1.0)):
        src = np.stack([X, Y, np.full_like(X, z0)], -1)
        d = P[:, None, None, :] - src[None]
        r3 = np.linalg.norm(d, axis=-1)[..., None] ** 3
        ref += sign * 1.3 / (4 * math.pi) * np.einsum("ij,nijk->nk", W, d / r3)
    np.testing.assert_allclose(block(P), ref, rtol=1e-9, atol=1e-12)
    far = np.array([[0.4, -0.3, 0.5]])
    m = 1.3 / an.MU0 * size.prod()
    np.testing.assert_allclose(block(far), an.dipole_field([0, 0, m], far), rtol=3e-4)


def test_rigid_placement_rotates_the_field():
    size = np.array([0.01, 0.006, 0.004])
    along_z = an.block_magnet_field(np.zeros(3), Z, size, 1.0)
    along_x = an.block_magnet_field(np.zeros(3), np.array([1.0, 0, 0]), size, 1.0, roll=0.0)
    from magfem.field.spec import frame

    Qz, Qx = frame(Z), frame(np.array([1.0, 0, 0]))
    R = Qx @ Qz.T  # maps the z-magnet's frame onto the x-magnet's
    P = np.array([[0.01, 0.02, 0.015], [-0.02, 0.005, 0.01]])
    np.testing.assert_allclose(along_x(P @ R.T), along_z(P) @ R.T, rtol=1e-12, atol=1e-15)
