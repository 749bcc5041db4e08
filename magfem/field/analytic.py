"""Closed-form reference fields, independent of the finite-element code.

Everything is in SI (m, A, T) and vectorised over points. Cylindrical
kernels take (ρ, z) in the source frame (axis = local z, centre at 0);
Cartesian wrappers place a source by ``center`` and ``axis`` (rigid
transform) and return B (N, 3) in T.

Circular current loop (radius a, current I), complete elliptic integrals
K(m), E(m) of parameter m = k² (Simpson, Lane, Immer, Youngquist, NASA
TM-2001-210042; Jackson, Classical Electrodynamics §5.5)::

    α² = a² + ρ² + z² − 2aρ,  β² = a² + ρ² + z² + 2aρ,  m = 1 − α²/β²,  C = µ0 I / π
    B_ρ = C z / (2 α² β ρ) [(a² + ρ² + z²) E(m) − α² K(m)]
    B_z = C / (2 α² β)     [(a² − ρ² − z²) E(m) + α² K(m)]

On its axis B_z = µ0 I a² / (2 (a² + z²)^{3/2}).

Thick coil (radii r1 < r2, axial length L, N turns of current I, uniform
J = N I / ((r2 − r1) L)); on the axis, with z± = z ± L/2 (integrating the
loop's on-axis field over the cross-section)::

    B_z = µ0 J / 2 [z₊ ln((r2 + √(r2² + z₊²)) / (r1 + √(r1² + z₊²)))
                   − z₋ ln((r2 + √(r2² + z₋²)) / (r1 + √(r1² + z₋²)))]

Off the axis the loop field is integrated over the winding cross-section by
composite Gauss–Legendre quadrature (the integrand is analytic away from
the winding; the quadrature error is checked in the tests by doubling the
points).

Axially magnetised cylinder (radius R, length L, remanence Br): equivalent
to a solenoid sheet of surface current Br/µ0 per unit length on ρ = R (the
bound current M × n); on the axis::

    B_z = Br/2 [z₊ / √(R² + z₊²) − z₋ / √(R² + z₋²)]

(B, inside and outside). Off the axis the sheet is integrated over z by
composite Gauss–Legendre quadrature of the loop field.

Block magnet (edges 2a, 2b, 2c, magnetised along z with Br = µ0 M): the
field of the two magnetic-charge sheets σ = ±M on z = ±c (Furlani,
Permanent Magnet and Electromechanical Devices, Academic Press 2001, §4.3;
Engel-Herbert & Hesjedal, J. Appl. Phys. 97, 074504 (2005)). For a sheet
[x1, x2] × [y1, y2] at height z0 with u_i = x_i − x, v_j = y_j − y,
Z = z − z0, R_ij = √(u_i² + v_j² + Z²), s_1 = −1, s_2 = +1::

    H_x = σ/4π Σ s_i s_j ln(v_j + R_ij)
    H_y = σ/4π Σ s_i s_j ln(u_i + R_ij)
    H_z = σ/4π Σ s_i s_j arctan(u_i v_j / (Z R_ij))

and B = µ0 H (+ Br ẑ inside the block). Gradients of all references are
4th-order central differences of these smooth closed forms with step
``h = 1e-4 ×`` the source size (truncation ~h⁴, round-off ~1e-12).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import numpy as np
from scipy.special import ellipe, ellipk

__all__ = [
    "MU0",
    "block_magnet_field",
    "coil_field",
    "cylinder_magnet_field",
    "cylinder_magnet_on_axis",
    "dipole_field",
    "gradient_fd",
    "loop_field",
    "loop_on_axis",
    "place",
    "thick_coil_field",
    "thick_coil_on_axis",
]

MU0 = 4e-7 * math.pi
"""Vacuum permeability, H/m (the pre-2019 exact value; the 2019 SI value differs by 1e-10)."""


def loop_on_axis(a: float, current: float, z: np.ndarray) -> np.ndarray:
    """On-axis B_z (T) of a loop of radius ``a`` (m) and ``current`` (A) at heights z (m)."""
    z = np.asarray(z, dtype=float)
    return MU0 * current * a**2 / (2 * (a**2 + z**2) ** 1.5)


def loop_field(
    a: float, current: float, rho: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(B_ρ, B_z), T, of a current loop (radius a, m; current, A) at (ρ, z) (arrays, m).

    Loop in the plane z = 0 centred on the axis; elliptic-integral form of
    the module docstring. On the axis (ρ < 1e-12 a) B_ρ = 0 exactly.
    """
    rho, z = np.broadcast_arrays(np.asarray(rho, dtype=float), np.asarray(z, dtype=float))
    return _loop_field_array(np.asarray(a, dtype=float), np.asarray(current, dtype=float), rho, z)


