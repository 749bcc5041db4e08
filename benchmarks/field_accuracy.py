"""Accuracy vs wall time of the magnetostatic solves against the closed forms.

Sources (SCENES.md): the experiments' coil pair (2 × 270 turns, r 25-57.5 mm,
35 mm thick, 70 mm centre to centre, 1 A) and a 10 mm × 10 mm cylinder
magnet (Br = 1.3 T) whose top face is 5 mm below a 20 mm robot workspace.
Errors are max over a 5³ grid of the 20 mm workspace cube:
``eB = max |B_h − B| / max |B|``, ``eG = max ‖∇B_h − ∇B‖ / max ‖∇B‖``.
Times are wall times on one rank after a warm-up (forms JIT-compiled).

Usage::

    python benchmarks/field_accuracy.py            # axisymmetric tables (~1 min)
    python benchmarks/field_accuracy.py --solid    # + the 3D block magnet (~3 min)
    python benchmarks/field_accuracy.py --figure docs/field_coil_pair.png --only-figure
                                                   # coil pair PNG + model errors
    python benchmarks/field_accuracy.py --model-cost --only-figure
                                                   # FE model refresh per time step
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from mpi4py import MPI

import magfem  # noqa: F401  (MPI before dolfinx)
from magfem.config import from_table
from magfem.field import analytic as an
from magfem.field.solvers import solve_source
from magfem.field.spec import BlockMagnetSpec, CoilPairSpec, CylinderMagnetSpec, SolveSpec
from magfem.parallel import rank0_print

Z = np.array([0.0, 0.0, 1.0])
WS = np.array([[-0.01] * 3, [0.01] * 3])
_g = np.linspace(-0.01, 0.01, 5)
POINTS = np.stack(np.meshgrid(_g, _g, _g, indexing="ij"), -1).reshape(-1, 3)


def pair_case():
    spec = from_table(CoilPairSpec, {"kind": "coil_pair", "current": "1 A"}, "pair")

    def ref(P):
        return sum(
            an.coil_field(np.array([0, 0, dz]), Z, 0.025, 0.0575, 0.035, 270, 1.0)(P)
            for dz in (-0.035, 0.035)
        )

    return "coil pair", spec, ref, 0.0737


def magnet_case():
    spec = from_table(CylinderMagnetSpec, {"kind": "cylinder_magnet", "center": [0, 0, -0.02]}, "m")
    return (
        "cylinder magnet",
        spec,
        an.cylinder_field(np.array(spec.center), Z, 0.005, 0.01, 1.3),
        0.00707,
    )


def errors(field, ref):
    B, G = ref(POINTS), an.gradient_fd(ref, POINTS, 1e-6)
    eB = (
        np.linalg.norm(field.flux_density(POINTS) - B, axis=1).max()
        / np.linalg.norm(B, axis=1).max()
    )
    eG = (
        np.linalg.norm(field.gradient(POINTS) - G, axis=(1, 2)).max()
        / np.linalg.norm(G, axis=(1, 2)).max()
    )
    return eB, eG


def run(spec, ref, solve):
    t = time.perf_counter()
    field, _ = solve_source(spec, solve, MPI.COMM_WORLD, workspace=WS)
    wall = time.perf_counter() - t
    return field, wall, *errors(field, ref)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--solid", action="store_true", help="also the 3D block magnet")
    parser.add_argument("--figure", help="write the coil pair PNG (|B| + field lines) here")
    parser.add_argument("--only-figure", action="store_true", help="skip the accuracy tables")
    parser.add_argument("--model-cost", action="store_true", help="time the FE model's refresh")
    args = parser.parse_args()
    if args.figure:
        figure(args.figure)
    if args.model_cost:
        model_cost()
    if args.only_figure:
        return
    for name, spec, ref, s in (pair_case(), magnet_case()):
        run(spec, ref, SolveSpec(degree=2, mesh_size=s / 4))  # warm-up (JIT)
        run(spec, ref, SolveSpec(degree=3, mesh_size=s / 4))
        print(f"\n## {name}: accuracy vs cost (air_factor 20, Robin boundary)")
        print(
            "| degree | mesh_size (mm) | workspace h (mm) | dofs | wall (s) "
            "| mesh | solve | recover | eB | eG |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|")
        for degree in (2, 3):
            for k in (0.5, 1.0, 2.0):
                solve = SolveSpec(
                    degree=degree, mesh_size=s / 15 / k, workspace_mesh_size=0.002 / k
                )
                field, wall, eB, eG = run(spec, ref, solve)
                tm = field.timings
                print(
                    f"| {degree} | {1e3 * s / 15 / k:.2f} | {2 / k:.1f} | {field.ndofs} "
                    f"| {wall:.2f} | {tm['mesh']:.2f} | {tm['solve']:.2f} | {tm['recover']:.2f} "
                    f"| {eB:.1e} | {eG:.1e} |"
                )
        print(f"\n## {name}: open-boundary truncation (degree 3, default mesh)")
        print("| air_factor | boundary | eB | eG |")
        print("|---|---|---|---|")
        for af in (5.0, 10.0, 20.0, 40.0):
            for ob in ("dirichlet", "robin"):
                _, _, eB, eG = run(spec, ref, SolveSpec(air_factor=af, open_boundary=ob))
                print(f"| {af:g} | {ob} | {eB:.1e} | {eG:.1e} |")
    if args.solid:
        block = from_table(
            BlockMagnetSpec,
            {"kind": "block_magnet", "center": [0, 0, -0.02], "size": ["10 mm", "10 mm", "5 mm"]},
            "b",
        )
        ref = an.block_magnet_field(np.array(block.center), Z, np.array(block.size), 1.3)
        print("\n## 3D block magnet 10 x 10 x 5 mm (Br 1.3 T), top face 7.5 mm below the workspace")
        print(
            "| degree | mesh_size (mm) | workspace h (mm) | dofs | CG its | wall (s) "
            "| solve | eB | eG |"
        )
        print("|---|---|---|---|---|---|---|---|---|")
        run(block, ref, SolveSpec(mesh_size=0.004))  # warm-up
        for degree, h, hw in (
            (2, 0.004, 0.004),
            (2, 0.002, 0.004),
            (2, 0.002, 0.002),
            (3, 0.004, 0.004),
        ):
            solve = SolveSpec(solid_degree=degree, mesh_size=h, workspace_mesh_size=hw)
            field, wall, eB, eG = run(block, ref, solve)
            print(
                f"| {degree} | {1e3 * h:g} | {1e3 * hw:g} | {field.ndofs} | {field.iterations} "
                f"| {wall:.1f} | {field.timings['solve']:.1f} | {eB:.1e} | {eG:.1e} |"
            )


def model_cost() -> None:
    """Wall time of FieldModel.update(t, u=u) (FE model) on a 20 x 10 mm membrane mesh."""
    from dolfinx import fem, mesh

    from magfem.field.model import create_field_model
    from magfem.field.spec import FieldSpec

    comm = MPI.COMM_WORLD
    table = {
        "model": "fe",
        "sources": [
            {"kind": "cylinder_magnet", "center": [0, 0, -0.02]},
            {"kind": "coil_pair", "current": 2.0, "axis": [1, 0, 0]},
        ],
    }
    model = create_field_model(from_table(FieldSpec, table, "field"), comm)
    domain = mesh.create_box(comm, [[-0.01, -0.005, 0], [0.01, 0.005, 0.0002]], [40, 20, 1])
    model.bind(domain)
    u = fem.Function(fem.functionspace(domain, ("Lagrange", 2, (3,))))
    t = time.perf_counter()
    for k in range(10):
        model.update(0.001 * k, u=u)
    refresh = (time.perf_counter() - t) / 10
    t = time.perf_counter()
    for k in range(10):
        model.update(0.001 * k)
    amp = (time.perf_counter() - t) / 10
    nodes = model._f["B"].function_space.dofmap.index_map.size_global
    rank0_print(
        f"FE model, 2 sources, {nodes} P2 nodes, {comm.size} rank(s): "
        f"update(t, u=u) {refresh:.3f} s, update(t) {1e3 * amp:.2f} ms",
        comm=comm,
    )


def figure(path: str) -> None:
    """Coil pair at 10 mT (axis x, as for in-plane fields), robot workspace at the centre."""
    from pathlib import Path

    from magfem.field.model import build_source_fields, model_errors, workspace_points
    from magfem.field.output import plot_field
    from magfem.field.spec import FieldSpec

    table = {"sources": [{"kind": "coil_pair", "axis": [1, 0, 0], "flux_density": "10 mT"}]}
    spec = from_table(FieldSpec, table, "field")
    comm = MPI.COMM_WORLD
    sources = build_source_fields(spec, comm)
    robot = np.array([[-0.0075, -0.002, -0.0005], [0.0075, 0.002, 0.0005]])  # a 15 mm strip
    plot_field(spec, [f for f, _ in sources], Path(path), comm, robot=robot)
    print(f"wrote {path}")
    for edge in (0.01, 0.02, 0.04):
        err = model_errors(sources, comm, np.zeros(3), workspace_points(np.zeros(3), edge))
        row = ", ".join(f"{k} B {v['B']:.1e} / gradB {v['gradB']:.1e}" for k, v in err.items())
        print(f"coil pair, {1e3 * edge:g} mm workspace: {row}")
    spec = from_table(
        FieldSpec, {"sources": [{"kind": "cylinder_magnet", "center": [0, 0, -0.02]}]}, "f"
    )
    sources = build_source_fields(spec, comm)
    for edge in (0.005, 0.01, 0.02):
        err = model_errors(sources, comm, np.zeros(3), workspace_points(np.zeros(3), edge))
        row = ", ".join(f"{k} B {v['B']:.1e} / gradB {v['gradB']:.1e}" for k, v in err.items())
        print(f"magnet 15 mm below, {1e3 * edge:g} mm workspace: {row}")


if __name__ == "__main__":
    main()
