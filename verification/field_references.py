"""Independent references for the field tests: brute-force quadratures and exact solutions.

Each is computed differently from :mod:`magfem.field.analytic` (which the
package uses): loops summed by composite Gauss–Legendre quadrature over the
winding or sheet, Coulomb integrals over a magnet's charged faces, and the
exact solution of an iron sphere in a uniform field.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy.optimize import brentq
from scipy.special import eval_legendre, lpmv

from magfem.field import analytic as an

MU0 = 4e-7 * math.pi


def gauss(lo: float, hi: float, n: int, pieces: int) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre nodes and weights on [lo, hi]."""
    x, w = np.polynomial.legendre.leggauss(n)
    edges = np.linspace(lo, hi, pieces + 1)
    nodes = np.concatenate([(b - a) / 2 * x + (a + b) / 2 for a, b in itertools.pairwise(edges)])
    weights = np.concatenate([(b - a) / 2 * w for a, b in itertools.pairwise(edges)])
    return nodes, weights


def sheet_by_loops(a: float, b: float, K: float, rho: np.ndarray, z: np.ndarray, n: int = 400):
    """(B_ρ, B_z) of a current sheet (radius a, −b ≤ z ≤ b, K A/m) as a sum of loops."""
    zs, ws = gauss(-b, b, 8, n // 8)
    br, bz = np.zeros(len(rho)), np.zeros(len(rho))
    for zk, wk in zip(zs, ws, strict=True):
        r, zz = an.loop_field(a, K * wk, rho, z - zk)
        br, bz = br + r, bz + zz
    return br, bz


def thick_coil_by_loops(r1, r2, length, turns, current, rho, z, n: int = 64):
    """(B_ρ, B_z) of a thick coil as a 2D Gauss–Legendre sum of loops over its cross-section."""
    ra, wa = gauss(r1, r2, 8, n // 8)
    za, wz = gauss(-length / 2, length / 2, 8, n // 8)
    J = turns * current / ((r2 - r1) * length)
    br, bz = np.zeros(len(rho)), np.zeros(len(rho))
    for a, w1 in zip(ra, wa, strict=True):
        for zk, w2 in zip(za, wz, strict=True):
            r, zz = an.loop_field(a, J * w1 * w2, rho, z - zk)
            br, bz = br + r, bz + zz
    return br, bz


def block_by_charges(half: np.ndarray, remanence: float, p: np.ndarray, n: int = 24):
    """B (N, 3) and ∇B (N, 3, 3) of a z-magnetised block from the Coulomb integrals of its faces.

    µ0 H(x) = B_r/(4π) Σ± ±∫ (x − x')/|x − x'|³ dA'; ∂_j µ0H_i = B_r/(4π) Σ± ±∫ (δ_ij/r³ −
    3 d_i d_j / r⁵) dA' with d = x − x'; composite Gauss–Legendre with ``n`` panels of 8 nodes
    per edge. Points must be outside the block.
    """
    xs, wx = gauss(-half[0], half[0], 8, n)
    ys, wy = gauss(-half[1], half[1], 8, n)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    W = np.outer(wx, wy).ravel()
    B, G = np.zeros((len(p), 3)), np.zeros((len(p), 3, 3))
    for zf, sign in ((half[2], 1.0), (-half[2], -1.0)):
        src = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, zf)])
        for k, x in enumerate(p):
            d = x - src
            r = np.linalg.norm(d, axis=1)
            B[k] += sign * (W / r**3) @ d
            G[k] += sign * (
                np.eye(3) * (W / r**3).sum() - 3 * np.einsum("n,ni,nj->ij", W / r**5, d, d)
            )
    c = remanence / (4 * math.pi)
    return c * B, c * G


def iron_sphere(mu_r: float, b0: float, saturation: float | None = None) -> tuple[float, float]:
    """(B inside, magnetisation M inside) of an iron sphere in a uniform field b0 (T), A/m.

    A uniformly magnetised sphere has the uniform demagnetising field −M/3, so with an
    isotropic law the interior is uniform: h + (B(h)/µ0 − h)/3 = b0/µ0 with h the interior
    H, B(h) = µ0 µr h (linear) or µ0 h + (2 J_s/π) arctan(π (µr − 1) µ0 h / (2 J_s)).
    """

    def law(h: float) -> float:
        if saturation is None:
            return MU0 * mu_r * h
        return MU0 * h + 2 * saturation / math.pi * math.atan(
            math.pi * (mu_r - 1) * MU0 * h / (2 * saturation)
        )

    h0 = b0 / MU0
    h = brentq(lambda h: h + (law(h) / MU0 - h) / 3 - h0, 0.0, h0, xtol=1e-14 * h0, rtol=1e-15)
    return law(h), law(h) / MU0 - h


