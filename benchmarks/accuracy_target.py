"""Requested against achieved accuracy of ``[solver] accuracy`` (magfem.accuracy), and the
strip's measured table.

``verify`` (default): for each case and requested accuracy, the case is run
with ``[solver] accuracy`` and without the keys the target chooses (mesh
size, layers, degree, step; the model where the case lets ``auto`` choose),
and its tip-angle history is compared with a refined run of the same case:
the largest difference over the window is the achieved error. Cases (each
with its own settings here, not the case files' meshes and steps):

* ``strip``: the static-field cantilever's arm (7.5 × 2 mm, 80 µm, plane
  strain, bonded root, no gravity) in the default drive (2 mT along −x,
  20 Hz square wave), 0–25 ms; reference 0.0625 mm, 2 layers, Δt 12.5 µs.
* ``rectangle``: cases/one_arm_shapes_rectangle.toml's arm (7.5 × 3 mm,
  100 µm, gravity, ground, air drag), strip, 0–25 ms; reference 0.0625 mm,
  2 layers, Δt 12.5 µs. The strip's table was measured on the same arm at
  80 µm (``strip-table``): at 100 µm ℓ and τ are 1.25 × the table's.
* ``rod``: the narrow arm (0.25 mm wide) at 4 mT, where ℓ and τ are
  1/√2 and 1/2 of the tables' (the rule's scaling is what is tested),
  0–12.5 ms; reference 0.0625 mm P3, Δt 3.9 µs.
* ``shell``: cases/one_arm_trapezoid.toml's robot and drive with gravity and
  ground, 0–25 ms, the shell's reference of docs/verification.md §4c
  (benchmarks/data/shell_25ms/, P2 0.125 × 0.5 mm, Δt 25 µs).

``phases --run DIR``: steps, Newton iterations and cuts per 25 ms of a run
of the default case (``magfem run cases/one_arm_trapezoid.toml --out DIR``),
and its error over 0–25 ms against the shell reference (in air or in vacuum, as the run was).

``strip-table``: the grid behind the strip's rows of ``magfem.accuracy.TABLES``
(``--grid rectangle``: the ``rectangle`` arm at 80 µm, sizes × layers × steps
against a refined run; ``--grid cantilever``: the same on the ``strip`` case).

Run from the repository root (serial; the shell rows take minutes)::

    .venv/bin/python -m benchmarks.accuracy_target verify --cases strip rectangle rod
    .venv/bin/python -m benchmarks.accuracy_target strip-table --grid rectangle
"""

from __future__ import annotations

import argparse
import json
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

import magfem  # noqa: F401  (MPI before dolfinx)
from benchmarks._common import Report
from benchmarks.mechanics_convergence import compare
from magfem.accuracy import resolve_case
from magfem.case import Case, apply_overrides, parse_case
from magfem.config import CaseError
from magfem.mechanics.columns import read_history
from magfem.mechanics.simulation import SimulationError
from magfem.parallel import rank0_print
from magfem.pipeline import build_simulation

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "benchmarks" / "data"
SHELL_REFERENCE = DATA / "shell_25ms" / "reference_p2_0.125x0.5_dt0.025.json"
SHELL_REFERENCE_AIR = DATA / "shell_25ms" / "reference_air_p2_0.125x0.5_dt0.025.json"
"""The default case's converged first 25 ms in vacuum and in air (docs/verification.md §4c)."""


def _shell_reference(run_dir: Path) -> Path:
    """The converged reference for a run of the default case: in air or in vacuum, as it ran."""
    resolved = tomllib.loads((run_dir / "case.resolved.toml").read_text())
    fluid = resolved.get("fluid")
    if fluid is None:
        return SHELL_REFERENCE
    if fluid.get("medium") == "air" and not {"density", "viscosity"} & set(fluid):
        return SHELL_REFERENCE_AIR
    raise SystemExit(f"{run_dir}: no converged reference for the fluid {fluid}")


_QUIET = {"csv": False, "vtx_every": 0, "plot": False, "animation": False}
_DRIVE = {
    "kind": "uniform",
    "flux_density": "2 mT",
    "direction": [-1, 0, 0],
    "waveform": {"kind": "square", "frequency": "20 Hz"},
}


def _arm(width: str, model: str | None, flux: str, end: str) -> dict[str, Any]:
    """The cantilever's arm (7.5 mm, 1 mm bonded root, 80 µm) in the drive, no gravity."""
    return {
        "name": "accuracy_arm",
        "robot": {
            "shape": "rectangle",
            "thickness": "80 um",
            "length": "7.5 mm",
            "width": width,
            "clamp_length": "1 mm",
        },
        "mesh": {} if model is None else {"model": model},
        "material": {
            "shear_modulus": "115 kPa",
            "density": "2130 kg/m^3",
            "remanence": "123 kA/m",
            "plane": "strain",
        },
        "field": {"sources": [_DRIVE | {"flux_density": flux}]},
        "time": {"end": end},
        "environment": {"gravity": [0, 0, 0]},
        "output": _QUIET,
    }


