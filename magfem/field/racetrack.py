"""Closed-form field of a racetrack coil: a rounded-rectangle winding of rectangular section.

Local frame: the coil's axis is z, its mid-plane z = 0. The winding is the
set of points at in-plane distance s ∈ [r1, r2] from the *spine* rectangle
[−cx, cx] × [−cy, cy] and at |z| ≤ h/2: four straight bars (offset cx + s or
cy + s from the axis, of length 2cy or 2cx) and four quarter-annulus corners
(radii r1 … r2 about the spine's corners). With cx = cy = 0 it is a thick
circular coil of radii r1, r2. The current density J = NI / ((r2 − r1) h)
(NI ampere-turns) circulates counter-clockwise about +z.

Biot–Savart, B(p) = µ0/(4π) ∫ J t × (p − X)/|p − X|³ dV (t the current
direction), split as:

* **bars**: at each offset s the bar's current sheet (a vertical rectangle,
  current along its length) gives t × E with E = ∫∫ (p − X)/|p − X|³ dA the
  Coulomb field of a uniformly charged rectangle, in closed form with its
  gradient (:func:`magfem.field.analytic.rect_sheet_local`, the sums of the
  block-magnet field of Furlani §4.3); the s integral is Gauss–Legendre;
* **corners**: each vertical strip (s, φ) of height h, current along
  t = (−sin φ, cos φ, 0), gives t × E with the line integral in closed form
  (ρ the horizontal offset from the strip, ζ₁,₂ = Z ± h/2, r_k = √(ρ² + ζ_k²))::

      E = ρ g + ẑ (1/r₂ − 1/r₁),   g = (ζ₁/r₁ − ζ₂/r₂)/ρ²
        = (ζ₁² − ζ₂²) / (r₁ r₂ (ζ₁ r₂ + ζ₂ r₁))   (ζ₁, ζ₂ > 0: no cancellation)

  and (s, φ) by Gauss–Legendre.

Both quadratures are composite 8-node Gauss–Legendre rules whose panels are
no longer than twice the distance of the evaluated points to the winding
(as for the thick circular coil, :func:`magfem.field.analytic.thick_coil_local`):
the integrands are analytic there and the error falls geometrically.
Gradients are exact derivatives of the same sums.
"""

from __future__ import annotations

import math

import numpy as np

from magfem.field.analytic import MU0, _gauss, rect_sheet_local

__all__ = ["racetrack_distance", "racetrack_local", "racetrack_resolution"]

_NODES = 8
_MAX_LEVEL = 8  # at most 2**8 panels across the longest winding dimension


def racetrack_distance(
    cx: float, cy: float, r1: float, r2: float, height: float, p: np.ndarray
) -> np.ndarray:
    """Distance (m) from local points p (N, 3) to the winding (0 inside)."""
    qx = np.maximum(np.abs(p[:, 0]) - cx, 0.0)
    qy = np.maximum(np.abs(p[:, 1]) - cy, 0.0)
    q = np.hypot(qx, qy)
    dr = np.maximum(np.maximum(r1 - q, q - r2), 0.0)
    dz = np.maximum(np.abs(p[:, 2]) - height / 2, 0.0)
    return np.hypot(dr, dz)


def _scale(r1: float, r2: float) -> float:
    """Longest quadrature direction (m): the winding's depth or a corner's outer arc."""
    return max(r2 - r1, 0.5 * math.pi * r2)


def racetrack_resolution(r1: float, r2: float) -> float:
    """Smallest distance (m) to a winding of offsets r1 < r2 (m) at which
    :func:`racetrack_local` is converged."""
    return _scale(r1, r2) / 2 ** (_MAX_LEVEL + 1)


