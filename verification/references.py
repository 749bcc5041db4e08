r"""Independent reference solutions the mechanics is verified against.

Nothing here uses the finite-element code: closed forms, scipy ODE/BVP
solves and quadratures, each with its derivation and source.

1. Hard-magnetic elastica (static cantilever in a uniform field)
-----------------------------------------------------------------
Wang, Zhao et al., "Hard-magnetic elastica", J. Mech. Phys. Solids 142,
104045 (2020), doi:10.1016/j.jmps.2020.104045. An inextensible, unshearable
rod of length L, cross-section A, bending stiffness E'I, carries a
remanent magnetization of magnitude M (A/m) at angle α to its tangent
(α = π/2: magnetized through the thickness). In the reference state it lies
along +x; the uniform applied flux density B (T) makes angle φ with +x in
the bending plane. With θ(s) the rotation of the cross-section (angle of
the tangent from +x, positive towards the second in-plane axis) the
magnetization in the current state is rotated by θ (rigid-cross-section
kinematics: F M̃ = R M̃ to first order in the strain), so the energy per
unit length is

.. math::

    \frac{E'I}{2}\,\theta'^2 - A M B\cos(\theta + \alpha - \varphi).

The magnetic load is a distributed body couple m = A M B sin(φ − α − θ);
a uniform field exerts no net force. Stationarity gives the
hard-magnetic elastica with clamped–free boundary conditions

.. math::

    E'I\,\theta'' = A M B \sin(\theta + \alpha - \varphi),\quad
    \theta(0) = 0,\quad \theta'(L) = 0,

or with s̄ = s/L, θ'' = λ sin(θ + α − φ), where the single load parameter
is (rectangular section, thickness h: I/A = h²/12)

.. math::

    \lambda = \frac{A M B L^2}{E' I} = \frac{12\,M B L^2}{E' h^2}.

For the case of the experiments (α = π/2, φ = 0: field along the arm,
magnetization through the thickness) θ'' = λ cos θ: the tip turns towards
−π/2 (the magnetization aligns with B), θ_tip ≈ −λ/2 for small λ and
θ_tip → −π/2 as λ → ∞. :func:`hard_magnetic_elastica` solves the BVP with
``scipy.integrate.solve_bvp`` by continuation in λ;
:func:`elastica_tip_angle_first_integral` is an independent check through
the first integral θ'²/2 = λ(sin θ − sin θ_L):

.. math::

    1 = \int_{\theta_L}^{0} \frac{d\theta}{\sqrt{2\lambda(\sin\theta - \sin\theta_L)}}.

E' is the bending modulus of the section (:func:`bending_modulus`): E for
a narrow beam or a plane-stress strip, E/(1 − ν²) for a plane-strain strip
or a plate whose anticlastic curvature is suppressed (wide plate). The
rod model neglects shear and thickness change: its error relative to a
continuum solution is O((h/L)²).

2. Euler–Bernoulli cantilever frequencies
-----------------------------------------
Free vibration of a clamped–free beam, E'I w'''' + ρA ẅ = 0:
ω_n = (β_n L)² sqrt(E'I / (ρ A L⁴)), with β_n L the roots of
1 + cos(βL) cosh(βL) = 0 (1.87510407, 4.69409113, 7.85475744, ...;
Timoshenko, Young & Weaver, *Vibration Problems in Engineering*, 1974,
§5.3). For a rectangular section f_n = (β_n L)²/(2π L²) · h sqrt(E'/(12ρ)).
The plate correction E' = E/(1 − ν²) applies to a plate in cylindrical
bending (plane strain across the width); a narrow beam has E' = E.

3. Ground contact (see :mod:`magfem.mechanics.contacts`)
-------------------------------------------------------
A flat membrane of density ρ and thickness h resting on the ground presses
with p = ρ g h (Pa). The penalty pressure is p = k_n r(δ) with the C¹ ramp
r (quadratic onset of width δ0), so the static penetration is
δ = sqrt(2 δ0 p / k_n) for p/k_n < δ0/2 and δ = p/k_n + δ0/2 beyond
(:func:`penalty_penetration`, the time loop's own function from
:mod:`magfem.mechanics.contacts.penalty`, re-exported here). The membrane's own compression
(≈ ρ g h² / (2 (K + 4μ/3))) does not enter: the bottom face carries the
whole weight whatever the layer does.

A rigid block sliding on the ground with Coulomb friction decelerates at
μ_f g until it stops: v(t) = max(v0 − μ_f g t, 0). With the regularised law
t_t = −μ_f p v / sqrt(v² + v_ε²), dv/dt = −μ_f g v / sqrt(v² + v_ε²)
integrates in closed form (:func:`regularized_sliding_time`): with
G(v) = sqrt(v² + v_ε²) − v_ε ln((v_ε + sqrt(v² + v_ε²)) / v),
μ_f g t = G(v0) − G(v). The distance to rest is
∫ v dt = ∫₀^{v0} sqrt(v² + v_ε²) dv / (μ_f g)
= [v0 sqrt(v0² + v_ε²) + v_ε² asinh(v0/v_ε)] / (2 μ_f g)
(:func:`regularized_sliding_distance`; v0²/(2 μ_f g) for Coulomb).

4. Anticlastic bending of a strip (the rod's section law)
--------------------------------------------------------
A plate strip of width b, thickness h, plate rigidity D = E h³/(12(1 − ν²)),
bent to a uniform curvature κ along its length, takes a cross-section shape
w(y), |y| ≤ b/2, that minimises its energy per unit length

.. math::

    U[w] = \int_{-b/2}^{b/2} \frac D2\big(\kappa^2 + w''^2 + 2\nu\kappa w''\big)
        + \frac{E h \kappa^2}2 (w - \bar w)^2 \,dy

(plate bending with the transverse curvature w''; the longitudinal fibres at
height w − w̄ are stretched by κ (w − w̄) and carry no transverse force).
Stationarity gives D w⁗ + E h κ² (w − w̄) = 0 with free edges
w'' = −ν κ, w‴ = 0 at y = ±b/2: w is even, a combination of
cosh βy cos βy and sinh βy sin βy, β⁴ = E h κ²/(4D).
:func:`anticlastic_energy_ratio` solves that 2 × 2 system and integrates
U[w] by quadrature, U/(D b κ²/2): the beam's 1 − ν² for a narrow strip,
the plate's 1 for a wide one. The rod's section law (Ashwell's closed form,
:mod:`magfem.mechanics.models.rod_section`) is checked against it.

5. Free rigid bodies
--------------------
*Magnetic pendulum.* A rigid plate of magnetic moment m = M V along its
normal d, free to turn about a principal axis of inertia I perpendicular to
a uniform field B at angle φ_B to the initial normal, has the energy
−m·B = −M V B cos(φ − φ_B): I φ'' = −M V B sin(φ − φ_B)
(:func:`magnetic_pendulum`, solve_ivp). A uniform field exerts no force, so
its centre of mass stays put; for a plate L × W × t turning about the W
edge direction I = m_p (L² + t²)/12.

*Constant gradient.* In B(x) = B0 + G (x − x0) (G symmetric and traceless
in air) a rigid body of moment m aligned with B feels no torque and the
force ∇(m·B) = Gᵀm = (m·∇)B: its centre of mass accelerates uniformly at
(m·∇)B / mass.

*Levitation above a magnet.* A rigid horizontal plate of thickness t and
area A, magnetised M against the +z field of a magnet below it, has the
energy U(z) = M t ∫_A B_z(x, y, z) dA at height z of its mid-surface
(:func:`levitation_equilibrium` integrates it with Gauss–Legendre points of
the exact magnet field): the magnetic force F(z) = −M t ∫_A ∂B_z/∂z dA
balances the weight ρ t A g at z*, and small vertical oscillations about z*
have ω² = −F'(z*)/(ρ t A). The anti-aligned plate is vertically stable
where B_z is convex, laterally unstable (Earnshaw), and stable against
tilting only when it is wide: U_φφ ∝ ∫ (2 x² ∂²B_z/∂z² − B_z) dA > 0, i.e.
a half-width beyond ~0.35 z for a dipole far field.

*Block on a slope.* A rigid block on a plane inclined by θ with Coulomb
friction μ_f stays at rest for tan θ ≤ μ_f and otherwise accelerates at
g (sin θ − μ_f cos θ) (:func:`slope_acceleration`). Under the regularised
law t_t = −μ_f p v/sqrt(v² + ε²) it creeps below the threshold at the
steady speed where friction balances the slope, v = ε tan θ/sqrt(μ_f² − tan² θ)
(:func:`creep_velocity`), and above it the acceleration tends to the
Coulomb value as (ε/v)² → 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import integrate, optimize

from magfem.mechanics.contacts.penalty import penalty_penetration

__all__ = [
    "NARROW_SHELL_DRIVE_DEG",
    "ElasticaSolution",
    "anticlastic_energy_ratio",
    "bending_modulus",
    "cantilever_eigenvalue",
    "cantilever_frequency",
    "creep_velocity",
    "elastica_load",
    "elastica_tip_angle_first_integral",
    "hard_magnetic_elastica",
    "levitation_equilibrium",
    "magnetic_pendulum",
    "penalty_penetration",
    "poisson_ratio",
    "regularized_sliding_distance",
    "regularized_sliding_time",
    "resting_pressure",
    "sliding_velocity",
    "slope_acceleration",
    "young_modulus",
]


def young_modulus(shear_modulus: float, bulk_modulus: float) -> float:
    """Small-strain Young's modulus E = 9Kμ/(3K + μ) (Pa) of the neo-Hookean solid."""
    return 9.0 * bulk_modulus * shear_modulus / (3.0 * bulk_modulus + shear_modulus)


