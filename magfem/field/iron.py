"""Magnetostatics of soft-iron parts in the field of coils and magnets (reduced/total potential).

Splitting (two-potential method: J. Simkin and C. W. Trowbridge, Int. J.
Numer. Meth. Eng. 14, 423 (1979); Meunier (ed.), The Finite Element Method
for Electromagnetic Modeling, ch. 4). Sources (coils, magnets, uniform
fields) in free space give B_s = µ0 H_s in closed form (:mod:`magfem.field.analytic`);
only the iron's reaction is solved for. With b = µ0 H (T):

* in air, B = B_s − ∇u: u is the *reduced* potential of the reaction;
* in iron, b = −∇(u + g), where g is a potential of the source field fitted
  over the iron, ∫_iron (∇g + B_s)·∇w = 0 (a Neumann problem made definite by
  10⁻⁶/s² ∫ g w; s the iron's size), so u + g is the *total* potential
  there and the small field inside highly permeable iron carries no
  cancellation error (a reduced potential alone would lose it as µr grows);
* B = B(b) in iron: linear µr b, the saturating law of
  :mod:`magfem.field.iron_spec`, or a measured curve (:mod:`magfem.field.bh_table`).

div B = 0 with the source's own flux balance subtracted gives, for all w,

    ∫_air ∇u·∇w dx + ∫_iron (B_s − B(−∇(u + g)))·∇w dx + ∮_outer (2/ρ) u w ds = 0,

ρ the distance to the centre of the air ball of radius R: the outer term is
the Robin condition ∂u/∂n = −2u/R exact for the reaction's dipole far field
(``open_boundary = "dirichlet"``: u = 0 there). Axisymmetric configurations
(iron and sources about one axis) are solved in the (r, z) half-plane with
weight r (natural condition on the axis). Linear iron: one solve per source
with one matrix (CG + GAMG); nonlinear iron: one Newton solve (PETSc SNES,
line search, started from the linear solution) of all sources together.
The air field is then recovered by L² projection over the air
(:mod:`magfem.field.recovery`) and evaluated by :class:`~magfem.field.reaction.ReactionField`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import ufl
from dolfinx import fem, mesh
from dolfinx.cpp import mesh as cpp_mesh
from dolfinx.fem import petsc
from mpi4py import MPI
from petsc4py import PETSc

from magfem.config import CaseError
from magfem.field.analytic import MU0
from magfem.field.iron_mesh import build_iron_mesh, common_axis, iron_size
from magfem.field.iron_spec import IronSpec
from magfem.field.reaction import AxisFrame, ReactionField
from magfem.field.recovery import Projector, air_indicator, pack
from magfem.field.source import SourceField
from magfem.field.spec import SolveSpec
from magfem.parallel import JIT_WAIT

__all__ = ["solve_iron"]

_KRYLOV = {
    "ksp_type": "cg",
    "ksp_rtol": 1e-11,
    "ksp_atol": 0.0,
    "ksp_max_it": 2000,
    "pc_type": "gamg",
    "pc_gamg_type": "agg",
    "mg_levels_ksp_type": "chebyshev",
    "mg_levels_pc_type": "jacobi",
    "pc_gamg_esteig_ksp_type": "cg",  # eigenvalue bounds of the SPD operator by CG, not GMRES
}


class _Problem:
    """Spaces, coefficients and measures of one iron mesh (3D or (r, z))."""

    def __init__(
        self,
        data: Any,
        parts: Sequence[IronSpec],
        frame: AxisFrame | None,
        center: np.ndarray,
        r_air: float,
        solve: SolveSpec,
    ):
        self.msh, self.frame, self.solve = data.mesh, frame, solve
        msh = self.msh
        p = solve.degree or (3 if frame is not None else 2)
        self.degree = p
        self.gdim = msh.geometry.dim
        self.tags = [data.physical_groups[f"iron_{k + 1}"][1] for k in range(len(parts))]
        x = ufl.SpatialCoordinate(msh)
        self.weight: Any = x[0] if frame is not None else 1.0
        q = 2 * p + (1 if frame is not None else 0)
        self.dx = ufl.Measure(
            "dx", domain=msh, subdomain_data=data.cell_tags, metadata={"quadrature_degree": q}
        )
        self.dxi = self.dx(tuple(self.tags))
        self.dxa = self.dx(data.physical_groups["air"][1])
        self.V = fem.functionspace(msh, ("Lagrange", p))
        self.W = fem.functionspace(msh, ("Lagrange", p, (self.gdim,)))
        self.iron_cells = np.unique(np.concatenate([data.cell_tags.find(t) for t in self.tags]))
        self._coefficients(parts, data.cell_tags)
        self._boundary(center, r_air, q)
        self.chi = air_indicator(msh, data.cell_tags, self.tags)
        self.size = iron_size(parts)[1]
        self.hcell = fem.Function(self.chi.function_space, name="cell_size")
        tdim = msh.topology.dim
        n = msh.topology.index_map(tdim).size_local + msh.topology.index_map(tdim).num_ghosts
        self.hcell.x.array[:] = cpp_mesh.h(msh._cpp_object, tdim, np.arange(n, dtype=np.int32))

    def _coefficients(self, parts: Sequence[IronSpec], cell_tags: Any) -> None:
        Q = fem.functionspace(self.msh, ("DG", 0))
        self.mu, self.js = fem.Function(Q), fem.Function(Q)
        self.mu.x.array[:] = 1.0
        self.js.x.array[:] = 1e6  # no saturation in practice: B = µr b
        for part, tag in zip(parts, self.tags, strict=True):
            cells = cell_tags.find(tag)
            self.mu.x.array[cells] = part.permeability
            if part.saturation is not None:
                self.js.x.array[cells] = part.saturation
        self.mu.x.scatter_forward()
        self.js.x.scatter_forward()
        self.linear = all(p.linear for p in parts)
        curves = [(p.bh_curve(), tag) for p, tag in zip(parts, self.tags, strict=True)]
        self.curve = next((c for c, _ in curves if c is not None), None)
        self.knots = None if self.curve is None else self.curve.constant(self.msh)
        self.tab = fem.Function(Q)  # 1 on the cells of the tabulated curve
        for c, tag in curves:
            if c is not None:
                self.tab.x.array[cell_tags.find(tag)] = 1.0
        self.tab.x.scatter_forward()

    def _boundary(self, center: np.ndarray, r_air: float, q: int) -> None:
        msh = self.msh
        fdim = msh.topology.dim - 1
        msh.topology.create_connectivity(fdim, msh.topology.dim)
        facets = mesh.exterior_facet_indices(msh.topology)
        mid = mesh.compute_midpoints(msh, fdim, facets)
        outer = facets if self.frame is None else facets[mid[:, 0] > 1e-6 * r_air]
        c = (
            center
            if self.frame is None
            else np.array([0.0, float((center - self.frame.origin) @ self.frame.axis)])
        )
        x = ufl.SpatialCoordinate(msh)
        d = x - fem.Constant(msh, np.asarray(c[: self.gdim], dtype=float))
        tags = mesh.meshtags(msh, fdim, np.sort(outer), 1)
        self.ds = ufl.Measure(
            "ds", domain=msh, subdomain_data=tags, metadata={"quadrature_degree": q}
        )(1)
        self.robin = 2.0 / ufl.sqrt(ufl.dot(d, d))
        self.bcs: list[Any] = []
        if self.solve.open_boundary == "dirichlet":
            dofs = fem.locate_dofs_topological(self.V, fdim, outer)
            self.bcs = [fem.dirichletbc(0.0, dofs, self.V)]
            self.robin = 0.0

    def flux(self, b: Any, *, linear: bool = False) -> Any:
        """B(b) in the iron (UFL), b = µ0 H (T): the B-H law of each cell (``linear``: µr b)."""
        if self.linear or linear:
            return self.mu * b
        nb = ufl.sqrt(ufl.dot(b, b) + 1e-24)
        a = math.pi * (self.mu - 1.0) / (2.0 * self.js)
        law = b * (1.0 + 2.0 * self.js / math.pi * ufl.atan(a * nb) / nb)
        if self.curve is None:
            return law
        return self.tab * b * self.curve.ufl(nb, self.knots) / nb + (1.0 - self.tab) * law

    def source(self, load: SourceField) -> Any:
        """B_s of ``load`` interpolated on the iron cells (vector Lagrange, gdim components)."""
        Bs = fem.Function(self.W, name="B_source")

        def values(xT: np.ndarray) -> np.ndarray:
            pts = xT.T.copy()
            if self.frame is None:
                return load.flux_density(pts).T
            world = (
                self.frame.origin + pts[:, :1] * self.frame.Q[:, 0] + pts[:, 1:2] * self.frame.axis
            )
            B = load.flux_density(world)
            return np.vstack([B @ self.frame.Q[:, 0], B @ self.frame.axis])

        Bs.interpolate(values, cells0=self.iron_cells)
        Bs.x.scatter_forward()
        return Bs


class _Linear:
    """One assembled operator and its CG + GAMG solver, for several right-hand sides."""

    def __init__(self, a: Any, bcs: list[Any], prefix: str):
        self.a, self.bcs, self.prefix = fem.form(a, jit_options=JIT_WAIT), bcs, prefix
        self.A = petsc.assemble_matrix(self.a, bcs=bcs)
        self.A.assemble()
        self.ksp = PETSc.KSP().create(self.A.getComm())
        self.ksp.setOptionsPrefix(prefix)
        opts: Any = PETSc.Options()
        for k, v in _KRYLOV.items():
            opts[f"{prefix}{k}"] = v
        self.ksp.setOperators(self.A)
        self.ksp.setFromOptions()
        self.iterations = 0

    def solve(self, L: Any, u: Any) -> None:
        """Solve a u = L into the Function ``u``; raises if CG fails."""
        b = petsc.assemble_vector(fem.form(L, jit_options=JIT_WAIT))
        petsc.apply_lifting(b, [self.a], [self.bcs])
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)  # type: ignore[arg-type]
        petsc.set_bc(b, self.bcs)
        self.ksp.solve(b, u.x.petsc_vec)
        reason = int(self.ksp.getConvergedReason())  # type: ignore[call-overload]
        self.iterations = max(self.iterations, int(self.ksp.getIterationNumber()))
        if reason <= 0:  # CG + GAMG failed: a direct solve instead (slower, robust)
            self.ksp.setType("preonly")
            self.ksp.getPC().setType("lu")
            self.ksp.getPC().setFactorSolverType("mumps")
            self.ksp.solve(b, u.x.petsc_vec)
            reason = int(self.ksp.getConvergedReason())  # type: ignore[call-overload]
        u.x.scatter_forward()
        b.destroy()
        if reason <= 0:
            raise RuntimeError(
                f"{self.prefix}: linear solve failed (KSP converged reason {reason})"
            )

    def destroy(self) -> None:
        """Free the PETSc objects."""
        self.ksp.destroy()
        self.A.destroy()


def _fit_source_potential(P: _Problem, Bs: Any, name: str) -> Any:
    """g with ∫_iron (∇g + B_s)·∇w + δ g w = 0 (module docstring); g = 0 off the iron."""
    g, w = ufl.TrialFunction(P.V), ufl.TestFunction(P.V)
    delta = 1e-6 / P.size**2
    a = (ufl.inner(ufl.grad(g), ufl.grad(w)) + delta * g * w) * P.weight * P.dxi
    L = -ufl.inner(Bs, ufl.grad(w)) * P.weight * P.dxi
    iron_dofs = np.unique(P.V.dofmap.list[P.iron_cells].ravel())
    n_local = P.V.dofmap.index_map.size_local + P.V.dofmap.index_map.num_ghosts
    off = np.setdiff1d(np.arange(n_local, dtype=np.int32), iron_dofs).astype(np.int32)
    solver = _Linear(a, [fem.dirichletbc(0.0, off, P.V)], f"magfem_{name}_g_")
    gh = fem.Function(P.V, name="g")
    solver.solve(L, gh)
    solver.destroy()
    return gh


def _residual(P: _Problem, u: Any, g: Any, Bs: Any, *, linear: bool = False) -> Any:
    """The weak form of the module docstring (``linear``: µr b; u may be a TrialFunction)."""
    w = ufl.TestFunction(P.V)
    F = ufl.inner(ufl.grad(u), ufl.grad(w)) * P.weight * P.dxa
    F += ufl.inner(Bs - P.flux(-ufl.grad(u + g), linear=linear), ufl.grad(w)) * P.weight * P.dxi
    if not P.bcs:
        F += P.robin * u * w * P.weight * P.ds
    return F


def _solve_nonlinear(P: _Problem, u: Any, g: Any, Bs: Any, name: str) -> int:
    """Newton (SNES) for u from the initial guess in ``u``; returns the Newton iterations."""
    F = _residual(P, u, g, Bs)
    opts = {
        "snes_type": "newtonls",
        "snes_linesearch_type": "bt",
        "snes_rtol": 1e-10,
        "snes_atol": 1e-13,
        "snes_max_it": 50,
        **_KRYLOV,
    }
    problem = petsc.NonlinearProblem(
        F,
        u,
        bcs=P.bcs,
        petsc_options_prefix=f"magfem_{name}_",
        petsc_options=opts,
        jit_options=JIT_WAIT,
    )
    problem.solve()
    snes: Any = problem.solver
    reason, its = int(snes.getConvergedReason()), int(snes.getIterationNumber())
    if reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE:
        # CG stops when GAMG's smoother is not positive on a strongly saturated Jacobian
        # (differential µr from ~1 to ~10⁴ side by side): GMRES from the last iterate
        ksp = snes.getKSP()
        ksp.setType("gmres")
        ksp.setGMRESRestart(200)
        problem.solve()
        reason = int(snes.getConvergedReason())
        its += int(snes.getIterationNumber())
    if reason <= 0:
        raise RuntimeError(
            f"{name}: nonlinear iron solve failed (SNES reason {reason} after {its} iterations); "
            "refine field.solve.mesh_size or check the B-H law (permeability, saturation)"
        )
    return its


def _recover(P: _Problem, u: Any, name: str) -> Any:
    """Blocked Function of the air field −∇u and its gradient (:class:`ReactionField`)."""
    weight = P.chi * P.weight
    if P.frame is None:
        proj = Projector(P.V, P.dx, weight, prefix=f"magfem_{name}_P_")
        B = [proj(-u.dx(i), name=f"B_{i}") for i in range(3)]
        funcs = B + [proj(B[i].dx(j), name=f"dB_{i}{j}") for i in range(3) for j in range(3)]
    else:
        fdim = P.msh.topology.dim - 1
        facets = mesh.locate_entities_boundary(P.msh, fdim, lambda x: np.isclose(x[0], 0.0))
        axis_dofs = fem.locate_dofs_topological(P.V, fdim, facets)
        proj = Projector(P.V, P.dx, weight, zero_dofs=axis_dofs, prefix=f"magfem_{name}_P_")
        Br = proj(-u.dx(0), constrained=True, name="B_r")
        Bz = proj(-u.dx(1), name="B_z")
        # ∂B_r/∂z = ∂B_z/∂r = 0 on the axis (B_r odd, B_z even in r)
        funcs = [
            Br,
            Bz,
            proj(Br.dx(0), name="dBr_dr"),
            proj(Br.dx(1), constrained=True, name="dBr_dz"),
            proj(Bz.dx(0), constrained=True, name="dBz_dr"),
            proj(Bz.dx(1), name="dBz_dz"),
        ]
    proj.destroy()
    return pack(funcs, f"{name}_recovered")


def _iron_field(P: _Problem, u: Any, g: Any) -> tuple[Any, np.ndarray]:
    """Total B in the iron (DG, degree p − 1) and the iron's dipole moment (3,), A m²."""
    b = -ufl.grad(u + g)
    B = P.flux(b)
    D = fem.functionspace(P.msh, ("DG", P.degree - 1, (P.gdim,)))
    Bi = fem.Function(D, name="B_iron")
    Bi.interpolate(
        fem.Expression(B, D.element.interpolation_points, jit_options=JIT_WAIT), cells0=P.iron_cells
    )
    Bi.x.scatter_forward()
    comm = P.msh.comm
    m = (
        np.array(
            [
                comm.allreduce(
                    fem.assemble_scalar(
                        fem.form((B[i] - b[i]) * P.weight * P.dxi, jit_options=JIT_WAIT)
                    )
                )
                for i in range(P.gdim)
            ]
        )
        / MU0
    )
    if P.frame is None:
        return Bi, m
    return Bi, 2 * math.pi * m[1] * P.frame.axis


