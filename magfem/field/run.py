"""``magfem field CASE``: solve the case's field sources and write the field outputs.

Outputs (in ``outdir``):

* ``field_<source>.bp``: VTX (BP4) of each FE solve (potential, recovered B, ∇B) for ParaView;
* ``field_grid.vti``: the superposed B sampled on a 41³ grid around the sources (ParaView);
* ``field_axis.csv``: B and ∇B along the first placed source's axis (z for uniform
  sources) through the workspace centre, over the figure's extent;
* ``field_workspace.csv``: B and ∇B on a 9³ grid filling the robot workspace;
* ``field_models.csv``: error of the uniform and Taylor models against the FE field over
  the workspace, and the model ``auto`` picks;
* ``field.png``: |B| with field lines in the plane through the sources' axis and the robot.

All values at nominal strength (every waveform = 1).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from magfem.field.model import (
    build_source_fields,
    create_field_model,
    model_errors,
    workspace_points,
)
from magfem.field.output import plot_field, plot_plane, sample, write_csv, write_grid, write_vtx
from magfem.parallel import rank0_print

__all__ = ["run_field"]


def run_field(
    case: Any, outdir: Path, comm: MPI.Comm, *, robot: np.ndarray | None = None
) -> dict[str, Path]:
    """Solve ``case.field`` and write its outputs (collective).

    Args:
        case: a :class:`magfem.case.Case` (only ``case.field`` is used).
        outdir: output directory (created).
        comm: communicator.
        robot: robot position for the figure, a box (2, 3) or points (N, 3), m
            (default: the workspace cube).

    Returns:
        Output name → path (``vtx_<source>``, ``grid``, ``axis_csv``, ``workspace_csv``,
        ``models_csv``, ``png``).
    """
    import time

    spec = case.field
    outdir = Path(outdir)
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    if not spec.sources:
        rank0_print("field: no sources (no applied field); nothing to write", comm=comm)
        return {}
    t0 = time.perf_counter()
    rank0_print(f"field: solving {len(spec.sources)} source(s)", comm=comm)
    solved = build_source_fields(spec, comm)
    fields = [f for f, _ in solved]
    for f in fields:
        info = getattr(f, "timings", None)
        if info is not None:
            parts = ", ".join(f"{k} {v:.2f} s" for k, v in info.items())
            total = sum(info.values())
            rank0_print(
                f"  {f.name}: {getattr(f, 'ndofs', 0)} dofs, {total:.2f} s ({parts})", comm=comm
            )
    written: dict[str, Path] = {}
    for p in write_vtx(fields, outdir):
        written[f"vtx_{p.stem}"] = p
    x0 = np.asarray(spec.expansion_point, dtype=float)
    c, _, v, s = plot_plane(spec, 101)
    axis_pts = x0 + np.outer(s + (c - x0) @ v, v)
    ok = np.all([f.covers(axis_pts) for f in fields], axis=0)
    axis_pts = axis_pts[ok]
    B, G = sample(fields, axis_pts if comm.rank == 0 else np.zeros((0, 3)))
    written["axis_csv"] = write_csv(outdir / "field_axis.csv", axis_pts, B, G, comm)
    ws = workspace_points(x0, spec.workspace_size, 9)
    B, G = sample(fields, ws if comm.rank == 0 else np.zeros((0, 3)))
    written["workspace_csv"] = write_csv(outdir / "field_workspace.csv", ws, B, G, comm)
    if comm.rank == 0 and len(B):
        c0 = len(ws) // 2
        nb = np.linalg.norm(B, axis=1)
        rank0_print(
            f"  workspace ({spec.workspace_size * 1e3:g} mm cube at {x0} m): "
            f"|B| centre {nb[c0] * 1e3:.4g} mT, "
            f"range {nb.min() * 1e3:.4g}-{nb.max() * 1e3:.4g} mT, "
            f"max |∇B| {np.abs(G).max():.4g} T/m",
            comm=comm,
        )
    err = model_errors(solved, comm, x0, workspace_points(x0, spec.workspace_size))
    chosen = create_field_model(spec, comm, sources=solved).name
    if comm.rank == 0:
        lines = ["model,B_error,gradB_error,chosen"]
        lines += [f"{k},{v['B']:.6e},{v['gradB']:.6e},{int(k == chosen)}" for k, v in err.items()]
        (outdir / "field_models.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    written["models_csv"] = outdir / "field_models.csv"
    rank0_print(
        "  model error over the workspace (max |ΔB| / max |B|): "
        + ", ".join(f"{k} {v['B']:.2e}" for k, v in err.items())
        + f"; model = {spec.model} -> {chosen}",
        comm=comm,
    )
    written["grid"] = write_grid(spec, fields, outdir / "field_grid.vti", comm)
    written["png"] = plot_field(spec, fields, outdir / "field.png", comm, robot=robot)
    rank0_print(
        f"field: wrote {len(written)} outputs to {outdir} in {time.perf_counter() - t0:.1f} s",
        comm=comm,
    )
    return written
