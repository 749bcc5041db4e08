"""Ground contact: convergence as the penalty and the regularisation are tightened; impact.

Part 1 (``simulate``'s time loop; the set-up of tests/test_verification_contact.py):
a free 2 × 1 mm, 100 µm membrane (2D strip) on the ground under gravity.
Resting penetration against the closed form of the penalty law for
κ = 1, 10, 100; sliding from 20 mm/s: deceleration against μ_f g and the
distance against the regularised closed form and the Coulomb limit
v0²/(2 μ_f g), for v_ε = 10, 1, 0.1 mm/s and κ = 1, 10, 100.

Part 2 (impact): a 4 × 1 × 0.1 mm P2 plate (μ = 250 kPa) dropped flat at
0.2 m/s, assembled here from the package's pieces (material, integrator,
Newton solver, contact law) so the three ways of treating the contact in the
time step can be compared: the contact at the generalized-α stage point
(what ``problem.py`` did when this was written), at the end of the step
(x_{n+1}, v_{n+1}), and at the end of the step plus
:class:`magfem.mechanics.contacts.ground.ImpactAbsorber`. Reported: rebound speed
(mean vertical velocity 1 ms after the drop, m/s, positive = up), mean
height of the mid-plane above its resting position, Newton iterations per
step, step cuts, wall time. From the repository root:

    .venv/bin/python -m benchmarks.contact_convergence

Part 1's cases and runs are those of the tests, from :mod:`verification.setups`.
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import math
import time
from typing import Any

import numpy as np
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from benchmarks._common import Report
from magfem import material
from magfem.mechanics.contacts.ground import GroundPlane, ImpactAbsorber
from magfem.mechanics.contacts.penalty import (
    PenaltyLaw,
    contact_stiffness,
    critical_contact_damping,
)
from magfem.mechanics.integrator import TimeIntegrator
from magfem.mechanics.solver import NewtonSolver
from magfem.mechanics.spec import SolverSpec
from verification import references as ref
from verification import setups as vc

MU_F, G, V0 = vc.FRICTION, vc.GRAVITY, vc.SLIDE_SPEED


def resting(comm: Any, penalty: float) -> tuple[float, float]:
    """(FE penetration m, penalty-law closed form m) of the strip after 20 ms on the ground."""
    run = vc.rest_on_ground(comm, "strip", {"penalty": penalty})
    return run.penetration, run.expected


def sliding(comm: Any, penalty: float, eps: float) -> tuple[float, float, float]:
    """(deceleration m/s², distance m, wall s, set-up included) of the strip sliding from V0.

    v_ε = ``eps``; the ℓ/Δt stick regularisation off, as in the test: the
    regularised closed form compared with is the v_ε law alone.
    """
    t0 = time.perf_counter()
    decel, distance = vc.slide_on_ground(comm, eps, {"penalty": penalty, "slip_length": 0.0})
    return decel, distance, time.perf_counter() - t0


def drop(
    comm: Any,
    variant: str,
    dt: float,
    penalty: float = 10.0,
    *,
    gap: float = 2e-6,
    fall: float = 0.2,
    slide: float = 0.0,
    t_end: float = 1e-3,
) -> dict[str, float]:
    """Plate released ``gap`` above the ground falling at ``fall`` and sliding at ``slide``
    (m/s) along x; state after ``t_end`` (s)."""
    Lp, Wp, h, mu, rho = 4e-3, 1e-3, 1e-4, 250e3, 2130.0
    m = mesh.create_box(comm, [[0, 0, 0], [Lp, Wp, h]], [16, 4, 1], mesh.CellType.hexahedron)
    V = fem.functionspace(m, ("Lagrange", 2, (3,)))
    u = fem.Function(V)
    integ = TimeIntegrator(u, "generalized_alpha", rho_inf=0.5, dt=dt)
    integ.u0.interpolate(lambda X: np.vstack([0 * X[0], 0 * X[0], gap + 0 * X[0]]))
    integ.v0.interpolate(lambda X: np.vstack([slide + 0 * X[0], 0 * X[0], -fall + 0 * X[0]]))
    integ.a0.interpolate(lambda X: np.vstack([0 * X[0], 0 * X[0], -G + 0 * X[0]]))
    u.x.array[:] = integ.u0.x.array
    k_n = contact_stiffness(penalty, mu, h)
    law = PenaltyLaw(
        stiffness=k_n,
        onset=0.05 * h,
        damping=critical_contact_damping(k_n, rho, h),
        friction=MU_F,
    )
    contact = GroundPlane(law, m, vertical=2)
    q = 4
    dx = ufl.Measure("dx", m, metadata={"quadrature_degree": q})
    bottom = mesh.locate_entities_boundary(m, 2, lambda X: np.isclose(X[2], 0.0))
    tags = mesh.meshtags(m, 2, bottom, np.full(bottom.size, 1, dtype=np.int32))
    ds = ufl.Measure("ds", m, subdomain_data=tags, metadata={"quadrature_degree": q})(1)
    w = ufl.TestFunction(V)
    g = fem.Constant(m, np.array([0.0, 0.0, -G]))
    X = ufl.SpatialCoordinate(m)
    end_of_step = variant != "stage"

    def residual(u_: Any, v_: Any, a_: Any, t_: Any) -> Any:
        F = ufl.variable(material.deformation_gradient(u_))
        P = ufl.diff(material.elastic_energy(F, mu, 100 * mu), F)
        x, v = (X + integ.u, integ.velocity()) if end_of_step else (X + u_, v_)
        inertia = rho * ufl.dot(a_, w) - rho * ufl.dot(g, w)
        return (inertia + ufl.inner(P, ufl.grad(w))) * dx - contact.work(x, v, w, ds)

    solver = NewtonSolver(integ.discretise(residual), u, [], SolverSpec(max_iterations=25))
    absorber = ImpactAbsorber(V, bottom, vertical=2) if variant == "end+absorber" else None
    vol = Lp * Wp * h
    zc = fem.form((X[2] + integ.u0[2]) * dx)
    vz = fem.form(integ.v0[2] * dx)
    vx = fem.form(integ.v0[0] * dx)
    t, step, its, steps, cuts = 0.0, dt, 0, 0, 0
    wall = time.perf_counter()
    while t < t_end - 1e-12:
        step = min(step, t_end - t)
        integ.begin(step)
        report = solver.solve()
        if not report.converged:
            integ.restore()
            step /= 2
            cuts += 1
            if step < dt / 4096:
                return {
                    "rebound": math.nan,
                    "height": math.nan,
                    "newton": math.nan,
                    "cuts": cuts,
                    "wall": time.perf_counter() - wall,
                }
            continue
        integ.advance()
        if absorber is not None:
            absorber.apply(integ.u0, integ.v0, integ.a0)
        t += step
        steps += 1
        its += report.iterations
        step = min(step * 1.5, dt)
    height = comm.allreduce(fem.assemble_scalar(zc), op=MPI.SUM) / vol - h / 2
    rebound = comm.allreduce(fem.assemble_scalar(vz), op=MPI.SUM) / vol
    speed = comm.allreduce(fem.assemble_scalar(vx), op=MPI.SUM) / vol
    return {
        "rebound": rebound,
        "speed": speed,
        "height": height,
        "newton": its / max(steps, 1),
        "cuts": cuts,
        "wall": time.perf_counter() - wall,
    }


def main() -> None:
    comm = MPI.COMM_WORLD
    report = Report(
        "Resting penetration (strip membrane, 100 um): FE vs penalty closed form",
        f"{'kappa':>6} {'FE m':>12} {'closed form m':>14} {'rel':>9}",
    )
    for kappa in (1.0, 10.0, 100.0):
        pen, exact = resting(comm, kappa)
        report.row(f"{kappa:6g} {pen:12.5e} {exact:14.5e} {pen / exact - 1:+9.1e}")
    coulomb = V0**2 / (2 * MU_F * G)
    report.add(
        "",
        f"Sliding from {V0 * 1e3:g} mm/s: deceleration vs mu_f g = {MU_F * G:g} m/s^2; "
        f"distance vs Coulomb {coulomb:.5e} m",
        f"{'kappa':>6} {'v_eps m/s':>9} {'decel':>8} {'rel':>8} {'distance m':>12} "
        f"{'vs regul.':>9} {'vs Coulomb':>10} {'wall s':>6}",
    )
    for kappa, eps in ((10.0, 1e-2), (10.0, 1e-3), (10.0, 1e-4), (1.0, 1e-3), (100.0, 1e-3)):
        decel, dist, wall = sliding(comm, kappa, eps)
        reg = ref.regularized_sliding_distance(V0, MU_F, eps, G)
        report.row(
            f"{kappa:6g} {eps:9.0e} {decel:8.4f} {decel / (MU_F * G) - 1:+8.2%} {dist:12.5e} "
            f"{dist / reg - 1:+9.2%} {dist / coulomb - 1:+10.2%} {wall:6.1f}"
        )
    report.add(
        "",
        "Plate 4 x 1 x 0.1 mm dropped flat at 0.2 m/s (kappa 10, critical dashpot), after 1 ms",
        f"{'variant':14} {'dt s':>6} {'rebound m/s':>11} {'height um':>9} {'newton':>6} "
        f"{'cuts':>4} {'wall s':>6}",
    )
    for variant in ("stage", "end", "end+absorber"):
        for dt in (1e-4, 1e-5):
            r = drop(comm, variant, dt)
            report.row(
                f"{variant:14} {dt:6.0e} {r['rebound']:11.4f} {r['height'] * 1e6:9.3f} "
                f"{r['newton']:6.2f} {r['cuts']:4d} {r['wall']:6.1f}"
            )
    report.add(
        "",
        "The same plate resting on the ground, sliding at 20 mm/s: deceleration over 2 ms vs "
        f"mu_f g = {MU_F * G:g} m/s^2 (the absorber must leave resting contact alone)",
        f"{'variant':14} {'dt s':>6} {'decel':>8} {'rel':>8} {'newton':>6} {'cuts':>4}",
    )
    for variant in ("stage", "end", "end+absorber"):
        r = drop(comm, variant, 1e-4, gap=0.0, fall=0.0, slide=V0, t_end=2e-3)
        decel = (V0 - r["speed"]) / 2e-3
        report.row(
            f"{variant:14} {1e-4:6.0e} {decel:8.4f} {decel / (MU_F * G) - 1:+8.2%} "
            f"{r['newton']:6.2f} {r['cuts']:4d}"
        )
    report.print()


if __name__ == "__main__":
    main()
