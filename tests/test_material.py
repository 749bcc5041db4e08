"""Hard-magnetic neo-Hookean material (magfem.material) against closed forms.

Every check evaluates the UFL expressions by assembling them over a small
mesh (so it runs on any number of ranks) and compares with an independent
closed form. Tolerances: the integrands are constant (or linear in X, with
exact quadrature), so assembly is exact up to round-off; 1e-10 relative
leaves six orders of margin over the ~1e-16 round-off measured here.
"""

from __future__ import annotations

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI
from scipy.optimize import brentq

import magfem  # noqa: F401  (MPI before dolfinx)
from magfem import material

MU = 115e3  # Pa
K = material.default_bulk_modulus(MU)
RTOL = 1e-10


def _cube(comm: MPI.Comm, dim: int = 3) -> mesh.Mesh:
    if dim == 3:
        return mesh.create_unit_cube(comm, 2, 1, 1)
    return mesh.create_unit_square(comm, 2, 1)


def _integrate(domain: mesh.Mesh, expr: ufl.core.expr.Expr, degree: int = 2) -> float:
    dx = ufl.dx(domain=domain, metadata={"quadrature_degree": degree})
    local = fem.assemble_scalar(fem.form(expr * dx))
    return domain.comm.allreduce(local, op=MPI.SUM)


def _matrix(domain: mesh.Mesh, values: np.ndarray) -> fem.Constant:
    return fem.Constant(domain, np.asarray(values, dtype=float))


def test_derived_constants_satisfy_isotropic_identities():
    E = material.youngs_modulus(MU, K)
    nu = material.poisson_ratio(MU, K)
    assert K == pytest.approx(100 * MU, rel=1e-15)
    # textbook identities between isotropic constants
    assert E == pytest.approx(2 * MU * (1 + nu), rel=1e-14)
    assert K == pytest.approx(E / (3 * (1 - 2 * nu)), rel=1e-12)
    assert nu == pytest.approx(0.4950166, rel=1e-6)  # (300 - 2) / (2 * 301)
    # plane-strain modulus from the Lamé constants: 4μ(λ+μ)/(λ+2μ), λ = K − 2μ/3
    lam = K - 2 * MU / 3
    assert material.plane_strain_modulus(MU, K) == pytest.approx(
        4 * MU * (lam + MU) / (lam + 2 * MU), rel=1e-12
    )
    t = 80e-6
    D_plate = material.bending_stiffness(MU, K, t)
    D_beam = material.bending_stiffness(MU, K, t, plate=False)
    assert D_plate == pytest.approx(D_beam / (1 - nu**2), rel=1e-12)
    assert D_beam == pytest.approx(E * t**3 / 12, rel=1e-14)
    assert material.energy_density(MU, 0.02) == pytest.approx(1.5 * MU * 4e-4, rel=1e-14)
    assert material.power_density(MU, 0.02, 20.0) == pytest.approx(20 * 1.5 * MU * 4e-4)


@pytest.mark.parametrize("kinematics", ["solid", "plane_strain", "plane_stress"])
def test_reference_configuration_is_stress_free(comm, kinematics):
    dim = 3 if kinematics == "solid" else 2
    domain = _cube(comm, dim)
    F = _matrix(domain, np.eye(dim))
    P = material.first_piola_kirchhoff(F, MU, K, kinematics)
    assert _integrate(domain, ufl.inner(P, P)) == pytest.approx(0.0, abs=1e-20 * MU**2)


def _sigma_closed_form(stretches: np.ndarray) -> np.ndarray:
    """Principal Cauchy stresses μ J^(-5/3) dev(B) + K (J − 1) for F = diag(stretches)."""
    J = float(np.prod(stretches))
    b = stretches**2
    return MU * J ** (-5 / 3) * (b - b.sum() / 3) + K * (J - 1)


