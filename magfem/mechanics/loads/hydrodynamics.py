r"""Coefficients of the reduced fluid model: closed forms from the literature, per plate area.

A thin plate of chord b (its width across the direction it moves in) in a
fluid of density ρ and viscosity μ (ν = μ/ρ), moving with the velocity v
relative to the fluid, feels per unit plate area (both faces together)

.. math::

    \mathbf f = -\big(m_a\,a_n + c_n v_n + \tfrac12\rho\,C_{nl}(Re)\,|v_n|\,v_n\big)\,\mathbf n
              - 2\big(c_t + 0.664\sqrt{\rho\mu/L}\;|\mathbf v_t|^{1/2}\big)\,\mathbf v_t ,

v_n = v·n and v_t the normal and tangential parts, a_n the normal
acceleration, Re = |v_n| b/ν. The terms and where they come from:

* **Added mass** m_a = C_m (π/4) ρ b Γ_r(ω): the potential flow of a 2D flat
  plate of chord b moving normal to itself carries ρπb²/4 per unit span
  (Lamb, *Hydrodynamics*, 6th ed. 1932, §71), i.e. (π/4)ρb per unit area;
  Γ_r(ω) → 1 is its viscous correction at the characteristic angular
  frequency ω (Sader, J. Appl. Phys. 84 (1998) 64, the real part of the
  hydrodynamic function of a thin rectangular beam). C_m scales the strip
  value for a plate of finite aspect ratio: an elliptic plate of aspect ratio
  AR has exactly 1/E(e) of it, E the complete elliptic integral of the
  second kind, e² = 1 − 1/AR² (Lamb's elliptic disk, 8/3 ρa³ when circular),
  :func:`elliptic_plate_factor`.
* **Viscous (linear) normal drag** c_n = max(c_s, c_ω): the Stokes drag of a
  disk of diameter b moving broadside, F = 16μaU (Lamb §339), per area
  c_s = 32μ/(πb), valid for Re ≪ 1; and for oscillation at ω the imaginary
  part of Sader's hydrodynamic function, c_ω = (π/4)ρωbΓ_i(ω), valid for
  small amplitudes (Keulegan–Carpenter number KC = 2πA/b ≪ 1) at
  Re_ω = ρωb²/(4μ) from 10⁻⁶ to 10⁴ (the fit's range).
* **Pressure (quadratic) drag**: the broadside disk correlation of Clift,
  Grace & Weber (*Bubbles, Drops and Particles*, 1978),
  C_D(Re) = 64/(πRe) (1 + 0.138 Re^0.792) for 1.5 < Re ≤ 133 and 1.17 above
  (Hoerner, *Fluid-Dynamic Drag*, 1965), continuous at 133. The model takes
  C_D(Re) = max(64/(πRe)(1 + 0.138 Re^0.792), C_D∞) for every Re (the 1.5–133
  branch extended to Re → 0 is within 1 % of Clift's low-Re branches);
  its linear Stokes part is c_s above, so the quadratic part is
  C_nl = C_D − 64/(πRe) = max(0.138 (64/π) Re^−0.208, C_D∞ − 64/(πRe))
  (:func:`nonlinear_drag_coefficient`). C_D∞ = 1.17 by default (a disk;
  a 2D strip has 1.98, Hoerner). Steady flow: valid for slowly varying
  motion (KC ≳ 20); oscillating plates at KC ~ 1–10 shed vortices at their
  edges and the 2D Navier–Stokes cross-check (docs/fluid.md) measures how far
  the model is from a resolved flow there.
* **Skin friction** per face: the laminar boundary layer of a plate of length
  L along the flow, mean C_f = 1.328/√Re_L (Blasius 1908), τ = 0.664
  √(ρμ/L) |v_t|^{3/2}, valid for 10³ ≲ Re_L ≲ 5·10⁵, plus the linear part
  c_t = max(32μ/(3πb), √(ρμω/2)): the Stokes drag of a disk moving edgewise,
  F = (32/3)μaU over its two faces (valid for Re ≪ 1), or the Stokes layer of
  a plate oscillating in its plane at ω (Stokes's second problem).
* **Buoyancy**: the hydrostatic pressure on the closed body, −ρ g per unit
  of its volume.

The ``[fluid] medium`` presets (:data:`magfem.mechanics.fluid_spec.FLUID_MEDIA`):
water at 20 °C (ρ = 998.2 kg/m³, μ = 1.002 mPa·s) and air at 20 °C,
101.325 kPa (ρ = 1.204 kg/m³, μ = 18.13 µPa·s), from the CRC Handbook of
Chemistry and Physics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special

__all__ = [
    "CD_DISK",
    "FluidCoefficients",
    "circular_hydrodynamic_function",
    "describe_fluid",
    "drag_coefficient",
    "elliptic_plate_factor",
    "fluid_coefficients",
    "nonlinear_drag_coefficient",
    "oscillatory_reynolds",
    "rectangular_hydrodynamic_function",
    "regime_estimate",
]

CD_DISK = 1.17
"""Drag coefficient of a disk broadside at high Reynolds number (Hoerner 1965)."""
STOKES_DISK = 64.0 / math.pi
"""C_D·Re of a disk broadside in Stokes flow (F = 16 μ a U, Re on the diameter)."""
CLIFT_FACTOR, CLIFT_POWER = 0.138, 0.792
"""C_D = (64/(π Re)) (1 + 0.138 Re^0.792), 1.5 < Re ≤ 133 (Clift, Grace & Weber 1978)."""
BLASIUS = 0.664
"""Mean skin friction of a laminar flat plate, per face: τ = 0.664 √(ρμ/L) U^(3/2)."""

_OMEGA_REAL = (
    (0.91324, -0.48274, 0.46842, -0.12886, 0.044055, -0.0035117, 0.00069085),
    (1.0, -0.56964, 0.48690, -0.13444, 0.045155, -0.0035862, 0.00069085),
)
_OMEGA_IMAG = (
    (-0.024134, -0.029256, 0.016294, -0.00010961, 0.000064577, -0.000044510),
    (1.0, -0.59702, 0.55182, -0.18357, 0.079156, -0.014369, 0.0028361),
)


def oscillatory_reynolds(density: float, viscosity: float, omega: float, chord: float) -> float:
    """Re_ω = ρ ω b²/(4μ) of a plate of chord b (m) oscillating at ω (rad/s), Sader's."""
    return density * omega * chord**2 / (4.0 * viscosity)


