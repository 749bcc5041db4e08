"""Which sizes mesh into quadrilaterals/hexahedra, with which recipe, and how good the elements are.

gmsh only (no dolfinx, serial): each robot is meshed as
:func:`magfem.geometry.robot_gmsh.robot_builder` meshes it for
:func:`magfem.geometry.robot_mesh.create_robot_mesh`. Prints per mesh the
cell count, the worst scaled Jacobian (``minSJ``, the check of magfem) and
the worst signed inverse condition number (``minSICN``), and the recipe:
``full-quad`` (gmsh's blossom full-quad, the first recipe) or the retries,
used only where it fails: odd curve counts made even, curved curves at >=
``ARC_SEGMENTS`` segments per turn (docs/geometry.md, "Hexahedra"). From
the repository root (a few seconds each):

    .venv/bin/python -m benchmarks.hex_meshing           # five-arm star 0.30-1.50 mm
    .venv/bin/python -m benchmarks.hex_meshing --cases   # every solid/surface case robot
    .venv/bin/python -m benchmarks.hex_meshing --cases --arc-segments 12   # another retry
    .venv/bin/python -m benchmarks.hex_meshing --cases --tip-size 0.25     # tip refinement
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import gmsh
import numpy as np

from magfem.case import load_case
from magfem.config import CaseError, from_table, to_table
from magfem.geometry import robot_gmsh
from magfem.geometry.robot_gmsh import robot_builder
from magfem.geometry.robot_mesh import SHELL_CLAMP_INSET
from magfem.geometry.robots import outline_of
from magfem.geometry.spec import MeshSpec, RobotSpec

CASES = Path(__file__).resolve().parents[1] / "cases"

FACTORS = (0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.25, 1.5, 1.75, 2.0, 2.5, 3.0, 4.0)
"""Sizes tried per case robot, times the case's ``mesh.size`` (up to its smallest feature)."""


def mesh_once(robot: RobotSpec, spec: MeshSpec) -> dict[str, Any]:
    """Mesh ``robot`` as ``spec`` says; ``num_cells``, ``min_quality``, ``min_sicn``, ``recipe``.

    ``error`` instead when magfem rejects the mesh.
    """
    inset = SHELL_CLAMP_INSET * robot.thickness
    bonded_shell = spec.model == "surface" and spec.root == "bonded"
    outline = outline_of(robot, clamp_inset=inset if bonded_shell else 0.0)
    info: dict[str, Any] = {}
    gmsh.option.restoreDefaults()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("robot")
    try:
        robot_builder(robot, spec, outline, info)(gmsh)
        tdim = 3 if spec.model == "solid" else 2
        _, tags, _ = gmsh.model.mesh.getElements(dim=tdim)
        info["min_sicn"] = float(np.min(gmsh.model.mesh.getElementQualities(tags[0], "minSICN")))
    except Exception as err:  # reported in the table
        info = {"error": f"{type(err).__name__}: {err}"}
    gmsh.model.remove()
    return info


def cell(info: dict[str, Any]) -> str:
    if "error" in info:
        return "FAILED " + info["error"][:60]
    retry = "" if info["recipe"] == "full-quad" else "  (" + info["recipe"] + ")"
    return f"{info['num_cells']:6d} {info['min_quality']:7.3f} {info['min_sicn']:7.3f}{retry}"


def star_sweep() -> None:
    """cases/five_arm.toml's star as a solid, 0.30-1.50 mm in steps of 0.05 mm."""
    robot = load_case(CASES / "five_arm.toml").robot
    print("five-arm star (cases/five_arm.toml), solid, 1 layer")
    print(f"{'size mm':>8s} {'cells':>6s} {'minSJ':>7s} {'minSICN':>7s}")
    for size in (round(0.30 + 0.05 * i, 2) for i in range(25)):
        spec = from_table(MeshSpec, {"size": size * 1e-3, "model": "solid"}, "mesh")
        print(f"{size:8.2f} {cell(mesh_once(robot, spec))}", flush=True)


def case_robots(tip: float | None) -> None:
    """Every case robot meshed as a solid and as a surface at sizes around its case's
    (``tip_size`` = ``tip`` x size if given)."""
    print(f"{'case':22s} {'model':8s} {'size mm':>8s} {'cells':>6s} {'minSJ':>7s} {'minSICN':>7s}")
    for path in sorted(CASES.glob("*.toml")):
        try:
            case = load_case(path)
        except CaseError:  # a field-only case (no [robot])
            continue
        table = {k: v for k, v in to_table(case.mesh).items() if v is not None}
        if case.mesh.model not in ("solid", "surface") or case.mesh.element != "hex":
            continue
        for model in ("solid", "surface"):
            for factor in FACTORS:
                size = factor * case.mesh.size
                if size > case.robot.min_feature:
                    continue
                keys = table | {"size": size, "model": model}
                if tip is not None:
                    keys["tip_size"] = tip * size
                if "size_across" in keys:
                    keys["size_across"] = max(keys["size_across"], size)
                try:
                    spec = from_table(MeshSpec, keys, "mesh")
                except CaseError:
                    continue
                info = mesh_once(case.robot, spec)
                print(f"{path.stem:22s} {model:8s} {size * 1e3:8.3g} {cell(info)}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", action="store_true", help="every solid/surface case robot")
    parser.add_argument(
        "--arc-segments",
        type=int,
        default=robot_gmsh.ARC_SEGMENTS,
        help="segments per turn of the retry (default: magfem's ARC_SEGMENTS)",
    )
    parser.add_argument("--tip-size", type=float, help="with --cases: tip_size / size")
    args = parser.parse_args()
    robot_gmsh.ARC_SEGMENTS = args.arc_segments
    gmsh.initialize(interruptible=False)
    try:
        case_robots(args.tip_size) if args.cases else star_sweep()
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main()