def _rectangle(thickness: str) -> dict[str, Any]:
    """cases/one_arm_shapes_rectangle.toml's arm (gravity, ground, air), strip, 25 ms."""
    data = tomllib.loads((REPO / "cases" / "one_arm_shapes_rectangle.toml").read_text())
    return {
        "name": "accuracy_rectangle",
        "robot": data["robot"] | {"thickness": thickness},
        "mesh": {"model": "strip"},
        "material": data["material"],
        "field": data["field"],
        "time": {"end": "25 ms"},
        "contact": {"ground": True, "friction": 0.5},
        "environment": data["environment"],
        "fluid": data["fluid"],
        "output": _QUIET,
    }


def _trapezoid() -> dict[str, Any]:
    """cases/one_arm_trapezoid.toml's robot, material, drive, contact, gravity; 25 ms."""
    data = tomllib.loads((REPO / "cases" / "one_arm_trapezoid.toml").read_text())
    return {
        "name": "accuracy_trapezoid",
        "robot": data["robot"],
        "mesh": {},
        "material": data["material"],
        "field": data["field"],
        "time": {"end": "25 ms", "scheme": "generalized_alpha", "rho_inf": 0.5},
        "contact": {"ground": True, "friction": 0.5},
        "environment": data["environment"],
        "output": _QUIET,
    }


# name -> (tables without the chosen keys, overrides of the refined reference run)
CASES: dict[str, tuple[dict[str, Any], list[str]]] = {
    "strip": (
        _arm("2 mm", "strip", "2 mT", "25 ms"),
        ["mesh.size=0.0625mm", "mesh.layers=2", "time.step=12.5us"],
    ),
    "rectangle": (
        _rectangle("100 um"),
        ["mesh.size=0.0625mm", "mesh.layers=2", "time.step=12.5us"],
    ),
    "rod": (
        _arm("0.25 mm", "rod", "4 mT", "12.5 ms"),
        ["mesh.size=0.0625mm", "solver.degree=3", "time.step=3.90625us"],
    ),
    "shell": (_trapezoid(), []),
}


def _run(case: Case, comm: MPI.Comm) -> dict[str, Any] | None:
    """History (time, angle in rad), wall time (s), steps of one run; None if it failed."""
    t0 = time.perf_counter()
    sim = build_simulation(case, comm)
    try:
        result = sim.run(progress=False)
    except SimulationError as err:
        rank0_print(f"  FAILED: {err}")
        return None
    angle = next(k for k in result.history if k.startswith("angle_"))
    return {
        "time": result.history["time"],
        "angle": result.history[angle],
        "wall": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX),
        "steps": int(result.summary["steps"]),
    }


def _reference(name: str, comm: MPI.Comm) -> dict[str, Any] | None:
    tables, refined = CASES[name]
    if name == "shell":
        (ref,) = json.loads(SHELL_REFERENCE.read_text())[-1:]
        return {"time": np.asarray(ref["time"]), "angle": np.asarray(ref["angle"])}
    return _run(parse_case(apply_overrides(tables, refined), require_units=True), comm)


def verify(names: list[str], targets: list[float], comm: MPI.Comm) -> None:
    """Requested vs achieved error and wall time, one row per case and target."""
    report = Report(
        "[solver] accuracy: requested vs achieved (largest tip-angle error over the window, deg)",
        f"{'case':9} {'asked°':>6} {'got°':>6} {'wall s':>7} {'steps':>5}  choices",
    )
    for name in names:
        reference = _reference(name, comm)
        if reference is None:
            continue
        for target in targets:
            tables = apply_overrides(CASES[name][0], [f'solver.accuracy="{target:g} deg"'])
            try:
                case = resolve_case(parse_case(tables, require_units=True))[0]
            except CaseError as err:
                report.row(f"{name:9} {target:6g} {'-':>6}  refused: {err.problem}")
                continue
            m = case.mesh
            chosen = (
                f"{m.model} P{case.solver.degree} {m.size * 1e3:.3g}"
                + ("" if m.size_across is None else f" x {m.size_across * 1e3:.3g}")
                + f" mm, {m.layers} layer(s), dt {case.time.step * 1e6:.3g} us"
            )
            run = _run(case, comm)
            if run is None:
                report.row(f"{name:9} {target:6g} {'failed':>6}  {chosen}")
                continue
            error = compare(run, reference)[0]
            report.row(
                f"{name:9} {target:6g} {error:6.2f} {run['wall']:7.1f} {run['steps']:5d}  {chosen}"
            )
    report.print()


