"""A measured B-H curve as a monotone C¹ interpolant (numpy and UFL), for nonlinear iron.

The table (H_k, B_k), k = 0 … n, starts at (0, 0) and increases strictly in
both. In b = µ0 H (T) it is interpolated by piecewise cubic Hermite
polynomials whose slopes m_k keep every piece monotone (F. N. Fritsch and
J. Butland, SIAM J. Sci. Stat. Comput. 5, 300 (1984); the weighted harmonic
mean of the neighbouring secants δ_k = ΔB/Δb at interior points, δ_0 at
the first point)::

    m_k = (w1 + w2) / (w1/δ_{k−1} + w2/δ_k),  w1 = 2h_k + h_{k−1},  w2 = h_k + 2h_{k−1}

Beyond the last point the curve is continued by the straight line of slope
1 (dB/dH = µ0: the polarisation has saturated); the last point's slope is
set to 1 (clipped to 3 δ_{n−1}, Fritsch–Carlson's monotonicity bound), so
the continuation is C¹ where the table's last secant is at least 1/3.
The isotropic law is then B = F(|b|) b/|b|. In UFL the knots are one
``fem.Constant`` of shape (3, n + 1), so a compiled form depends on the number
of table points only (a second table of that length costs no compilation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import ufl
from dolfinx import fem

from magfem.config import CaseError
from magfem.field.analytic import MU0

__all__ = ["BHCurve"]


@dataclass(frozen=True)
class BHCurve:
    """Knots b_k = µ0 H_k (T), B_k (T) and Hermite slopes m_k (dimensionless), each (n + 1,)."""

    b: np.ndarray
    B: np.ndarray
    m: np.ndarray

    @classmethod
    def from_table(cls, h: tuple[float, ...], B: tuple[float, ...]) -> BHCurve:
        """The curve through (H (A/m), B (T)); CaseError naming ``bh_h``/``bh_b`` if invalid."""
        hh, bb = np.asarray(h, dtype=float), np.asarray(B, dtype=float)
        if len(hh) != len(bb) or len(hh) < 2:
            raise CaseError(
                "bh_b", tuple(B), f"must have as many entries as bh_h ({len(hh)}), at least 2"
            )
        if hh[0] != 0.0 or bb[0] != 0.0:
            raise CaseError("bh_h", tuple(h), "the table must start at H = 0 A/m, B = 0 T")
        if np.any(np.diff(hh) <= 0.0):
            raise CaseError("bh_h", tuple(h), "must increase strictly (sorted, no repeats)")
        if np.any(np.diff(bb) <= 0.0):
            raise CaseError("bh_b", tuple(B), "must increase strictly with H (monotone curve)")
        x = MU0 * hh
        dx = np.diff(x)
        d = np.diff(bb) / dx
        m = np.empty_like(x)
        m[0] = d[0]
        w1, w2 = 2 * dx[1:] + dx[:-1], dx[1:] + 2 * dx[:-1]
        m[1:-1] = (w1 + w2) / (w1 / d[:-1] + w2 / d[1:])
        m[-1] = min(1.0, 3.0 * d[-1])
        return cls(x, bb, m)

    def __call__(self, nb: np.ndarray) -> np.ndarray:
        """|B| (T) at |b| = µ0|H| (T), elementwise (numpy)."""
        nb = np.asarray(nb, dtype=float)
        k = np.clip(np.searchsorted(self.b, nb, side="right") - 1, 0, len(self.b) - 2)
        out = _hermite(
            self.b[k], self.b[k + 1], self.B[k], self.B[k + 1], self.m[k], self.m[k + 1], nb
        )
        beyond = nb > self.b[-1]
        return np.where(beyond, self.B[-1] + (nb - self.b[-1]), out)

    @property
    def knots(self) -> np.ndarray:
        """(3, n + 1): the rows b_k, B_k, m_k (the values of :meth:`constant`)."""
        return np.stack([self.b, self.B, self.m])

    def constant(self, msh: Any) -> Any:
        """The knots as a ``fem.Constant`` on ``msh`` (the argument of :meth:`ufl`)."""
        return fem.Constant(msh, self.knots)

    def ufl(self, nb: Any, knots: Any) -> Any:
        """|B| (UFL) at the UFL scalar ``nb`` = |b|: nested conditionals over the intervals.

        ``knots`` is :meth:`constant` (or any UFL (3, n + 1) tensor): the compiled form
        depends on the number of points only, not on their values.
        """
        n = len(self.b)
        b, B, m = ([knots[i, k] for k in range(n)] for i in range(3))
        expr = B[-1] + (nb - b[-1])
        for k in range(n - 2, -1, -1):
            piece = _hermite(b[k], b[k + 1], B[k], B[k + 1], m[k], m[k + 1], nb)
            expr = ufl.conditional(ufl.lt(nb, b[k + 1]), piece, expr)
        return expr


def _hermite(x0: Any, x1: Any, y0: Any, y1: Any, m0: Any, m1: Any, x: Any) -> Any:
    """The cubic Hermite polynomial on [x0, x1] with values y and slopes m, at x."""
    h = x1 - x0
    t = (x - x0) / h
    t2, t3 = t * t, t * t * t
    return (
        y0 * (2 * t3 - 3 * t2 + 1)
        + h * m0 * (t3 - 2 * t2 + t)
        + y1 * (-2 * t3 + 3 * t2)
        + h * m1 * (t3 - t2)
    )