def circular_hydrodynamic_function(re: float) -> complex:
    """Γ of a circular cylinder of diameter b oscillating at Re_ω (Stokes 1851; Sader 1998).

    Γ = 1 + 4i K₁(−i√(iRe)) / (√(iRe) K₀(−i√(iRe))); the force per length is
    (π/4) ρ ω² b² Γ times the displacement amplitude.
    """
    root = np.sqrt(1j * re)
    return complex(1.0 + 4j * special.kv(1, -1j * root) / (root * special.kv(0, -1j * root)))


def rectangular_hydrodynamic_function(re: float) -> complex:
    """Γ of a thin rectangular beam of width b at Re_ω (Sader 1998).

    Γ_rect = Ω(τ) Γ_circ, τ = log₁₀ Re_ω, Ω Sader's rational fit (0.1 % over
    10⁻⁶ ≤ Re_ω ≤ 10⁴). Γ_r → 1 (potential flow) as Re_ω → ∞.
    """
    tau = math.log10(re)
    real = np.polyval(_OMEGA_REAL[0][::-1], tau) / np.polyval(_OMEGA_REAL[1][::-1], tau)
    imag = np.polyval(_OMEGA_IMAG[0][::-1], tau) / np.polyval(_OMEGA_IMAG[1][::-1], tau)
    return complex(real + 1j * imag) * circular_hydrodynamic_function(re)


