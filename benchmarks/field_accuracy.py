"""Error and time of the field models and of the iron solve, against exact fields.

Sources (the experiments' coil pair at 1 A: 2 × 270 turns, r 25-57.5 mm, 35 mm
thick, 70 mm centre to centre; a 10 × 10 mm cylinder magnet and a 10 × 10 × 5 mm
block magnet, 1.3 T) have exact closed forms, so a model's error is measured
against them over the robot workspace (5³ grid): eB = max |B_m − B| / max |B|,
eG = max ‖∇B_m − ∇B‖ / max(max ‖∇B‖, max |B| / L), L the workspace edge (the
measure ``auto`` uses). The iron configuration is a sphere (radius a = 5 mm,
µr = 1000) in a uniform 1 mT field, exact inside (3 µr/(µr + 2) B0) and outside
(B0 + a dipole). Times are wall times on one rank after a warm-up (forms
JIT-compiled); run under ``mpirun -n 2`` for two ranks.

Usage::

    python -m benchmarks.field_accuracy                 # models and sphere tables (~1 min)
    python -m benchmarks.field_accuracy --tweezers      # + the tweezers case at 2 meshes (~3 min)
    python -m benchmarks.field_accuracy --figure docs/field_coil_pair.png --only-figure
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import dataclasses
import math
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI
from scipy.optimize import brentq

from benchmarks._common import Report
from magfem.case import load_field_case
from magfem.config import from_table
from magfem.field import analytic as an
from magfem.field.build import build_terms
from magfem.field.choice import choose_model, model_errors, sample_points, workspace_points
from magfem.field.iron import solve_iron
from magfem.field.iron_spec import IronSpec
from magfem.field.model import create_field_model
from magfem.field.output import plot_field
from magfem.field.source import UniformField
from magfem.field.spec import FieldSpec, SolveSpec

COMM = MPI.COMM_WORLD
CASES = Path(__file__).resolve().parents[1] / "cases"
PAIR = {"kind": "coil_pair", "current": "1 A", "axis": [1, 0, 0]}
CYLINDER = {"kind": "cylinder_magnet", "center": [0, 0, -0.02]}
BLOCK = {"kind": "block_magnet", "center": [0, 0, -0.02], "size": [0.01, 0.01, 0.005]}
SCENES = [
    ("coil pair, centre", PAIR, (0.0, 0.0, 0.0), (0.01, 0.02, 0.04)),
    ("cylinder magnet, 20 mm above its centre", CYLINDER, (0.0, 0.0, 0.0), (0.005, 0.01, 0.02)),
    ("block magnet, 20 mm above its centre", BLOCK, (0.0, 0.0, 0.0), (0.005, 0.01, 0.02)),
]


def _timed(fn, *args, repeat: int = 3, **kwargs):  # type: ignore[no-untyped-def]
    """(result, best wall time of ``repeat`` calls, s)."""
    best, out = math.inf, None
    for _ in range(repeat):
        COMM.barrier()
        t0 = time.perf_counter()
        out = fn(*args, **kwargs)
        best = min(best, time.perf_counter() - t0)
    return out, best


def models(report: Report) -> None:
    """Model errors over workspaces of several sizes, auto's choice, cost of the nodal update."""
    report.add(
        "Field models against the exact field (eB / eG over a 5³ grid of the workspace cube):",
        "",
        "| scene | workspace | uniform | taylor1 | taylor2 | auto (1 %) |",
        "|---|---|---|---|---|---|",
    )
    for name, source, x0, sizes in SCENES:
        for size in sizes:
            spec = from_table(
                FieldSpec,
                {"sources": [source], "expansion_point": list(x0), "workspace_size": size},
                "field",
            )
            terms = build_terms(spec, COMM)
            pts = workspace_points(x0, size)
            err = model_errors(terms, COMM, np.array(x0), pts, size)
            chosen, _ = choose_model(spec, terms, COMM, sample_points(spec, None))
            cells = " | ".join(
                f"{err[m]['B']:.1e} / {err[m]['gradB']:.1e}"
                for m in ("uniform", "taylor1", "taylor2")
            )
            report.row(f"| {name} | {size * 1e3:g} mm | {cells} | {chosen} |")
    report.add(
        "",
        "Cost of the exact field (B and ∇B) at 10⁴ points in a 10 mm cube 20 mm from the source"
        " (what the nodal model evaluates at each time step):",
        "",
        "| source | time (ms) |",
        "|---|---|",
    )
    rng = np.random.default_rng(0)
    pts = rng.uniform(-0.005, 0.005, (10_000, 3))
    for name, source, _, _ in SCENES:
        spec = from_table(FieldSpec, {"sources": [source]}, "field")
        (term,) = build_terms(spec, COMM)
        _, t = _timed(term.field.field_and_gradient, pts)
        report.row(f"| {name.split(',')[0]} | {1e3 * t:.1f} |")