def poisson_ratio(shear_modulus: float, bulk_modulus: float) -> float:
    """Small-strain Poisson ratio ν = (3K − 2μ)/(2(3K + μ)) (-); 0.4950 for K = 100 μ."""
    return (3.0 * bulk_modulus - 2.0 * shear_modulus) / (2.0 * (3.0 * bulk_modulus + shear_modulus))


def bending_modulus(young: float, poisson: float, kind: str) -> float:
    """Modulus E' of the section in E'I (Pa).

    Args:
        young: E (Pa).
        poisson: ν (-).
        kind: ``"beam"`` or ``"plane_stress"`` (E'= E), ``"plate"`` or
            ``"plane_strain"`` (E' = E/(1 − ν²), anticlastic curvature suppressed).
    """
    if kind in ("beam", "plane_stress"):
        return young
    if kind in ("plate", "plane_strain"):
        return young / (1.0 - poisson**2)
    raise ValueError(f"kind must be beam, plane_stress, plate or plane_strain, got {kind!r}")


def elastica_load(
    magnetization: float, flux_density: float, length: float, thickness: float, modulus: float
) -> float:
    """Dimensionless magnetic load λ = 12 M B L² / (E' h²) of a rectangular section.

    Args:
        magnetization: remanent magnetization M (A/m).
        flux_density: applied |B| (T).
        length: arm length L (m).
        thickness: h (m).
        modulus: bending modulus E' (Pa), see :func:`bending_modulus`.
    """
    return 12.0 * magnetization * flux_density * length**2 / (modulus * thickness**2)