def _solve_load(P: _Problem, linear: _Linear, load: SourceField, name: str) -> tuple[Any, Any, int]:
    """(u, g, Newton iterations) of one load: linear solve, then Newton if the iron saturates."""
    Bs = P.source(load)
    g = _fit_source_potential(P, Bs, name)
    u = fem.Function(P.V, name="u")
    linear.solve(ufl.rhs(_residual(P, ufl.TrialFunction(P.V), g, Bs, linear=True)), u)
    its = 0 if P.linear else _solve_nonlinear(P, u, g, Bs, name)
    return u, g, its


def solve_iron(
    parts: Sequence[IronSpec],
    loads: Sequence[SourceField],
    solve: SolveSpec,
    comm: MPI.Comm,
    *,
    workspace: np.ndarray | None = None,
    name: str = "iron",
) -> list[ReactionField]:
    """The iron parts' reaction to each load at nominal strength (collective; module docstring).

    Args:
        parts: iron parts (all in one rigid group).
        loads: closed-form source fields (rank-local). Linear iron: one
            reaction per load; nonlinear iron: pass one load (all sources summed).
        solve: FE settings (``geometry`` picks 3D or (r, z); ``auto`` uses
            (r, z) when the parts and loads share one symmetry axis).
        comm: communicator. workspace: robot box (2, 3), m, kept in the mesh.
        name: label (PETSc prefixes, messages).

    Returns:
        One :class:`ReactionField` per load.
    """
    t0 = time.perf_counter()
    frame = None if solve.geometry == "3d" else common_axis(parts, loads)
    if solve.geometry == "axisymmetric" and frame is None:
        raise CaseError(
            "field.solve.geometry",
            "axisymmetric",
            "the iron parts and sources do not share one symmetry axis",
        )
    data, center, r_air, h_iron = build_iron_mesh(parts, frame, solve, comm, workspace)
    P = _Problem(data, parts, frame, center, r_air, solve)
    step = solve.hessian_step or (
        float(np.max(workspace[1] - workspace[0])) / 10 if workspace is not None else 2 * h_iron
    )
    trial = ufl.TrialFunction(P.V)
    zero, zero_vec = fem.Constant(P.msh, 0.0), fem.Constant(P.msh, np.zeros(P.gdim))
    linear = _Linear(
        ufl.lhs(_residual(P, trial, zero, zero_vec, linear=True)), P.bcs, f"magfem_{name}_u_"
    )
    info = {
        "dofs": P.V.dofmap.index_map.size_global,
        "mesh_s": time.perf_counter() - t0,
        "h_iron": h_iron,
        "r_air": r_air,
    }
    out = []
    for k, load in enumerate(loads):
        u, g, its = _solve_load(P, linear, load, f"{name}{k}")
        Bi, moment = _iron_field(P, u, g)
        out.append(
            ReactionField(
                _recover(P, u, f"{name}{k}"),
                Bi,
                moment=moment,
                center=center,
                r_air=r_air,
                parts=parts,
                cell_size=P.hcell,
                axis=frame,
                hessian_step=step,
                name=f"{name} reaction to {load.name}",
                info=info
                | {
                    "cg_iterations": linear.iterations,
                    "newton_iterations": its,
                    "total_s": time.perf_counter() - t0,
                },
            )
        )
    linear.destroy()
    return out