def _sphere_errors(reaction, mu_r: float) -> dict[str, float]:  # type: ignore[no-untyped-def]
    a, b0 = 5e-3, np.array([0.0, 0.0, 1e-3])
    rng = np.random.default_rng(1)
    d = rng.normal(size=(60, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    inner, outer = d * rng.uniform(0, 0.9 * a, (60, 1)), d * rng.uniform(1.2 * a, 4 * a, (60, 1))
    m = 4 * math.pi * a**3 / an.MU0 * (mu_r - 1) / (mu_r + 2) * b0
    B, G = reaction.field_and_gradient(outer)
    Bd, Gd = an.dipole_field(m, outer), an.dipole_gradient(m, outer)
    b_in = 3 * mu_r / (mu_r + 2) * b0
    return {
        "interior": np.abs(reaction.iron_flux_density(inner) - b_in).max() / np.linalg.norm(b_in),
        "B": np.linalg.norm(B - Bd, axis=1).max() / np.linalg.norm(Bd, axis=1).max(),
        "G": np.linalg.norm(G - Gd, axis=(1, 2)).max() / np.linalg.norm(Gd, axis=(1, 2)).max(),
    }


def sphere(report: Report) -> None:
    """The linear iron sphere in (r, z) and in 3D at several meshes: error and time."""
    report.add(
        "",
        "Iron sphere (a = 5 mm, µr = 1000) in 1 mT: errors inside and outside (1.2-4 a; B and ∇B"
        " relative to the largest dipole field there):",
        "",
        "| solve | degree | surface mesh | dofs | wall (s) | inside | B outside | ∇B outside |",
        "|---|---|---|---|---|---|---|---|",
    )
    part = from_table(IronSpec, {"kind": "sphere", "radius": 5e-3, "permeability": 1000}, "iron")
    rows = [
        ("(r, z)", {"mesh_size": "0.5 mm"}),
        ("(r, z)", {}),
        ("3D", {"geometry": "3d", "mesh_size": "1.67 mm"}),
        ("3D", {"geometry": "3d", "mesh_size": "1 mm"}),
        ("3D", {"geometry": "3d", "mesh_size": "0.71 mm"}),
        ("3D", {"geometry": "3d", "mesh_size": "1 mm", "degree": 3}),
        ("3D, flat elements", {"geometry": "3d", "mesh_size": "1 mm", "curved": False}),
    ]
    for label, table in rows:
        solve = from_table(SolveSpec, table, "solve")
        (r,), t = _timed(
            solve_iron, [part], [UniformField(np.array([0, 0, 1e-3]))], solve, COMM, repeat=2
        )
        e = _sphere_errors(r, 1000.0)
        deg = solve.degree or (3 if r.axis is not None else 2)
        report.row(
            f"| {label} | {deg} | {r.info['h_iron'] * 1e3:.2g} mm | {int(r.info['dofs']):,} | "
            f"{t:.2f} | {e['interior']:.1e} | {e['B']:.1e} | {e['G']:.1e} |"
        )


def nonlinear(report: Report) -> None:
    """A saturating sphere (µr 1000, J_s 1.5 T) in 1 T, (r, z), P2, refined uniformly."""
    report.add(
        "",
        "Nonlinear sphere (a = 5 mm, µr = 1000, J_s = 1.5 T) in 1 T, (r, z), P2, surface mesh"
        " and grading refined together; exact interior 1.9988 T; RMS of B over 200 points at"
        " 1.2-3 a:",
        "",
        "| surface mesh | dofs | Newton | wall (s) | inside | outside (RMS) | rate |",
        "|---|---|---|---|---|---|---|",
    )
    a, mu_r, js = 5e-3, 1000.0, 1.5
    part = from_table(
        IronSpec, {"kind": "sphere", "radius": a, "permeability": mu_r, "saturation": js}, "iron"
    )
    mu0 = an.MU0

    def law(h: float) -> float:
        return mu0 * h + 2 * js / math.pi * math.atan(math.pi * (mu_r - 1) * mu0 * h / (2 * js))

    h = brentq(lambda h: h + (law(h) / mu0 - h) / 3 - 1.0 / mu0, 0.0, 1.0 / mu0, xtol=1e-9)
    b_in, moment = law(h), np.array([0, 0, 4 / 3 * math.pi * a**3 * (law(h) / mu0 - h)])
    rng = np.random.default_rng(2)
    d = rng.normal(size=(200, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    outer, inner = d * rng.uniform(1.2 * a, 3 * a, (200, 1)), d[:20] * 0.5 * a
    Bd = an.dipole_field(moment, outer)
    last = None
    for n in (2, 4, 8, 16):
        table = {"degree": 2, "mesh_size": a / n, "grading": 0.8 / n, "air_factor": 6}
        solve = from_table(SolveSpec, table, "solve")
        (r,), t = _timed(
            solve_iron, [part], [UniformField(np.array([0, 0, 1.0]))], solve, COMM, repeat=1
        )
        rms = np.sqrt(np.mean(np.sum((r.flux_density(outer) - Bd) ** 2, axis=1)))
        e_out = rms / np.sqrt(np.mean(np.sum(Bd**2, axis=1)))
        e_in = np.abs(r.iron_flux_density(inner)[:, 2] - b_in).max() / b_in
        rate = f"{math.log2(last / e_out):.2f}" if last else ""
        last = e_out
        report.row(
            f"| a/{n} | {int(r.info['dofs']):,} | {int(r.info['newton_iterations'])} | {t:.2f} | "
            f"{e_in:.1e} | {e_out:.1e} | {rate} |"
        )


def tweezers(report: Report) -> None:
    """The tweezers case at two meshes: B and ∇B at the robot's centre at the closest approach."""
    report.add(
        "",
        "Tweezers case (cases/tweezers_field.toml), nonlinear 3D solve; B and ∇B at the robot's"
        " centre with the tips closest (t = 100 ms):",
        "",
        "| iron surface / tips (mm) | dofs | Newton | solve (s) | Bz (mT) | dBz/dz (T/m) |",
        "|---|---|---|---|---|---|",
    )
    for h, hw in (("3mm", "1mm"), ("1.5mm", "0.5mm"), ("1mm", "0.35mm")):
        sets = [f"field.solve.mesh_size={h}", f"field.solve.workspace_mesh_size={hw}"]
        spec = load_field_case(CASES / "tweezers_field.toml", sets).field
        t0 = time.perf_counter()
        model = create_field_model(dataclasses.replace(spec, model="nodal"), COMM)
        wall = time.perf_counter() - t0
        (r,) = [f for f in model.terms[0].field.fields if hasattr(f, "info")]  # type: ignore[attr-defined]
        B, G = model.field(np.zeros((1, 3)), 0.1, exact=True)
        report.row(
            f"| {h[:-2]} / {hw[:-2]} | {int(r.info['dofs']):,} | {int(r.info['newton_iterations'])}"
            f" | {wall:.1f} | {B[0, 2] * 1e3:.4f} | {G[0, 2, 2]:.4f} |"
        )


def figure(path: str) -> None:
    """|B| of the coil pair at 10 mT with field lines and a 15 mm strip robot (docs PNG)."""
    table = {"sources": [{"kind": "coil_pair", "axis": [1, 0, 0], "flux_density": "10 mT"}]}
    spec = from_table(FieldSpec, table, "field")
    robot = np.array([[0.0, -0.0025, 0.0], [0.015, 0.0025, 0.0001]])
    plot_field(spec, build_terms(spec, COMM), Path(path), COMM, robot=robot)


def main() -> None:
    """Parse the options, print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tweezers", action="store_true", help="also the tweezers case")
    parser.add_argument("--figure", help="write the coil pair PNG (|B| + field lines) here")
    parser.add_argument("--only-figure", action="store_true", help="skip the tables")
    args = parser.parse_args()
    if args.figure:
        figure(args.figure)
    if args.only_figure:
        return
    report = Report(f"field_accuracy.py on {COMM.size} rank(s)", "")
    models(report)
    sphere(report)
    nonlinear(report)
    if args.tweezers:
        tweezers(report)
    report.print()


if __name__ == "__main__":
    main()