@dataclass(frozen=True)
class ElasticaSolution:
    """Solution of the hard-magnetic elastica on s̄ ∈ [0, 1].

    Attributes:
        load: λ (-).
        s: arc length s/L, shape (n,).
        theta: tangent angle θ(s) (rad), shape (n,).
        x, y: centreline position divided by L, shape (n,) each; y along the
            second in-plane axis (positive in the direction of positive θ).
        tip_angle: θ(1) (rad).
    """

    load: float
    s: NDArray[np.float64]
    theta: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    tip_angle: float


def hard_magnetic_elastica(
    load: float,
    *,
    magnetization_angle: float = math.pi / 2,
    field_angle: float = 0.0,
    points: int = 401,
    tol: float = 1e-10,
) -> ElasticaSolution:
    """Solve θ'' = λ sin(θ + α − φ), θ(0) = 0, θ'(1) = 0 (clamped–free) with solve_bvp.

    Continuation from λ = 0 in steps that keep the Newton guess close.

    Args:
        load: λ = 12 M B L²/(E' h²) >= 0.
        magnetization_angle: α, angle of M̃ to the reference tangent (rad).
        field_angle: φ, angle of B to the reference tangent (rad).
        points: number of output points along the arm.
        tol: solve_bvp tolerance.

    Raises:
        RuntimeError: if solve_bvp does not converge.
    """
    if not (load >= 0 and math.isfinite(load)):
        raise ValueError(f"load must be finite and >= 0, got {load!r}")
    shift = magnetization_angle - field_angle
    s = np.linspace(0.0, 1.0, points)
    y = np.zeros((2, s.size))
    loads = [load]  # geometric continuation: λ, λ/1.5, ... down to <= 2, solved upwards
    while loads[-1] > 2.0:
        loads.append(loads[-1] / 1.5)
    for lam in reversed(loads):

        def rhs(_s, yy, lam=lam):
            return np.vstack([yy[1], lam * np.sin(yy[0] + shift)])

        def bc(ya, yb):
            return np.array([ya[0], yb[1]])

        sol = integrate.solve_bvp(rhs, bc, s, y, tol=tol, max_nodes=200000)
        if not sol.success:
            raise RuntimeError(
                f"hard_magnetic_elastica: solve_bvp failed at λ={lam}: {sol.message}"
            )
        y = sol.sol(s)
    theta = y[0]
    x = integrate.cumulative_trapezoid(np.cos(theta), s, initial=0.0)
    yc = integrate.cumulative_trapezoid(np.sin(theta), s, initial=0.0)
    return ElasticaSolution(float(load), s, theta, x, yc, float(theta[-1]))


