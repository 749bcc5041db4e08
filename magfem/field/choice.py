"""Which field model a case gets: the model errors, ``auto`` and the resolution warnings.

The error of a model over the robot workspace (a grid of points, at the
keyframe times of moving terms, every waveform at 1) is measured against the
exact field of the terms:

* B: max |B_model − B| / max |B|;
* ∇B: max ‖∇B_model − ∇B‖ / max(max ‖∇B‖, max |B| / L), L the workspace
  edge: a gradient error that changes B by less than the tolerance across
  the workspace matters no more than a B error of that size, so a nearly
  uniform field is not judged by the relative error of its tiny gradient.

``auto`` takes the first of ``uniform``, ``taylor1``, ``taylor2`` whose two
errors are within ``tolerance``, else ``nodal`` (exact at the nodes). Points
closer to a source than its field is resolved (inside a winding, magnet or
iron part, nearer a winding than its quadrature resolves, within one element
of iron) are reported in a :class:`FieldResolutionWarning` on
rank 0, as is an explicitly chosen expansion whose errors exceed the tolerance.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
from mpi4py import MPI

from magfem.field.build import Term, as_terms
from magfem.field.models import FieldModel, TaylorFieldModel, UniformFieldModel, term_values
from magfem.field.source import SourceField
from magfem.field.spec import FieldSpec
from magfem.field.waveforms import Waveform

__all__ = [
    "FieldResolutionWarning",
    "choose_model",
    "model_errors",
    "sample_points",
    "sample_times",
    "unresolved_points",
    "warn",
    "workspace_points",
]


class FieldResolutionWarning(UserWarning):
    """Requested points lie where the field model is not resolved."""


def workspace_points(center: Sequence[float] | np.ndarray, size: float, n: int = 5) -> np.ndarray:
    """Grid of n³ points filling the cube of edge ``size`` (m) about ``center``: (n³, 3)."""
    s = np.linspace(-size / 2, size / 2, n)
    g = np.stack(np.meshgrid(s, s, s, indexing="ij"), axis=-1).reshape(-1, 3)
    return g + np.asarray(center, dtype=float)


def sample_times(terms: Sequence[Term]) -> np.ndarray:
    """Times at which moving terms are checked (keyframes and midpoints; [0] if none move)."""
    ts = [term.trajectory.sample_times() for term in terms if term.trajectory is not None]
    return np.unique(np.concatenate(ts)) if ts else np.zeros(1)


def _ones(terms: Sequence[Term]) -> list[Term]:
    return [Term(term.field, _One(), term.trajectory) for term in terms]


class _One(Waveform):
    """w = 1 at every time (a term at its nominal strength)."""

    def _raw(self, tau: np.ndarray, side: str) -> np.ndarray:
        return np.ones(np.shape(tau))

    def value(self, t: Any, *, side: str = "right") -> Any:
        return 1.0 if np.ndim(t) == 0 else np.ones(np.shape(t))


def _global_max(a: np.ndarray, comm: MPI.Comm) -> float:
    return float(comm.allreduce(float(np.max(a)) if len(a) else 0.0, op=MPI.MAX))


def model_errors(
    terms: Sequence[Term | tuple[SourceField, Waveform]],
    comm: MPI.Comm,
    x0: np.ndarray,
    points: np.ndarray,
    size: float | None = None,
) -> dict[str, dict[str, float]]:
    """Errors of ``uniform``, ``taylor1``, ``taylor2`` over ``points`` (N, 3) (module docstring).

    ``size``: workspace edge L, m (default: the extent of the points). Returns,
    per model, ``{"B": ..., "gradB": ...}``; ``nodal`` is exact (0). Collective.
    """
    ones = _ones(as_terms(terms))
    pts = np.atleast_2d(points)
    L = size or float(np.ptp(pts, axis=0).max()) or 1.0
    models: list[FieldModel] = [UniformFieldModel(ones, comm, x0)]
    models += [TaylorFieldModel(ones, comm, x0, k) for k in (1, 2)]
    worst = {m.name: [0.0, 0.0] for m in models}
    for t in sample_times(ones):
        B, G = np.zeros((len(pts), 3)), np.zeros((len(pts), 3, 3))
        for term in ones:
            b, g = term_values(term, pts, t)
            B, G = B + b, G + g
        nb = _global_max(np.linalg.norm(B, axis=1), comm)
        ng = max(_global_max(np.linalg.norm(G, axis=(1, 2)), comm), nb / L)
        for m in models:
            Bm, Gm = m.field(pts, t)
            eb = _global_max(np.linalg.norm(Bm - B, axis=1), comm) / nb if nb > 0 else 0.0
            eg = _global_max(np.linalg.norm(Gm - G, axis=(1, 2)), comm) / ng if ng > 0 else 0.0
            worst[m.name] = [max(worst[m.name][0], eb), max(worst[m.name][1], eg)]
    out = {k: {"B": v[0], "gradB": v[1]} for k, v in worst.items()}
    out["nodal"] = {"B": 0.0, "gradB": 0.0}
    return out


def unresolved_points(terms: Sequence[Term], points: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """(term name, first unresolved point (3,)) for every term with points it does not resolve."""
    out = []
    pts = np.atleast_2d(points)
    for term in terms:
        for t in sample_times([term]):
            ref = pts if term.trajectory is None else term.trajectory.placement(t).to_reference(pts)
            bad = np.flatnonzero(term.field.unresolved(ref))
            if len(bad):
                out.append((term.field.name, pts[bad[0]]))
                break
    return out


def warn(comm: MPI.Comm, text: str) -> None:
    """A :class:`FieldResolutionWarning` with ``text``, on rank 0."""
    if comm.rank == 0:
        warnings.warn(text, FieldResolutionWarning, stacklevel=3)


def sample_points(spec: FieldSpec, workspace: np.ndarray | None) -> np.ndarray:
    """Points (N, 3) where the model is judged: 5³ in the workspace box, or the given points."""
    if workspace is None:
        return workspace_points(spec.expansion_point, spec.workspace_size)
    w = np.atleast_2d(np.asarray(workspace, dtype=float))
    if w.shape == (2, 3):
        s = [np.linspace(w[0][k], w[1][k], 5) for k in range(3)]
        return np.stack(np.meshgrid(*s, indexing="ij"), axis=-1).reshape(-1, 3)
    return w.reshape(-1, 3)


def choose_model(
    spec: FieldSpec, terms: Sequence[Term], comm: MPI.Comm, pts: np.ndarray
) -> tuple[str, dict[str, dict[str, float]]]:
    """The model to use (``auto`` resolved) and the model errors ({} when not measured).

    Warns as the module docstring says (collective).
    """
    for name, p in unresolved_points(terms, pts):
        warn(
            comm,
            f"field: workspace point ({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}) m is closer to "
            f"{name} than its field is resolved (inside it, or nearer than the model's "
            "resolution); move the workspace or refine",
        )
    model = "nodal" if spec.model == "fe" else spec.model
    if all(term.field.uniform for term in terms):
        return ("uniform" if model == "auto" else model), {}
    if model in ("nodal", "nodal2"):
        return model, {}
    x0 = np.asarray(spec.expansion_point, dtype=float)
    err = model_errors(terms, comm, x0, pts, float(np.ptp(pts, axis=0).max()) or None)
    if model == "auto":
        tol = spec.tolerance
        ok = [m for m in ("uniform", "taylor1", "taylor2") if max(err[m].values()) <= tol]
        return (ok[0] if ok else "nodal"), err
    if max(err[model].values()) > spec.tolerance:
        warn(
            comm,
            f"field: model {model} is off by {err[model]['B']:.2g} in B and "
            f"{err[model]['gradB']:.2g} in grad B over the workspace (tolerance "
            f"{spec.tolerance:g}); model 'nodal' is exact at the robot's nodes",
        )
    return model, err