def _loop_field_array(
    a: np.ndarray, current: np.ndarray, rho: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Kernel of :func:`loop_field`; ``a`` and ``current`` broadcast with ρ, z."""
    r2 = rho**2 + z**2
    alpha2 = a**2 + r2 - 2 * a * rho
    beta2 = a**2 + r2 + 2 * a * rho
    beta = np.sqrt(beta2)
    m = 1.0 - alpha2 / beta2
    K, E = ellipk(m), ellipe(m)
    C = MU0 * current / math.pi
    on_axis = rho < 1e-12 * a
    safe_rho = np.where(on_axis, 1.0, rho)
    b_rho = np.where(
        on_axis, 0.0, C * z / (2 * alpha2 * beta * safe_rho) * ((a**2 + r2) * E - alpha2 * K)
    )
    b_z = C / (2 * alpha2 * beta) * ((a**2 - r2) * E + alpha2 * K)
    return b_rho, b_z


def thick_coil_on_axis(
    r1: float, r2: float, length: float, turns: int, current: float, z: np.ndarray
) -> np.ndarray:
    """On-axis B_z (T) of a thick coil centred at z = 0 (closed form of the module docstring)."""
    z = np.asarray(z, dtype=float)
    J = turns * current / ((r2 - r1) * length)

    def term(zz: np.ndarray) -> np.ndarray:
        return zz * np.log((r2 + np.sqrt(r2**2 + zz**2)) / (r1 + np.sqrt(r1**2 + zz**2)))

    return MU0 * J / 2 * (term(z + length / 2) - term(z - length / 2))


def _gauss(lo: float, hi: float, n: int, pieces: int) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre nodes and weights on [lo, hi]."""
    x, w = np.polynomial.legendre.leggauss(n)
    edges = np.linspace(lo, hi, pieces + 1)
    nodes = np.concatenate(
        [(e1 - e0) / 2 * x + (e0 + e1) / 2 for e0, e1 in itertools.pairwise(edges)]
    )
    weights = np.concatenate([(e1 - e0) / 2 * w for e0, e1 in itertools.pairwise(edges)])
    return nodes, weights


def thick_coil_field(
    r1: float,
    r2: float,
    length: float,
    turns: int,
    current: float,
    rho: np.ndarray,
    z: np.ndarray,
    *,
    n: int = 16,
    pieces: int = 4,
) -> tuple[np.ndarray, np.ndarray]:
    """(B_ρ, B_z), T, of a thick coil centred at z = 0 at (ρ, z) (arrays, m).

    Loop field integrated over the winding cross-section by composite
    Gauss–Legendre quadrature (``pieces`` × ``n`` nodes per direction).
    """
    ra, wa = _gauss(r1, r2, n, pieces)
    za, wz = _gauss(-length / 2, length / 2, n, pieces)
    J = turns * current / ((r2 - r1) * length)
    a = np.repeat(ra, len(za))
    zc = np.tile(za, len(ra))
    w = J * np.outer(wa, wz).ravel()
    return _sum_loops(a, zc, w, rho, z)


def cylinder_magnet_on_axis(
    radius: float, length: float, remanence: float, z: np.ndarray
) -> np.ndarray:
    """On-axis B_z (T) of an axially magnetised cylinder centred at z = 0 (closed form)."""
    z = np.asarray(z, dtype=float)
    zp, zm = z + length / 2, z - length / 2
    return remanence / 2 * (zp / np.sqrt(radius**2 + zp**2) - zm / np.sqrt(radius**2 + zm**2))


def cylinder_magnet_field(
    radius: float,
    length: float,
    remanence: float,
    rho: np.ndarray,
    z: np.ndarray,
    *,
    n: int = 24,
    pieces: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """(B_ρ, B_z), T, of an axially magnetised cylinder (equivalent current sheet Br/µ0)."""
    za, wz = _gauss(-length / 2, length / 2, n, pieces)
    return _sum_loops(np.full_like(za, radius), za, wz * remanence / MU0, rho, z)


def _sum_loops(
    a: np.ndarray, zc: np.ndarray, current: np.ndarray, rho: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Σ_k loop_field(a_k, current_k, ρ, z − zc_k), vectorised in chunks of points.

    ρ and z (m) broadcast against each other; scalars give arrays of one point.
    """
    rho, z = np.broadcast_arrays(
        np.atleast_1d(np.asarray(rho, dtype=float)), np.atleast_1d(np.asarray(z, dtype=float))
    )
    shape = rho.shape
    rho, z = rho.ravel(), z.ravel()
    br, bz = np.zeros(len(rho)), np.zeros(len(rho))
    chunk = max(1, 400_000 // max(1, len(a)))
    for s in range(0, len(rho), chunk):
        sl = slice(s, s + chunk)
        dr, dz = _loop_field_array(
            a[None, :], current[None, :], rho[sl, None], z[sl, None] - zc[None, :]
        )
        br[sl], bz[sl] = dr.sum(axis=1), dz.sum(axis=1)
    return br.reshape(shape), bz.reshape(shape)


def _block_local(half: np.ndarray, remanence: float, p: np.ndarray) -> np.ndarray:
    """B (N, 3), T, of a block [-a, a] × [-b, b] × [-c, c] magnetised along z, at local p (N, 3)."""
    a, b, c = half
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    H = np.zeros((len(p), 3))  # µ0 H, T
    for z0, sigma in ((c, 1.0), (-c, -1.0)):
        Z = z - z0
        for xi, si in ((-a, -1.0), (a, 1.0)):
            for yj, sj in ((-b, -1.0), (b, 1.0)):
                u, v = xi - x, yj - y
                R = np.sqrt(u**2 + v**2 + Z**2)
                s = sigma * si * sj * remanence / (4 * math.pi)
                H[:, 0] += s * _log_plus(v, R, u**2 + Z**2)
                H[:, 1] += s * _log_plus(u, R, v**2 + Z**2)
                H[:, 2] += s * np.arctan(u * v / (Z * R))
    inside = (np.abs(x) < a) & (np.abs(y) < b) & (np.abs(z) < c)
    H[inside, 2] += remanence
    return H


def _log_plus(v: np.ndarray, R: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """ln(v + R) with R = √(v² + rest), without cancellation for v < 0."""
    neg = v < 0
    out = np.empty_like(v)
    out[~neg] = np.log(v[~neg] + R[~neg])
    out[neg] = np.log(rest[neg] / (R[neg] - v[neg]))
    return out


def dipole_field(moment: np.ndarray, points: np.ndarray) -> np.ndarray:
    """B (N, 3), T, of a point dipole ``moment`` (3,), A m², at the origin, at ``points`` (N, 3)."""
    p = np.atleast_2d(points)
    r = np.linalg.norm(p, axis=1)[:, None]
    rhat = p / r
    m = np.asarray(moment, dtype=float)
    return MU0 / (4 * math.pi) * (3 * rhat * (rhat @ m)[:, None] - m) / r**3


def frame_matrix(axis: np.ndarray, roll: float = 0.0) -> np.ndarray:
    """Columns = local x, y, z axes (local z = unit ``axis``); same convention as the spec."""
    from magfem.field.spec import frame

    return frame(np.asarray(axis, dtype=float) / np.linalg.norm(axis), roll)


def place(
    local: Callable[[np.ndarray], np.ndarray],
    center: np.ndarray,
    axis: np.ndarray,
    roll: float = 0.0,
) -> Callable[[np.ndarray], np.ndarray]:
    """Rigidly place a field given in its local frame: B(x) = Q B_loc(Qᵀ (x − center))."""
    Q = frame_matrix(axis, roll)
    c = np.asarray(center, dtype=float)

    def field(points: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(points)
        return local((p - c) @ Q) @ Q.T

    return field


def _axisymmetric(
    fn: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]],
) -> Callable[[np.ndarray], np.ndarray]:
    def local(p: np.ndarray) -> np.ndarray:
        rho = np.hypot(p[:, 0], p[:, 1])
        br, bz = fn(rho, p[:, 2])
        safe = np.where(rho > 0, rho, 1.0)
        return np.column_stack([br * p[:, 0] / safe, br * p[:, 1] / safe, bz])

    return local


def coil_field(
    center: np.ndarray,
    axis: np.ndarray,
    r1: float,
    r2: float,
    length: float,
    turns: int,
    current: float,
    **quad: int,
) -> Callable[[np.ndarray], np.ndarray]:
    """B(points (N, 3)) → (N, 3), T, of a thick coil placed at ``center`` along ``axis``."""
    return place(
        _axisymmetric(lambda r, z: thick_coil_field(r1, r2, length, turns, current, r, z, **quad)),
        center,
        axis,
    )


def cylinder_field(
    center: np.ndarray,
    axis: np.ndarray,
    radius: float,
    length: float,
    remanence: float,
    **quad: int,
) -> Callable[[np.ndarray], np.ndarray]:
    """B(points (N, 3)) → (N, 3), T, of a cylinder magnet magnetised along ``axis``."""
    return place(
        _axisymmetric(lambda r, z: cylinder_magnet_field(radius, length, remanence, r, z, **quad)),
        center,
        axis,
    )


def block_magnet_field(
    center: np.ndarray, axis: np.ndarray, size: np.ndarray, remanence: float, roll: float = 0.0
) -> Callable[[np.ndarray], np.ndarray]:
    """B(points (N, 3)) → (N, 3), T, of a block magnet (edges ``size`` along local x, y, z)."""
    half = np.asarray(size, dtype=float) / 2
    return place(lambda p: _block_local(half, remanence, p), center, axis, roll)


def gradient_fd(
    field: Callable[[np.ndarray], np.ndarray], points: np.ndarray, h: float
) -> np.ndarray:
    """∇B (N, 3, 3), ``[n, i, j] = ∂B_i/∂x_j``: 4th-order central differences of a smooth field."""
    p = np.atleast_2d(points)
    G = np.zeros((len(p), 3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        G[:, :, j] = (
            -field(p + 2 * e) + 8 * field(p + e) - 8 * field(p - e) + field(p - 2 * e)
        ) / (12 * h)
    return G
