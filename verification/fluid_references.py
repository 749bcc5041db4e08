r"""Independent references for a thin plate in a fluid: published closed forms, no FE code.

1. Hydrodynamic function of a thin rectangular beam
---------------------------------------------------
Sader, "Frequency response of cantilever beams immersed in viscous fluids
with applications to the atomic force microscope", J. Appl. Phys. 84, 64
(1998). A beam of width b oscillating normal to itself at ω in a fluid
(ρ, μ) feels the force per length (π/4) ρ ω² b² Γ(ω) ŵ, with
Re_ω = ρωb²/(4μ) and Γ = Ω(τ) Γ_circ (τ = log₁₀ Re_ω): Γ_circ the exact
function of a circular cylinder of diameter b (Stokes 1851), here written
with Hankel functions (K_ν(z) = (π/2) i^(ν+1) H⁽¹⁾_ν(iz)),

.. math::

    \Gamma_{circ} = 1 - \frac{4 H^{(1)}_1(\sqrt{i Re})}{\sqrt{i Re}\,H^{(1)}_0(\sqrt{i Re})},

and Ω Sader's rational fit of the thin strip's correction (accurate to
0.1 % for 10⁻⁶ ≤ Re_ω ≤ 10⁴). A uniform cantilever of
thickness h and density ρ_c then resonates, for a quality factor well
above 1, at ω_R and with the quality factor Q (T the mass ratio)

.. math::

    \frac{\omega_R}{\omega_{vac}} = \Big(1 + T\,\Gamma_r(\omega_R)\Big)^{-1/2},\qquad
    Q = \frac{1/T + \Gamma_r(\omega_R)}{\Gamma_i(\omega_R)},\qquad
    T = \frac{\pi \rho b}{4 \rho_c h}.

These are also exactly the undamped natural frequency and quality factor
of a single mode with the added mass and damping of Γ at ω_R, which is what
a free decay measures (ω_R = ω_d/√(1 − ζ²), Q = 1/(2ζ)).

2. Steady drag of a disk broadside
----------------------------------
Clift, Grace & Weber, *Bubbles, Drops and Particles* (1978): C_D of a thin
disk of diameter d moving normal to itself, Re = U d/ν:

* Re < 0.01: C_D = 64/(πRe) (1 + Re/(2π)) (Oseen's correction of Stokes' 16μaU);
* 0.01 ≤ Re ≤ 1.5: C_D = 64/(πRe) (1 + 10^x), x = −0.883 + 0.906 log Re − 0.025 (log Re)²;
* 1.5 < Re ≤ 133: C_D = 64/(πRe) (1 + 0.138 Re^0.792);
* Re > 133: C_D = 1.17.

A plate of thickness h and density ρ_p settling broadside in a fluid of
density ρ at its terminal speed U carries its apparent weight on the drag:
(ρ_p − ρ) g h = ½ ρ C_D(Re) U² (:func:`terminal_velocity`). From rest, with
the added mass m_a per area of a plate started impulsively (potential flow:
the whole fluid motion appears at once, Lamb §71: ρπb²/4 per length of a
2D plate of chord b), (ρ_p h + m_a) dU/dt = (ρ_p − ρ) g h − ½ρ C_D U²
(:func:`settling_velocity`); its first instant is the impulsive start,
a₀ = (ρ_p − ρ) g h / (ρ_p h + m_a), with the added-mass force −m_a a₀.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import integrate, optimize, special

__all__ = [
    "disk_drag_coefficient",
    "mass_ratio",
    "sader_gamma",
    "sader_resonance",
    "settling_velocity",
    "terminal_velocity",
]

_OMEGA_R_NUM = (0.91324, -0.48274, 0.46842, -0.12886, 0.044055, -0.0035117, 0.00069085)
_OMEGA_R_DEN = (1.0, -0.56964, 0.48690, -0.13444, 0.045155, -0.0035862, 0.00069085)
_OMEGA_I_NUM = (-0.024134, -0.029256, 0.016294, -0.00010961, 0.000064577, -0.000044510)
_OMEGA_I_DEN = (1.0, -0.59702, 0.55182, -0.18357, 0.079156, -0.014369, 0.0028361)


def _series(coefficients: tuple[float, ...], tau: float) -> float:
    return sum(c * tau**k for k, c in enumerate(coefficients))


def sader_gamma(re: float) -> complex:
    """Γ(Re_ω) of a thin rectangular beam (section 1 of the module docstring)."""
    root = np.sqrt(1j * re)
    circular = 1.0 - 4.0 * special.hankel1(1, root) / (root * special.hankel1(0, root))
    tau = math.log10(re)
    omega = complex(
        _series(_OMEGA_R_NUM, tau) / _series(_OMEGA_R_DEN, tau),
        _series(_OMEGA_I_NUM, tau) / _series(_OMEGA_I_DEN, tau),
    )
    return complex(omega * circular)


def mass_ratio(fluid_density: float, width: float, beam_density: float, thickness: float) -> float:
    """T = πρb/(4ρ_c h): the fluid's added mass over the beam's, per length."""
    return math.pi * fluid_density * width / (4.0 * beam_density * thickness)


def sader_resonance(
    vacuum_frequency: float,
    *,
    fluid_density: float,
    viscosity: float,
    width: float,
    beam_density: float,
    thickness: float,
) -> tuple[float, float]:
    """(f_R in Hz, Q) of a cantilever whose vacuum frequency is ``vacuum_frequency`` (Hz).

    Solves ω_R = ω_vac (1 + T Γ_r(ω_R))^(−1/2) (Sader 1998) and returns
    Q = (1/T + Γ_r)/Γ_i at ω_R.
    """
    t = mass_ratio(fluid_density, width, beam_density, thickness)

    def reynolds(f: float) -> float:
        return fluid_density * 2.0 * math.pi * f * width**2 / (4.0 * viscosity)

    def mismatch(f: float) -> float:
        return f - vacuum_frequency / math.sqrt(1.0 + t * sader_gamma(reynolds(f)).real)

    f = optimize.brentq(mismatch, 1e-6 * vacuum_frequency, vacuum_frequency, xtol=1e-14)
    gamma = sader_gamma(reynolds(f))
    return f, (1.0 / t + gamma.real) / gamma.imag


def disk_drag_coefficient(re: float) -> float:
    """C_D(Re) of a disk broadside (Clift, Grace & Weber 1978; section 2)."""
    stokes = 64.0 / (math.pi * re)
    if re < 0.01:
        return stokes * (1.0 + re / (2.0 * math.pi))
    if re <= 1.5:
        lg = math.log10(re)
        return stokes * (1.0 + 10.0 ** (-0.883 + 0.906 * lg - 0.025 * lg**2))
    if re <= 133.0:
        return stokes * (1.0 + 0.138 * re**0.792)
    return 1.17


def _drag(speed: float, density: float, viscosity: float, chord: float) -> float:
    """½ρ C_D U² (Pa) of a disk of diameter ``chord`` broadside at ``speed`` (m/s)."""
    if speed <= 0.0:
        return 0.0
    re = density * speed * chord / viscosity
    return 0.5 * density * disk_drag_coefficient(re) * speed**2


def terminal_velocity(load: float, *, density: float, viscosity: float, chord: float) -> float:
    """U (m/s) at which the broadside drag ½ρ C_D(Re) U² equals ``load`` (Pa)."""
    return optimize.brentq(
        lambda u: _drag(u, density, viscosity, chord) - load, 1e-12, 100.0, xtol=1e-15
    )


def settling_velocity(
    times: NDArray[np.float64],
    *,
    load: float,
    inertia: float,
    density: float,
    viscosity: float,
    chord: float,
) -> NDArray[np.float64]:
    """U(t) (m/s) of a plate from rest: ``inertia`` dU/dt = ``load`` − ½ρ C_D U² (section 2).

    Args:
        times: (N,) increasing, from 0 (s).
        load: the apparent weight per area (Pa). inertia: ρ_p h + m_a (kg/m²).
    """

    def rhs(_t: float, u: NDArray[np.float64]) -> list[float]:
        return [(load - _drag(float(u[0]), density, viscosity, chord)) / inertia]

    sol = integrate.solve_ivp(
        rhs, (0.0, float(times[-1])), [0.0], t_eval=times, rtol=1e-10, atol=1e-14
    )
    return np.asarray(sol.y[0])
