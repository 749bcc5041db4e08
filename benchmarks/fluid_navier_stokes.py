r"""Cross-check of the reduced fluid model against a resolved 2D Navier–Stokes flow.

A section of a thin plate (chord b, thickness b/50, square edges) oscillates
normal to itself, y(t) = A (1 − cos ωt), in a fluid at rest; the force per
unit length on it, from an incompressible Navier–Stokes solve, is compared
with the reduced model's (:mod:`magfem.mechanics.loads.hydrodynamics`,
the same coefficients a case gets)

    F_model = −b [ m_a V̇ + c_n V + ½ ρ C_nl(Re) |V| V ].

Two numbers set the flow: β = f b²/ν (the frequency parameter; Sader's
Re_ω = πβ/2) and the Keulegan–Carpenter number KC = 2πA/b (the stroke's
amplitude over the chord); the peak Reynolds number is Re = KC β.

Solver: units b = ρ = f = 1 (ν = 1/β), the plate's frame (far field
moving with −V(t); the force in the still fluid's frame adds the
Froude–Krylov term ρ V̇ × the section's area), a square domain of half-size
``radius`` b with the velocity prescribed on its edge, Taylor–Hood P2/P1
triangles graded from b/``resolution`` at the plate, BDF2 in time
(BDF1 for the first step) with the convecting velocity extrapolated
(2uⁿ − uⁿ⁻¹), one direct (MUMPS) solve per step, ``steps`` per period.
The force is the momentum residual tested with the velocity field that is
e_y on the plate and 0 elsewhere (exact for the discrete solution).

Outputs per case: the force history's rms difference to the model's over
the last period, normalised by the Navier–Stokes force's rms, and the
coefficients of the model form fitted to the Navier–Stokes force by least
squares (m_a, c, C_D: what the model would need to reproduce it). At small
KC the fitted added mass and damping are Sader's hydrodynamic function,
which checks the solver (``sader`` command).

From the repository root (about 2–4 min per case on one core)::

    .venv/bin/python -m benchmarks.fluid_navier_stokes run --beta 50 --kc 1
    .venv/bin/python -m benchmarks.fluid_navier_stokes sader --beta 50
    .venv/bin/python -m benchmarks.fluid_navier_stokes scenes --save out.json
"""

from __future__ import annotations

# isort: off
import magfem  # noqa: F401  (the PyPI wheel loads MPI before dolfinx)

# isort: on
import argparse
import json
import math
import time
from dataclasses import asdict, dataclass
from typing import Any

import basix.ufl
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI

from benchmarks._common import Report
from magfem.geometry.gmshio import build_mesh
from magfem.mechanics.loads import hydrodynamics as hd

PLATE, OUTER, FLUID = 1, 2, 3
SCENES = ((50.0, 1.0), (50.0, 3.0), (25.0, 3.0))
"""(β, KC) of the cross-check's table: rect-water and the manta (docs/fluid.md)."""


@dataclass(frozen=True)
class Flow:
    """One oscillating-plate flow (units b = ρ = f = 1)."""

    beta: float
    kc: float
    resolution: float = 60.0
    radius: float = 8.0
    thickness: float = 0.02
    periods: float = 3.0
    steps: int = 120

    @property
    def amplitude(self) -> float:
        """A = KC b/(2π)."""
        return self.kc / (2.0 * math.pi)


