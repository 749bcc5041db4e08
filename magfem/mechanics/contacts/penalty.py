r"""The penalty contact law shared by the ground and the obstacles.

A point of the body at penetration δ into a rigid surface (δ > 0 inside;
the ground: δ = h_g − x_v) with unit normal e_v pointing out of the rigid
body carries a traction per *reference* area

.. math::

    \mathbf t = p_n\,\mathbf e_v
        - \mu_f\,p_n\,\frac{\mathbf v_t}{\sqrt{\mathbf v_t\cdot\mathbf v_t + v_\varepsilon^2}},
    \qquad
    p_n = \big\langle k_n\,r(\delta) + c_n\,s(\delta)\,\dot\delta \big\rangle_+ ,

with the penetration δ (m), its rate :math:`\dot\delta = -v_v` (m/s) where
:math:`v_v = \mathbf v\cdot\mathbf e_v` is the normal velocity relative to the
rigid surface, the tangential velocity
:math:`\mathbf v_t = \mathbf v - v_v\mathbf e_v` and
:math:`\langle a\rangle_+ = \max(a, 0)`.

Normal law (penalty).
    :math:`r` is a C¹ ramp that is *exactly zero for a positive gap* (a
    sqrt-smoothed penalty pulls on the body from afar, see
    docs/mechanics.md, "Ground contact"):

    .. math::

        r(\delta) = 0 \ (\delta \le 0),\quad
        \frac{\delta^2}{2\delta_0}\ (0 < \delta < \delta_0),\quad
        \delta - \frac{\delta_0}{2}\ (\delta \ge \delta_0).

    The onset width :math:`\delta_0` removes the kink of the plain ramp
    (Newton then sees a continuous tangent when a quadrature point crosses
    the ground). The stiffness is scaled with the membrane,
    :math:`k_n = \kappa\,\mu/h` (Pa/m), so that a pressure ``p`` penetrates
    by ``p h / (κ μ)``: 1/κ of the shear strain the same pressure would
    cause in the layer. This keeps the contact stiffness below the
    through-thickness stiffness of one element (≈ 100 μ/h for K = 100 μ)
    for κ ≲ 100, which is what keeps a thin P2 plate from inverting its
    bottom layer on impact; results converge as κ grows (see
    ``docs/verification.md``). The static penetration under a pressure
    ``p`` is the inverse of ``r``: :func:`penalty_penetration`.

Impact damping.
    :math:`c_n\,s(\delta)\,\dot\delta` is a contact dashpot that switches on
    continuously with the penetration (:math:`s = \min(\delta/\delta_0, 1)`
    for :math:`\delta > 0`, else 0; the Hunt–Crossley idea of a damping force
    that vanishes at first touch). :math:`c_n = 2\zeta\sqrt{k_n\rho h}` is
    ζ times the critical damping of the membrane (mass ρh per area) on the
    penalty spring. It dissipates the impact energy of a falling plate in the
    contact layer instead of letting it ring through the stiff thickness
    mode. The bracket keeps the pressure compressive (no adhesion while
    the body lifts off).

Friction (regularised Coulomb).
    The tangential traction is :math:`\mu_f p_n` opposite to the sliding
    velocity when :math:`|\mathbf v_t| \gg v_\varepsilon`, and viscous
    (:math:`\mu_f p_n \mathbf v_t / v_\varepsilon`) near sticking. A block
    sliding at speed ``v`` then decelerates at
    :math:`\mu_f g\,v/\sqrt{v^2 + v_\varepsilon^2}`, within
    :math:`(v_\varepsilon/v)^2/2` of :math:`\mu_f g` (Wriggers,
    *Computational Contact Mechanics*, 2nd ed., Springer 2006, §5.2 for the
    penalty and regularised-friction laws).

    Stick on tiny steps. With the velocity of the time integrator,
    :math:`\partial\mathbf v/\partial\mathbf u = \gamma/(\beta\Delta t)`, so the
    tangent of the viscous branch grows like :math:`\mu_f p_n/(v_\varepsilon\Delta t)`
    and Newton stalls when an impact forces Δt down to ~1e-6 s (the default
    case's arm landing on its top face at t ≈ 30 ms). The solver therefore
    passes Δt, and the regularisation is
    :math:`\sqrt{v_\varepsilon^2 + (\ell/\Delta t)^2}`: a slip of ℓ per step
    is "sticking". At the nominal step this is a few mm/s (ℓ = 0.01 h,
    Δt = 0.5 ms: 1.6 mm/s for 80 µm) and changes sliding by
    :math:`(\ell/(v\Delta t))^2/2`; on the tiny steps of an impact the
    friction tangent stays bounded by :math:`\mu_f p_n/\ell`, an elastic
    stick of stiffness μ_f p_n/ℓ.

Both laws are written with the *current* position and velocity as UFL
expressions of the unknown displacement, so ``ufl.derivative`` gives their
exact linearisation (including the dependence of the velocity on the
displacement through the time integrator). Tractions are per reference
area: for the membranes here (stretch ≈ 1 at the contact) the difference
from the current area is the in-plane strain, ≲ 1e-2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import ufl

__all__ = [
    "ContactParameters",
    "PenaltyLaw",
    "contact_stiffness",
    "create_penalty_law",
    "critical_contact_damping",
    "penalty_energy",
    "penalty_penetration",
    "penalty_ramp",
]


class ContactParameters(Protocol):
    """What :func:`create_penalty_law` reads from the ``[contact]`` table.

    ``magfem.mechanics.spec.ContactSpec`` provides these attributes.
    """

    @property
    def friction(self) -> float:
        """Coulomb coefficient μ_f (-)."""
        ...

    @property
    def penalty(self) -> float:
        """κ (-): k_n = κ μ / h."""
        ...

    @property
    def penalty_onset(self) -> float:
        """δ0 / h (-): width of the C¹ onset of the ramp."""
        ...

    @property
    def damping(self) -> float:
        """ζ (-): contact dashpot as a fraction of critical."""
        ...

    @property
    def regularization_velocity(self) -> float:
        """v_ε (m/s)."""
        ...


@dataclass(frozen=True)
class PenaltyLaw:
    """Constants of the penalty contact law, SI units.

    Attributes:
        stiffness: penalty stiffness k_n (Pa/m = N/m³; N/m² per m in 2D).
        onset: width δ0 > 0 of the C¹ onset of the penalty ramp (m).
        damping: contact dashpot c_n (Pa·s/m) >= 0.
        friction: Coulomb coefficient μ_f >= 0.
        regularization_velocity: v_ε > 0 (m/s).
        slip_length: ℓ >= 0 (m); with a time step Δt the friction is
            regularised by sqrt(v_ε² + (ℓ/Δt)²) instead of v_ε.
    """

    stiffness: float
    onset: float
    damping: float = 0.0
    friction: float = 0.5
    regularization_velocity: float = 1e-3
    slip_length: float = 0.0

    def __post_init__(self) -> None:
        # programming errors only: user input is validated by ContactSpec
        for name in ("stiffness", "onset", "regularization_velocity"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"PenaltyLaw.{name} must be finite and > 0, got {value!r}")
        for name in ("damping", "friction", "slip_length"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"PenaltyLaw.{name} must be finite and >= 0, got {value!r}")


def contact_stiffness(penalty: float, shear_modulus: float, thickness: float) -> float:
    """Penalty stiffness k_n = κ μ / h (Pa/m).

    Args:
        penalty: κ (-), the ratio of contact stiffness to the layer's shear stiffness.
        shear_modulus: μ (Pa).
        thickness: membrane thickness h (m).
    """
    return penalty * shear_modulus / thickness


def critical_contact_damping(stiffness: float, density: float, thickness: float) -> float:
    """Critical damping 2 sqrt(k_n ρ h) (Pa·s/m) of a membrane of mass ρh per area on k_n."""
    return 2.0 * math.sqrt(stiffness * density * thickness)


def create_penalty_law(
    spec: ContactParameters, *, shear_modulus: float, density: float, thickness: float
) -> PenaltyLaw:
    """The SI penalty law of a ``[contact]`` table for a membrane of the given material.

    Args:
        spec: the validated ``[contact]`` table (``ContactSpec``).
        shear_modulus: μ (Pa).
        density: ρ (kg/m³).
        thickness: membrane thickness h (m); the length that scales k_n and δ0.
    """
    k_n = contact_stiffness(spec.penalty, shear_modulus, thickness)
    return PenaltyLaw(
        stiffness=k_n,
        onset=spec.penalty_onset * thickness,
        damping=spec.damping * critical_contact_damping(k_n, density, thickness),
        friction=spec.friction,
        regularization_velocity=spec.regularization_velocity,
        slip_length=getattr(spec, "slip_length", 0.0) * thickness,
    )


def penalty_ramp(delta: Any, onset: Any) -> tuple[Any, Any]:
    """C¹ ramp r(δ) and its switch s(δ) = r'(δ) (UFL).

    Args:
        delta: penetration δ (m), UFL scalar.
        onset: δ0 > 0 (m), UFL scalar.

    Returns:
        ``(r, s)``: r in m, exactly 0 for δ <= 0; s in [0, 1].
    """
    inside = ufl.lt(delta, onset)
    r = ufl.conditional(
        ufl.le(delta, 0.0),
        0.0,
        ufl.conditional(inside, delta**2 / (2.0 * onset), delta - onset / 2.0),
    )
    s = ufl.conditional(ufl.le(delta, 0.0), 0.0, ufl.conditional(inside, delta / onset, 1.0))
    return r, s


def penalty_penetration(pressure: float, stiffness: float, onset: float) -> float:
    """Static penetration δ (m) of the C¹ penalty ramp carrying ``pressure`` (Pa).

    Inverse of p = k_n r(δ): sqrt(2 δ0 p/k_n) below p/k_n = δ0/2, p/k_n + δ0/2 above.
    """
    q = pressure / stiffness
    if q <= 0.0:
        return 0.0
    if q < onset / 2.0:
        return math.sqrt(2.0 * onset * q)
    return q + onset / 2.0


def penalty_energy(delta: Any, onset: Any) -> Any:
    """R(δ) = ∫₀^δ r (m²), the potential of the C¹ ramp r of :func:`penalty_ramp` (UFL).

    0 for δ <= 0, δ³/(6δ0) on the onset, δ²/2 − δ0 δ/2 + δ0²/6 beyond.
    """
    return ufl.conditional(
        ufl.le(delta, 0.0),
        0.0,
        ufl.conditional(
            ufl.lt(delta, onset),
            delta**3 / (6.0 * onset),
            delta**2 / 2.0 - onset * delta / 2.0 + onset**2 / 6.0,
        ),
    )