def elastica_tip_angle_first_integral(load: float) -> float:
    """Tip angle θ_L (rad) of θ'' = λ cos θ (α = π/2, φ = 0) from the first integral.

    Solves 1 = ∫_{θ_L}^0 dθ / sqrt(2λ(sin θ − sin θ_L)) for θ_L ∈ (−π/2, 0)
    (algebraic end-point weight for the inverse-square-root singularity).
    """
    if not (load > 0 and math.isfinite(load)):
        raise ValueError(f"load must be finite and > 0, got {load!r}")

    def length(theta_l: float) -> float:
        def smooth(t: float) -> float:
            # (t - θ_L)^(1/2) / sqrt(2λ(sin t − sin θ_L)): bounded at t = θ_L
            # sin t − sin θ_L = 2 cos((t + θ_L)/2) sin(d/2): no cancellation as d → 0
            d = t - theta_l
            ratio = 1.0 if d <= 0.0 else (d / 2.0) / math.sin(d / 2.0)
            return math.sqrt(ratio / (2.0 * load * math.cos((t + theta_l) / 2.0)))

        value, _ = integrate.quad(
            smooth, theta_l, 0.0, weight="alg", wvar=(-0.5, 0.0), epsabs=1e-12, epsrel=1e-10
        )
        return value - 1.0

    # length → 0 as θ_L → 0⁻ and → ∞ (logarithmically) as θ_L → −π/2⁺: bracket from
    # the upper side, approaching −π/2 only as far as the load requires
    high = -min(0.5 * load, 1.0) * 1e-3
    low = -math.pi / 2 + 0.1
    while length(low) < 0.0:
        low = -math.pi / 2 + (low + math.pi / 2) / 10.0
    return optimize.brentq(length, low, high, xtol=1e-14, rtol=1e-13)


def cantilever_eigenvalue(mode: int = 1) -> float:
    """β_n L, the n-th root of 1 + cos(βL) cosh(βL) = 0 (clamped–free beam)."""
    if mode < 1:
        raise ValueError(f"mode must be >= 1, got {mode}")
    # roots lie near (2n − 1)π/2; the sign change brackets each one
    centre = (2 * mode - 1) * math.pi / 2
    return optimize.brentq(
        lambda b: math.cos(b) / math.cosh(b) + 1.0 / math.cosh(b) ** 2,
        centre - 0.5,
        centre + 0.5,
        xtol=1e-15,
    )


