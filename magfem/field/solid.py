"""3D magnetostatics of permanent magnets that are not axisymmetric (block magnets).

Formulation: magnetic scalar potential (e.g. Meunier (ed.), The Finite
Element Method for Electromagnetic Modeling, ch. 4). Without free currents
curl H = 0, so H = −∇φ; with μ = μ0 everywhere and B = μ0 (H + M),
div B = 0 gives, for w vanishing on the outer sphere,

    ∫_Ω ∇φ·∇w dx = ∫_magnets M·∇w dx,       φ = 0 on |x − c| = R_air,

a symmetric positive definite Poisson problem, solved with CG + GAMG
(smoothed aggregation; measured in docs/field.md). The right-hand side is
the magnet's bound charge −div M in weak form (surface charge M·n on its
faces). The open boundary is truncated at the sphere |x − c| = R_air with
the asymptotic condition ∂φ/∂n = −2φ/R matched to a dipole potential
(φ ∝ r⁻²), adding ∮ 2/R φ w ds to the left side (``open_boundary =
"dirichlet"``: φ = 0 there, error ∝ R_air⁻³).

Recovery: H_h = L² projection over the air (the magnets, where H jumps,
are weighted out: :func:`magfem.field.recovery.air_indicator`) of −∇φ_h onto
continuous Lagrange functions of the same degree (CG + Jacobi), B = μ0 H_h
in air (inside a magnet the recovered value is not meaningful),
∇B = μ0 × L² projection of ∇H_h (continuous, converges at order p − 1 in
air), ∇∇B by central differences of that gradient
(:func:`magfem.field.model.hessian_from_gradient`).

Coils in 3D are not needed here: every coil is axisymmetric and solved
exactly in (r, z) (:mod:`magfem.field.axisymmetric`), then placed. A 3D
coil would use the reduced scalar potential H = H_s − ∇φ with H_s from
Biot–Savart, or an N1curl vector potential (degree 2); the curl-curl system
needs the AMS preconditioner of hypre (Hiptmair–Xu auxiliary space), which
this PETSc lacks — MUMPS LU is the fallback (FENICSX.md: 36 s for 266k
dofs).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from mpi4py import MPI

from magfem.field.analytic import MU0
from magfem.field.model import SourceField, hessian_from_gradient
from magfem.field.points import PointEvaluator
from magfem.field.recovery import Projector, air_indicator, pack
from magfem.field.spec import BlockMagnetSpec, SolveSpec, frame
from magfem.geometry.sources import BoxRegion, solid_builder

__all__ = ["SolidField", "solve_block_magnets"]


class SolidField(SourceField):
    """B, ∇B of a 3D scalar-potential solution (module docstring).

    Attributes:
        phi: scalar potential φ_h, A. H: recovered H components (3 Functions), A/m.
        dH: recovered ∂H_i/∂x_j (9 Functions, row-major), A/m².
        timings: wall times, s (``mesh``, ``solve``, ``recover``); ``iterations``: CG iterations.
    """

    def __init__(
        self,
        phi: Any,
        H: list[Any],
        dH: list[Any],
        magnets: Sequence[BlockMagnetSpec],
        *,
        r_air: float,
        hessian_step: float,
        name: str,
        timings: dict[str, float],
        iterations: int,
    ):
        self.phi, self.H, self.dH = phi, H, dH
        self.magnets = list(magnets)
        self.r_air = r_air
        self._center = np.mean([m.center for m in magnets], axis=0)
        self._packed = pack([*H, *dH], "H_gradH")
        self.hessian_step = hessian_step
        self.name = name
        self.timings = timings
        self.iterations = iterations
        self.ndofs = phi.function_space.dofmap.index_map.size_global
        self._eval = PointEvaluator(
            phi.function_space.mesh, f"air region of {name} (radius {r_air:g} m)"
        )

    def covers(self, points: np.ndarray) -> np.ndarray:
        # the outer boundary is a polygon inscribed in the circle/sphere of radius r_air
        d = np.atleast_2d(points).reshape(-1, 3) - self._center
        return np.linalg.norm(d, axis=1) < 0.99 * self.r_air

    def flux_density(self, points: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(points).reshape(-1, 3)
        return self.field_and_gradient(p)[0]

    def gradient(self, points: np.ndarray) -> np.ndarray:
        return self.field_and_gradient(points)[1]

    def field_and_gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        (v,) = self._eval([self._packed], np.atleast_2d(points).reshape(-1, 3))
        return MU0 * v[:, :3], MU0 * v[:, 3:].reshape(-1, 3, 3)

    def hessian(self, points: np.ndarray) -> np.ndarray:
        return hessian_from_gradient(self.gradient, points, self.hessian_step)


def _solve(a: Any, L: Any, u: Any, bcs: list[Any], prefix: str, options: dict[str, Any]) -> int:
    from dolfinx.fem.petsc import LinearProblem

    problem = LinearProblem(a, L, u=u, bcs=bcs, petsc_options_prefix=prefix, petsc_options=options)
    problem.solve()
    reason: Any = problem.solver.getConvergedReason()
    if reason <= 0:
        raise RuntimeError(f"{prefix}: linear solve failed (KSP converged reason {reason})")
    return int(problem.solver.getIterationNumber())


def solve_block_magnets(
    magnets: Sequence[BlockMagnetSpec],
    solve: SolveSpec,
    comm: MPI.Comm,
    *,
    workspace: np.ndarray | None = None,
    name: str = "magnets",
) -> SolidField:
    """Mesh, solve and recover the field of block magnets at nominal remanence (collective).

    Args:
        magnets: block magnet tables (placed by center, axis, roll).
        solve: FE settings (``solid_degree``, ``mesh_size``, ``workspace_mesh_size``,
            ``air_factor``, ``open_boundary``).
        comm: communicator. workspace: robot box (2, 3), m, refined.
        name: label.
    """
    import ufl
    from dolfinx import fem, mesh

    from magfem.geometry.gmshio import build_mesh

    t0 = time.perf_counter()
    centers = np.array([m.center for m in magnets], dtype=float)
    c0 = centers.mean(axis=0)
    s = max(
        float(np.linalg.norm(np.asarray(m.center) - c0)) + 0.5 * float(np.linalg.norm(m.size))
        for m in magnets
    )
    r_air = solve.air_factor * s
    ws = 20e-3
    if workspace is not None:
        ws = float(np.max(workspace[1] - workspace[0]))
        reach = float(np.max(np.linalg.norm(np.asarray(workspace) - c0, axis=1)))
        r_air = max(r_air, 2.0 * reach)
    boxes = [
        BoxRegion(
            f"magnet_{k + 1}",
            tuple(m.center),  # type: ignore[arg-type]
            tuple(m.size),  # type: ignore[arg-type]
            tuple(map(tuple, frame(m.unit_axis, m.roll))),
        )
        for k, m in enumerate(magnets)
    ]
    h_source = solve.mesh_size or s / 6
    builder = solid_builder(
        boxes,
        r_air,
        center=tuple(c0),
        h_source=h_source,
        workspace=workspace,
        h_workspace=solve.workspace_mesh_size or ws / 4,
    )
    data = build_mesh(builder, comm, gdim=3, name=name)
    msh = data.mesh
    t1 = time.perf_counter()

    p = solve.solid_degree
    q = 2 * p
    dx = ufl.Measure(
        "dx", domain=msh, subdomain_data=data.cell_tags, metadata={"quadrature_degree": q}
    )
    V = fem.functionspace(msh, ("Lagrange", p))
    phi, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = ufl.inner(ufl.grad(phi), ufl.grad(w)) * dx
    L: Any = fem.Constant(msh, 0.0) * w * dx
    for k, m in enumerate(magnets):
        tag = data.physical_groups[f"magnet_{k + 1}"][1]
        M = fem.Constant(msh, m.remanence / MU0 * m.unit_axis)
        L = L + ufl.inner(M, ufl.grad(w)) * dx(tag)
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, msh.topology.dim)
    outer = mesh.exterior_facet_indices(msh.topology)
    bcs = []
    if solve.open_boundary == "dirichlet":
        bcs = [fem.dirichletbc(0.0, fem.locate_dofs_topological(V, fdim, outer), V)]
    else:
        tags_o = mesh.meshtags(msh, fdim, np.sort(outer), 1)
        ds = ufl.Measure("ds", domain=msh, subdomain_data=tags_o, metadata={"quadrature_degree": q})
        xc = ufl.SpatialCoordinate(msh) - fem.Constant(msh, c0)
        a = a + 2.0 / ufl.sqrt(ufl.dot(xc, xc)) * phi * w * ds(1)
    phi_h = fem.Function(V, name="phi")
    krylov = {"ksp_type": "cg", "ksp_rtol": 1e-10, "ksp_atol": 0.0, "ksp_max_it": 500}
    its = _solve(
        a,
        L,
        phi_h,
        bcs,
        f"magfem_solid_{name}_",
        {**krylov, "pc_type": "gamg", "pc_gamg_type": "agg", "mg_levels_ksp_type": "chebyshev"},
    )
    t2 = time.perf_counter()

    tags = [data.physical_groups[f"magnet_{k + 1}"][1] for k in range(len(magnets))]
    chi = air_indicator(msh, data.cell_tags, tags)
    proj = Projector(V, dx, chi, prefix=f"magfem_solidP_{name}_")
    gphi = ufl.grad(phi_h)
    H = [proj(-gphi[i], name=f"H_{i}") for i in range(3)]
    dH = [proj(H[i].dx(j), name=f"dH_{i}{j}") for i in range(3) for j in range(3)]
    proj.destroy()
    t3 = time.perf_counter()
    return SolidField(
        phi_h,
        H,
        dH,
        magnets,
        r_air=r_air,
        hessian_step=solve.hessian_step or ws / 10,
        name=name,
        timings={"mesh": t1 - t0, "solve": t2 - t1, "recover": t3 - t2},
        iterations=its,
    )
