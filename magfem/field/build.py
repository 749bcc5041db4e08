"""From the ``[field]`` table to the terms of the applied field: field × waveform, placed in time.

A :class:`Term` is one field at nominal strength (:class:`~magfem.field.source.SourceField`),
the waveform that scales it and the trajectory that moves it (or None). Coils
and magnets become closed forms; with iron parts
(:func:`magfem.field.iron.solve_iron`), linear iron adds its reaction to each
source's term, nonlinear iron makes one term of all sources and the reaction
(they share one waveform, :mod:`magfem.field.spec`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

import magfem.field.analytic as an
from magfem.field.iron import solve_iron
from magfem.field.placement import Trajectory
from magfem.field.source import (
    BlockMagnetField,
    CoilField,
    CylinderMagnetField,
    RacetrackCoilField,
    SourceField,
    SumField,
    UniformField,
)
from magfem.field.source_spec import (
    BlockMagnetSpec,
    CoilPairSpec,
    CoilSpec,
    CylinderMagnetSpec,
    RacetrackCoilSpec,
    SourceSpec,
    UniformSourceSpec,
)
from magfem.field.spec import FieldSpec, MotionSpec
from magfem.field.waveforms import Waveform, build_waveform

__all__ = [
    "Term",
    "as_terms",
    "build_terms",
    "closed_form_field",
    "coil_current",
    "trajectory",
    "workspace_box",
]


@dataclass
class Term:
    """One field at nominal strength, its waveform and its trajectory (None: fixed)."""

    field: SourceField
    waveform: Waveform
    trajectory: Trajectory | None = None


def coil_current(spec: CoilSpec) -> float:
    """Nominal current of a coil or pair, A: ``current``, or the one giving ``flux_density``.

    ``flux_density`` is the on-axis field at the centre (closed form).
    """
    if spec.current is not None:
        return spec.current
    offsets = [0.0]
    if isinstance(spec, CoilPairSpec):
        offsets = [-spec.separation / 2, spec.separation / 2]
    per_amp = sum(
        float(
            an.thick_coil_on_axis(
                spec.inner_radius, spec.outer_radius, spec.length, spec.turns, 1.0, np.array(dz)
            )
        )
        for dz in offsets
    )
    return float(spec.flux_density or 0.0) / per_amp


def closed_form_field(spec: SourceSpec, name: str) -> SourceField:
    """The exact field of one source table at nominal strength (reference placement)."""
    if isinstance(spec, UniformSourceSpec):
        return UniformField(spec.flux_density * spec.unit_direction, name=name)
    if isinstance(spec, CoilSpec):
        windings = [(0.0, 1.0)]
        if isinstance(spec, CoilPairSpec):
            sign = 1.0 if spec.polarity == "same" else -1.0
            windings = [(-spec.separation / 2, 1.0), (spec.separation / 2, sign)]
        section = (spec.inner_radius, spec.outer_radius, spec.length, spec.turns)
        current = coil_current(spec)
        center = np.array(spec.center)
        return CoilField(center, spec.unit_axis, *section, current, windings, name=name)
    if isinstance(spec, RacetrackCoilSpec):
        cx, cy, r1, r2, height = spec.winding
        ampere_turns = spec.turns * spec.current
        center = np.array(spec.center)
        return RacetrackCoilField(
            center, spec.unit_axis, (cx, cy), r1, r2, height, ampere_turns, spec.roll, name=name
        )
    if isinstance(spec, CylinderMagnetSpec):
        axis, m = spec.unit_axis, spec.remanence
        return CylinderMagnetField(
            np.array(spec.center), axis, spec.radius, spec.length, m, name=name
        )
    if isinstance(spec, BlockMagnetSpec):
        return BlockMagnetField(
            np.array(spec.center),
            spec.unit_axis,
            np.array(spec.size),
            spec.remanence,
            spec.roll,
            name=name,
        )
    raise TypeError(f"no closed form for source kind {spec.kind}")


def trajectory(motion: MotionSpec | None) -> Trajectory | None:
    """The trajectory of a ``[[field.motions]]`` entry (None for none)."""
    if motion is None:
        return None
    n = len(motion.times)
    offsets = np.array(motion.offsets) if motion.offsets else np.zeros((n, 3))
    angles = list(motion.angles) if motion.angles else [0.0] * n
    axis = np.asarray(motion.rotation_axis, dtype=float)
    return Trajectory(
        motion.times,
        offsets,
        angles,
        axis / np.linalg.norm(axis),
        np.asarray(motion.pivot, dtype=float),
        name=motion.name,
    )


def workspace_box(spec: FieldSpec) -> np.ndarray:
    """The robot workspace cube (2, 3): min and max corners, m."""
    c = np.asarray(spec.expansion_point, dtype=float)
    return np.array([c - spec.workspace_size / 2, c + spec.workspace_size / 2])


def _workspace_in_group(box: np.ndarray, traj: Trajectory | None) -> np.ndarray:
    """Bounding box (2, 3) of the workspace seen from a moving group at its keyframes."""
    lo, hi = box
    corners = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    if traj is None:
        return box
    seen = np.vstack([traj.placement(t).to_reference(corners) for t in traj.sample_times()])
    return np.array([seen.min(axis=0), seen.max(axis=0)])


def build_terms(
    spec: FieldSpec, comm: MPI.Comm, *, workspace: np.ndarray | None = None
) -> list[Term]:
    """The terms of ``spec`` (collective: solves the iron's reaction if there is iron).

    Args:
        spec: the ``[field]`` table.
        comm: communicator.
        workspace: robot box (2, 3), m (default: the workspace cube of ``spec``).
    """
    fields = [closed_form_field(s, f"source{i}") for i, s in enumerate(spec.sources)]
    waves = [_waveform(s, i) for i, s in enumerate(spec.sources)]
    trajs = [trajectory(spec.motion(getattr(s, "motion", ""))) for s in spec.sources]
    if not spec.iron or not fields:  # iron without sources is not magnetised
        return [Term(f, w, t) for f, w, t in zip(fields, waves, trajs, strict=True)]
    group = trajectory(spec.motion(spec.iron[0].motion))
    box = _workspace_in_group(workspace if workspace is not None else workspace_box(spec), group)
    if all(p.linear for p in spec.iron):
        reactions = solve_iron(spec.iron, fields, spec.solve, comm, workspace=box)
        return [
            Term(SumField([f, r], f.name), w, t)
            for f, r, w, t in zip(fields, reactions, waves, trajs, strict=True)
        ]
    (reaction,) = solve_iron(
        spec.iron, [SumField(fields, "sources")], spec.solve, comm, workspace=box
    )
    return [Term(SumField([*fields, reaction], "sources and iron"), waves[0], group)]


def _waveform(spec: SourceSpec, i: int) -> Waveform:
    nominal = None
    if isinstance(spec, CoilSpec):
        nominal = coil_current(spec)
    elif isinstance(spec, RacetrackCoilSpec):
        nominal = spec.current
    return build_waveform(
        spec.waveform, nominal_current=nominal, key=f"field.sources[{i}].waveform"
    )


def as_terms(items: Sequence[Term | tuple[SourceField, Waveform]]) -> list[Term]:
    """Terms from terms or (field, waveform) pairs (fixed fields)."""
    return [t if isinstance(t, Term) else Term(t[0], t[1]) for t in items]
