"""Hard-magnetic neo-Hookean material: energies (UFL) and derived constants.

Model (Zhao, Kim, Yuk, Parada, Zhao, "Mechanics of hard-magnetic soft
materials", JMPS 124 (2019) 244–263, eq. 25; elastic part as Abaqus'
compressible neo-Hookean): with F = I + Grad u, J = det F, C = FᵀF,

    ψ(F, x) = ψ_el(F) + ψ_mag(F, x)
    ψ_el    = μ/2 (J^(-2/3) tr C − 3) + K/2 (J − 1)²                 [J/m³]
    ψ_mag   = −(F M̃) · B_a(x, t)                                    [J/m³]

M̃ (A/m) is the remanent magnetization in the reference configuration, so
F M̃ is the current magnetization per reference volume; B_a (T) is the
applied flux density at the *current* position x = X + u. The first
Piola–Kirchhoff stress is P = ∂ψ/∂F; the residual of the weak form is
written from the energy with ``ufl.derivative`` in
:mod:`magfem.mechanics.problem`, so the magnetic body torque (F M̃) × B_a
and the gradient force (Grad B_a)ᵀ(F M̃) come out of the one term
−(F M̃)·B_a(X + u) and are linearised consistently.

Cauchy stress of the elastic part (Abaqus Theory Manual, 4.6.1):
σ = μ J^(-5/3) dev(F Fᵀ) + K (J − 1) I.

Small-strain constants of this law: shear modulus μ, bulk modulus K, so
E = 9Kμ/(3K + μ) and ν = (3K − 2μ)/(2(3K + μ)); with the default K = 100 μ,
ν = 0.4950 and E = 2.990 μ.

2D strips (side view of a uniform-width arm, coordinates (x, z)):

* plane strain (F_yy = 1): J = det F₂, tr C = tr C₂ + 1, the 3D energy
  unchanged. Right for arms much wider than the bending length scale
  √(R t) (anticlastic curvature suppressed; plate stiffness E t³/12(1−ν²)).
* plane stress (σ_yy = 0): the out-of-plane stretch λ solves ∂ψ/∂λ = 0.
  We use its incompressible limit λ = 1/J₂, which is the closed form
  ψ = μ/2 (tr C₂ + J₂⁻² − 3) (Ogden, Non-linear Elastic Deformations, 1984,
  §7.2 thin-sheet energy). Its small-strain Young's modulus is 3μ instead of
  E = 9Kμ/(3K + μ): relative error μ/(3K) = 0.33 % for K = 100 μ. Right for
  narrow beams (width ≲ thickness).

The magnetic term of a strip keeps the in-plane components of M̃ and B_a.

All functions that build UFL are pure: they take UFL expressions (or numbers)
and return UFL expressions; no dolfinx objects are created here.
"""

from __future__ import annotations

import math
from typing import Literal

import ufl

__all__ = [
    "Kinematics",
    "bending_stiffness",
    "cauchy_stress",
    "default_bulk_modulus",
    "deformation_gradient",
    "elastic_energy",
    "energy_density",
    "first_piola_kirchhoff",
    "isochoric_energy",
    "magnetic_energy",
    "magnetoelastic_length",
    "magnetoelastic_time",
    "plane_strain_modulus",
    "poisson_ratio",
    "power_density",
    "volumetric_energy",
    "youngs_modulus",
]

Kinematics = Literal["solid", "plane_strain", "plane_stress"]
"""How a deformation gradient is read: 3D solid or a 2D strip (x, z)."""

BULK_TO_SHEAR = 100.0
"""Default K/μ of the source paper (Wang et al. 2020, following Zhao et al. 2019)."""


# --- derived constants (floats, SI) ---------------------------------------------------------


def default_bulk_modulus(shear_modulus: float) -> float:
    """K = 100 μ (Pa): nearly incompressible elastomer, as in the source simulations."""
    return BULK_TO_SHEAR * shear_modulus


