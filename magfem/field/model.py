"""Field models: the applied flux density B_a(x, t) as the mechanics sees it.

The mechanics writes the magnetic energy −(F M̃)·B_a(x, t) with x = X + u the
*current* position, as a UFL expression, so that ``ufl.derivative`` yields
both the torque m × B and the gradient force (m·∇)B, consistently
linearised (DESIGN.md). A :class:`FieldModel` supplies that expression:

==========  ==============================================================
``uniform``  B(x, t) = Σ_s w_s(t) B_s(x0): one ``Constant`` 3-vector, no
             gradient force (the cheapest; exact for uniform sources)
``taylor1``  B(x, t) = Σ_s w_s(t) [B_s(x0) + ∇B_s(x0)(x − x0)]
``taylor2``  … + ½ ∇∇B_s(x0) : (x − x0) ⊗ (x − x0)
``fe``       B(x, t) = Σ_s w_s(t) [B_s(x_n) + ∇B_s(x_n)(x − x_n)] with x_n
             the robot's node positions at the last ``update(t, u=u)``:
             B and ∇B of the FE solution are interpolated at the current
             nodes each time step, and inside the step the field is linear
             in x − x_n, so the ∇B·δu term of the Jacobian is exact in UFL
==========  ==============================================================

Here x0 is ``FieldSpec.expansion_point``, w_s the waveform of source s and
B_s its field at nominal strength (``magfem.field.sources``: FE solutions or
the uniform field). Time enters only through ``fem.Constant``/``Function``
values updated in place by :meth:`FieldModel.update`, so the forms are
compiled once.

The Taylor models' error against the FE field over the robot workspace is
:func:`model_errors`; ``model = "auto"`` picks the cheapest model whose
relative B error over the workspace is below ``FieldSpec.tolerance``.

Conventions: points are (N, 3) arrays in m; B in T; gradients
``G[..., i, j] = ∂B_i/∂x_j`` in T/m; Hessians ``H[..., i, j, k] =
∂²B_i/∂x_j∂x_k`` in T/m². For 2D meshes (gdim = 2, side views in the (x, z)
plane) a mesh point (X0, X1) is the 3D point (X0, 0, X1).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any

import numpy as np
from mpi4py import MPI

from magfem.config import CaseError
from magfem.field.spec import FieldSpec, UniformSourceSpec
from magfem.field.waveforms import Waveform, build_waveform

__all__ = [
    "FEFieldModel",
    "FieldModel",
    "SourceField",
    "TaylorFieldModel",
    "UniformField",
    "UniformFieldModel",
    "create_field_model",
    "embed_points",
    "hessian_from_gradient",
    "model_errors",
    "workspace_points",
]


class SourceField(ABC):
    """The field of one source at nominal strength (waveform value 1), as numpy functions.

    Subclasses: :class:`UniformField`, the FE fields of
    :mod:`magfem.field.axisymmetric` and :mod:`magfem.field.solid`. Methods
    taking points are collective for FE fields (every rank calls them, each
    with its own points, possibly none).
    """

    name: str = "source"
    uniform: bool = False

    @abstractmethod
    def flux_density(self, points: np.ndarray) -> np.ndarray:
        """B at ``points`` (N, 3), m → (N, 3), T."""

    @abstractmethod
    def gradient(self, points: np.ndarray) -> np.ndarray:
        """∇B at ``points`` (N, 3) → (N, 3, 3), ``[n, i, j] = ∂B_i/∂x_j``, T/m."""

    @abstractmethod
    def hessian(self, points: np.ndarray) -> np.ndarray:
        """∇∇B at ``points`` (N, 3) → (N, 3, 3, 3), T/m²."""

    def field_and_gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B (N, 3), ∇B (N, 3, 3)) at ``points`` in one pass (FE fields locate points once)."""
        return self.flux_density(points), self.gradient(points)

    def covers(self, points: np.ndarray) -> np.ndarray:
        """Mask (N,) of ``points`` (N, 3) where the field can be evaluated (its air region)."""
        return np.ones(len(np.atleast_2d(points)), dtype=bool)


class UniformField(SourceField):
    """A spatially uniform flux density ``vector`` (shape (3,), T)."""

    uniform = True

    def __init__(self, vector: np.ndarray, name: str = "uniform"):
        self.vector = np.asarray(vector, dtype=float).reshape(3)
        self.name = name

    def flux_density(self, points: np.ndarray) -> np.ndarray:
        return np.tile(self.vector, (len(np.atleast_2d(points)), 1))

    def gradient(self, points: np.ndarray) -> np.ndarray:
        return np.zeros((len(np.atleast_2d(points)), 3, 3))

    def hessian(self, points: np.ndarray) -> np.ndarray:
        return np.zeros((len(np.atleast_2d(points)), 3, 3, 3))