def _builder(flow: Flow) -> Any:
    def build(gmsh: Any) -> None:
        occ = gmsh.model.occ
        r, h = flow.radius, 0.5 * flow.thickness
        box = occ.addRectangle(-r, -r, 0.0, 2 * r, 2 * r)
        plate = occ.addRectangle(-0.5, -h, 0.0, 1.0, 2 * h)
        occ.cut([(2, box)], [(2, plate)])
        occ.synchronize()
        curves = gmsh.model.getEntities(1)
        on_plate = []
        for _, tag in curves:
            x, y, _z = occ.getCenterOfMass(1, tag)
            if abs(x) < 0.6 and abs(y) < 0.6:
                on_plate.append(tag)
        outer = [tag for _, tag in curves if tag not in on_plate]
        gmsh.model.addPhysicalGroup(1, on_plate, PLATE, "plate")
        gmsh.model.addPhysicalGroup(1, outer, OUTER, "outer")
        surfaces = [tag for _, tag in gmsh.model.getEntities(2)]
        gmsh.model.addPhysicalGroup(2, surfaces, FLUID, "fluid")
        field = gmsh.model.mesh.field
        distance = field.add("Distance")
        field.setNumbers(distance, "CurvesList", on_plate)
        field.setNumber(distance, "Sampling", 400)
        threshold = field.add("Threshold")
        field.setNumber(threshold, "InField", distance)
        field.setNumber(threshold, "SizeMin", 1.0 / flow.resolution)
        field.setNumber(threshold, "SizeMax", r / 8.0)
        field.setNumber(threshold, "DistMin", 0.05)
        field.setNumber(threshold, "DistMax", 0.6 * r)
        field.setAsBackgroundMesh(threshold)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.model.mesh.generate(2)

    return build