STRIP_GRIDS: dict[str, tuple[dict[str, Any], str, tuple[str, ...], tuple[str, ...]]] = {
    # name -> (tables, reference step, sizes mm, steps ms); reference 0.0625 mm, 2 layers
    "rectangle": (
        _rectangle("80 um"),
        "12.5us",
        ("1", "0.5", "0.25", "0.125"),
        ("0.2", "0.1", "0.05"),
    ),
    "cantilever": (
        CASES["strip"][0],
        "6.25us",
        ("0.5", "0.25", "0.125"),
        ("0.1", "0.05", "0.025", "0.0125"),
    ),
}
"""The strip grids: ``rectangle`` (80 µm, gravity, ground, air) is the table's; ``cantilever``
(the ``strip`` case, undamped) shows what the table does not hold."""


def strip_table(grid: str, comm: MPI.Comm) -> None:
    """The strip grid (sizes × layers × steps) against a refined run, 0–25 ms."""
    tables, ref_step, sizes, steps = STRIP_GRIDS[grid]
    refined = ["mesh.size=0.0625mm", "mesh.layers=2", f"time.step={ref_step}"]
    ref = _run(_pinned(tables, refined), comm)
    if ref is None:
        return
    report = Report(
        f"strip grid '{grid}', 0-25 ms of the drive; error vs 0.0625 mm, 2 layers, dt {ref_step}",
        f"{'size mm':>7} {'layers':>6} {'dt ms':>6} {'steps':>5} {'wall s':>6} {'max err°':>8}",
    )
    for size in sizes:
        for layers in (1, 2):
            for dt in steps:
                extra = [f"mesh.size={size}mm", f"mesh.layers={layers}", f"time.step={dt}ms"]
                run = _run(_pinned(tables, extra), comm)
                if run is None:
                    report.row(f"{size:>7} {layers:6d} {dt:>6}  failed")
                    continue
                report.row(
                    f"{size:>7} {layers:6d} {dt:>6} {run['steps']:5d} {run['wall']:6.1f} "
                    f"{compare(run, ref)[0]:8.3f}"
                )
    report.print()


def _pinned(tables: dict[str, Any], overrides: list[str]) -> Case:
    return parse_case(apply_overrides(tables, overrides), require_units=True)


def phases(run_dir: Path, phase: float = 25e-3) -> None:
    """Steps, Newton iterations and cuts per ``phase`` of a run's history.csv, and its error
    over the first phase against the shell reference (a run of the default case)."""
    history = read_history(run_dir / "history.csv")[0]
    t = history["time"]
    report = Report(
        f"{run_dir}: per {phase * 1e3:g} ms",
        f"{'from ms':>7} {'to ms':>6} {'steps':>5} {'newton':>6} {'cuts':>4} {'min dt us':>9}",
    )
    for start in np.arange(0.0, t[-1] - 1e-12, phase):
        rows = (t > start + 1e-12) & (t <= start + phase + 1e-12)
        report.row(
            f"{start * 1e3:7.0f} {(start + phase) * 1e3:6.0f} {int(rows.sum()):5d} "
            f"{int(history['newton_iterations'][rows].sum()):6d} "
            f"{int(history['cuts'][rows].sum()):4d} {history['dt'][rows].min() * 1e6:9.3g}"
        )
    reference_file = _shell_reference(run_dir)
    (ref,) = json.loads(reference_file.read_text())[-1:]
    first = t <= phase + 1e-12
    run = {"time": t[first], "angle": history["angle_arm"][first]}
    reference = {"time": np.asarray(ref["time"]), "angle": np.asarray(ref["angle"])}
    error = compare(run, reference)
    report.add(
        f"0-{phase * 1e3:g} ms vs the shell reference ({reference_file.name}): "
        f"max {error[0]:.3f} deg, end {error[1]:.3f} deg"
    )
    report.print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "mode", nargs="?", default="verify", choices=("verify", "strip-table", "phases")
    )
    parser.add_argument("--run", type=Path, help="phases: the run's output directory")
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--targets", nargs="+", type=float, default=[12.0, 5.0, 2.0, 1.0])
    parser.add_argument("--grid", default="rectangle", choices=list(STRIP_GRIDS))
    args = parser.parse_args()
    if args.mode == "strip-table":
        strip_table(args.grid, MPI.COMM_WORLD)
    elif args.mode == "phases":
        phases(args.run)
    else:
        verify(args.cases, args.targets, MPI.COMM_WORLD)


if __name__ == "__main__":
    main()
