"""Static elastica and first-frequency errors against mesh refinement (tables for the docs).

Part 1, static cantilever vs the hard-magnetic elastica (the set-up of
tests/test_verification_elastica.py): 80 µm arm, 7.5 mm with a 1 mm bonded
root strip, μ = 115 kPa, M = 123 kA/m through the thickness, field along −x
ramped quasi-statically to 0.4 mT and sampled at 0.1, 0.2, 0.3, 0.4 mT.
Models: plane-strain strip (2 mm wide arm, reference modulus E/(1 − ν²)),
plane-stress strip (3μ), 3D solid of a narrow arm (0.25 mm wide ≈ 3 h:
beam modulus E; a 2 mm wide 3D arm sits between beam and plate, see
docs/verification.md).

Part 1b (``--rigid``), the rod model's own clamp: the whole root block
(x <= 1 mm) held (``[mesh] root = "rigid"``), K = μ (ν = 1/8) so the Poisson
contraction the rigid face forbids is a ν² = 1.6 % effect. Plane-strain strip
(0.1-0.4 mT; the bonded patch at K = μ for contrast) and the narrow 3D arm
(0.1, 0.2 mT), with the discretisation part of the 3D error (vs the finest level).

Part 2, first bending frequency after a modal push (the set-up of
tests/test_verification_frequency.py), ρ∞ = 1, Δt = T/80. From the repository root:

    .venv/bin/python -m benchmarks.elastica_convergence            # everything (~10 min)
    .venv/bin/python -m benchmarks.elastica_convergence --quick    # strips only
    .venv/bin/python -m benchmarks.elastica_convergence --rigid    # part 1b only (~5 min)

The cases, runs and reference observables are those of the tests, from
:mod:`verification.setups`.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
from mpi4py import MPI

import magfem  # noqa: F401
from benchmarks._common import Report
from magfem import material
from magfem.geometry.robot_mesh import SHELL_CLAMP_INSET
from verification import references as ref
from verification import setups as vc

MU, RHO, H, FREE = vc.SHEAR_MODULUS, vc.DENSITY, vc.THICKNESS, vc.FREE_LENGTH


def static_row(
    comm: Any,
    model: str,
    size: float,
    width: float,
    plane: str,
    modulus: float,
    *,
    bulk: float = 100 * MU,
    environment: dict[str, Any] | None = None,
    **ramp: Any,
):
    """(FE angles °, errors °, elastica angles °, dofs, wall s) of one static run.

    ``ramp``: ``b_max``, ``fractions``, ``step``, ``root`` of
    :func:`verification.static_tip_angles`.
    """
    t0 = time.perf_counter()
    sim, fields, fe = vc.static_tip_angles(
        comm,
        model=model,
        size=size,
        width=width,
        plane=plane,
        bulk_modulus=bulk,
        environment=environment,
        **ramp,
    )
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    exact = vc.elastica_reference_angles(modulus, fields)
    return np.degrees(fe), np.degrees(fe - exact), np.degrees(exact), vc.global_dofs(sim), wall


def frequency_row(comm: Any, model: str, size: float, width: float, plane: str, f_ref: float):
    """(FE frequency Hz, dofs, wall s) of one free-vibration run."""
    t0 = time.perf_counter()
    sim, f = vc.measured_frequency(
        comm, model=model, size=size, width=width, plane=plane, expected=f_ref
    )
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    return f, vc.global_dofs(sim), wall


def rigid_tables(comm: Any) -> None:
    """Part 1b: rigid root block, K = μ; strip and narrow 3D arm vs the elastica."""
    soft = MU
    E = ref.young_modulus(MU, soft)
    plate = material.plane_strain_modulus(MU, soft)
    head = f"{'model':30} {'size mm':>7} {'dofs':>6} {'wall s':>6}  FE angle° (error°) per load"
    report = Report(
        "Rigid root block, K = mu (nu = 1/8), vs the hard-magnetic elastica; strips at "
        "B = 0.1, 0.2, 0.3, 0.4 mT, solid at 0.1, 0.2 mT",
        head,
    )
    runs: list[tuple[str, str, float, float, Any, list[float], dict[str, Any]]] = [
        (
            "strip, rigid block",
            "strip",
            2e-3,
            plate,
            "rigid",
            [0.5e-3, 0.25e-3, 0.125e-3, 0.0625e-3],
            {},
        ),
        (
            "strip, bonded patch",
            "strip",
            2e-3,
            plate,
            "bonded",
            [0.5e-3, 0.25e-3, 0.125e-3, 0.0625e-3],
            {},
        ),
        (
            "solid 0.25 mm wide, rigid",
            "solid",
            0.25e-3,
            E,
            "rigid",
            [0.25e-3, 0.125e-3, 0.0625e-3],
            {"b_max": 0.2e-3, "fractions": (0.5, 1.0), "step": 0.125},
        ),
    ]
    solid_errors = []
    for title, model, width, modulus, root, sizes, extra in runs:
        for size in sizes:
            fe, err, exact, dofs, wall = static_row(
                comm, model, size, width, "strain", modulus, bulk=soft, root=root, **extra
            )
            cells = "  ".join(f"{a:7.3f} ({e:+.4f})" for a, e in zip(fe, err, strict=True))
            report.row(f"{title[:30]:30} {size * 1e3:7.4g} {dofs:6d} {wall:6.1f}  {cells}")
            if model == "solid":
                solid_errors.append(err)
        report.add(
            f"{'':30} {'elastica':>7} {'':6} {'':6}  " + "  ".join(f"{a:7.3f}" for a in exact)
        )
    e = np.array(solid_errors)  # (3 levels, loads), degrees, halving size
    # the finest level stands in for the converged 3D solution: e - e[-1] is the
    # discretisation part of each error, e[-1] the 3D continuum's offset from the rod model
    report.add(
        "3D: error minus the finest level's, per level: "
        + ";  ".join(", ".join(f"{x:+.4f}" for x in row) for row in e[:-1] - e[-1])
        + f"  (finest level: {', '.join(f'{x:+.4f}' for x in e[-1])}°)"
    )
    report.print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="strips only")
    parser.add_argument("--rigid", action="store_true", help="rigid root block tables only")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    if args.rigid:
        rigid_tables(comm)
        return
    E, nu = ref.young_modulus(MU, 100 * MU), ref.poisson_ratio(MU, 100 * MU)
    plate = material.plane_strain_modulus(MU, 100 * MU)
    configs: list[tuple[str, str, float, str, float, list[float]]] = [
        ("strip, plane strain", "strip", 2e-3, "strain", plate, [2e-3, 1e-3, 0.5e-3, 0.25e-3]),
        ("strip, plane stress", "strip", 2e-3, "stress", 3 * MU, [1e-3, 0.5e-3, 0.25e-3]),
    ]
    if not args.quick:
        configs.append(("solid, 0.25 mm wide", "solid", 0.25e-3, "strain", E, [0.25e-3, 0.125e-3]))
        configs.append(("solid, 2 mm wide (vs plate)", "solid", 2e-3, "strain", plate, [1e-3]))
    report = Report(
        "Static tip angle vs the hard-magnetic elastica at B = 0.1, 0.2, 0.3, 0.4 mT",
        f"{'model':28} {'size mm':>7} {'dofs':>6} {'wall s':>6}  FE angle° (error°) per load",
    )
    for title, model, width, plane, modulus, sizes in configs:
        for size in sizes:
            fe, err, exact, dofs, wall = static_row(comm, model, size, width, plane, modulus)
            cells = "  ".join(f"{a:7.3f} ({e:+.3f})" for a, e in zip(fe, err, strict=True))
            report.row(f"{title:28} {size * 1e3:7.3g} {dofs:6d} {wall:6.1f}  {cells}")
        report.add(
            f"{'':28} {'elastica':>7} {'':6} {'':6}  " + "  ".join(f"{a:7.3f}" for a in exact)
        )
    f_plate = ref.cantilever_frequency(E / (1 - nu**2), RHO, H, FREE)
    f_beam = ref.cantilever_frequency(E, RHO, H, FREE)
    f_stress = ref.cantilever_frequency(3 * MU, RHO, H, FREE)
    report.add(
        "",
        f"First bending frequency: Euler-Bernoulli plate {f_plate:.4f} Hz, beam (E) "
        f"{f_beam:.4f} Hz, beam (3 mu) {f_stress:.4f} Hz",
        f"{'model':28} {'size mm':>7} {'dofs':>6} {'wall s':>6} {'f FE Hz':>8} {'reference':>9} "
        f"{'error':>8}",
    )
    fconfigs: list[tuple[str, str, float, str, float, list[float]]] = [
        ("strip, plane strain", "strip", 2e-3, "strain", f_plate, [1e-3, 0.5e-3]),
        ("strip, plane stress", "strip", 2e-3, "stress", f_stress, [1e-3, 0.5e-3]),
    ]
    if not args.quick:
        fconfigs.append(("solid, 0.25 mm wide", "solid", 0.25e-3, "strain", f_beam, [0.25e-3]))
        fconfigs.append(("solid, 2 mm wide", "solid", 2e-3, "strain", f_plate, [1e-3, 0.5e-3]))
        # the shell's rod is clamped at the inset patch edge: free length + SHELL_CLAMP_INSET h
        f_shell = ref.cantilever_frequency(E, RHO, H, FREE + SHELL_CLAMP_INSET * H)
        fconfigs.append(
            ("shell, 0.25 mm wide (+inset)", "surface", 0.25e-3, "strain", f_shell, [5e-4, 2.5e-4])
        )
    for title, model, width, plane, f_ref, sizes in fconfigs:
        for size in sizes:
            f, dofs, wall = frequency_row(comm, model, size, width, plane, f_ref)
            report.row(
                f"{title:28} {size * 1e3:7.3g} {dofs:6d} {wall:6.1f} {f:8.4f} {f_ref:9.4f} "
                f"{f / f_ref - 1:+8.2%}"
            )
    report.print()


if __name__ == "__main__":
    main()