def sphere_in_axial_field(a, mu_r, hz, rho, n_max=40, n_fft=128):
    """Reaction and interior field of a linear sphere (centre 0, radius a) in an axisymmetric field.

    The source is given by its on-axis H_z(z) (A/m), ``hz`` accepting complex z and analytic in
    |z| ≤ ``rho``. Its potential about the centre is φ_s = Σ a_n r^n P_n(cos θ) with
    a_n = −h_{n−1}/n (h_k the Taylor coefficients of H_z, from an FFT on the circle |z| = rho);
    continuity of φ and of µ ∂φ/∂r at r = a gives the reaction outside, Σ b_n r^−(n+1) P_n with
    b_n = a^(2n+1) a_n n (1 − µr)/(n µr + n + 1), and the total potential inside,
    Σ c_n r^n P_n with c_n = a_n + b_n a^−(2n+1). Returns (reaction B(points), interior B(points)).
    """
    k = np.arange(n_fft)
    vals = hz(rho * np.exp(2j * math.pi * k / n_fft))
    h = (np.fft.fft(vals) / n_fft).real / rho**k
    n = np.arange(1, n_max + 1)
    an = -h[n - 1] / n
    bn = a ** (2 * n + 1) * an * n * (1 - mu_r) / (n * mu_r + n + 1)
    cn = an + bn * a ** (-(2 * n + 1))

    def field(points, coef, power, radial, scale):
        p = np.atleast_2d(points)
        r = np.linalg.norm(p, axis=1)
        ct = p[:, 2] / r
        rho_xy = np.hypot(p[:, 0], p[:, 1])
        Hr, Ht = np.zeros(len(p)), np.zeros(len(p))
        for nn, c in zip(n, coef, strict=True):
            rp = r ** power(nn)
            Hr += radial(nn) * c * rp / r * eval_legendre(nn, ct)
            Ht -= c * rp / r * lpmv(1, nn, ct)  # −(1/r) ∂/∂θ of c r^k P_n(cos θ)
        st = rho_xy / r
        safe = np.where(rho_xy > 0, rho_xy, 1.0)
        cx, cy = (
            np.where(rho_xy > 0, p[:, 0] / safe, 1.0),
            np.where(rho_xy > 0, p[:, 1] / safe, 0.0),
        )
        Hrho = Hr * st + Ht * ct
        Hz = Hr * ct - Ht * st
        return scale * np.column_stack([Hrho * cx, Hrho * cy, Hz])

    def reaction(points):
        return field(points, bn, lambda nn: -(nn + 1), lambda nn: nn + 1, MU0)

    def interior(points):
        return field(points, cn, lambda nn: nn, lambda nn: -nn, MU0 * mu_r)

    return reaction, interior


SPHERE_RADIUS = 5e-3
"""a (m): the iron sphere of the field tests."""

SPHERE_FIELD = np.array([0.0, 0.0, 1e-3])
"""B0 (T): the uniform field the sphere sits in."""


def sphere_points(n: int = 60, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Random points inside (r < 0.9 a) and outside (1.2 a < r < 4 a) the test sphere."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    a = SPHERE_RADIUS
    return d * rng.uniform(0, 0.9 * a, (n, 1)), d * rng.uniform(1.2 * a, 4 * a, (n, 1))


def linear_sphere(mu_r: float) -> tuple[np.ndarray, np.ndarray]:
    """(interior B (T), dipole moment (A m²)) of the linear test sphere in SPHERE_FIELD."""
    b_in = 3 * mu_r / (mu_r + 2) * SPHERE_FIELD
    return b_in, 4 * math.pi * SPHERE_RADIUS**3 / MU0 * (mu_r - 1) / (mu_r + 2) * SPHERE_FIELD


def sphere_errors(reaction, b_in: np.ndarray, moment: np.ndarray) -> dict[str, float]:
    """Relative errors of an iron reaction against a uniform interior ``b_in`` and the
    exterior dipole ``moment``: interior B, exterior B and ∇B, the moment."""
    inner, outer = sphere_points()
    B, G = reaction.field_and_gradient(outer)
    Bd, Gd = an.dipole_field(moment, outer), an.dipole_gradient(moment, outer)
    return {
        "interior": np.abs(reaction.iron_flux_density(inner) - b_in).max() / np.linalg.norm(b_in),
        "B": np.linalg.norm(B - Bd, axis=1).max() / np.linalg.norm(Bd, axis=1).max(),
        "G": np.linalg.norm(G - Gd, axis=(1, 2)).max() / np.linalg.norm(Gd, axis=(1, 2)).max(),
        "moment": np.linalg.norm(reaction.moment - moment) / np.linalg.norm(moment),
    }