def _strip(rho: np.ndarray, Z: np.ndarray, h: float) -> tuple[np.ndarray, ...]:
    """g, w and their derivatives ∂g/∂(ρ²), ∂g/∂Z, ∂w/∂(ρ²), ∂w/∂Z (module docstring)."""
    rho2 = rho[..., 0] ** 2 + rho[..., 1] ** 2
    z1, z2 = Z + h / 2, Z - h / 2
    r1, r2 = np.sqrt(rho2 + z1**2), np.sqrt(rho2 + z2**2)
    below = z1 <= 0.0  # mirror: g(ζ1, ζ2) = g(−ζ2, −ζ1)
    a = np.where(below, -z2, z1)
    b = np.where(below, -z1, z2)
    ra, rb = np.where(below, r2, r1), np.where(below, r1, r2)
    same = b >= 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        D = ra * rb * (a * rb + b * ra)
        N = a**2 - b**2
        g_s = N / D
        dD = (rb / (2 * ra) + ra / (2 * rb)) * (a * rb + b * ra) + ra * rb * (
            a / (2 * rb) + b / (2 * ra)
        )
        dg_s = -N * dD / D**2
        safe = np.where(same, 1.0, rho2)
        g_d = (a / ra - b / rb) / safe
        dg_d = -g_d / safe - (a / ra**3 - b / rb**3) / (2 * safe)
    g = np.where(same, g_s, g_d)
    dg = np.where(same, dg_s, dg_d)
    gz = 1.0 / r1**3 - 1.0 / r2**3
    w = 1.0 / r2 - 1.0 / r1
    dw = 0.5 / r1**3 - 0.5 / r2**3
    wz = z1 / r1**3 - z2 / r2**3
    return g, dg, gz, w, dw, wz


def _cross_t(t: np.ndarray, E: np.ndarray) -> np.ndarray:
    """t × E for t (..., 3) and E (..., 3), or E (..., 3, 3) crossed in its first index."""
    if E.ndim == t.ndim:
        return np.cross(t, E)
    return np.cross(t[..., None, :], np.swapaxes(E, -1, -2)).swapaxes(-1, -2)


