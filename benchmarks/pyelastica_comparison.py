"""magfem's rod against PyElastica on a dynamic magnetic cantilever: wall time to 1° and 0.1°.

The problem: the narrow cantilever of benchmarks/rod_vs_shell.py (80 µm thick,
0.25 mm wide, 6.5 mm free, rigidly clamped at the bonded patch's edge,
μ = 115 kPa, K = 100 μ (E = 342.9 kPa), ρ = 2130 kg/m³, M = 123 kA/m through
the thickness), beam bending law, no gravity, in the default case's field for
its first half period: 2 mT along −x from t = 0 to 25 ms (the arm rises past
vertical by 6 ms and swings there). Observable: the tip angle every
millisecond; error: its largest difference over 0–25 ms from the same
code's finest run (each code's converged reference).

magfem: ``[mesh] model = "rod"`` (``root = "rigid"``, ``rod_bending =
"beam"``), implicit generalized-α (ρ∞ = 0.5), steps of Δt (cut where Newton
fails). PyElastica
(optional: ``pip install pyelastica``): a Cosserat rod with the same
rectangular section (bending E b t³/12 and E t b³/12, Saint-Venant torsion,
5/6 μ A shear, rotary inertia ρ I), explicit position Verlet, clamped by
``OneEndFixedBC``; the magnetic couple is the forcing class
:class:`MagneticCouple` below (m × B per element, m = M A Δl along the
section normal d₁, turned into the material frame). Both run on one core;
times are CPU seconds of the process (on a shared machine the wall time
swings 2x with the other jobs; on an idle core the two agree) and exclude
the one-off compilation (a warm-up run first). From the
repository root (~2 min; ``--split``: where magfem's 0.25 mm P3, Δt = 31.25 µs
run spends its time, per step):

    .venv/bin/python -m benchmarks.pyelastica_comparison [--split]
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np
from mpi4py import MPI

from benchmarks._common import Report
from magfem.case import Case
from magfem.mechanics.models.rod_section import torsion_constant
from magfem.parallel import rank0_print
from magfem.pipeline import build_simulation
from verification import references as ref
from verification import setups as vc

H, W, FREE = vc.THICKNESS, vc.NARROW_WIDTH, vc.FREE_LENGTH
MU, RHO, M_R, B = vc.SHEAR_MODULUS, vc.DENSITY, vc.REMANENCE, 2e-3
E = ref.young_modulus(MU, 100 * MU)
END = vc.HALF_PERIOD
SAMPLES = np.arange(0.0, END + 1e-9, 1e-3)  # s

MAGFEM_LEVELS = [  # (size m, degree, step s); the last is the reference
    (1e-3, 2, 0.5e-3),
    (0.5e-3, 2, 0.25e-3),
    (0.5e-3, 2, 0.125e-3),
    (0.5e-3, 3, 0.0625e-3),
    (0.5e-3, 3, 0.03125e-3),
    (0.25e-3, 3, 0.0625e-3),
    (0.25e-3, 3, 0.03125e-3),
    (0.125e-3, 3, 0.015625e-3),
]
ELASTICA_LEVELS = [(25, 4e-6), (50, 2e-6), (100, 1e-6), (200, 5e-7), (400, 2.5e-7)]  # (n, Δt s)


def magfem_case(size: float, degree: int, step: float) -> Case:
    """The case of magfem's rod at one level (mesh size m, degree, step s)."""
    return vc.cantilever_case(
        "rod",
        size,
        W,
        "strain",
        name="pyelastica_comparison",
        root="rigid",
        mesh_options={"rod_bending": "beam"},
        field=vc.DRIVE,
        time={"end": END, "step": step, "rho_inf": 0.5},
        solver={"degree": degree},
    )


def magfem_run(size: float, degree: int, step: float) -> tuple[float, np.ndarray]:
    """(CPU s, tip angle in degrees at SAMPLES) of magfem's rod."""
    start = time.process_time()
    sim = build_simulation(magfem_case(size, degree, step), MPI.COMM_SELF)
    history = sim.run(progress=False).history
    wall = time.process_time() - start
    return wall, np.interp(SAMPLES, history["time"], np.degrees(history["angle_arm"]))


def magfem_split(size: float, degree: int, step: float) -> None:
    """Print where one level's run spends its time, per step (``--split``)."""
    magfem_run(size, degree, step)  # compilation
    sim = build_simulation(magfem_case(size, degree, step), MPI.COMM_SELF)
    start = time.process_time()
    result = sim.run(progress=False)
    cpu = time.process_time() - start
    steps = len(result.history["time"]) - 1
    newton = int(result.history["newton_iterations"].sum())
    timings = result.timings
    parts = ", ".join(
        f"{k} {timings[k] / steps * 1e3:.2f}" for k in ("residual", "jacobian", "linear_solve")
    )
    rest = timings["total"] - sum(timings[k] for k in ("residual", "jacobian", "linear_solve"))
    rank0_print(
        f"{size * 1e3:g} mm P{degree}, dt {step * 1e3:g} ms: {steps} steps, {newton} Newton "
        f"iterations, CPU {cpu / steps * 1e3:.2f} ms per step; wall ms per step: {parts}, "
        f"the rest (observers, loads, integrator, SNES) {rest / steps * 1e3:.2f}"
    )