@pytest.mark.parametrize("stretch", [0.8, 1.05, 1.5])
def test_uniaxial_cauchy_stress_solid(comm, stretch):
    # lateral stretch of uniaxial stress: σ22 = σ33 = 0 solved from the closed form
    lateral = brentq(lambda s: _sigma_closed_form(np.array([stretch, s, s]))[1], 0.3, 3.0)
    expected = _sigma_closed_form(np.array([stretch, lateral, lateral]))
    domain = _cube(comm)
    F = _matrix(domain, np.diag([stretch, lateral, lateral]))
    sigma = material.cauchy_stress(F, material.first_piola_kirchhoff(F, MU, K))
    for i in range(3):
        got = _integrate(domain, sigma[i, i])
        assert got == pytest.approx(expected[i], rel=RTOL, abs=RTOL * MU)
    assert abs(expected[0]) > 0.01 * MU  # the test is not trivially zero


@pytest.mark.parametrize("stretch", [0.9, 1.3])
def test_plane_strain_stress_equals_solid_with_unit_out_of_plane_stretch(comm, stretch):
    domain = _cube(comm, 2)
    lam2 = 0.95
    expected = _sigma_closed_form(np.array([stretch, 1.0, lam2]))  # (x, y=out of plane, z)
    F = _matrix(domain, np.diag([stretch, lam2]))
    sigma = material.cauchy_stress(F, material.first_piola_kirchhoff(F, MU, K, "plane_strain"))
    assert _integrate(domain, sigma[0, 0]) == pytest.approx(expected[0], rel=RTOL)
    assert _integrate(domain, sigma[1, 1]) == pytest.approx(expected[2], rel=RTOL)


@pytest.mark.parametrize("stretch", [0.8, 1.5, 2.0])
def test_plane_stress_uniaxial_matches_incompressible_neo_hookean(comm, stretch):
    # incompressible uniaxial tension: λ2 = λ3 = λ^(-1/2), σ = μ (λ² − 1/λ)
    domain = _cube(comm, 2)
    F = _matrix(domain, np.diag([stretch, stretch**-0.5]))
    sigma = material.cauchy_stress(F, material.first_piola_kirchhoff(F, MU, K, "plane_stress"))
    # the 2D Cauchy stress divides by J2 = det F2 = λ^(1/2); the 3D one by J = 1
    J2 = stretch**0.5
    assert _integrate(domain, sigma[0, 0] * J2) == pytest.approx(
        MU * (stretch**2 - 1 / stretch), rel=RTOL
    )
    assert _integrate(domain, sigma[1, 1]) == pytest.approx(0.0, abs=RTOL * MU)


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    n = axis / np.linalg.norm(axis)
    W = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + np.sin(angle) * W + (1 - np.cos(angle)) * W @ W


@pytest.mark.parametrize("angle", [0.0, 0.7, 2.5])
def test_magnetic_torque_of_rigid_rotation_is_m_cross_b(comm, angle):
    """dΠ/dθ about n of Π = ∫ −(F M̃)·B dV equals −n·(m × B), m = R M̃ V."""
    domain = _cube(comm)
    V = fem.functionspace(domain, ("Lagrange", 1, (3,)))
    R = _rotation(np.array([1.0, 2.0, 0.5]), angle)
    u = fem.Function(V)
    u.interpolate(lambda X: (R - np.eye(3)) @ X)
    M = np.array([0.0, 0.0, 123e3])
    B = np.array([2e-3, -1e-3, 0.5e-3])
    F = material.deformation_gradient(u)
    Pi = material.magnetic_energy(F, ufl.as_vector(M), ufl.as_vector(B)) * ufl.dx(
        metadata={"quadrature_degree": 1}
    )
    volume = 1.0
    m = R @ M * volume
    for axis in np.eye(3):
        rot = fem.Function(V)  # virtual rotation δu = n × x of the current position
        rot.interpolate(lambda X, a=axis: np.cross(a, (R @ X).T).T)
        dPi = fem.assemble_scalar(fem.form(ufl.derivative(Pi, u, rot)))
        dPi = comm.allreduce(dPi, op=MPI.SUM)
        assert dPi == pytest.approx(-axis @ np.cross(m, B), rel=RTOL, abs=1e-12 * 123e3 * 2e-3)


