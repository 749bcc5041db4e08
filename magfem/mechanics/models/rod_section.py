r"""Section constants of the rod model: a thin rectangular section b × t, and its bending law.

Small-strain isotropic elasticity with the case's μ and ν (E = 2μ(1 + ν)):
axial EA and shear (5/6) μ A with A = b t; torsion μ J_t with Saint-Venant's
constant of a rectangle a × c (a ≥ c; Roark's formula, error < 0.5 %)

.. math::

    J_t = a c^3 \Big(\tfrac13 - 0.21\,\tfrac ca\big(1 - \tfrac{c^4}{12 a^4}\big)\Big);

bending within the membrane's plane (about its normal) E t b³/12; bending
out of the plane (about the width axis), three laws (``[mesh] rod_bending``):

* ``beam``: E b t³/12, a narrow arm whose cross-section curls freely;
* ``plate``: D b with D = E t³/(12(1 − ν²)), a wide arm whose anticlastic
  curl is suppressed (the plane-strain strip);
* ``anticlastic`` (default): between the two, after Ashwell (The anticlastic
  curvature of rectangular beams and plates, J. R. Aeronaut. Soc. 54 (1950)
  708–715). A strip bent to curvature κ curls across its width into a shape
  w(y) that minimises the plate's bending energy plus the stretching energy
  of its longitudinal fibres, (E t κ²/2) ∫ (w − w̄)² dy: the cross-section is
  a beam on an elastic foundation of modulus E t κ², with free edges
  (M_y = V_y = 0). Its minimum energy per unit length is

  .. math::

      W(\kappa) = \frac{D b \kappa^2}{2}\big(1 - \nu^2 \phi(x)\big),\quad
      \phi(x) = \frac2x\,\frac{\cosh x - \cos x}{\sinh x + \sin x},\quad
      x^4 = 3(1 - \nu^2)\,\frac{b^4 \kappa^2}{t^2},

  so the stiffness goes from the beam's (x → 0, φ → 1) to the plate's
  (x → ∞, φ ≈ 2/x): a strip bends like a beam while its bend radius R is
  large against b²/t and like a plate once it is small (Searle's parameter
  b²/(R t)). φ is an entire function of u = x⁴ ∝ κ² (:func:`ashwell_phi`
  uses its series below x = 2 and the closed form above), so W is smooth
  at κ = 0. The moment M = dW/dκ is not W's secant D b κ (1 − ν² φ); the
  test checks W against the minimised energy of the discretised
  cross-section. The law is quasi-static across the width (the curl follows
  the bend at once: its foundation frequency κ √(E/ρ) is kHz at R ~ 1 mm)
  and ignores the clamp, which also holds the curl near a bonded root.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl

__all__ = [
    "SHEAR_CORRECTION",
    "ashwell_phi",
    "ashwell_phi_ufl",
    "bending_energy",
    "torsion_constant",
]

SHEAR_CORRECTION = 5.0 / 6.0
"""Shear correction factor of a rectangular section (Reissner)."""

_TERMS = 7
"""Series terms of φ(u) below x = 2 (the next term is < 1e-20 there)."""
_SERIES_BELOW = 16.0
"""u = x⁴ below which the series is used (x = 2)."""
_ASYMPTOTIC_ABOVE = 40.0
"""x above which φ = 2/x to double precision (cosh would overflow near 710)."""


def _series(u: Any, n_terms: int = _TERMS) -> tuple[Any, Any]:
    """(Σ 2uᵏ/(4k+2)!, Σ uᵏ/(4k+1)!): (cosh x − cos x)/x² and (sinh x + sin x)/(2x)."""
    num = 0.0
    den = 0.0
    for k in range(n_terms):
        num = num + 2.0 * u**k / float(math.factorial(4 * k + 2))
        den = den + u**k / float(math.factorial(4 * k + 1))
    return num, den


def ashwell_phi(x: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """φ(x) of the module docstring (numpy, x ≥ 0)."""
    x = np.asarray(x, dtype=float)
    u = x**4
    num, den = _series(u)
    small = num / den
    big = np.minimum(x, _ASYMPTOTIC_ABOVE)
    with np.errstate(divide="ignore", invalid="ignore"):
        closed = (2.0 / big) * (np.cosh(big) - np.cos(big)) / (np.sinh(big) + np.sin(big))
    out = np.where(u < _SERIES_BELOW, small, closed)
    return np.where(x > _ASYMPTOTIC_ABOVE, 2.0 / np.maximum(x, 1e-300), out)


def ashwell_phi_ufl(u: Any) -> Any:
    """φ as a UFL expression of u = x⁴ ≥ 0 (smooth in κ: u ∝ κ²)."""
    num, den = _series(u)
    x = (u + 1e-300) ** 0.25
    closed = (2.0 / x) * (ufl.cosh(x) - ufl.cos(x)) / (ufl.sinh(x) + ufl.sin(x))
    far = ufl.conditional(ufl.gt(x, _ASYMPTOTIC_ABOVE), 2.0 / x, closed)
    return ufl.conditional(ufl.lt(u, _SERIES_BELOW), num / den, far)


def torsion_constant(width: Any, thickness: Any) -> Any:
    """Saint-Venant torsion constant J_t (m⁴) of a b × t rectangle (UFL or numpy)."""
    if isinstance(width, float | int | np.ndarray) and isinstance(thickness, float | int):
        a = np.maximum(width, thickness)
        c = np.minimum(width, thickness)
    else:
        a = ufl.max_value(width, thickness)
        c = ufl.min_value(width, thickness)
    r = c / a
    return a * c**3 * (1.0 / 3.0 - 0.21 * r * (1.0 - r**4 / 12.0))


def bending_energy(
    kappa: Any, width: Any, thickness: float, young: Any, poisson: float, law: str
) -> Any:
    """Energy per unit length (J/m) of out-of-plane bending at curvature κ (1/m), UFL.

    Args:
        kappa: curvature about the width axis (UFL scalar).
        width: section width b (m, UFL scalar).
        thickness: t (m). young: E (Pa). poisson: ν.
        law: ``anticlastic``, ``beam`` or ``plate`` (module docstring).
    """
    t = thickness
    if law == "beam":
        return 0.5 * young * width * t**3 / 12.0 * kappa**2
    plate = young * t**3 / (12.0 * (1.0 - poisson**2)) * width
    if law == "plate":
        return 0.5 * plate * kappa**2
    if law != "anticlastic":
        raise ValueError(f"unknown rod bending law {law!r}")
    u = 3.0 * (1.0 - poisson**2) * width**4 * kappa**2 / t**2
    return 0.5 * plate * kappa**2 * (1.0 - poisson**2 * ashwell_phi_ufl(u))