def elastica_run(n: int, dt: float, end: float = END) -> tuple[float, np.ndarray]:
    """(wall s, tip angle in degrees at SAMPLES) of PyElastica's rod of ``n`` elements."""
    import elastica as ea  # optional benchmark dependency

    class MagneticCouple(ea.NoForces):  # type: ignore[misc]
        """The hard-magnetic couple m × B, m = M_r A Δl d₁ (d₁ the section normal)."""

        def __init__(self, moment: float, field: Any) -> None:
            super().__init__()
            self.moment, self.field = moment, np.asarray(field, dtype=float)

        def apply_torques(self, system: Any, time: Any = 0.0) -> None:
            directors = system.director_collection  # (3 directors, 3 components, n)
            couple = self.moment * np.cross(directors[0].T, self.field).T  # global (3, n)
            system.external_torques += np.einsum("ijk,jk->ik", directors, couple)

    class Simulator(ea.BaseSystemCollection, ea.Constraints, ea.Forcing):  # type: ignore[misc]
        pass

    sim = Simulator()
    x, z = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    radius = np.sqrt(W * H / np.pi)  # the section's area
    rod = ea.CosseratRod.straight_rod(
        n, np.zeros(3), x, z, FREE, radius, RHO, youngs_modulus=E, shear_modulus=MU
    )
    area, dl = W * H, FREE / n
    i_normal, i_width = W * H**3 / 12, H * W**3 / 12  # about d₂ (across) and d₁ (normal)
    bend = (E * i_width, E * i_normal, MU * torsion_constant(W, H))  # about d₁, d₂, d₃
    inertia = RHO * dl * np.array([i_width, i_normal, i_width + i_normal])
    for k in range(3):
        rod.bend_matrix[k, k, :] = bend[k]
        rod.shear_matrix[k, k, :] = E * area if k == 2 else 5 / 6 * MU * area
        rod.mass_second_moment_of_inertia[k, k, :] = inertia[k]
        rod.inv_mass_second_moment_of_inertia[k, k, :] = 1 / inertia[k]
    sim.append(rod)
    sim.constrain(rod).using(
        ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,)
    )
    sim.add_forcing_to(rod).using(MagneticCouple, M_R * area * dl, [-B, 0.0, 0.0])
    sim.finalize()
    stepper, now = ea.PositionVerlet(), np.float64(0.0)
    every = round(1e-3 / dt)
    angles = [0.0]
    start = time.process_time()
    for k in range(round(end / dt)):
        now = stepper.step(sim, now, np.float64(dt))
        if (k + 1) % every == 0:
            tip = rod.position_collection[:, -1] - rod.position_collection[:, -2]
            angles.append(np.degrees(np.arctan2(tip[2], tip[0])))
    return time.process_time() - start, np.array(angles)


RISE = SAMPLES <= 6e-3  # the rise to vertical, before the swing


def time_to(levels: list[tuple[float, float, float]], tolerance: float, column: int) -> float:
    """Least wall time (s) of a level within ``tolerance`` (deg) of the reference in
    ``column`` (1: 0-25 ms, 2: the rise); inf if none."""
    return min((level[0] for level in levels if level[column] <= tolerance), default=np.inf)


def compare(report: Report, name: str, runs: list[tuple[str, float, np.ndarray]]) -> list:
    """Rows (label, wall, errors) against the last run; returns [(wall, error, rise error)]."""
    reference = runs[-1][2]
    out = []
    for label, wall, angles in runs[:-1]:
        error = np.abs(angles - reference)
        rise = float(np.max(error[RISE]))
        report.row(f"| {name} | {label} | {wall:.2f} | {np.max(error):.3f} | {rise:.3f} |")
        out.append((wall, float(np.max(error)), rise))
    report.row(f"| {name} | {runs[-1][0]} (reference) | {runs[-1][1]:.2f} | - | - |")
    return out


def main() -> None:
    if "--split" in sys.argv[1:]:
        magfem_split(*MAGFEM_LEVELS[-2])
        return
    report = Report(
        "| code | resolution | CPU (s, 1 core) | max error 0-25 ms (deg) | 0-6 ms (deg) |",
        "|---|---|---|---|---|",
    )
    magfem_run(*MAGFEM_LEVELS[0])  # compilation
    runs = [
        (f"{s * 1e3:g} mm P{p}, dt {dt * 1e3:g} ms", *magfem_run(s, p, dt))
        for s, p, dt in MAGFEM_LEVELS
    ]
    magfem, magfem_reference = compare(report, "magfem rod", runs), runs[-1][2]
    elastica_run(10, 1e-6, 1e-5)  # compilation
    runs = [(f"{n} elements, dt {dt:g} s", *elastica_run(n, dt)) for n, dt in ELASTICA_LEVELS]
    elastica, elastica_reference = compare(report, "PyElastica", runs), runs[-1][2]
    report.add("")
    for column, window in ((1, "0-25 ms"), (2, "0-6 ms")):
        for tolerance in (1.0, 0.1):
            a, b = time_to(magfem, tolerance, column), time_to(elastica, tolerance, column)
            report.add(
                f"{window}, to {tolerance:g} deg: magfem {a:.2f} s, PyElastica {b:.2f} s, "
                f"PyElastica/magfem {b / a:.2f}"
            )
    gap = np.abs(magfem_reference - elastica_reference)
    report.add(
        f"converged magfem vs converged PyElastica: max {gap.max():.2f} deg at "
        f"{SAMPLES[int(np.argmax(gap))] * 1e3:g} ms; every ms: {np.round(gap, 2).tolist()}"
    )
    report.print()


if __name__ == "__main__":
    main()
