"""Closed-form fields of coils and permanent magnets in air, with their gradients.

Pure numpy kernels, vectorised over points, SI units (m, A, T). Axisymmetric
kernels take (ρ, z) in the source frame (axis = local z, centre at 0) and
return B_ρ, B_z and the four derivatives ∂_ρB_ρ, ∂_zB_ρ, ∂_ρB_z, ∂_zB_z;
:func:`axisymmetric_to_cartesian` turns them into B (N, 3) and ∇B (N, 3, 3)
(``G[n, i, j] = ∂B_i/∂x_j``) in the local Cartesian frame.

Current loop (radius a, current I), complete elliptic integrals K(m), E(m)
of parameter m = k² (Simpson et al., NASA TM-2001-210042; Jackson,
Classical Electrodynamics §5.5)::

    α² = a² + ρ² + z² − 2aρ,  β² = a² + ρ² + z² + 2aρ,  m = 1 − α²/β²,  C = µ0 I / π
    B_ρ = C z / (2 α² β ρ) [(a² + ρ² + z²) E(m) − α² K(m)]
    B_z = C / (2 α² β)     [(a² − ρ² − z²) E(m) + α² K(m)]

Current sheet (finite solenoid of radius a on −b ≤ z ≤ b carrying K A/m
azimuthally), in Bulirsch's generalised complete elliptic integral
cel(k_c, p, c, s) = ∫₀^{π/2} (c cos²φ + s sin²φ) / ((cos²φ + p sin²φ)
√(cos²φ + k_c² sin²φ)) dφ (R. Bulirsch, Numer. Math. 13, 305 (1969);
E. P. Derby and S. Olbert, Am. J. Phys. 78, 229 (2010))::

    z± = z ± b,  D± = √(z±² + (a + ρ)²),  k± = √(z±² + (a − ρ)²) / D±,  γ = (a − ρ)/(a + ρ)
    B_ρ = µ0 K/π [a/D₊ cel(k₊, 1, 1, −1) − a/D₋ cel(k₋, 1, 1, −1)]
    B_z = µ0 K/π · a/(a + ρ) [z₊/D₊ cel(k₊, γ², 1, γ) − z₋/D₋ cel(k₋, γ², 1, γ)]

An axially magnetised cylinder (remanence B_r) is the sheet with
K = B_r/µ0 (its bound current M × n), exact inside and outside. A thick coil
(radii r1 < r2, length L, N turns of current I, J = N I / ((r2 − r1) L)) is
the sheet integrated over its radius, ∫ J sheet(a) da, by composite
Gauss–Legendre quadrature whose panels are no longer than the distance of
the nearest evaluated point to the winding (the integrand is analytic there,
so the error falls geometrically; measured in tests/test_field_analytic.py).

Gradients are exact: differentiating the sheet integral over z gives the
difference of two loop fields, ∂_z B_sheet(ρ, z) = K [B_loop(ρ, z + b) −
B_loop(ρ, z − b)] (unit-current loops of radius a); in air (and inside a
uniformly magnetised cylinder) curl B = 0 and div B = 0 give ∂_ρ B_z =
∂_z B_ρ and ∂_ρ B_ρ = −∂_z B_z − B_ρ/ρ (→ −½ ∂_z B_z on the axis).

Block magnet (edges 2a, 2b, 2c, magnetised along z with B_r = µ0 M): the
field of the charge sheets σ = ±M on z = ±c (Furlani, Permanent Magnet and
Electromechanical Devices, Academic Press 2001, §4.3; Engel-Herbert and
Hesjedal, J. Appl. Phys. 97, 074504 (2005)). For a sheet [x1, x2] × [y1, y2]
at height z0 with u_i = x_i − x, v_j = y_j − y, Z = z − z0, R_ij =
√(u_i² + v_j² + Z²) and signs s_1 = −1, s_2 = +1::

    µ0 H_x = σ' Σ s_i s_j ln(v_j + R_ij),   µ0 H_y = σ' Σ s_i s_j ln(u_i + R_ij),
    µ0 H_z = σ' Σ s_i s_j arctan(u_i v_j / (Z R_ij)),         σ' = ±B_r/(4π)

and B = µ0 H (+ B_r ẑ inside). Its gradient, by differentiating each term::

    ∂_x µ0H_x = −σ' Σ s s u/(R (v + R)),  ∂_y µ0H_x = −σ' Σ s s /R,
    ∂_z µ0H_x = σ' Σ s s Z/(R (v + R))
    ∂_y µ0H_y = −σ' Σ s s v/(R (u + R)),  ∂_z µ0H_y = σ' Σ s s Z/(R (u + R))

with ∇H symmetric and traceless away from the charges; 1/(v + R) is
evaluated as (R − v)/(u² + Z²) for v < 0 (no cancellation).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy.special import ellipe, ellipk

__all__ = [
    "MU0",
    "Axisymmetric",
    "axisymmetric_to_cartesian",
    "block_magnet_local",
    "cel",
    "coil_resolution",
    "cylinder_magnet_local",
    "cylinder_magnet_on_axis",
    "dipole_field",
    "dipole_gradient",
    "gradient_fd",
    "loop_field",
    "loop_on_axis",
    "rect_sheet_local",
    "sheet_field",
    "thick_coil_local",
    "thick_coil_on_axis",
    "winding_distance",
]

MU0 = 4e-7 * math.pi
"""Vacuum permeability, H/m (the pre-2019 exact value; the 2019 SI value differs by 1e-10)."""

Axisymmetric = tuple[np.ndarray, np.ndarray, np.ndarray]
"""(B_ρ, B_z) each (N,), and the derivatives (N, 4): ∂_ρB_ρ, ∂_zB_ρ, ∂_ρB_z, ∂_zB_z."""


def cel(kc: np.ndarray, p: np.ndarray, c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Bulirsch's complete elliptic integral cel(k_c, p, c, s) (module docstring), elementwise.

    Arguments broadcast; k_c ≠ 0. Iterates the arithmetic–geometric mean
    until every element has converged to round-off (quadratic convergence,
    ~5–8 iterations for 0 < k_c ≤ 1).
    """
    kc, p, c, s = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (kc, p, c, s)))
    k = np.abs(kc)
    pos = p > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        f, g = k**2, 1.0 - p
        pp = np.where(pos, np.sqrt(np.abs(p)), np.sqrt(np.abs((f - p) / g)))
        aa = np.where(pos, c, (c - s) / g)
        bb = np.where(pos, s / pp, -(1.0 - f) * (s - c * p) / (g * g * pp) + aa * pp)
    e, em = k.copy(), np.ones_like(k)
    for _ in range(60):
        f = aa
        aa = aa + bb / pp
        g = e / pp
        bb = 2.0 * (bb + f * g)
        pp = g + pp
        g = em
        em = em + k
        if np.all(np.abs(g - k) <= 1e-9 * g):
            break
        k = 2.0 * np.sqrt(e)
        e = k * em
    return 0.5 * math.pi * (bb + aa * em) / (em * (em + pp))