def elliptic_plate_factor(aspect: float) -> float:
    """Added mass of an elliptic plate over its strip-theory value, 1/E(e) (aspect ≥ 1).

    e² = 1 − 1/aspect²: 2/π = 0.637 for a disk, 0.826 at aspect 2, 0.933 at 4, → 1.
    """
    if aspect < 1.0:
        raise ValueError(f"aspect ratio must be >= 1, got {aspect}")
    return 1.0 / float(special.ellipe(1.0 - 1.0 / aspect**2))


def drag_coefficient(re: float, cd_inf: float = CD_DISK) -> float:
    """C_D(Re) of a plate broadside, Re on its chord: max(64/(πRe)(1 + 0.138 Re^0.792), C_D∞)."""
    if re <= 0.0:
        return math.inf
    return max(STOKES_DISK / re * (1.0 + CLIFT_FACTOR * re**CLIFT_POWER), cd_inf)


def nonlinear_drag_coefficient(re: float, cd_inf: float = CD_DISK) -> float:
    """C_nl(Re) = C_D(Re) − 64/(πRe): the part of :func:`drag_coefficient` beyond Stokes drag."""
    if re <= 0.0:
        return math.inf
    return max(STOKES_DISK * CLIFT_FACTOR * re ** (CLIFT_POWER - 1.0), cd_inf - STOKES_DISK / re)


@dataclass(frozen=True)
class FluidCoefficients:
    """The coefficients of the module's model for one plate (SI).

    Attributes:
        density, viscosity: ρ (kg/m³), μ (Pa·s).
        chord: b (m). friction_length: L (m).
        frequency: the characteristic frequency f (Hz); 0 for steady flow.
        hydrodynamic: Γ(ω) of the thin beam (1 for steady flow).
        added_mass: m_a (kg/m² of plate).
        normal_damping: c_n (Pa·s/m per plate area).
        stokes_damping: c_s (Pa·s/m per plate area).
        tangential_damping: c_t (Pa·s/m per face).
        drag_coefficient: C_D∞, the high-Reynolds drag coefficient.
    """

    density: float
    viscosity: float
    chord: float
    friction_length: float
    frequency: float
    hydrodynamic: complex
    added_mass: float
    normal_damping: float
    stokes_damping: float
    tangential_damping: float
    drag_coefficient: float

    @property
    def kinematic_viscosity(self) -> float:
        """ν = μ/ρ (m²/s)."""
        return self.viscosity / self.density

    @property
    def oscillatory_reynolds(self) -> float:
        """Re_ω = ρωb²/(4μ) at the characteristic frequency (0 for steady flow)."""
        omega = 2.0 * math.pi * self.frequency
        return oscillatory_reynolds(self.density, self.viscosity, omega, self.chord)


def fluid_coefficients(
    density: float,
    viscosity: float,
    chord: float,
    *,
    frequency: float = 0.0,
    friction_length: float | None = None,
    added_mass_coefficient: float = 1.0,
    drag_coefficient: float = CD_DISK,
) -> FluidCoefficients:
    """The model's coefficients for a plate of chord b (m) in a fluid (module docstring).

    Args:
        density, viscosity: ρ (kg/m³) and μ (Pa·s), both > 0.
        chord: b (m) > 0.
        frequency: characteristic frequency (Hz) ≥ 0; 0 gives the steady-flow
            coefficients (Γ = 1, no Stokes layers).
        friction_length: L of the skin friction (m); default the chord.
        added_mass_coefficient: C_m (1: strip theory).
        drag_coefficient: C_D∞.
    """
    omega = 2.0 * math.pi * frequency
    stokes = 32.0 * viscosity / (math.pi * chord)
    edgewise = 32.0 * viscosity / (3.0 * math.pi * chord)
    gamma = complex(1.0)
    oscillating = 0.0
    layer = 0.0
    if omega > 0.0:
        gamma = rectangular_hydrodynamic_function(
            oscillatory_reynolds(density, viscosity, omega, chord)
        )
        oscillating = 0.25 * math.pi * density * omega * chord * gamma.imag
        layer = math.sqrt(0.5 * density * viscosity * omega)
    return FluidCoefficients(
        density=density,
        viscosity=viscosity,
        chord=chord,
        friction_length=friction_length or chord,
        frequency=frequency,
        hydrodynamic=gamma,
        added_mass=added_mass_coefficient * 0.25 * math.pi * density * chord * gamma.real,
        normal_damping=max(stokes, oscillating),
        stokes_damping=stokes,
        tangential_damping=max(edgewise, layer),
        drag_coefficient=drag_coefficient,
    )