def _corners(
    cx: float, cy: float, s: np.ndarray, ws: np.ndarray, phi: np.ndarray, wphi: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Strip positions (M, 2), tangents (M, 3) and weights (M,) of the four corners."""
    pos, tan, wt = [], [], []
    for k, (ox, oy) in enumerate(((cx, cy), (-cx, cy), (-cx, -cy), (cx, -cy))):
        f = phi + 0.5 * math.pi * k
        S, F = np.meshgrid(s, f, indexing="ij")
        W = np.outer(ws * s, wphi)
        pos.append(np.column_stack([ox + (S * np.cos(F)).ravel(), oy + (S * np.sin(F)).ravel()]))
        tan.append(np.column_stack([-np.sin(F).ravel(), np.cos(F).ravel(), 0 * F.ravel()]))
        wt.append(W.ravel())
    return np.vstack(pos), np.vstack(tan), np.concatenate(wt)


def _corner_field(
    p: np.ndarray, pos: np.ndarray, tan: np.ndarray, wt: np.ndarray, h: float, grad: bool
) -> tuple[np.ndarray, np.ndarray | None]:
    """Σ wt t × E_strip (N, 3) and its gradient (N, 3, 3) (or None) at points p (N, 3)."""
    rho = p[:, None, :2] - pos[None, :, :]
    g, dg, gz, w, dw, wz = _strip(rho, np.broadcast_to(p[:, None, 2], rho.shape[:2]), h)
    E = np.concatenate([rho * g[..., None], w[..., None]], axis=-1)
    B = np.einsum("nmi,m->ni", _cross_t(tan[None], E), wt)
    if not grad:
        return B, None
    dE = np.zeros((*rho.shape[:2], 3, 3))
    for j in range(2):
        dE[..., 0, j] = 2 * rho[..., 0] * rho[..., j] * dg
        dE[..., 1, j] = 2 * rho[..., 1] * rho[..., j] * dg
        dE[..., j, j] += g
        dE[..., 2, j] = 2 * rho[..., j] * dw
    dE[..., 0, 2] = rho[..., 0] * gz
    dE[..., 1, 2] = rho[..., 1] * gz
    dE[..., 2, 2] = wz
    G = np.einsum("nmij,m->nij", _cross_t(tan[None], dE), wt)
    return B, G


_ROT = [
    np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1.0]])
    for a in (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi)
]


def _bar_field(
    cx: float, cy: float, h: float, p: np.ndarray, s: np.ndarray, ws: np.ndarray, grad: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Σ over the four bars and the offsets s of ws t × E_sheet, and its gradient."""
    B, G = np.zeros((len(p), 3)), np.zeros((len(p), 3, 3))
    perm = [2, 0, 1]  # bar-0 components (x, y, z) = sheet (Z, X, Y)
    for k, Q in enumerate(_ROT):
        off, half = (cx, cy) if k % 2 == 0 else (cy, cx)
        if half <= 0.0:
            continue
        q = p @ Q  # into the frame of bar 0 (x = off + s, current along +y)
        # sheet frame: (X, Y, Z) = (y, z, x − off − s): a rectangle [−half, half] × [−h/2, h/2],
        # all offsets s at once: rows (point, offset)
        loc = np.stack(
            np.broadcast_arrays(q[:, None, 1], q[:, None, 2], q[:, None, 0] - off - s[None, :]),
            axis=-1,
        ).reshape(-1, 3)
        E, dE = rect_sheet_local(half, h / 2, loc)
        Eb = np.einsum("nsi,s->ni", E.reshape(len(p), len(s), 3), ws)[:, perm]
        b = np.column_stack([Eb[:, 2], np.zeros(len(p)), -Eb[:, 0]])  # ŷ × E
        B += b @ Q.T
        if grad:
            dEb = np.einsum("nsij,s->nij", dE.reshape(len(p), len(s), 3, 3), ws)
            dEb = dEb[:, perm][:, :, perm]
            gb = np.stack([dEb[:, 2, :], np.zeros((len(p), 3)), -dEb[:, 0, :]], axis=1)
            G += np.einsum("ia,nab,jb->nij", Q, gb, Q)
    return B, G


def racetrack_local(
    cx: float,
    cy: float,
    r1: float,
    r2: float,
    height: float,
    ampere_turns: float,
    p: np.ndarray,
    *,
    grad: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """B (N, 3), T, and ∇B (N, 3, 3), T/m (zeros if not ``grad``), at local points p (N, 3).

    Spine half-sides cx, cy, winding offsets r1 < r2 and height (m); outside the
    winding (module docstring). Points are grouped by their distance d to the
    winding; each group's panels are at most 2d long (points closer than
    :func:`racetrack_resolution` are not resolved).
    """
    p = np.atleast_2d(np.asarray(p, dtype=float))
    J = ampere_turns / ((r2 - r1) * height)
    scale = _scale(r1, r2)
    d = racetrack_distance(cx, cy, r1, r2, height, p)
    need = np.clip(np.ceil(scale / np.maximum(2 * d, 1e-300)), 1, 2**_MAX_LEVEL)
    need[d <= 0.0] = 1
    level = np.ceil(np.log2(need)).astype(int)
    B, G = np.zeros((len(p), 3)), np.zeros((len(p), 3, 3))
    c = MU0 * J / (4 * math.pi)
    for lev in np.unique(level):
        idx = np.flatnonzero(level == lev)
        n_s = max(1, math.ceil((r2 - r1) * 2**lev / scale))
        n_phi = max(1, math.ceil(0.5 * math.pi * r2 * 2**lev / scale))
        s, ws = _gauss(r1, r2, _NODES, n_s)
        phi, wphi = _gauss(0.0, 0.5 * math.pi, _NODES, n_phi)
        pos, tan, wt = _corners(cx, cy, s, ws, phi, wphi)
        chunk = max(1, 100_000 // len(wt))
        for k in range(0, len(idx), chunk):
            sl = idx[k : k + chunk]
            b, g = _corner_field(p[sl], pos, tan, wt, height, grad)
            bb, gb = _bar_field(cx, cy, height, p[sl], s, ws, grad)
            B[sl] = c * (b + bb)
            if grad and g is not None:
                G[sl] = c * (g + gb)
    return B, G
