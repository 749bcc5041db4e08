"""The independent references (verification.references) checked against each other
and against their known limits. Pure scipy: no mesh, runs on every rank.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from verification import references as ref


def test_material_constants_of_the_neo_hookean_solid():
    mu, K = 250e3, 100 * 250e3
    nu = ref.poisson_ratio(mu, K)
    E = ref.young_modulus(mu, K)
    assert nu == pytest.approx(0.4950166, rel=1e-6)  # (300 - 2) / (2 · 301)
    assert E == pytest.approx(2 * mu * (1 + nu), rel=1e-14)  # isotropic identity
    assert E == pytest.approx(3 * K * (1 - 2 * nu), rel=1e-12)
    assert ref.bending_modulus(E, nu, "plate") == pytest.approx(E / (1 - nu**2))
    assert ref.bending_modulus(E, nu, "plane_stress") == E
    with pytest.raises(ValueError):
        ref.bending_modulus(E, nu, "shell")


@pytest.mark.parametrize("load", [0.5, 3.0, 10.0, 40.0])
def test_elastica_bvp_agrees_with_first_integral(load):
    bvp = ref.hard_magnetic_elastica(load)
    quad = ref.elastica_tip_angle_first_integral(load)
    # both are converged to ~1e-10 by construction; 1e-7 rad covers the BVP mesh
    assert bvp.tip_angle == pytest.approx(quad, abs=1e-7)
    assert -math.pi / 2 < bvp.tip_angle < 0


def test_elastica_small_load_is_linear_beam():
    """θ'' = λ cos θ ≈ λ: θ(s) = λ(s²/2 − s), tip −λ/2 with O(λ³) correction."""
    for load in (1e-3, 1e-2):
        sol = ref.hard_magnetic_elastica(load)
        exact = load * (sol.s**2 / 2 - sol.s)
        assert np.max(np.abs(sol.theta - exact)) < load**3  # measured ≈ 0.02 λ³


def test_elastica_large_load_aligns_with_field():
    sol = ref.hard_magnetic_elastica(400.0)
    assert sol.tip_angle == pytest.approx(-math.pi / 2, abs=1e-3)
    assert np.all(np.diff(sol.theta) <= 1e-12)  # monotone bending
    # inextensible centreline: polygon length 1 up to the chord error of 400 segments
    length = np.sum(np.hypot(np.diff(sol.x), np.diff(sol.y)))
    assert length == pytest.approx(1.0, abs=1e-4)


def test_elastica_general_angles_reduce_to_standard_case():
    """Field along +x with M at α is the same as field at −(α − π/2) with M normal."""
    a = ref.hard_magnetic_elastica(5.0, magnetization_angle=math.pi / 2, field_angle=0.0)
    b = ref.hard_magnetic_elastica(5.0, magnetization_angle=math.pi, field_angle=math.pi / 2)
    assert a.tip_angle == pytest.approx(b.tip_angle, abs=1e-9)


def test_cantilever_eigenvalues():
    # Timoshenko et al. (1974) table: 1.875104, 4.694091, 7.854757
    assert ref.cantilever_eigenvalue(1) == pytest.approx(1.8751040687, abs=1e-9)
    assert ref.cantilever_eigenvalue(2) == pytest.approx(4.6940911330, abs=1e-9)
    assert ref.cantilever_eigenvalue(3) == pytest.approx(7.8547574382, abs=1e-9)


def test_cantilever_frequency_matches_rayleigh_ritz():
    """Independent: Rayleigh–Ritz with many polynomial modes for E'I w'''' + ρA ẅ = 0."""
    E, rho, h, L = 1e6, 2000.0, 1e-4, 1e-2
    f = ref.cantilever_frequency(E, rho, h, L)
    # w = Σ a_k (x/L)^(k+1), k = 1..n: clamped at 0, free end natural
    n = 8
    xs, wq = np.polynomial.legendre.leggauss(40)
    xs, wq = 0.5 * (xs + 1), 0.5 * wq
    phi2 = np.array([(k + 1) * k * xs ** (k - 1) for k in range(1, n + 1)])  # d²/dξ²
    phi0 = np.array([xs ** (k + 1) for k in range(1, n + 1)])
    Kq = (phi2 * wq) @ phi2.T * E * h**3 / 12 / L**3
    Mq = (phi0 * wq) @ phi0.T * rho * h * L
    from scipy.linalg import eigh

    omega = math.sqrt(eigh(Kq, Mq, eigvals_only=True)[0])
    assert f == pytest.approx(omega / (2 * math.pi), rel=1e-8)


def test_penalty_penetration_and_sliding_references():
    k, d0 = 1e10, 1e-7
    for p in (1.0, 1e3, 1e5):
        delta = ref.penalty_penetration(p, k, d0)
        r = delta**2 / (2 * d0) if delta < d0 else delta - d0 / 2
        assert k * r == pytest.approx(p, rel=1e-12)
    assert ref.resting_pressure(2130.0, 1e-4) == pytest.approx(2130 * 9.8 * 1e-4)
    # regularised sliding: closed form against a numerical ODE solve
    mu, eps, v0, g = 0.5, 1e-3, 0.05, 9.8
    sol = integrate.solve_ivp(
        lambda t, v: -mu * g * v / np.hypot(v, eps),
        (0, 0.02),
        [v0],
        rtol=1e-11,
        atol=1e-14,
        dense_output=True,
    )
    for v in (0.04, 0.01, 0.002):
        t = ref.regularized_sliding_time(v, v0, mu, eps)
        assert sol.sol(t)[0] == pytest.approx(v, rel=1e-7)
    # Coulomb limit while v >> v_ε
    t = ref.regularized_sliding_time(0.02, v0, mu, eps)
    assert ref.sliding_velocity(t, v0, mu)[()] == pytest.approx(0.02, rel=1e-3)


def test_regularized_sliding_distance():
    mu, eps, v0, g = 0.5, 1e-3, 0.02, 9.8
    sol = integrate.solve_ivp(
        lambda t, y: [y[1], -mu * g * y[1] / np.hypot(y[1], eps)],
        (0, 0.05),
        [0.0, v0],
        rtol=1e-11,
        atol=1e-15,
    )
    assert ref.regularized_sliding_distance(v0, mu, eps) == pytest.approx(sol.y[0, -1], rel=1e-6)
    # Coulomb limit
    assert ref.regularized_sliding_distance(v0, mu, 1e-9) == pytest.approx(
        v0**2 / (2 * mu * g), rel=1e-9
    )