class PlateFlow:
    """The discrete Navier–Stokes problem of a :class:`Flow` (collective)."""

    def __init__(self, flow: Flow, comm: MPI.Comm):
        self.flow = flow
        data = build_mesh(_builder(flow), comm, gdim=2, name="plate_flow")
        mesh, facets = data.mesh, data.facet_tags
        cell = mesh.basix_cell()
        element = basix.ufl.mixed_element(
            [
                basix.ufl.element("Lagrange", cell, 2, shape=(2,)),
                basix.ufl.element("Lagrange", cell, 1),
            ]
        )
        W = fem.functionspace(mesh, element)
        self.mesh, self.W = mesh, W
        self.dt = fem.Constant(mesh, 1.0 / flow.steps)
        self.coef = fem.Constant(mesh, np.array([1.0, -1.0, 0.0]))  # BDF: a0 uⁿ⁺¹ + a1 uⁿ + a2 uⁿ⁻¹
        self.nu = fem.Constant(mesh, 1.0 / flow.beta)
        self.up = fem.Function(W)
        self.u_n = fem.Function(W)
        self.u_nm1 = fem.Function(W)
        self.far = fem.Function(W.sub(0).collapse()[0])
        self._boundary(facets)
        self._forms()

    def _boundary(self, facets: Any) -> None:
        W, mesh = self.W, self.mesh
        V, _ = W.sub(0).collapse()
        fdim = mesh.topology.dim - 1
        plate, outer = facets.find(PLATE), facets.find(OUTER)
        zero = fem.Function(V)
        on_plate = fem.locate_dofs_topological((W.sub(0), V), fdim, plate)
        on_outer = fem.locate_dofs_topological((W.sub(0), V), fdim, outer)
        Q, _ = W.sub(1).collapse()
        r = self.flow.radius
        corner = fem.locate_dofs_geometrical(
            (W.sub(1), Q), lambda x: np.isclose(x[0], -r) & np.isclose(x[1], -r)
        )
        self.bcs = [
            fem.dirichletbc(zero, on_plate, W.sub(0)),
            fem.dirichletbc(self.far, on_outer, W.sub(0)),
            fem.dirichletbc(fem.Function(Q), corner, W.sub(1)),
        ]
        self.probe = fem.Function(W)  # e_y on the plate, 0 elsewhere: the force functional
        plate_y = fem.locate_dofs_topological(
            (W.sub(0).sub(1), W.sub(0).sub(1).collapse()[0]), fdim, plate
        )
        self.probe.x.array[plate_y[0]] = 1.0

    def _forms(self) -> None:
        u, p = ufl.TrialFunctions(self.W)
        v, q = ufl.TestFunctions(self.W)
        un, unm1 = ufl.split(self.u_n)[0], ufl.split(self.u_nm1)[0]
        dx = ufl.Measure("dx", domain=self.mesh, metadata={"quadrature_degree": 4})
        convect = 2.0 * un - unm1
        a0, a1, a2 = self.coef[0], self.coef[1], self.coef[2]

        def eps(w: Any) -> Any:
            return ufl.sym(ufl.grad(w))

        def momentum(uu: Any, pp: Any, w: Any) -> Any:
            return (
                ufl.dot(ufl.grad(uu) * convect, w) + 2.0 * self.nu * ufl.inner(eps(uu), eps(w))
            ) * dx - pp * ufl.div(w) * dx

        a = a0 / self.dt * ufl.dot(u, v) * dx + momentum(u, p, v) - q * ufl.div(u) * dx
        L = -ufl.dot(a1 * un + a2 * unm1, v) / self.dt * dx
        self.problem = fem_petsc.LinearProblem(
            a,
            L,
            bcs=self.bcs,
            u=self.up,
            petsc_options_prefix="plate_flow_",
            petsc_options={
                "ksp_type": "preonly",
                "pc_type": "lu",
                "pc_factor_mat_solver_type": "mumps",
            },
        )
        uu, pp = ufl.split(self.up)
        w = ufl.split(self.probe)[0]
        rate = (a0 * uu + a1 * un + a2 * unm1) / self.dt
        self.force = fem.form(-(ufl.dot(rate, w) * dx + momentum(uu, pp, w)))

    def run(self) -> dict[str, np.ndarray]:
        """Time histories (t, V, V̇, F_y per length) over ``periods`` (collective)."""
        flow, comm = self.flow, self.mesh.comm
        omega, amp = 2.0 * math.pi, flow.amplitude
        n = round(flow.periods * flow.steps)
        dt = 1.0 / flow.steps
        rows = [(0.0, 0.0, amp * omega**2, 0.0)]
        for k in range(1, n + 1):
            t = k * dt
            speed = amp * omega * math.sin(omega * t)
            accel = amp * omega**2 * math.cos(omega * t)
            self.coef.value = [1.5, -2.0, 0.5] if k > 1 else [1.0, -1.0, 0.0]
            self.far.interpolate(lambda x, s=speed: np.vstack([0 * x[0], -s + 0 * x[0]]))
            self.problem.solve()
            reason = self.problem.solver.getConvergedReason()
            if reason <= 0:
                raise RuntimeError(f"step {k}: linear solve failed ({reason})")
            force = comm.allreduce(fem.assemble_scalar(self.force), op=MPI.SUM)
            force += accel * flow.thickness  # Froude–Krylov: ρ V̇ × section area
            rows.append((t, speed, accel, force))
            self.u_nm1.x.array[:] = self.u_n.x.array
            self.u_n.x.array[:] = self.up.x.array
        t, speed, accel, force = (np.array(c) for c in zip(*rows, strict=True))
        return {"time": t, "speed": speed, "acceleration": accel, "force": force}


def model_force(flow: Flow, speed: np.ndarray, accel: np.ndarray, cd_inf: float) -> np.ndarray:
    """The reduced model's force per length (units b = ρ = f = 1) for the plate's motion."""
    c = hd.fluid_coefficients(1.0, 1.0 / flow.beta, 1.0, frequency=1.0, drag_coefficient=cd_inf)
    re = np.abs(speed) * flow.beta
    nonlinear = np.array([hd.nonlinear_drag_coefficient(r, cd_inf) if r > 0 else 0.0 for r in re])
    return -(
        c.added_mass * accel + c.normal_damping * speed + 0.5 * nonlinear * np.abs(speed) * speed
    )


def fitted(history: dict[str, np.ndarray], window: np.ndarray) -> dict[str, float]:
    """m_a, c and C_D of −(m V̇ + c V + ½ C_D |V| V) fitted to the force over ``window``."""
    s, a, f = (history[k][window] for k in ("speed", "acceleration", "force"))
    basis = -np.column_stack([a, s, 0.5 * np.abs(s) * s])
    (m, c, cd), *_ = np.linalg.lstsq(basis, f, rcond=None)
    return {"added_mass": float(m), "damping": float(c), "drag_coefficient": float(cd)}