def cantilever_frequency(
    modulus: float, density: float, thickness: float, length: float, mode: int = 1
) -> float:
    """Euler–Bernoulli natural frequency (Hz) of a rectangular clamped–free beam.

    f_n = (β_n L)² / (2π L²) · h sqrt(E' / (12 ρ)).

    Args:
        modulus: E' (Pa): E for a beam, E/(1 − ν²) for a plate in cylindrical bending.
        density: ρ (kg/m³).
        thickness: h (m).
        length: L (m).
        mode: n >= 1.
    """
    beta = cantilever_eigenvalue(mode)
    return beta**2 / (2.0 * math.pi * length**2) * thickness * math.sqrt(modulus / (12.0 * density))


def resting_pressure(density: float, thickness: float, gravity: float = 9.8) -> float:
    """Pressure ρ g h (Pa) of a flat membrane resting on the ground."""
    return density * gravity * thickness


def sliding_velocity(
    time: NDArray[np.float64] | float, initial_speed: float, friction: float, gravity: float = 9.8
) -> NDArray[np.float64]:
    """Speed (m/s) of a block sliding with Coulomb friction: max(v0 − μ_f g t, 0)."""
    return np.maximum(initial_speed - friction * gravity * np.asarray(time, dtype=float), 0.0)


def regularized_sliding_time(
    speed: float,
    initial_speed: float,
    friction: float,
    regularization_velocity: float,
    gravity: float = 9.8,
) -> float:
    """Time (s) for a block to slow from v0 to v under regularised Coulomb friction.

    dv/dt = −μ_f g v / sqrt(v² + v_ε²) ⇒ μ_f g t = G(v0) − G(v),
    G(v) = sqrt(v² + v_ε²) − v_ε ln((v_ε + sqrt(v² + v_ε²)) / v).
    """
    eps = regularization_velocity

    def g(v: float) -> float:
        r = math.hypot(v, eps)
        return r - eps * math.log((eps + r) / v)

    if not 0 < speed <= initial_speed:
        raise ValueError("need 0 < speed <= initial_speed")
    return (g(initial_speed) - g(speed)) / (friction * gravity)


def regularized_sliding_distance(
    initial_speed: float, friction: float, regularization_velocity: float, gravity: float = 9.8
) -> float:
    """Distance (m) a block slides to rest under regularised Coulomb friction.

    [v0 sqrt(v0² + v_ε²) + v_ε² asinh(v0/v_ε)] / (2 μ_f g); v0²/(2 μ_f g) as v_ε → 0.
    """
    v0, eps = initial_speed, regularization_velocity
    return (v0 * math.hypot(v0, eps) + eps**2 * math.asinh(v0 / eps)) / (2.0 * friction * gravity)


