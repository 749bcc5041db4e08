"""The cost of the self-contact search, with and without its reach filter.

The search pairs every slave vertex with the facets around its nearest master
vertices; a slave farther from every candidate than any facet around it could
reach has no master, and the filter skips its facets
(:func:`magfem.mechanics.contacts.self_contact.geometry.reach`). This builds
the failure study's largest triangle (cases/failure.toml, type III at 45 µm,
the shell with self-contact on itself) and times ``pairing.search`` at three
states: flat (the membrane before it lifts), lifted (bent up about a line
across it, the base in the plane, as in the first lift) and rolled (its far
part wound into a spiral whose turns lie 3 thicknesses apart, a folded
membrane whose layers face each other). Each state is searched with the filter
and with the filter off (every slave examined); the pairings must agree to
the last bit. From the repository root:

    .venv/bin/python -m benchmarks.self_contact_search [--size 0.3mm] [--repeat 5]

(~20 s at 0.3 mm on one core, most of it building the model).
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from benchmarks._common import Report
from magfem.case import load_case
from magfem.mechanics.contacts.self_contact import search as search_module
from magfem.pipeline import build_simulation

CASE = Path(__file__).resolve().parents[1] / "cases" / "failure.toml"
THICKNESS = 45e-6


def _states(X: np.ndarray, comm: MPI.Comm) -> dict[str, np.ndarray]:
    """Displacements (nodes, 3) of the membrane at rest coordinates X: flat, lifted, rolled.

    The part beyond 30 % of its extent along x bends, the rest stays in its plane: lifted,
    a uniform arc of a quarter turn; rolled, one and a half turns of an Archimedean spiral
    whose turns lie 3 thicknesses apart."""
    x0 = comm.allreduce(float(X[:, 0].min()), op=MPI.MIN)  # the whole membrane's extent
    x1 = comm.allreduce(float(X[:, 0].max()), op=MPI.MAX)
    start = x0 + 0.3 * (x1 - x0)
    s = np.maximum(X[:, 0] - start, 0.0)  # arc length along the bent part
    bent = s > 0
    arc = x1 - start
    lifted = np.zeros_like(X)
    radius = arc / (np.pi / 2)
    lifted[bent, 0] = start + radius * np.sin(s[bent] / radius) - X[bent, 0]
    lifted[bent, 2] = radius * (1 - np.cos(s[bent] / radius))
    turns = 3 * np.pi
    pitch = 3 * THICKNESS / (2 * np.pi)  # r = r0 + pitch φ
    r0 = (arc - 0.5 * pitch * turns**2) / turns  # the whole part in 1.5 turns
    phi = s / r0
    for _ in range(30):  # Newton on r0 φ + pitch φ²/2 = s
        phi -= (r0 * phi + 0.5 * pitch * phi**2 - s) / (r0 + pitch * phi)
    r = r0 + pitch * phi
    rolled = np.zeros_like(X)
    rolled[bent, 0] = start + r[bent] * np.sin(phi[bent]) - X[bent, 0]
    rolled[bent, 2] = r0 - r[bent] * np.cos(phi[bent])
    return {"flat": np.zeros_like(X), "lifted": lifted, "rolled": rolled}


def _search_time(pairing: Any, u: np.ndarray, repeat: int, comm: MPI.Comm) -> float:
    """Best of ``repeat`` searches at displacement ``u`` (s, the slowest rank's)."""
    best = np.inf
    for _ in range(repeat):
        comm.Barrier()
        t0 = time.perf_counter()
        pairing.search(u)
        best = min(best, comm.allreduce(time.perf_counter() - t0, op=MPI.MAX))
    return best


def _pairing(pairing: Any) -> list[np.ndarray]:
    arrays = (pairing.partner, pairing.gap, pairing.nbar.x.array, pairing.vpartner)
    return [a.copy() for a in (*arrays, pairing.xbar.x.array)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="0.3mm", help="mesh.size and mesh.size_across")
    parser.add_argument("--repeat", type=int, default=5, help="searches per state (best kept)")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    sets = [
        "robot.type=III",
        f"robot.thickness={THICKNESS * 1e6:g}um",
        f"mesh.size={args.size}",
        f"mesh.size_across={args.size}",
    ]
    sim = build_simulation(load_case(CASE, sets), comm)
    (contact,) = [c for c in sim.problem.contacts if hasattr(c, "pairing")]
    pairing = contact.pairing
    V = sim.model.unknowns[0].function_space
    X = V.tabulate_dof_coordinates()
    vertices = comm.allreduce(int(np.count_nonzero(pairing.nodes < pairing.size_local)))
    report = Report(
        f"Self-contact search of type III at 45 um, {args.size} mesh, {vertices} contact "
        f"vertices, {comm.size} rank(s); best of {args.repeat} (s)",
        "",
        "| state | paired vertices | filtered (s) | all examined (s) | ratio |",
        "|---|---|---|---|---|",
    )
    reach = search_module.reach
    for name, u in _states(X, comm).items():
        flat_u = u.ravel()
        timed = {}
        found = {}
        for mode in ("filtered", "all"):
            search_module.reach = reach if mode == "filtered" else _no_filter  # type: ignore[assignment]
            timed[mode] = _search_time(pairing, flat_u, args.repeat, comm)
            found[mode] = _pairing(pairing)
        search_module.reach = reach  # type: ignore[assignment]
        pairs = zip(found["filtered"], found["all"], strict=True)
        same = all(np.array_equal(a, b, equal_nan=True) for a, b in pairs)
        if not comm.allreduce(same, op=MPI.LAND):  # every rank stops, or none
            raise SystemExit(f"{name}: the filtered search paired differently")
        owned = found["filtered"][0][: pairing.size_local]  # partner per local vertex
        paired = comm.allreduce(int(np.count_nonzero(owned >= 0)))
        report.row(
            f"| {name} | {paired} | {timed['filtered']:.3f} | {timed['all']:.3f} | "
            f"{timed['filtered'] / timed['all']:.2f} |"
        )
    report.print()


def _no_filter(gap: float, vertices: np.ndarray, *_: Any) -> np.ndarray:
    return np.full(len(vertices), np.inf)


if __name__ == "__main__":
    main()
