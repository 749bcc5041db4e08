"""Field models: the applied flux density B_a(x, t) as the mechanics sees it.

The mechanics writes the magnetic energy −(F M̃)·B_a(x, t) with x = X + u the
*current* position, as a UFL expression, so that ``ufl.derivative`` yields
both the torque m × B and the gradient force (m·∇)B, consistently
linearised. A :class:`FieldModel` supplies that expression from the terms of
:mod:`magfem.field.build` (field B_s at nominal strength, waveform w_s(t),
rigid placement P_s(t): B_s(x, t) = R B_s(Rᵀ(x − d))):

==========  ==============================================================
``uniform``  B(x, t) = Σ_s w_s(t) B_s(x0, t): one ``Constant`` 3-vector, no
             gradient force (the cheapest; exact for uniform sources)
``taylor1``  B(x, t) = Σ_s w_s(t) [B_s(x0, t) + ∇B_s(x0, t)(x − x0)]
``taylor2``  … + ½ ∇∇B_s(x0, t) : (x − x0) ⊗ (x − x0)
``nodal``    B(x, t) = Σ_s w_s(t) [B_s(x_n, t) + ∇B_s(x_n, t)(x − x_n)] with
             x_n the robot's node positions at the last ``update(t, u=u)``:
             the exact field (closed forms, plus the FE reaction of iron) at
             the current nodes, refreshed each time step; inside a step the
             field is linear in x − x_n, so the ∇B·δu term of the Jacobian is
             exact in UFL (``fe`` is the former name of this model)
``nodal2``   … + ½ ∇∇B_s(x_n, t) : (x − x_n) ⊗ (x − x_n): the gradient force
             follows the body within a step (free bodies in a field trap)
==========  ==============================================================

x0 is ``FieldSpec.expansion_point``. Time enters only through
``fem.Constant``/``Function`` values updated in place by
:meth:`FieldModel.update`, so the forms are compiled once. Coefficients of
fixed terms are computed once; those of moving terms at every update.

Conventions: points (N, 3) in m; B in T; ``G[..., i, j] = ∂B_i/∂x_j`` in
T/m; ``H[..., i, j, k] = ∂²B_i/∂x_j∂x_k`` in T/m². On 2D meshes (gdim = 2,
side views in the (x, z) plane) a mesh point (X0, X1) is (X0, 0, X1).
Methods that take points are collective when a term is (an iron reaction).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from magfem.field.build import Term
from magfem.field.placement import Placement

__all__ = [
    "FieldModel",
    "NodalFieldModel",
    "TaylorFieldModel",
    "UniformFieldModel",
    "embed_points",
    "taylor_flux",
    "term_values",
]


def embed_points(x: np.ndarray, gdim: int) -> np.ndarray:
    """Mesh coordinates (N, >= gdim) → 3D points (N, 3); 2D (X0, X1) ↦ (X0, 0, X1)."""
    x = np.atleast_2d(x)
    if gdim == 3:
        return np.ascontiguousarray(x[:, :3], dtype=float)
    if gdim == 2:
        out = np.zeros((len(x), 3))
        out[:, 0], out[:, 2] = x[:, 0], x[:, 1]
        return out
    raise ValueError(f"gdim must be 2 or 3, got {gdim}")


def term_values(term: Term, points: np.ndarray, t: float, order: int = 1) -> tuple[np.ndarray, ...]:
    """(B, ∇B[, ∇∇B]) of ``term`` at nominal strength and its placement at time t.

    ``order`` 1: (B (N, 3), G (N, 3, 3)); 2: also H (N, 3, 3, 3). Collective if the term is.
    """
    pts = np.atleast_2d(np.asarray(points, dtype=float)).reshape(-1, 3)
    P = term.trajectory.placement(t) if term.trajectory is not None else Placement.identity()
    ref = P.to_reference(pts)
    B, G = term.field.field_and_gradient(ref)
    if order == 2:
        return P.vectors(B), P.tensors(G), P.tensors3(term.field.hessian(ref))
    return P.vectors(B), P.tensors(G)


def taylor_flux(B: Any, G: Any, H: Any, d: Any, order: int) -> Any:
    """B + G d (+ ½ H : d d at ``order`` 2, else H unused) at the offset d from the point (UFL)."""
    flux = B + ufl.dot(G, d)
    if order == 2:
        i, j, k = ufl.indices(3)
        flux = flux + 0.5 * ufl.as_vector(H[i, j, k] * d[j] * d[k], i)
    return flux


class FieldModel(ABC):
    """Applied field B_a(x, t) for the mechanics (module docstring).

    Args:
        terms: the field terms (:func:`magfem.field.build.build_terms`).
        comm: communicator of the collective terms.
    """

    name = "model"

    def __init__(self, terms: Sequence[Term], comm: MPI.Comm):
        self.terms = list(terms)
        self.comm = comm
        self.t = 0.0
        self.side = "right"

    # -- time ----------------------------------------------------------------------------
    def amplitudes(self, t: float, side: str = "right") -> np.ndarray:
        """Waveform values w_s(t), shape (S,)."""
        return np.array([term.waveform.value(t, side=side) for term in self.terms], dtype=float)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Sorted switching instants of the waveforms and keyframe times in (t0, t1], s."""
        pts = [term.waveform.breakpoints(t0, t1) for term in self.terms]
        pts += [term.trajectory.breakpoints(t0, t1) for term in self.terms if term.trajectory]
        return np.unique(np.concatenate(pts)) if pts else np.zeros(0)

    @property
    def moving(self) -> bool:
        """True when a term moves in time."""
        return any(term.trajectory is not None for term in self.terms)

    # -- mechanics interface -------------------------------------------------------------
    @abstractmethod
    def bind(self, domain: Any) -> None:
        """Create the Constants/Functions on the robot mesh (once, before compiling forms)."""

    @abstractmethod
    def flux_density(self, x: Any) -> Any:
        """B_a as a UFL 3-vector expression of the current position ``x`` (UFL 3-vector), T."""

    @abstractmethod
    def update(self, t: float, *, side: str = "right", u: Any = None) -> None:
        """Set the Constants/Functions to time ``t`` (one-sided limit ``side``); collective."""

    # -- numpy evaluation ------------------------------------------------------------------
    def field(
        self, points: np.ndarray, t: float, *, side: str = "right", exact: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """(B (N, 3), ∇B (N, 3, 3)) at ``points`` (N, 3) and time t.

        ``exact=False``: the field as this model represents it; ``exact=True``: the
        terms' fields themselves.
        """
        pts = np.atleast_2d(np.asarray(points, dtype=float)).reshape(-1, 3)
        B, G = np.zeros((len(pts), 3)), np.zeros((len(pts), 3, 3))
        for k, (term, a) in enumerate(zip(self.terms, self.amplitudes(t, side), strict=True)):
            b, g = term_values(term, pts, t)[:2] if exact else self._model_term(k, pts, t)
            B += a * b
            G += a * g
        return B, G

    def evaluate(
        self, points: np.ndarray, t: float, *, side: str = "right", exact: bool = False
    ) -> np.ndarray:
        """B (N, 3), T, at ``points`` (N, 3) and time t (see :meth:`field`)."""
        return self.field(points, t, side=side, exact=exact)[0]

    def gradient(
        self, points: np.ndarray, t: float, *, side: str = "right", exact: bool = False
    ) -> np.ndarray:
        """∇B (N, 3, 3), ``[n, i, j] = ∂B_i/∂x_j``, T/m (see :meth:`field`)."""
        return self.field(points, t, side=side, exact=exact)[1]

    def _model_term(self, k: int, pts: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(B, ∇B) of term k as the model represents it (default: exact)."""
        B, G = term_values(self.terms[k], pts, t)
        return B, G


class TaylorFieldModel(FieldModel):
    """Expansion about x0 of order 0 (``uniform``), 1 or 2 (module docstring).

    Args:
        x0: expansion point (3,), m.
        order: 0, 1 or 2.
    """

    def __init__(self, terms: Sequence[Term], comm: MPI.Comm, x0: np.ndarray, order: int):
        super().__init__(terms, comm)
        if order not in (0, 1, 2):
            raise ValueError(f"Taylor order must be 0, 1 or 2, got {order}")
        self.order = order
        self.name = "uniform" if order == 0 else f"taylor{order}"
        self.x0 = np.asarray(x0, dtype=float).reshape(3)
        self._cache: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._last: tuple[float, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] | None = None
        self._c: dict[str, Any] = {}

    def coefficients(self, t: float) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Per term (B (3,), ∇B (3, 3), ∇∇B (3, 3, 3)) at x0 and time t (collective)."""
        if self._last is not None and self._last[0] == t:
            return self._last[1]
        out = []
        for k, term in enumerate(self.terms):
            if term.trajectory is None and k in self._cache:
                out.append(self._cache[k])
                continue
            vals = term_values(term, self.x0[None, :], t, order=max(self.order, 1))
            c = (vals[0][0], vals[1][0], vals[2][0] if self.order == 2 else np.zeros((3, 3, 3)))
            if term.trajectory is None:
                self._cache[k] = c
            out.append(c)
        self._last = (t, out)
        return out

    def bind(self, domain: Any) -> None:
        self._c = {
            "B": fem.Constant(domain, np.zeros(3)),
            "G": fem.Constant(domain, np.zeros((3, 3))),
            "H": fem.Constant(domain, np.zeros((3, 3, 3))),
            "x0": fem.Constant(domain, self.x0.copy()),
        }
        self.update(self.t, side=self.side)

    def flux_density(self, x: Any) -> Any:
        if not self._c:
            raise RuntimeError("FieldModel.bind(domain) must be called before flux_density()")
        if self.order == 0:
            return self._c["B"]
        c = self._c
        return taylor_flux(c["B"], c["G"], c.get("H"), x - c["x0"], self.order)

    def update(self, t: float, *, side: str = "right", u: Any = None) -> None:
        self.t, self.side = float(t), side
        coef = self.coefficients(t)
        if not self._c:
            return
        a = self.amplitudes(t, side)
        for i, name in enumerate(("B", "G", "H")):
            self._c[name].value[:] = sum(w * c[i] for w, c in zip(a, coef, strict=True))

    def _model_term(self, k: int, pts: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        B0, G0, H0 = self.coefficients(t)[k]
        d = pts - self.x0
        if self.order == 0:
            return np.tile(B0, (len(pts), 1)), np.zeros((len(pts), 3, 3))
        B = B0 + d @ G0.T + 0.5 * np.einsum("ijk,nj,nk->ni", H0, d, d)
        G = G0[None] + np.einsum("ijk,nk->nij", H0, d)
        return B, G


class UniformFieldModel(TaylorFieldModel):
    """B(x, t) = Σ_s w_s(t) B_s(x0, t): a ``Constant`` 3-vector; no gradient force."""

    def __init__(self, terms: Sequence[Term], comm: MPI.Comm, x0: np.ndarray):
        super().__init__(terms, comm, x0, 0)


class NodalFieldModel(FieldModel):
    """The exact field re-expanded about the robot's current nodes at each update.

    On the robot mesh it keeps, per term s, B_s(x_n) and ∇B_s(x_n) at the nodes
    x_n = X + u_n of a Lagrange space of the mesh's geometry degree; between
    refreshes B(x) = Σ_s w_s(t) [B_s(x_n) + ∇B_s(x_n)(x − x_n)]. Fixed terms are
    re-evaluated when ``u`` is passed, moving terms at every update.

    ``order = 2`` (``nodal2``) adds ½ ∇∇B_s(x_n) : (x − x_n) ⊗ (x − x_n). With
    order 1 the field gradient, and so the gradient force (m·∇)B, is frozen at
    the start of the step: a body oscillating in a field trap of frequency ω
    then gains energy at a relative rate of about π ω Δt per period (a force
    lagging the motion by Δt/2); the Hessian term makes the force follow the
    body within the step, and the lag second order.
    """

    name = "nodal"

    def __init__(self, terms: Sequence[Term], comm: MPI.Comm, order: int = 1):
        super().__init__(terms, comm)
        if order not in (1, 2):
            raise ValueError(f"nodal order must be 1 or 2, got {order}")
        self.order = order
        self.name = "nodal" if order == 1 else "nodal2"
        self._f: dict[str, Any] = {}
        self._x = np.zeros((0, 3))
        self._bs: list[np.ndarray] = []
        self._gs: list[np.ndarray] = []
        self._hs: list[np.ndarray] = []

    def bind(self, domain: Any) -> None:
        deg = max(2, domain.geometry.cmaps[0].degree)
        self._gdim = domain.geometry.dim
        V3 = fem.functionspace(domain, ("Lagrange", deg, (3,)))
        VG = fem.functionspace(domain, ("Lagrange", deg, (3, 3)))
        Vu = fem.functionspace(domain, ("Lagrange", deg, (self._gdim,)))
        self._f = {
            "B": fem.Function(V3, name="B_applied"),
            "G": fem.Function(VG, name="gradB_applied"),
            "xn": fem.Function(V3, name="x_expansion"),
            "u": fem.Function(Vu),
        }
        if self.order == 2:
            VH = fem.functionspace(domain, ("Lagrange", deg, (3, 3, 3)))
            self._f["H"] = fem.Function(VH, name="hessB_applied")
        self._X = embed_points(V3.tabulate_dof_coordinates(), self._gdim)
        self._refresh(self._X, self.t, every=True)
        self.update(self.t, side=self.side)

    def _refresh(self, x: np.ndarray, t: float, *, every: bool) -> None:
        self._x = x
        self._f["xn"].x.array[:] = x.ravel()
        if every:
            self._bs = [np.zeros((len(x), 3)) for _ in self.terms]
            self._gs = [np.zeros((len(x), 3, 3)) for _ in self.terms]
            self._hs = [np.zeros((len(x), 3, 3, 3)) for _ in self.terms]
        for k, term in enumerate(self.terms):
            if every or term.trajectory is not None:
                values = term_values(term, x, t, order=self.order)
                self._bs[k], self._gs[k] = values[0], values[1]
                if self.order == 2:
                    self._hs[k] = values[2]

    def flux_density(self, x: Any) -> Any:
        if not self._f:
            raise RuntimeError("FieldModel.bind(domain) must be called before flux_density()")
        f = self._f
        return taylor_flux(f["B"], f["G"], f.get("H"), x - f["xn"], self.order)

    def update(self, t: float, *, side: str = "right", u: Any = None) -> None:
        self.t, self.side = float(t), side
        if not self._f:
            return
        if u is not None:
            un = self._f["u"]
            un.interpolate(u)
            disp = un.x.array.reshape(-1, self._gdim)
            self._refresh(self._X + embed_points(disp, self._gdim), t, every=True)
        elif self.moving:
            self._refresh(self._x, t, every=False)
        a = self.amplitudes(t, side)
        self._f["B"].x.array[:] = sum(
            (w * b for w, b in zip(a, self._bs, strict=True)), np.zeros_like(self._x)
        ).ravel()
        self._f["G"].x.array[:] = sum(
            (w * g for w, g in zip(a, self._gs, strict=True)), np.zeros((len(self._x), 3, 3))
        ).ravel()
        names = ["B", "G", "xn"]
        if self.order == 2:
            self._f["H"].x.array[:] = sum(
                (w * h for w, h in zip(a, self._hs, strict=True)),
                np.zeros((len(self._x), 3, 3, 3)),
            ).ravel()
            names.append("H")
        for name in names:
            self._f[name].x.scatter_forward()