def compare(flow: Flow, comm: MPI.Comm) -> dict[str, Any]:
    """Run one flow; its force against the model's (C_D∞ of a disk and of a 2D strip)."""
    t0 = time.perf_counter()
    history = PlateFlow(flow, comm).run()
    t = history["time"]
    window = t >= t[-1] - 1.0 - 1e-9
    ns = history["force"][window]
    scale = float(np.sqrt(np.mean(ns**2)))
    out: dict[str, Any] = {
        "flow": asdict(flow),
        "wall": time.perf_counter() - t0,
        "rms_force": scale,
    }
    for label, cd in (("disk", hd.CD_DISK), ("strip", 1.98)):
        model = model_force(flow, history["speed"], history["acceleration"], cd)[window]
        out[f"error_{label}"] = float(np.sqrt(np.mean((model - ns) ** 2)) / scale)
        out[f"peak_ratio_{label}"] = float(np.abs(model).max() / np.abs(ns).max())
    out["fit"] = fitted(history, window)
    c = hd.fluid_coefficients(1.0, 1.0 / flow.beta, 1.0, frequency=1.0)
    out["model"] = {"added_mass": c.added_mass, "damping": c.normal_damping}
    out["history"] = {k: v.tolist() for k, v in history.items()}
    return out


def _line(result: dict[str, Any]) -> str:
    flow, fit, model = result["flow"], result["fit"], result["model"]
    return (
        f"| {flow['beta']:g} | {flow['kc']:g} | {flow['kc'] * flow['beta']:.0f} | "
        f"{flow['resolution']:g} | {fit['added_mass']:.3f} ({model['added_mass']:.3f}) | "
        f"{fit['damping']:.3f} ({model['damping']:.3f}) | {fit['drag_coefficient']:.2f} | "
        f"{100 * result['error_disk']:.1f} % | {100 * result['error_strip']:.1f} % | "
        f"{result['wall']:.0f} |"
    )


HEADER = (
    "| β | KC | Re | b/h | m_a NS (model) | c NS (model) | C_D NS | model error (C_D∞ 1.17) "
    "| (1.98) | wall (s) |",
    "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("command", choices=("run", "sader", "scenes"))
    parser.add_argument("--beta", type=float, default=50.0)
    parser.add_argument("--kc", type=float, default=1.0)
    parser.add_argument("--resolution", type=float, default=60.0)
    parser.add_argument("--radius", type=float, default=8.0)
    parser.add_argument("--steps", type=int, default=120)
    parser.add_argument("--periods", type=float, default=3.0)
    parser.add_argument("--save", help="write the results (histories included) as JSON")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    base = {"resolution": args.resolution, "radius": args.radius, "steps": args.steps}
    base["periods"] = args.periods
    if args.command == "run":
        flows = [Flow(args.beta, args.kc, **base)]
    elif args.command == "sader":
        flows = [Flow(args.beta, 0.05, **base)]
    else:
        flows = [Flow(beta, kc, **base) for beta, kc in SCENES]
    report = Report(
        "Oscillating plate section, 2D Navier–Stokes against the reduced model", *HEADER
    )
    results = []
    for flow in flows:
        result = compare(flow, comm)
        results.append(result)
        report.row(_line(result))
        if args.command == "sader":
            gamma = hd.rectangular_hydrodynamic_function(math.pi * flow.beta / 2)
            re_w = math.pi * flow.beta / 2
            report.row(
                f"Sader: m_a = {math.pi / 4 * gamma.real:.4f}, "
                f"c = {math.pi / 4 * 2 * math.pi * gamma.imag:.4f} (Re_w = {re_w:.3g})"
            )
    report.print()
    if args.save and comm.rank == 0:
        with open(args.save, "w", encoding="utf-8") as fh:
            json.dump(results, fh)


if __name__ == "__main__":
    main()