def regime_estimate(
    coefficients: FluidCoefficients, amplitude: float, current: float = 0.0
) -> tuple[float, float, float]:
    """(speed U m/s, Re = Ub/ν, KC = 2πA/b) of a stroke of amplitude A (m) at the frequency.

    U = 2πfA + |current|; KC is 0 for steady flow (f = 0).
    """
    c = coefficients
    speed = 2.0 * math.pi * c.frequency * amplitude + current
    kc = 2.0 * math.pi * amplitude / c.chord if c.frequency > 0 else 0.0
    return speed, speed * c.chord / c.kinematic_viscosity, kc


def describe_fluid(
    coefficients: FluidCoefficients, *, areal_mass: float, amplitude: float, current: float
) -> list[str]:
    """Lines for ``magfem check``: each coefficient with its source and validity, and the regime.

    Args:
        coefficients: the model's coefficients.
        areal_mass: the robot's mass per area ρ_s t (kg/m²).
        amplitude: the stroke amplitude estimate A (m).
        current: the current's speed (m/s).
    """
    c = coefficients
    gamma = c.hydrodynamic
    lines = [
        f"added mass     m_a = {c.added_mass:.4g} kg/m^2 ({c.added_mass / areal_mass:.3g} x the "
        f"robot's {areal_mass:.3g} kg/m^2): (pi/4) rho b of a 2D plate in potential flow "
        "(Lamb 1932, 71)"
        + (
            f" x Gamma_r = {gamma.real:.3g} at Re_w = {c.oscillatory_reynolds:.3g} (Sader 1998; "
            "fit valid for 1e-6 <= Re_w <= 1e4, small amplitude KC << 1)"
            if c.frequency > 0
            else " (steady flow: no viscous correction)"
        ),
        f"normal drag    c_n = {c.normal_damping:.4g} Pa*s/m per area: the larger of the Stokes "
        f"drag of a broadside disk {c.stokes_damping:.3g} (Lamb 1932, 339; Re << 1)"
        + (
            f" and Sader's viscous part (pi/4) rho w b Gamma_i, Gamma_i = {gamma.imag:.3g}"
            if c.frequency > 0
            else ""
        )
        + "; plus 1/2 rho (C_D - 64/(pi Re)) |v|v, C_D(Re) = max(64/(pi Re)(1 + 0.138 "
        f"Re^0.792), {c.drag_coefficient:g}) (Clift, Grace & Weber 1978; Hoerner 1965; "
        "steady flow)",
        f"friction       c_t = {c.tangential_damping:.3g} Pa*s/m per face (Stokes drag of an "
        "edgewise disk, Re << 1"
        + (", or the Stokes layer sqrt(rho mu w/2)" if c.frequency > 0 else "")
        + f") plus laminar 0.664 sqrt(rho mu/L)|v|^1.5, L = {c.friction_length * 1e3:.3g} mm "
        "(Blasius 1908; 1e3 <~ Re_L <~ 5e5)",
    ]
    speed, re, kc = regime_estimate(c, amplitude, current)
    regime = (
        f"regime         stroke amplitude ~ {amplitude * 1e3:.3g} mm at {c.frequency:g} Hz"
        + (f" in a {current:.3g} m/s current" if current else "")
        + f": U ~ {speed:.3g} m/s, Re ~ {re:.3g}, KC ~ {kc:.3g} (estimates; the run records "
        "fluid_reynolds)"
    )
    lines.append(regime)
    if c.frequency > 0 and kc > 1.0:
        lines.append(
            f"validity       KC ~ {kc:.2g}: beyond small amplitude (KC << 1) and below steady "
            "flow (KC >~ 20); the 2D Navier-Stokes cross-check gives the model's error there "
            "(docs/fluid.md)"
        )
    return lines