def loop_on_axis(a: float, current: float, z: np.ndarray) -> np.ndarray:
    """On-axis B_z (T) of a loop of radius ``a`` (m) and ``current`` (A) at heights z (m)."""
    z = np.asarray(z, dtype=float)
    return MU0 * current * a**2 / (2 * (a**2 + z**2) ** 1.5)


def loop_field(
    a: np.ndarray | float, current: np.ndarray | float, rho: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(B_ρ, B_z), T, of a current loop (radius a, m; current, A) at (ρ, z) (m); all broadcast.

    Loop in the plane z = 0 centred on the axis; B_ρ = 0 on the axis (ρ < 1e-12 a).
    """
    a = np.asarray(a, dtype=float)
    r2 = rho**2 + z**2
    alpha2 = a**2 + r2 - 2 * a * rho
    beta2 = a**2 + r2 + 2 * a * rho
    beta = np.sqrt(beta2)
    m = 1.0 - alpha2 / beta2
    K, E = ellipk(m), ellipe(m)
    C = MU0 * np.asarray(current, dtype=float) / math.pi
    on_axis = rho < 1e-12 * a
    safe_rho = np.where(on_axis, 1.0, rho)
    b_rho = np.where(
        on_axis, 0.0, C * z / (2 * alpha2 * beta * safe_rho) * ((a**2 + r2) * E - alpha2 * K)
    )
    b_z = C / (2 * alpha2 * beta) * ((a**2 - r2) * E + alpha2 * K)
    return b_rho, b_z


def sheet_field(
    a: np.ndarray | float, b: float, K: np.ndarray | float, rho: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(B_ρ, B_z), T, of a current sheet (radius a, −b ≤ z ≤ b, K A/m) at (ρ, z); broadcast."""
    a = np.asarray(a, dtype=float)
    zp, zm = z + b, z - b
    ap, am = a + rho, a - rho
    Dp, Dm = np.sqrt(zp**2 + ap**2), np.sqrt(zm**2 + ap**2)
    kp = np.maximum(np.sqrt(zp**2 + am**2) / Dp, 1e-300)
    km = np.maximum(np.sqrt(zm**2 + am**2) / Dm, 1e-300)
    gamma = am / ap
    one = np.ones_like(kp)
    B0 = MU0 * np.asarray(K, dtype=float) / math.pi
    b_rho = B0 * a * (cel(kp, one, one, -one) / Dp - cel(km, one, one, -one) / Dm)
    g2 = gamma**2
    b_z = B0 * a / ap * (zp / Dp * cel(kp, g2, one, gamma) - zm / Dm * cel(km, g2, one, gamma))
    return b_rho, b_z


def _sheet_dz(
    a: np.ndarray | float, b: float, K: np.ndarray | float, rho: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(∂_zB_ρ, ∂_zB_z), T/m, of a current sheet: K [B_loop(z + b) − B_loop(z − b)]."""
    r1, z1 = loop_field(a, K, rho, z + b)
    r2, z2 = loop_field(a, K, rho, z - b)
    return r1 - r2, z1 - z2


def _curl_div_free(
    rho: np.ndarray, br: np.ndarray, dz_br: np.ndarray, dz_bz: np.ndarray
) -> np.ndarray:
    """Complete (B_ρ, B_z)'s derivatives from the z-derivatives (curl B = 0, div B = 0)."""
    tiny = rho < 1e-12
    br_over_rho = np.where(tiny, -0.5 * dz_bz, br / np.where(tiny, 1.0, rho))
    dr_br = -dz_bz - br_over_rho
    return np.column_stack([dr_br, dz_br, dz_br, dz_bz])


def cylinder_magnet_local(
    radius: float, length: float, remanence: float, rho: np.ndarray, z: np.ndarray
) -> Axisymmetric:
    """B_ρ, B_z (T) and derivatives (T/m) of an axially magnetised cylinder centred at 0."""
    K = remanence / MU0
    br, bz = sheet_field(radius, length / 2, K, rho, z)
    dz_br, dz_bz = _sheet_dz(radius, length / 2, K, rho, z)
    return br, bz, _curl_div_free(rho, br, dz_br, dz_bz)


def _gauss(lo: float, hi: float, n: int, pieces: int) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre nodes and weights on [lo, hi]."""
    x, w = np.polynomial.legendre.leggauss(n)
    edges = np.linspace(lo, hi, pieces + 1)
    nodes = np.concatenate(
        [(e1 - e0) / 2 * x + (e0 + e1) / 2 for e0, e1 in itertools.pairwise(edges)]
    )
    weights = np.concatenate([(e1 - e0) / 2 * w for e0, e1 in itertools.pairwise(edges)])
    return nodes, weights


def winding_distance(
    r1: float, r2: float, length: float, rho: np.ndarray, z: np.ndarray
) -> np.ndarray:
    """Distance (m) in the (ρ, z) half-plane from points to the winding rectangle (0 inside)."""
    dr = np.maximum(np.maximum(r1 - rho, rho - r2), 0.0)
    dz = np.maximum(np.abs(z) - length / 2, 0.0)
    return np.hypot(dr, dz)


_PANEL_NODES = 8
_MAX_PANELS = 256


def coil_resolution(r1: float, r2: float) -> float:
    """Smallest distance (m) to a winding at which :func:`thick_coil_local` is converged (~1e-9)."""
    return (r2 - r1) / (2 * _MAX_PANELS)


def thick_coil_local(
    r1: float, r2: float, length: float, turns: int, current: float, rho: np.ndarray, z: np.ndarray
) -> Axisymmetric:
    """B_ρ, B_z (T) and derivatives (T/m) of a thick coil centred at 0, outside its winding.

    Radial integral of current sheets; points are grouped by their distance d
    to the winding and each group uses 8-node panels of length ≤ 2d (at most
    256: points closer than :func:`coil_resolution` are not resolved).
    """
    rho, z = np.broadcast_arrays(np.atleast_1d(rho).astype(float), np.atleast_1d(z).astype(float))
    J = turns * current / ((r2 - r1) * length)
    d = winding_distance(r1, r2, length, rho, z)
    need = np.clip(np.ceil((r2 - r1) / np.maximum(2 * d, 1e-300)), 1, _MAX_PANELS)
    need[d <= 0.0] = 1  # inside the winding: not resolved at any panel count
    level = np.ceil(np.log2(need)).astype(int)
    br, bz, dz_br, dz_bz = (np.zeros(len(rho)) for _ in range(4))
    for lev in np.unique(level):
        idx = np.flatnonzero(level == lev)
        a, w = _gauss(r1, r2, _PANEL_NODES, 2**lev)
        Kw = J * w
        for s in range(0, len(idx), max(1, 200_000 // len(a))):
            sl = idx[s : s + max(1, 200_000 // len(a))]
            R, Z = rho[sl, None], z[sl, None]
            fr, fz = sheet_field(a[None, :], length / 2, Kw[None, :], R, Z)
            gr, gz = _sheet_dz(a[None, :], length / 2, Kw[None, :], R, Z)
            br[sl], bz[sl] = fr.sum(axis=1), fz.sum(axis=1)
            dz_br[sl], dz_bz[sl] = gr.sum(axis=1), gz.sum(axis=1)
    return br, bz, _curl_div_free(rho, br, dz_br, dz_bz)


def thick_coil_on_axis(
    r1: float, r2: float, length: float, turns: int, current: float, z: np.ndarray
) -> np.ndarray:
    """On-axis B_z (T) of a thick coil centred at z = 0 (loop field integrated over the winding)::

    B_z = µ0 J / 2 [z₊ ln((r2 + √(r2² + z₊²)) / (r1 + √(r1² + z₊²))) − (same with z₋)]
    """
    z = np.asarray(z, dtype=float)
    J = turns * current / ((r2 - r1) * length)

    def term(zz: np.ndarray) -> np.ndarray:
        return zz * np.log((r2 + np.sqrt(r2**2 + zz**2)) / (r1 + np.sqrt(r1**2 + zz**2)))

    return MU0 * J / 2 * (term(z + length / 2) - term(z - length / 2))


def cylinder_magnet_on_axis(
    radius: float, length: float, remanence: float, z: np.ndarray
) -> np.ndarray:
    """On-axis B_z (T) of an axially magnetised cylinder centred at z = 0::

    B_z = B_r/2 [z₊ / √(R² + z₊²) − z₋ / √(R² + z₋²)]
    """
    z = np.asarray(z, dtype=float)
    zp, zm = z + length / 2, z - length / 2
    return remanence / 2 * (zp / np.sqrt(radius**2 + zp**2) - zm / np.sqrt(radius**2 + zm**2))


def axisymmetric_to_cartesian(
    p: np.ndarray, br: np.ndarray, bz: np.ndarray, d: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """B (N, 3) and ∇B (N, 3, 3) at local points p (N, 3) from (B_ρ, B_z) and their derivatives.

    With e_ρ = (cos φ, sin φ, 0), e_φ = (−sin φ, cos φ, 0)::

        ∇B = ∂_ρB_ρ e_ρ⊗e_ρ + (B_ρ/ρ) e_φ⊗e_φ + ∂_zB_ρ e_ρ⊗e_z + ∂_ρB_z e_z⊗e_ρ + ∂_zB_z e_z⊗e_z

    (B_ρ/ρ → ∂_ρB_ρ on the axis).
    """
    rho = np.hypot(p[:, 0], p[:, 1])
    on = rho < 1e-14
    safe = np.where(on, 1.0, rho)
    c = np.where(on, 1.0, p[:, 0] / safe)
    s = np.where(on, 0.0, p[:, 1] / safe)
    B = np.column_stack([br * c, br * s, bz])
    zero = np.zeros(len(p))
    er = np.column_stack([c, s, zero])
    ephi = np.column_stack([-s, c, zero])
    br_rho = np.where(on, d[:, 0], br / safe)
    G = d[:, 0, None, None] * er[:, :, None] * er[:, None, :]
    G += br_rho[:, None, None] * ephi[:, :, None] * ephi[:, None, :]
    G[:, :, 2] += d[:, 1, None] * er
    G[:, 2, :] += d[:, 2, None] * er
    G[:, 2, 2] += d[:, 3]
    return B, G


def _inv_sum(v: np.ndarray, R: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """1/(v + R) with R = √(v² + rest), without cancellation for v < 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(v >= 0, 1.0 / (v + R), (R - v) / rest)


def _log_plus(v: np.ndarray, R: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """ln(v + R) with R = √(v² + rest), without cancellation for v < 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(v >= 0, np.log(np.abs(v + R)), np.log(rest / (R - v)))


def rect_sheet_local(a: float, b: float, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """E = ∫∫ (p − X)/|p − X|³ dA (N, 3), m⁻¹·m², and ∇E (N, 3, 3), 1/m, over the rectangle
    [−a, a] × [−b, b] in the plane z = 0, at local points p (N, 3) off the rectangle.

    The Coulomb field of a unit charge density on the rectangle (the sums of the
    module docstring with σ' = 1); ∇E is symmetric and traceless.
    """
    x, y = p[:, 0], p[:, 1]
    Z = np.where(p[:, 2] == 0.0, 1e-300, p[:, 2])
    E = np.zeros((len(p), 3))
    G = np.zeros((len(p), 3, 3))
    for (xi, si), (yj, sj) in itertools.product(((-a, -1.0), (a, 1.0)), ((-b, -1.0), (b, 1.0))):
        u, v = xi - x, yj - y
        R = np.sqrt(u**2 + v**2 + Z**2)
        s = si * sj
        iv = _inv_sum(v, R, u**2 + Z**2)  # 1/(v + R)
        iu = _inv_sum(u, R, v**2 + Z**2)  # 1/(u + R)
        E[:, 0] += s * _log_plus(v, R, u**2 + Z**2)
        E[:, 1] += s * _log_plus(u, R, v**2 + Z**2)
        E[:, 2] += s * np.arctan(u * v / (Z * R))
        G[:, 0, 0] -= s * u * iv / R
        G[:, 0, 1] -= s / R
        G[:, 0, 2] += s * Z * iv / R
        G[:, 1, 1] -= s * v * iu / R
        G[:, 1, 2] += s * Z * iu / R
    G[:, 1, 0] = G[:, 0, 1]
    G[:, 2, 0] = G[:, 0, 2]
    G[:, 2, 1] = G[:, 1, 2]
    G[:, 2, 2] = -G[:, 0, 0] - G[:, 1, 1]
    return E, G


def block_magnet_local(
    half: np.ndarray, remanence: float, p: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """B (N, 3), T, and ∇B (N, 3, 3), T/m, of the block [−a, a] × [−b, b] × [−c, c] magnetised
    along z, at local points p (N, 3) (module docstring)."""
    a, b, c = (float(h) for h in half)
    H = np.zeros((len(p), 3))  # µ0 H, T
    G = np.zeros((len(p), 3, 3))  # ∂(µ0 H_i)/∂x_j, T/m
    for z0, sigma in ((c, 1.0), (-c, -1.0)):
        E, dE = rect_sheet_local(a, b, p - np.array([0.0, 0.0, z0]))
        H += sigma * remanence / (4 * math.pi) * E
        G += sigma * remanence / (4 * math.pi) * dE
    inside = np.all(np.abs(p) < np.array([a, b, c]), axis=1)
    H[inside, 2] += remanence
    return H, G


def dipole_field(moment: np.ndarray, points: np.ndarray) -> np.ndarray:
    """B (N, 3), T, of a point dipole ``moment`` (3,), A m², at the origin, at ``points`` (N, 3)."""
    p = np.atleast_2d(points)
    r = np.linalg.norm(p, axis=1)[:, None]
    rhat = p / r
    m = np.asarray(moment, dtype=float)
    return MU0 / (4 * math.pi) * (3 * rhat * (rhat @ m)[:, None] - m) / r**3


def dipole_gradient(moment: np.ndarray, points: np.ndarray) -> np.ndarray:
    """∇B (N, 3, 3), T/m, of a point dipole ``moment`` (3,), A m², at the origin.

    ∂_j B_i = 3µ0/(4π r⁵) [m_i x_j + m_j x_i + (m·x) δ_ij − 5 (m·x) x_i x_j / r²].
    """
    p = np.atleast_2d(points)
    m = np.asarray(moment, dtype=float)
    r2 = np.einsum("ni,ni->n", p, p)
    mx = p @ m
    G = m[None, :, None] * p[:, None, :] + p[:, :, None] * m[None, None, :]
    G += mx[:, None, None] * np.eye(3)[None]
    G -= 5 * (mx / r2)[:, None, None] * p[:, :, None] * p[:, None, :]
    return 3 * MU0 / (4 * math.pi) * G / (r2**2.5)[:, None, None]


def gradient_fd(field, points: np.ndarray, h: float) -> np.ndarray:  # type: ignore[no-untyped-def]
    """∇B (N, 3, 3), ``[n, i, j] = ∂B_i/∂x_j``: 4th-order central differences of ``field``.

    ``field(points (N, 3)) -> (N, 3)``; step ``h`` (m).
    """
    p = np.atleast_2d(points)
    G = np.zeros((len(p), 3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        G[:, :, j] = (
            -field(p + 2 * e) + 8 * field(p + e) - 8 * field(p - e) + field(p - 2 * e)
        ) / (12 * h)
    return G