def youngs_modulus(shear_modulus: float, bulk_modulus: float) -> float:
    """Small-strain Young's modulus E = 9Kμ/(3K + μ) (Pa)."""
    return 9.0 * bulk_modulus * shear_modulus / (3.0 * bulk_modulus + shear_modulus)


def poisson_ratio(shear_modulus: float, bulk_modulus: float) -> float:
    """Small-strain Poisson ratio ν = (3K − 2μ)/(2(3K + μ)) (dimensionless)."""
    return (3.0 * bulk_modulus - 2.0 * shear_modulus) / (2.0 * (3.0 * bulk_modulus + shear_modulus))


def plane_strain_modulus(shear_modulus: float, bulk_modulus: float) -> float:
    """E' = E/(1 − ν²) (Pa), the bending modulus of a plate or plane-strain strip."""
    nu = poisson_ratio(shear_modulus, bulk_modulus)
    return youngs_modulus(shear_modulus, bulk_modulus) / (1.0 - nu * nu)


def bending_stiffness(
    shear_modulus: float, bulk_modulus: float, thickness: float, *, plate: bool = True
) -> float:
    """Bending stiffness per unit width (N·m): E' t³/12 (plate) or E t³/12 (beam).

    Args:
        thickness: t (m).
        plate: True for a plate/plane strain (E' = E/(1 − ν²)), False for a
            narrow beam/plane stress (E).
    """
    modulus = (
        plane_strain_modulus(shear_modulus, bulk_modulus)
        if plate
        else youngs_modulus(shear_modulus, bulk_modulus)
    )
    return modulus * thickness**3 / 12.0


def magnetoelastic_length(
    shear_modulus: float, bulk_modulus: float, thickness: float, remanence: float, flux: float
) -> float:
    """ℓ = √(D/(M B t)) = t √(E/(12 M B)) (m): the length over which a magnetised arm bends.

    A thin arm with magnetisation M across its thickness t in a field B has
    the distributed torque M B t sin(φ) per unit area against the bending
    stiffness D = E t³/12; linearised about its equilibrium the angle obeys
    θ'' = (θ − θ_eq)/ℓ², so bends and boundary layers have the width ℓ.
    Resolving a bend to ~1° takes elements of about ℓ/3 along the arm
    (docs/verification.md §4a: the default case, ℓ = 0.86 mm, is within 0.7°
    at 0.25 mm and 5° off at 0.5 mm).
    """
    moment = remanence * flux * thickness
    return math.sqrt(
        bending_stiffness(shear_modulus, bulk_modulus, thickness, plate=False) / moment
    )


def magnetoelastic_time(
    shear_modulus: float,
    bulk_modulus: float,
    thickness: float,
    density: float,
    remanence: float,
    flux: float,
) -> float:
    """τ = ℓ² √(ρ t/D) (s): the time scale of a bend of width ℓ (:func:`magnetoelastic_length`).

    1/ω of a bending wave of wavenumber 1/ℓ (ω = k² √(D/(ρ t)), D = E t³/12):
    the field-driven swing of an arm changes its shape over this time. For the
    default case (80 µm, 2 mT) τ = 2.5 ms.
    """
    ell = magnetoelastic_length(shear_modulus, bulk_modulus, thickness, remanence, flux)
    stiffness = bending_stiffness(shear_modulus, bulk_modulus, thickness, plate=False)
    return ell**2 * math.sqrt(density * thickness / stiffness)


def energy_density(shear_modulus: float, strain: float) -> float:
    """ρE = 3 μ ε²/2 (J/m³) for the largest nominal strain ε (Wang et al. 2020)."""
    return 1.5 * shear_modulus * strain * strain


def power_density(shear_modulus: float, strain: float, frequency: float) -> float:
    """ρW = f ρE (W/m³) at actuation frequency f (Hz)."""
    return frequency * energy_density(shear_modulus, strain)


# --- UFL constitutive functions -------------------------------------------------------------


