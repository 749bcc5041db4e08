"""Root compliance of a bonded membrane, measured as a clamp inset (the shell's SHELL_CLAMP_INSET).

The static cantilever of tests/test_verification_elastica.py (80 µm arm,
7.5 mm with a 1 mm root strip whose bottom face is bonded, μ = 115 kPa,
K = 100 μ, M = 123 kA/m through the thickness, field along −x ramped to
0.4 mT) as a side-view strip, refined along the arm and through the
thickness together (size = t/1.6 … t/12.8 with 2 … 16 P2 layers), so that
the corner where the bond ends is resolved. At every load the tip angle is
matched with the hard-magnetic elastica of free length L_free + α t: α is the
root compliance as an extra free length, in thicknesses (α = 0: the rod's
rigid clamp). A constant α over the loads says the compliance is a local,
length-like effect; the finest levels say what it converges to.

Plane strain is the side view of a wide arm (the robots' arms are 10-50 t
wide), plane stress that of a narrow one (the strip's incompressible-limit
law, bending modulus 3μ). From the repository root:

    .venv/bin/python -m benchmarks.clamp_compliance              # 3 levels per plane (~1.5 min)
    .venv/bin/python -m benchmarks.clamp_compliance --finest     # + 16 layers (~6 min more)
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from mpi4py import MPI

import magfem  # noqa: F401
from benchmarks._common import Report
from magfem import material
from magfem.geometry.robot_mesh import SHELL_CLAMP_INSET
from verification import setups as vc

MU, H = vc.SHEAR_MODULUS, vc.THICKNESS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--finest", action="store_true", help="add the 16-layer level")
    parser.add_argument(
        "--planes", nargs="+", default=["strain", "stress"], choices=["strain", "stress"]
    )
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    levels = [(2, H / 1.6), (4, H / 3.2), (8, H / 6.4)] + ([(16, H / 12.8)] if args.finest else [])
    modulus = {"strain": material.plane_strain_modulus(MU, 100 * MU), "stress": 3 * MU}
    report = Report(
        "Bonded root strip, static, K = 100 mu: clamp inset alpha (thicknesses) at "
        "B = 0.1, 0.2, 0.3, 0.4 mT",
        f"{'plane':7} {'layers':>6} {'size um':>7} {'dofs':>7} {'wall s':>6}  "
        "FE angle° / alpha per load",
    )
    for plane in args.planes:
        for layers, size in levels:
            t0 = time.perf_counter()
            sim, fields, fe = vc.static_tip_angles(
                comm, model="strip", size=size, width=1e-3, plane=plane, layers=layers
            )
            wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
            alphas = [
                vc.clamp_inset_of(modulus[plane], b, a) for b, a in zip(fields, fe, strict=True)
            ]
            cells = "  ".join(
                f"{np.degrees(a):7.3f} / {al:.3f}" for a, al in zip(fe, alphas, strict=True)
            )
            report.row(
                f"{plane:7} {layers:6d} {size * 1e6:7.2f} {vc.global_dofs(sim):7d} {wall:6.1f}  "
                f"{cells}"
            )
    report.add(f"shell model: SHELL_CLAMP_INSET = {SHELL_CLAMP_INSET:g}")
    report.print()


if __name__ == "__main__":
    main()