def test_gradient_force_of_rigid_translation(comm):
    """With B = B0 + G x, dΠ/ds along e is −m·(G e): the force (Gᵀ m)·e, m = F M̃ V."""
    domain = _cube(comm)
    V = fem.functionspace(domain, ("Lagrange", 1, (3,)))
    u = fem.Function(V)
    u.interpolate(lambda X: np.vstack([0.1 + 0 * X[0], -0.2 + 0 * X[0], 0.05 + 0 * X[0]]))
    G = np.array([[0.1, 0.02, 0.0], [0.02, -0.05, 0.01], [0.0, 0.01, -0.05]])  # T/m, curl-free
    B0 = np.array([1e-3, 0.0, 2e-3])
    x = ufl.SpatialCoordinate(domain) + u
    B = ufl.as_vector(B0) + ufl.dot(ufl.as_matrix(G), x)
    M = np.array([50e3, 0.0, 100e3])
    Pi = material.magnetic_energy(material.deformation_gradient(u), ufl.as_vector(M), B) * ufl.dx(
        metadata={"quadrature_degree": 2}
    )
    for e in np.eye(3):
        shift = fem.Function(V)
        shift.interpolate(lambda X, e=e: np.outer(e, np.ones(X.shape[1])))
        dPi = comm.allreduce(
            fem.assemble_scalar(fem.form(ufl.derivative(Pi, u, shift))), op=MPI.SUM
        )
        assert dPi == pytest.approx(-M @ G @ e, rel=RTOL)


def test_magnetoelastic_length_is_the_decay_length_of_the_elastica():
    """ℓ = t √(E/(12 M B)) is the width of a field-driven bend.

    Independent reference: the clamped hard-magnetic elastica θ'' = λ sin(θ + α − φ)
    (scipy solve_bvp, verification.references) of an arm 15 ℓ long, M across
    the thickness (α = 90°), B along the arm (φ = 0): beyond the root bend the
    angle approaches −90° and its deficit decays as exp(−s/ℓ) (the linearised
    equation). The fitted decay length over 4 ℓ < s < 10 ℓ agrees to 1e-3: there
    the deficit δ is below 0.03 rad, so sin δ differs from δ by δ²/6 < 1.5e-4
    relative, and solve_bvp's tolerance is 1e-10 (measured agreement 5e-6).
    """
    from verification import references as reference

    t, M, B = 80e-6, 123e3, 2e-3
    ell = material.magnetoelastic_length(MU, K, t, M, B)
    assert ell == pytest.approx(0.8634e-3, rel=1e-3)  # by hand: 80 µm √(2.990 μ / 2952 Pa)
    E = material.youngs_modulus(MU, K)
    length = 15 * ell
    load = reference.elastica_load(M, B, length, t, E)
    assert load == pytest.approx(15**2, rel=1e-12)  # λ = (L/ℓ)²: the same combination
    sol = reference.hard_magnetic_elastica(load, points=1501)
    s = sol.s * length
    deficit = np.abs(sol.theta) - np.pi / 2  # θ → −π/2 (M turns towards B)
    window = (s > 4 * ell) & (s < 10 * ell)
    slope = np.polyfit(s[window], np.log(np.abs(deficit[window])), 1)[0]
    assert -1.0 / slope == pytest.approx(ell, rel=1e-3)


def test_magnetoelastic_time_is_the_cantilever_period_of_length_ell():
    """τ = ℓ² √(ρ t/D): a clamped–free Euler–Bernoulli beam ℓ long has ω₁ = (β₁ℓ)²/τ.

    Independent reference: the cantilever frequency of verification.references
    (β₁ from 1 + cos β cosh β = 0), at the default case's 80 µm and 2 mT.
    """
    from verification import references as reference

    t, rho, M, B = 80e-6, 2130.0, 123e3, 2e-3
    ell = material.magnetoelastic_length(MU, K, t, M, B)
    tau = material.magnetoelastic_time(MU, K, t, rho, M, B)
    E = material.youngs_modulus(MU, K)
    omega = 2 * np.pi * reference.cantilever_frequency(E, rho, t, ell)
    assert omega * tau == pytest.approx(reference.cantilever_eigenvalue(1) ** 2, rel=1e-12)
    assert tau == pytest.approx(2.540e-3, rel=1e-3)  # by hand: ℓ² √(12 ρ/(E t²)), E = 2.990 μ