def deformation_gradient(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """F = I + Grad u, shape (d, d) with d the geometric dimension of u."""
    d = ufl.shape(u)[0]
    return ufl.Identity(d) + ufl.grad(u)


def _invariants(F: ufl.core.expr.Expr, kinematics: Kinematics) -> tuple:
    """(J, tr C) of the 3D deformation, from a 3D or plane-strain 2D F."""
    J = ufl.det(F)
    trC = ufl.tr(F.T * F)
    if kinematics == "plane_strain":
        trC = trC + 1.0
    return J, trC


def elastic_energy(
    F: ufl.core.expr.Expr,
    shear_modulus: ufl.core.expr.Expr | float,
    bulk_modulus: ufl.core.expr.Expr | float,
    kinematics: Kinematics = "solid",
) -> ufl.core.expr.Expr:
    """Neo-Hookean strain energy per reference volume (J/m³).

    Args:
        F: deformation gradient, (3, 3) for ``solid``, (2, 2) for strips.
        shear_modulus: μ (Pa). bulk_modulus: K (Pa; unused for plane stress,
            which takes the incompressible limit, see the module docstring).
        kinematics: ``solid``, ``plane_strain`` or ``plane_stress``.
    """
    return isochoric_energy(F, shear_modulus, kinematics) + volumetric_energy(
        F, bulk_modulus, kinematics
    )


def isochoric_energy(
    F: ufl.core.expr.Expr, shear_modulus: ufl.core.expr.Expr | float, kinematics: Kinematics
) -> ufl.core.expr.Expr:
    """μ/2 (J^(-2/3) tr C − 3) (J/m³); plane stress: μ/2 (tr C₂ + J₂⁻² − 3)."""
    mu = shear_modulus
    if kinematics == "plane_stress":
        J2 = ufl.det(F)
        return mu / 2 * (ufl.tr(F.T * F) + J2 ** (-2) - 3)
    J, trC = _invariants(F, kinematics)
    return mu / 2 * (J ** (-2.0 / 3.0) * trC - 3)


def volumetric_energy(
    F: ufl.core.expr.Expr, bulk_modulus: ufl.core.expr.Expr | float, kinematics: Kinematics
) -> ufl.core.expr.Expr:
    """K/2 (J − 1)² (J/m³); zero for plane stress (incompressible limit)."""
    if kinematics == "plane_stress":
        return ufl.as_ufl(0.0)
    J = ufl.det(F)
    return bulk_modulus / 2 * (J - 1) ** 2


def magnetic_energy(
    F: ufl.core.expr.Expr, magnetization: ufl.core.expr.Expr, flux_density: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """ψ_mag = −(F M̃)·B_a (J/m³).

    Args:
        F: deformation gradient (d, d).
        magnetization: remanent magnetization M̃ in the reference configuration, (d,) A/m.
        flux_density: applied B_a at the current position, (d,) T.
    """
    return -ufl.dot(F * magnetization, flux_density)


def first_piola_kirchhoff(
    F: ufl.core.expr.Expr,
    shear_modulus: ufl.core.expr.Expr | float,
    bulk_modulus: ufl.core.expr.Expr | float,
    kinematics: Kinematics = "solid",
    magnetization: ufl.core.expr.Expr | None = None,
    flux_density: ufl.core.expr.Expr | None = None,
) -> ufl.core.expr.Expr:
    """P = ∂ψ/∂F (Pa), shape of F, from the energy by ``ufl.diff``.

    With ``magnetization`` and ``flux_density`` the magnetic stress −B_a ⊗ M̃
    is included (B_a held fixed: the gradient force enters the residual
    through the dependence of B_a on x, not through P).
    """
    Fv = ufl.variable(F)
    psi = elastic_energy(Fv, shear_modulus, bulk_modulus, kinematics)
    if magnetization is not None and flux_density is not None:
        psi = psi + magnetic_energy(Fv, magnetization, flux_density)
    return ufl.diff(psi, Fv)


def cauchy_stress(F: ufl.core.expr.Expr, P: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """σ = J⁻¹ P Fᵀ (Pa), shape of F."""
    return P * F.T / ufl.det(F)
