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
