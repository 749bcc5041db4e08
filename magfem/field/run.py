"""``magfem field CASE``: build the case's field (closed forms, iron solve) and write it out.

Outputs (in ``outdir``), at nominal strength (every waveform = 1), sources placed as at t = 0:

* ``iron_reaction<k>.bp``: VTX of each iron solve (recovered air field) for ParaView;
* ``field_grid.vti``: the superposed B on a 41³ grid around the sources (ParaView);
* ``field_axis.csv``: B and ∇B along the first placed source's axis (z for uniform
  sources) through the workspace centre, over the figure's extent;
* ``field_workspace.csv``: B and ∇B on a 9³ grid filling the robot workspace;
* ``field_models.csv``: errors of the uniform and Taylor models over the workspace
  and the model ``auto`` picks;
* ``field_time.csv`` (moving sources only): B and ∇B at the workspace centre over
  the keyframe span (t first);
* ``field.png``: |B| with field lines in the plane through the sources' axis, with
  sources, iron parts and the robot's box.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from magfem.field.build import Term, build_terms, workspace_box
from magfem.field.choice import choose_model, model_errors, sample_points, workspace_points
from magfem.field.output import (
    CSV_COLUMNS,
    plot_field,
    plot_plane,
    reactions,
    sample,
    write_csv,
    write_grid,
    write_vtx,
)
from magfem.parallel import rank0_print

__all__ = ["run_field"]


def _report_solves(terms: list[Term], comm: MPI.Comm) -> None:
    for r in reactions(terms):
        i = r.info
        rank0_print(
            f"  {r.name}: {'(r, z)' if r.axis is not None else '3D'}, {int(i['dofs'])} dofs, "
            f"h {i['h_iron'] * 1e3:.3g} mm at the iron, air radius {i['r_air'] * 1e3:.3g} mm, "
            f"{int(i['cg_iterations'])} CG its, {int(i['newton_iterations'])} Newton its, "
            f"{i.get('total_s', 0.0):.2f} s",
            comm=comm,
        )


def _write_models(spec: Any, terms: list[Term], outdir: Path, comm: MPI.Comm) -> Path:
    x0 = np.asarray(spec.expansion_point, dtype=float)
    chosen, err = choose_model(spec, terms, comm, sample_points(spec, None))
    if not err:
        pts = workspace_points(x0, spec.workspace_size)
        err = model_errors(terms, comm, x0, pts, spec.workspace_size)
    path = outdir / "field_models.csv"
    if comm.rank == 0:
        lines = ["model,B_error,gradB_error,chosen"]
        lines += [f"{k},{v['B']:.6e},{v['gradB']:.6e},{int(k == chosen)}" for k, v in err.items()]
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    rank0_print(
        "  model errors over the workspace (B, grad B): "
        + ", ".join(f"{k} {v['B']:.2e}/{v['gradB']:.2e}" for k, v in err.items())
        + f"; model = {spec.model} -> {chosen}",
        comm=comm,
    )
    return path


def _write_time(spec: Any, terms: list[Term], outdir: Path, comm: MPI.Comm) -> Path | None:
    times = [t.trajectory.times for t in terms if t.trajectory is not None]
    if not times:
        return None
    ts = np.linspace(min(t[0] for t in times), max(t[-1] for t in times), 101)
    x0 = np.asarray(spec.expansion_point, dtype=float)
    rows = []
    for t in ts:
        B, G = sample(terms, x0[None, :] if comm.rank == 0 else np.zeros((0, 3)), t)
        if comm.rank == 0:
            rows.append(np.concatenate([[t], x0, B[0], [np.linalg.norm(B[0])], G[0].ravel()]))
    path = outdir / "field_time.csv"
    if comm.rank == 0:
        np.savetxt(
            path,
            np.array(rows),
            delimiter=",",
            header=",".join(["t", *CSV_COLUMNS]),
            comments="",
            fmt="%.9e",
        )
    return path


def run_field(
    case: Any, outdir: Path, comm: MPI.Comm, *, robot: np.ndarray | None = None
) -> dict[str, Path]:
    """Build ``case.field`` and write its outputs (collective).

    Args:
        case: anything with a ``field`` attribute (a :class:`~magfem.field.spec.FieldSpec`).
        outdir: output directory (created).
        comm: communicator.
        robot: robot position for the figure, a box (2, 3) or points (N, 3), m
            (default: the workspace cube).

    Returns:
        Output name → path (``vtx_<name>``, ``grid``, ``axis_csv``, ``workspace_csv``,
        ``models_csv``, ``time_csv``, ``png``).
    """
    spec = case.field
    outdir = Path(outdir)
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    if not spec.sources:
        rank0_print("field: no sources (no applied field); nothing to write", comm=comm)
        return {}
    t0 = time.perf_counter()
    rank0_print(f"field: {len(spec.sources)} source(s), {len(spec.iron)} iron part(s)", comm=comm)
    terms = build_terms(spec, comm, workspace=workspace_box(spec))
    _report_solves(terms, comm)
    written: dict[str, Path] = {f"vtx_{p.stem}": p for p in write_vtx(terms, outdir)}
    x0 = np.asarray(spec.expansion_point, dtype=float)
    c, _, v, s = plot_plane(spec, 101)
    axis_pts = x0 + np.outer(s + (c - x0) @ v, v)
    root = comm.rank == 0
    B, G = sample(terms, axis_pts if root else np.zeros((0, 3)))
    written["axis_csv"] = write_csv(outdir / "field_axis.csv", axis_pts, B, G, comm)
    ws = workspace_points(x0, spec.workspace_size, 9)
    B, G = sample(terms, ws if root else np.zeros((0, 3)))
    written["workspace_csv"] = write_csv(outdir / "field_workspace.csv", ws, B, G, comm)
    if root:
        nb = np.linalg.norm(B, axis=1)
        rank0_print(
            f"  workspace ({spec.workspace_size * 1e3:g} mm cube at {x0} m): |B| centre "
            f"{nb[len(ws) // 2] * 1e3:.4g} mT, range {nb.min() * 1e3:.4g}-{nb.max() * 1e3:.4g} mT,"
            f" max |grad B| {np.abs(G).max():.4g} T/m",
            comm=comm,
        )
    written["models_csv"] = _write_models(spec, terms, outdir, comm)
    path = _write_time(spec, terms, outdir, comm)
    if path is not None:
        written["time_csv"] = path
    written["grid"] = write_grid(spec, terms, outdir / "field_grid.vti", comm)
    written["png"] = plot_field(spec, terms, outdir / "field.png", comm, robot=robot)
    rank0_print(
        f"field: wrote {len(written)} outputs to {outdir} in {time.perf_counter() - t0:.1f} s",
        comm=comm,
    )
    return written
