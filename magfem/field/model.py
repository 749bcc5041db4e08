"""The field model of a case: :func:`create_field_model` (the mechanics' entry point).

The models themselves (``uniform``, ``taylor1``, ``taylor2``, ``nodal``, ``nodal2``) are
in :mod:`magfem.field.models`; how ``auto`` chooses and what it warns about
in :mod:`magfem.field.choice`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from mpi4py import MPI

from magfem.field.build import Term, as_terms, build_terms, workspace_box
from magfem.field.choice import choose_model, model_errors, sample_points, workspace_points
from magfem.field.models import (
    FieldModel,
    NodalFieldModel,
    TaylorFieldModel,
    UniformFieldModel,
    embed_points,
)
from magfem.field.source import SourceField
from magfem.field.spec import FieldSpec
from magfem.field.waveforms import Waveform

__all__ = [
    "FieldModel",
    "NodalFieldModel",
    "TaylorFieldModel",
    "UniformFieldModel",
    "create_field_model",
    "embed_points",
    "model_errors",
    "workspace_points",
]


def create_field_model(
    spec: FieldSpec,
    comm: MPI.Comm,
    *,
    workspace: np.ndarray | None = None,
    sources: Sequence[Term | tuple[SourceField, Waveform]] | None = None,
) -> FieldModel:
    """Build the field model the case asks for (collective: solves the iron if there is any).

    Args:
        spec: the ``[field]`` table.
        comm: communicator (every rank calls).
        workspace: points (N, 3) or a box ((2, 3): min, max corners), m, where
            the robot moves (model errors, warnings, the iron mesh). Default:
            the cube ``workspace_size`` about ``expansion_point``.
        sources: terms already built (skips :func:`~magfem.field.build.build_terms`).

    Returns:
        A :class:`~magfem.field.models.FieldModel`; call ``bind(mesh)`` before building forms.
    """
    w = None if workspace is None else np.asarray(workspace, dtype=float)
    box = w if w is not None and w.shape == (2, 3) else workspace_box(spec)
    terms = as_terms(sources) if sources is not None else build_terms(spec, comm, workspace=box)
    x0 = np.asarray(spec.expansion_point, dtype=float)
    name, _ = choose_model(spec, terms, comm, sample_points(spec, w))
    if name == "uniform":
        return UniformFieldModel(terms, comm, x0)
    if name in ("taylor1", "taylor2"):
        return TaylorFieldModel(terms, comm, x0, int(name[-1]))
    return NodalFieldModel(terms, comm, 2 if name == "nodal2" else 1)