def anticlastic_energy_ratio(beta_b: float, poisson: float, points: int = 20001) -> float:
    """U/(D b κ²/2) of a strip bent to curvature κ (section 4), at βb (β⁴ = E h κ²/(4D)).

    Units cancel: the strip is taken with b = 1, h = 1, E = 1.
    """
    nu, b, h, E = poisson, 1.0, 1.0, 1.0
    D = E * h**3 / (12.0 * (1.0 - nu**2))
    beta = beta_b / b
    kappa = math.sqrt(4.0 * beta**4 * D / (E * h))
    z = (1.0 + 1.0j) * beta  # cosh(z y) = cosh βy cos βy + i sinh βy sin βy

    def part(k: int, y: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        value = z**k * (np.cosh(z * y) if k % 2 == 0 else np.sinh(z * y))
        return value.real, value.imag

    edge = np.array([b / 2])
    rows = [[part(k, edge)[0][0], part(k, edge)[1][0]] for k in (2, 3)]
    A, B = np.linalg.solve(np.array(rows), [-nu * kappa, 0.0])
    y = np.linspace(-b / 2, b / 2, points)
    w = A * part(0, y)[0] + B * part(0, y)[1]
    w2 = A * part(2, y)[0] + B * part(2, y)[1]
    w = w - integrate.simpson(w, x=y) / b
    density = 0.5 * D * (kappa**2 + w2**2 + 2 * nu * kappa * w2) + 0.5 * E * h * kappa**2 * w**2
    return float(integrate.simpson(density, x=y) / (0.5 * D * b * kappa**2))


NARROW_SHELL_DRIVE_DEG = (
    *(0.0, 21.94, 40.11, 53.96, 64.61, 71.82, 77.58, 82.92, 81.23, 82.36, 94.56, 88.19, 80.58),
    *(78.81, 90.52, 98.78, 111.14, 109.45, 107.41, 85.39, 60.86, 54.27, 55.96, 63.87, 80.96),
    101.59,
)
"""The shell's tip angle (degrees) every millisecond, 0–25 ms, of the narrow arm in the
default case's drive (:func:`verification.setups.narrow_drive_history`: 0.25 mm wide, P3
at 0.25 mm, Δt = 0.125 ms), printed by ``python -m benchmarks.rod_vs_shell``."""


def magnetic_pendulum(
    times: NDArray[np.float64], stiffness: float, field_angle: float
) -> NDArray[np.float64]:
    """Angle φ(t) (rad) of φ'' = −k sin(φ − φ_B), φ(0) = φ'(0) = 0, at ``times`` (s).

    Args:
        stiffness: k = M V B / I (1/s²).
        field_angle: φ_B (rad).
    """
    t = np.asarray(times, dtype=float)
    sol = integrate.solve_ivp(
        lambda _, y: [y[1], -stiffness * math.sin(y[0] - field_angle)],
        (0.0, float(t[-1])),
        [0.0, 0.0],
        t_eval=t,
        rtol=1e-11,
        atol=1e-13,
    )
    return np.asarray(sol.y[0])


def levitation_equilibrium(
    gradient: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    *,
    half_width: float,
    magnetization: float,
    density: float,
    gravity: float = 9.8,
    bracket: tuple[float, float] = (1e-3, 0.2),
    points: int = 24,
) -> tuple[float, float]:
    """(z* (m), ω (rad/s)) of a square plate levitated against a magnet's field (section 4).

    Args:
        gradient: ∇B (N, 3, 3) (T/m) of the magnet at points (N, 3) (m); its
            field is along +z on the plate's axis x = y = 0.
        half_width: half the plate's edge (m); the plate is centred on the axis.
        magnetization: M (A/m) of the plate, against +z.
        density: ρ (kg/m³). gravity: g (m/s²).
        bracket: heights (m) that bracket z*.
        points: Gauss–Legendre points per direction.
    """
    xg, wg = np.polynomial.legendre.leggauss(points)
    X, Y = np.meshgrid(half_width * xg, half_width * xg, indexing="ij")
    W = np.outer(wg, wg).ravel() * half_width**2
    area = 4.0 * half_width**2

    def lift(z: float) -> float:  # F(z)/t per unit density of weight (m/s²)
        pts = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, z)])
        return -magnetization * float(np.sum(W * gradient(pts)[:, 2, 2])) / (density * area)

    z_eq = optimize.brentq(lambda z: lift(z) - gravity, *bracket, xtol=1e-14)
    h = 1e-6 * z_eq
    stiffness = -(lift(z_eq + h) - lift(z_eq - h)) / (2.0 * h)  # ω² (1/s²)
    return float(z_eq), math.sqrt(stiffness)


def slope_acceleration(angle: float, friction: float, gravity: float = 9.8) -> float:
    """Acceleration (m/s²) down a slope of ``angle`` (rad), Coulomb friction (0: it sticks)."""
    return max(gravity * (math.sin(angle) - friction * math.cos(angle)), 0.0)


def creep_velocity(angle: float, friction: float, regularization_velocity: float) -> float:
    """Steady creep speed (m/s) on a slope below the friction angle, regularised law (section 4).

    ε tan θ / sqrt(μ_f² − tan² θ); raises ValueError at or above tan θ = μ_f.
    """
    tan = math.tan(angle)
    if tan >= friction:
        raise ValueError("no steady creep at or above the friction angle")
    return regularization_velocity * tan / math.sqrt(friction**2 - tan**2)