def hessian_from_gradient(gradient: Any, points: np.ndarray, step: float) -> np.ndarray:
    """∇∇B (N, 3, 3, 3) by central differences of a continuous recovered gradient (step m).

    Symmetrised in the two derivative indices. Error O(step²) plus the
    gradient's error divided by ``step`` (the step should be of the order of
    the workspace, not of the mesh).
    """
    p = np.atleast_2d(points).reshape(-1, 3)
    H = np.zeros((len(p), 3, 3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = step
        H[:, :, :, k] = (gradient(p + e) - gradient(p - e)) / (2 * step)
    return 0.5 * (H + H.transpose(0, 1, 3, 2))


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


def workspace_points(center: Sequence[float] | np.ndarray, size: float, n: int = 5) -> np.ndarray:
    """Grid of n³ points filling the cube of edge ``size`` (m) about ``center``: (n³, 3)."""
    s = np.linspace(-size / 2, size / 2, n)
    g = np.stack(np.meshgrid(s, s, s, indexing="ij"), axis=-1).reshape(-1, 3)
    return g + np.asarray(center, dtype=float)


class FieldModel(ABC):
    """Applied field B_a(x, t) for the mechanics (module docstring).

    Args:
        sources: (field at nominal strength, waveform) per source.
        comm: communicator of the FE source solves.
        name: ``uniform``, ``taylor1``, ``taylor2`` or ``fe``.
    """

    name = "model"

    def __init__(self, sources: Sequence[tuple[SourceField, Waveform]], comm: MPI.Comm):
        self.sources = list(sources)
        self.comm = comm
        self.t = 0.0
        self.side = "right"
        self._bound = False

    # -- time ----------------------------------------------------------------------------
    def amplitudes(self, t: float, *, side: str = "right") -> np.ndarray:
        """Waveform values w_s(t), shape (S,)."""
        return np.array([w.value(t, side=side) for _, w in self.sources], dtype=float)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Sorted union of the sources' switching instants in (t0, t1], s."""
        pts = [w.breakpoints(t0, t1) for _, w in self.sources]
        if not pts:
            return np.zeros(0)
        return np.unique(np.concatenate(pts))

    # -- mechanics interface -------------------------------------------------------------
    @abstractmethod
    def bind(self, domain: Any) -> None:
        """Create the Constants/Functions on the robot mesh (once, before compiling forms)."""

    @abstractmethod
    def flux_density(self, x: Any) -> Any:
        """B_a as a UFL 3-vector expression of the current position ``x`` (UFL 3-vector), T."""

    @abstractmethod
    def update(self, t: float, *, side: str = "right", u: Any = None) -> None:
        """Set the Constants/Functions to time ``t`` (one-sided limit ``side``)."""

    # -- numpy evaluation ------------------------------------------------------------------
    def evaluate(
        self, points: np.ndarray, t: float, *, side: str = "right", exact: bool = False
    ) -> np.ndarray:
        """B at ``points`` (N, 3) and time t → (N, 3), T.

        ``exact=False``: the field as this model represents it;
        ``exact=True``: the underlying source fields (FE or uniform).
        Collective when FE sources are present.
        """
        a = self.amplitudes(t, side=side)
        pts = np.atleast_2d(np.asarray(points, dtype=float)).reshape(-1, 3)
        out = np.zeros((len(pts), 3))
        for (src, _), ai in zip(self.sources, a, strict=True):
            out += ai * (src.flux_density(pts) if exact else self._model_b(src, pts))
        return out

    def gradient(
        self, points: np.ndarray, t: float, *, side: str = "right", exact: bool = False
    ) -> np.ndarray:
        """∇B at ``points`` (N, 3) → (N, 3, 3), ``[n, i, j] = ∂B_i/∂x_j``, T/m."""
        a = self.amplitudes(t, side=side)
        pts = np.atleast_2d(np.asarray(points, dtype=float)).reshape(-1, 3)
        out = np.zeros((len(pts), 3, 3))
        for (src, _), ai in zip(self.sources, a, strict=True):
            out += ai * (src.gradient(pts) if exact else self._model_g(src, pts))
        return out

    def _model_b(self, src: SourceField, pts: np.ndarray) -> np.ndarray:
        return src.flux_density(pts)

    def _model_g(self, src: SourceField, pts: np.ndarray) -> np.ndarray:
        return src.gradient(pts)


class UniformFieldModel(FieldModel):
    """B(x, t) = Σ_s w_s(t) B_s(x0): a ``Constant`` 3-vector; no gradient force.

    Args:
        x0: point (3,), m, where non-uniform sources are sampled.
    """

    name = "uniform"

    def __init__(
        self, sources: Sequence[tuple[SourceField, Waveform]], comm: MPI.Comm, x0: np.ndarray
    ):
        super().__init__(sources, comm)
        self.x0 = np.asarray(x0, dtype=float).reshape(3)
        self._b0 = np.array([s.flux_density(self.x0[None, :])[0] for s, _ in self.sources]).reshape(
            -1, 3
        )
        self._B: Any = None

    def bind(self, domain: Any) -> None:
        from dolfinx import fem

        self._B = fem.Constant(domain, np.zeros(3))
        self._bound = True
        self.update(self.t, side=self.side)

    def flux_density(self, x: Any) -> Any:
        if self._B is None:
            raise RuntimeError("FieldModel.bind(domain) must be called before flux_density()")
        return self._B

    def update(self, t: float, *, side: str = "right", u: Any = None) -> None:
        self.t, self.side = float(t), side
        if self._B is not None:
            self._B.value[:] = self.amplitudes(t, side=side) @ self._b0

    def _model_b(self, src: SourceField, pts: np.ndarray) -> np.ndarray:
        i = [s for s, _ in self.sources].index(src)
        return np.tile(self._b0[i], (len(pts), 1))

    def _model_g(self, src: SourceField, pts: np.ndarray) -> np.ndarray:
        return np.zeros((len(pts), 3, 3))


class TaylorFieldModel(FieldModel):
    """Local Taylor expansion about x0 of order 1 or 2 (module docstring).

    Coefficients are per source at nominal strength, combined with the
    waveform values at each :meth:`update`.
    """

    def __init__(
        self,
        sources: Sequence[tuple[SourceField, Waveform]],
        comm: MPI.Comm,
        x0: np.ndarray,
        order: int,
    ):
        super().__init__(sources, comm)
        if order not in (1, 2):
            raise ValueError(f"Taylor order must be 1 or 2, got {order}")
        self.order = order
        self.name = f"taylor{order}"
        self.x0 = np.asarray(x0, dtype=float).reshape(3)
        p = self.x0[None, :]
        S = len(self.sources)
        self._b0 = np.array([s.flux_density(p)[0] for s, _ in self.sources]).reshape(S, 3)
        self._g0 = np.array([s.gradient(p)[0] for s, _ in self.sources]).reshape(S, 3, 3)
        if order == 2:
            self._h0 = np.array([s.hessian(p)[0] for s, _ in self.sources]).reshape(S, 3, 3, 3)
        else:
            self._h0 = np.zeros((S, 3, 3, 3))
        self._c: dict[str, Any] = {}

    def bind(self, domain: Any) -> None:
        from dolfinx import fem

        self._c = {
            "B": fem.Constant(domain, np.zeros(3)),
            "G": fem.Constant(domain, np.zeros((3, 3))),
            "x0": fem.Constant(domain, self.x0.copy()),
        }
        if self.order == 2:
            self._c["H"] = fem.Constant(domain, np.zeros((3, 3, 3)))
        self._bound = True
        self.update(self.t, side=self.side)

    def flux_density(self, x: Any) -> Any:
        import ufl

        if not self._c:
            raise RuntimeError("FieldModel.bind(domain) must be called before flux_density()")
        d = x - self._c["x0"]
        B = self._c["B"] + ufl.dot(self._c["G"], d)
        if self.order == 2:
            i, j, k = ufl.indices(3)
            B = B + 0.5 * ufl.as_vector(self._c["H"][i, j, k] * d[j] * d[k], i)
        return B

    def update(self, t: float, *, side: str = "right", u: Any = None) -> None:
        self.t, self.side = float(t), side
        if not self._c:
            return
        a = self.amplitudes(t, side=side)
        self._c["B"].value[:] = np.einsum("s,si->i", a, self._b0)
        self._c["G"].value[:] = np.einsum("s,sij->ij", a, self._g0)
        if self.order == 2:
            self._c["H"].value[:] = np.einsum("s,sijk->ijk", a, self._h0)

    def _index(self, src: SourceField) -> int:
        return [s for s, _ in self.sources].index(src)

    def _model_b(self, src: SourceField, pts: np.ndarray) -> np.ndarray:
        i = self._index(src)
        d = pts - self.x0
        out = self._b0[i] + d @ self._g0[i].T
        if self.order == 2:
            out = out + 0.5 * np.einsum("ijk,nj,nk->ni", self._h0[i], d, d)
        return out

    def _model_g(self, src: SourceField, pts: np.ndarray) -> np.ndarray:
        i = self._index(src)
        out = np.broadcast_to(self._g0[i], (len(pts), 3, 3)).copy()
        if self.order == 2:
            out += np.einsum("ijk,nk->nij", self._h0[i], pts - self.x0)
        return out


class FEFieldModel(FieldModel):
    """The FE field, re-linearised about the robot's current nodes at each ``update(t, u=u)``.

    On the robot mesh it keeps, per source s, B_s(x_n) and ∇B_s(x_n) at the
    nodes x_n = X + u_n of a Lagrange space of the mesh's geometry degree;
    between refreshes B(x) = Σ_s w_s(t)[B_s(x_n) + ∇B_s(x_n)(x − x_n)].
    Refreshing evaluates the FE solution at every node (collective).
    """

    name = "fe"

    def __init__(self, sources: Sequence[tuple[SourceField, Waveform]], comm: MPI.Comm):
        super().__init__(sources, comm)
        self._f: dict[str, Any] = {}
        self._bs = np.zeros((len(self.sources), 0, 3))
        self._gs = np.zeros((len(self.sources), 0, 3, 3))

    def bind(self, domain: Any) -> None:
        from dolfinx import fem

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
        self._X = embed_points(V3.tabulate_dof_coordinates(), self._gdim)
        self._bound = True
        self._refresh(self._X)
        self.update(self.t, side=self.side)

    def _refresh(self, x: np.ndarray) -> None:
        self._f["xn"].x.array[:] = x.ravel()
        pairs = [s.field_and_gradient(x) for s, _ in self.sources]
        self._bs = np.array([b for b, _ in pairs]).reshape(-1, len(x), 3)
        self._gs = np.array([g for _, g in pairs]).reshape(-1, len(x), 3, 3)

    def flux_density(self, x: Any) -> Any:
        import ufl

        if not self._f:
            raise RuntimeError("FieldModel.bind(domain) must be called before flux_density()")
        return self._f["B"] + ufl.dot(self._f["G"], x - self._f["xn"])

    def update(self, t: float, *, side: str = "right", u: Any = None) -> None:
        self.t, self.side = float(t), side
        if not self._f:
            return
        if u is not None:
            un = self._f["u"]
            un.interpolate(u)
            disp = un.x.array.reshape(-1, self._gdim)
            self._refresh(self._X + embed_points(disp, self._gdim))
        a = self.amplitudes(t, side=side)
        self._f["B"].x.array[:] = np.einsum("s,sni->ni", a, self._bs).ravel()
        self._f["G"].x.array[:] = np.einsum("s,snij->nij", a, self._gs).ravel()
        self._f["B"].x.scatter_forward()
        self._f["G"].x.scatter_forward()
        self._f["xn"].x.scatter_forward()


def model_errors(
    sources: Sequence[tuple[SourceField, Waveform]],
    comm: MPI.Comm,
    x0: np.ndarray,
    points: np.ndarray,
) -> dict[str, dict[str, float]]:
    """Error of the uniform and Taylor models against the FE field at ``points`` (N, 3).

    All sources at nominal strength (waveform value 1). Returns, per model
    name, ``{"B": max_n |B_model − B_fe| / max_n |B_fe|, "gradB": max_n
    ‖∇B_model − ∇B_fe‖ / max_n ‖∇B_fe‖}`` (Frobenius norms; gradB is 0/0 → 0
    for uniform sources). Collective.
    """
    pts = np.atleast_2d(points)
    ones = [(s, _ConstantOne()) for s, _ in sources]
    b_ref = sum((s.flux_density(pts) for s, _ in sources), np.zeros((len(pts), 3)))
    g_ref = sum((s.gradient(pts) for s, _ in sources), np.zeros((len(pts), 3, 3)))
    nb = _global_max(np.linalg.norm(b_ref, axis=1), comm)
    ng = _global_max(np.linalg.norm(g_ref, axis=(1, 2)), comm)
    out: dict[str, dict[str, float]] = {}
    models: list[FieldModel] = [
        UniformFieldModel(ones, comm, x0),
        TaylorFieldModel(ones, comm, x0, 1),
        TaylorFieldModel(ones, comm, x0, 2),
    ]
    for m in models:
        eb = _global_max(np.linalg.norm(m.evaluate(pts, 0.0) - b_ref, axis=1), comm)
        eg = _global_max(np.linalg.norm(m.gradient(pts, 0.0) - g_ref, axis=(1, 2)), comm)
        out[m.name] = {"B": eb / nb if nb > 0 else 0.0, "gradB": eg / ng if ng > 0 else 0.0}
    out["fe"] = {"B": 0.0, "gradB": 0.0}
    return out


class _ConstantOne(Waveform):
    """w = 1 at every time (a source at its nominal strength)."""

    def _raw(self, tau: np.ndarray, side: str) -> np.ndarray:
        return np.ones(np.shape(tau))

    def value(self, t: Any, *, side: str = "right") -> Any:
        return 1.0 if np.ndim(t) == 0 else np.ones(np.shape(t))


def _global_max(a: np.ndarray, comm: MPI.Comm) -> float:
    return float(comm.allreduce(float(np.max(a)) if len(a) else 0.0, op=MPI.MAX))


def build_source_fields(spec: FieldSpec, comm: MPI.Comm) -> list[tuple[SourceField, Waveform]]:
    """Solve/construct the field of every source of ``spec`` with its waveform (collective).

    Uniform sources are exact; coils, coil pairs and cylinder magnets are
    axisymmetric FE solves (:mod:`magfem.field.axisymmetric`); block magnets
    are 3D FE solves (:mod:`magfem.field.solid`).
    """
    out: list[tuple[SourceField, Waveform]] = []
    for i, src in enumerate(spec.sources):
        key = f"field.sources[{i}]"
        if isinstance(src, UniformSourceSpec):
            field: SourceField = UniformField(
                src.flux_density * src.unit_direction, name=f"source{i}"
            )
            nominal = None
        else:
            from magfem.field.solvers import solve_source

            field, nominal = solve_source(
                src, spec.solve, comm, workspace=_workspace_box(spec), name=f"source{i}"
            )
        out.append(
            (field, build_waveform(src.waveform, nominal_current=nominal, key=f"{key}.waveform"))
        )
    return out


def _workspace_box(spec: FieldSpec) -> np.ndarray:
    c = np.asarray(spec.expansion_point, dtype=float)
    h = spec.workspace_size / 2
    return np.array([c - h, c + h])


def create_field_model(
    spec: FieldSpec,
    comm: MPI.Comm,
    *,
    workspace: np.ndarray | None = None,
    sources: Sequence[tuple[SourceField, Waveform]] | None = None,
) -> FieldModel:
    """Build the field model the case asks for (collective: may run FE solves).

    Args:
        spec: the ``[field]`` table.
        comm: communicator (every rank calls).
        workspace: points (N, 3) or a box ((2, 3): min, max corners), m, where
            the robot moves; used by ``model = "auto"`` to measure the Taylor
            error. Default: the cube ``workspace_size`` about ``expansion_point``.
        sources: already solved source fields (skips the solves).

    Returns:
        A :class:`FieldModel`; call ``bind(mesh)`` before building forms.
    """
    srcs = list(sources) if sources is not None else build_source_fields(spec, comm)
    x0 = np.asarray(spec.expansion_point, dtype=float)
    model = spec.model
    if model == "auto":
        model = _choose_model(spec, srcs, comm, workspace)
    if model == "uniform":
        return UniformFieldModel(srcs, comm, x0)
    if model in ("taylor1", "taylor2"):
        return TaylorFieldModel(srcs, comm, x0, int(model[-1]))
    if model == "fe":
        return FEFieldModel(srcs, comm)
    raise CaseError("field.model", model, "unknown model")  # unreachable after validation


def _workspace_sample(spec: FieldSpec, workspace: np.ndarray | None) -> np.ndarray:
    if workspace is None:
        return workspace_points(spec.expansion_point, spec.workspace_size)
    w = np.atleast_2d(np.asarray(workspace, dtype=float))
    if w.shape == (2, 3):
        lo, hi = w
        s = [np.linspace(lo[k], hi[k], 5) for k in range(3)]
        return np.stack(np.meshgrid(*s, indexing="ij"), axis=-1).reshape(-1, 3)
    return w.reshape(-1, 3)


def _choose_model(
    spec: FieldSpec,
    srcs: Sequence[tuple[SourceField, Waveform]],
    comm: MPI.Comm,
    workspace: np.ndarray | None,
) -> str:
    if all(s.uniform for s, _ in srcs):
        return "uniform"
    pts = _workspace_sample(spec, workspace)
    err = model_errors(srcs, comm, np.asarray(spec.expansion_point, dtype=float), pts)
    for name in ("taylor1", "taylor2"):
        if err[name]["B"] <= spec.tolerance:
            return name
    return "fe"
