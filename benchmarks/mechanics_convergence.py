"""Speed/accuracy of the mechanics: mesh levels × time steps, 3D solid and 2D strip.

For a case (default: ``cases/one_arm_trapezoid.toml``, pinned to the P2 solid
of ``benchmarks._common.TRAPEZOID_SOLID`` before the grid's own keys and
``--set``) over a time window
(default: the first 10 ms, the arm's first swing to ~90°), every combination
of in-plane mesh size and nominal time step is run; the tip-angle history of
each run is compared with the finest run (interpolated on its time grid):
the largest difference over the window and the difference at its end. Wall
time is split as the simulation reports it (form compilation, residual and
Jacobian assembly, linear solves). A second table does the same for the
2D strip model against the 3D solid on a uniform-width arm
(``cases/one_arm_shapes_rectangle.toml`` with the trapezoid's thickness),
whose converged reference is the finest 3D run. ``--model surface`` runs the
grid with the shell model (:mod:`magfem.mechanics.models.shell`) instead of the
solid; with ``--reference`` it is compared with a saved solid run.

Run from the repository root, on 2 cores (timings vary ~30 % between identical runs)::

    .venv/bin/mpirun -n 2 .venv/bin/python -m benchmarks.mechanics_convergence
    .venv/bin/python -m benchmarks.mechanics_convergence --window 0.005 --sizes 2e-3 1e-3 \\
        --steps 1e-3 5e-4      # quick look

``--set KEY=VALUE ...`` passes case overrides to every run (e.g.
``solver.degree=3 solver.force_tolerance=0.1``, the shell configuration of
docs/verification.md §4c); ``--early T`` adds a column with the largest
error up to T.

Prints the tables (rank 0) and writes the runs as JSON with ``--json PATH``
(after every run); ``--load`` prints the table of saved runs again and
``--reference`` compares with the last run of another file, e.g. a finer
mesh run by a separate command.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

import magfem  # noqa: F401  (MPI before dolfinx)
from benchmarks._common import TRAPEZOID, pinned_trapezoid
from magfem.case import load_case
from magfem.mechanics.simulation import SimulationError
from magfem.parallel import rank0_print
from magfem.pipeline import build_simulation

REPO = Path(__file__).resolve().parents[1]


def _mesh_size(text: str) -> tuple[float, float | None]:
    """``"5e-4"`` -> (5e-4, None); ``"2.5e-4x1e-3"`` -> (size, size_across) in m."""
    along, _, across = text.partition("x")
    try:
        return float(along), (float(across) if across else None)
    except ValueError:
        msg = f"mesh size {text!r}: want SIZE or ALONGxACROSS (m)"
        raise argparse.ArgumentTypeError(msg) from None


def _size_label(size: float, across: float | None) -> str:
    """Mesh size in mm for the table: ``0.5`` or ``0.25x1`` (along x across)."""
    return f"{size * 1e3:g}" + ("" if across is None else f"x{across * 1e3:g}")


def run_one(case_path: Path, overrides: list[str], comm: MPI.Comm) -> dict[str, Any] | None:
    """Run a case with overrides; history arrays, timings and step statistics (None: failed)."""
    case = load_case(case_path, overrides)
    t0 = time.perf_counter()
    sim = build_simulation(case, comm)
    try:
        result = sim.run(progress=False)
    except SimulationError as err:
        rank0_print(f"  FAILED ({time.perf_counter() - t0:.0f} s): {err}")
        return None
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    angle_key = next(k for k in result.history if k.startswith("angle_"))
    dofs = sum(  # every unknown: the shell's angles too
        f.function_space.dofmap.index_map.size_global * f.function_space.dofmap.index_map_bs
        for f in sim.model.unknowns
    )
    timings = {k: comm.allreduce(v, op=MPI.MAX) for k, v in result.timings.items()}
    return {
        "time": result.history["time"],
        "angle": result.history[angle_key],
        "wall": wall,
        "timings": timings,
        "dofs": dofs,
        "steps": int(result.summary["steps"]),
        "newton": result.summary["mean_newton_iterations"],
        "cuts": int(result.summary["cuts"]),
        "degree": case.solver.degree,
        "ranks": comm.size,
        "force_tolerance": case.solver.force_tolerance,
    }


def compare(
    run: dict[str, Any], reference: dict[str, Any], until: float | None = None
) -> tuple[float, float]:
    """(max |Δangle| over the window or over t <= ``until``, |Δangle| at its end), degrees."""
    ref_on_run = np.interp(run["time"], reference["time"], reference["angle"])
    diff = np.degrees(np.abs(run["angle"] - ref_on_run))
    early = diff if until is None else diff[np.asarray(run["time"]) <= until * (1 + 1e-9)]
    return float(early.max()), float(diff[-1])


def _label(r: dict[str, Any]) -> str:
    """``shell``, ``shell P3`` (element degree other than 2), ``solid``, ``strip``."""
    degree = r.get("degree", 2)
    return r["model"] + ("" if degree == 2 else f" P{degree}")


def table(
    title: str, rows: list[dict[str, Any]], reference: dict[str, Any], early: float | None = None
) -> list[str]:
    """The runs against ``reference``; with ``early`` a column of the largest error up to it."""
    early_head = "" if early is None else f" {f'≤{early * 1e3:g}ms°':>8}"
    lines = [
        title,
        f"{'model':8} {'size mm':>9} {'dt ms':>6} {'np':>2} {'ftol':>4} {'dofs':>6} {'steps':>5} "
        f"{'newton':>6} {'cuts':>4} {'wall s':>7} {'compile':>7} {'resid':>6} {'jacob':>6} "
        f"{'solve':>6}{early_head} {'max err°':>8} {'end err°':>8} {'end angle°':>10}",
    ]
    for r in rows:
        err_max, err_end = compare(r, reference)
        cell = "" if early is None else f" {compare(r, reference, early)[0]:8.3f}"
        t = r["timings"]
        lines.append(
            f"{_label(r):8} {_size_label(r['size'], r.get('across')):>9} "
            f"{r['dt'] * 1e3:6.3g} {r.get('ranks', '-'):>2} {r.get('force_tolerance', 0):4.2g} "
            f"{r['dofs']:6d} {r['steps']:5d} {r['newton']:6.2f} {r['cuts']:4d} {r['wall']:7.1f} "
            f"{t.get('compile', math.nan):7.1f} {t.get('residual', math.nan):6.1f} "
            f"{t.get('jacobian', math.nan):6.1f} {t.get('linear_solve', math.nan):6.1f}{cell} "
            f"{err_max:8.3f} {err_end:8.3f} {math.degrees(r['angle'][-1]):10.3f}"
        )
    return lines


def _save(path: Path | None, rows: list[dict[str, Any]], comm: MPI.Comm) -> None:
    """Write the finished runs as JSON (after every run: an interrupted benchmark keeps them)."""
    if path is None or comm.rank != 0:
        return
    payload = [
        {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in r.items()} for r in rows
    ]
    path.write_text(json.dumps(payload, indent=1))


def _load(path: Path) -> list[dict[str, Any]]:
    """Runs saved by ``--json`` (histories back as arrays)."""
    rows = json.loads(path.read_text())
    for r in rows:
        r["time"], r["angle"] = np.asarray(r["time"]), np.asarray(r["angle"])
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--case", default=str(TRAPEZOID))
    parser.add_argument("--strip-case", default=str(REPO / "cases/one_arm_shapes_rectangle.toml"))
    parser.add_argument("--window", type=float, default=0.01, help="simulated time (s)")
    parser.add_argument(
        "--sizes",
        type=_mesh_size,
        nargs="+",
        default=[(2e-3, None), (1e-3, None), (0.5e-3, None)],
        help="in-plane sizes (m); ALONGxACROSS sets mesh.size_across too, e.g. 2.5e-4x1e-3",
    )
    parser.add_argument(
        "--model",
        choices=("solid", "surface"),
        default="solid",
        help="mesh.model of the mesh x step grid (surface: the shell model)",
    )
    parser.add_argument("--steps", type=float, nargs="+", default=[1e-3, 5e-4, 2.5e-4])
    parser.add_argument("--strip-sizes", type=float, nargs="+", default=[1e-3, 0.5e-3, 0.25e-3])
    parser.add_argument("--solid-sizes", type=float, nargs="+", default=[1e-3, 0.5e-3])
    parser.add_argument("--skip-strip", action="store_true")
    parser.add_argument(
        "--set",
        nargs="+",
        default=[],
        metavar="KEY=VALUE",
        help="case overrides for every run, e.g. solver.force_tolerance=0.1",
    )
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument(
        "--load",
        type=Path,
        nargs="+",
        default=None,
        help="read the solid runs from these --json files instead of running them",
    )
    parser.add_argument(
        "--reference",
        type=Path,
        default=None,
        help="compare with the last run of this --json file instead of this command's finest",
    )
    parser.add_argument(
        "--early",
        type=float,
        default=None,
        metavar="T",
        help="add a column: the largest error up to T (s), e.g. 0.012 for the first swing",
    )
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    common = [f"time.end={args.window!r}s", "output.csv=false", "output.vtx_every=0"]
    common += ["output.plot=false", *args.set]
    rank0_print(f"{comm.size} rank(s); window {args.window * 1e3:g} ms")

    # --- default case: mesh x step grid -----------------------------------------------------
    rows: list[dict[str, Any]] = []
    failed: list[str] = []
    # coarse to fine: the last run is the reference
    label_of = {"solid": "solid", "surface": "shell"}[args.model]
    if args.load:
        rows = [r for path in args.load for r in _load(path) if r["model"] in ("solid", "shell")]
    for size, across in (
        [] if args.load else sorted(args.sizes, key=lambda s: (-s[0], -(s[1] or s[0])))
    ):
        label = _size_label(size, across)
        for dt in sorted(args.steps, reverse=True):
            over = [*common, f"mesh.model={args.model}", f"mesh.size={size!r}m"]
            over.append(f"time.step={dt!r}s")
            if across is not None:
                over.append(f"mesh.size_across={across!r}m")
            if Path(args.case) == TRAPEZOID:
                over = pinned_trapezoid(*over)
            r = run_one(Path(args.case), over, comm)
            if r is None:
                failed.append(f"{label_of} size {label} mm, dt {dt * 1e3:g} ms")
                continue
            rows.append(r | {"model": label_of, "size": size, "across": across, "dt": dt})
            rank0_print(
                f"  {label_of} size={label} mm dt={dt:g}: {r['wall']:.1f} s, {r['steps']} steps, "
                f"{r['newton']:.2f} Newton/step, end angle {math.degrees(r['angle'][-1]):.3f} deg"
            )
            _save(args.json, rows, comm)
    # finest mesh, smallest step that completed (or the given one)
    reference = _load(args.reference)[-1] if args.reference else rows[-1]
    lines = table(
        f"{Path(args.case).name}, first {args.window * 1e3:g} ms; errors vs the reference",
        rows,
        reference,
        args.early,
    )

    # --- strip against solid on a uniform-width arm -----------------------------------------
    if not args.skip_strip:
        thickness = load_case(Path(args.case)).robot.thickness
        dt = min(args.steps)
        base = [*common, f"robot.thickness={thickness!r}m", f"time.step={dt!r}s", "mesh.layers=1"]
        strip_rows = []
        for model, sizes in (("solid", args.solid_sizes), ("strip", args.strip_sizes)):
            for size in sorted(sizes, reverse=True):
                over = [*base, f"mesh.model={model}", f"mesh.size={size!r}m"]
                r = run_one(Path(args.strip_case), over, comm)
                if r is None:
                    failed.append(f"{model} size {size * 1e3:g} mm (uniform-width arm)")
                    continue
                strip_rows.append(r | {"model": model, "size": size, "dt": dt})
                rank0_print(f"  {model} size={size:g}: {r['wall']:.1f} s")
                _save(args.json, rows + strip_rows, comm)
        solid_ref = [r for r in strip_rows if r["model"] == "solid"][-1]
        title = (
            f"{Path(args.strip_case).name} at {thickness * 1e6:g} um, dt {dt * 1e3:g} ms: "
            "strip and solid vs the finest solid"
        )
        lines += ["", *table(title, strip_rows, solid_ref)]
        rows += strip_rows
    lines += [
        f"reference: {_label(reference)} {_size_label(reference['size'], reference.get('across'))}"
        f" mm, dt "
        f"{reference['dt'] * 1e3:g} ms"
    ]
    lines += [f"FAILED (SimulationError): {f}" for f in failed]
    rank0_print("\n".join(lines))
    _save(args.json, rows, comm)


if __name__ == "__main__":
    main()
