"""Axisymmetric magnetostatics in the (r, z) half-plane: coils and axially magnetised cylinders.

Formulation (e.g. Jin, The Finite Element Method in Electromagnetics, 3rd
ed., §4.5; Meunier (ed.), The Finite Element Method for Electromagnetic
Modeling, ch. 5). With μ = μ0 everywhere (air, copper, and NdFeB taken as
μr = 1), B = curl(A_φ e_φ) and H = B/μ0 − M, Ampère's law curl H = J
becomes, for the azimuthal component A = A_φ(r, z),

    B_r = −∂A/∂z,   B_z = ∂A/∂r + A/r,

and its weak form on the half-disk Ω = {r ≥ 0, r² + z² ≤ R_air²}, for
test functions v vanishing on the axis and the outer boundary (the factor
2π cancels), is

    ∫_Ω 1/μ0 [∂A/∂z ∂v/∂z + (∂A/∂r + A/r)(∂v/∂r + v/r)] r dr dz
        = ∫_coils J_φ v r dr dz + ∫_magnets M (∂v/∂r + v/r) r dr dz

with J_φ = N I / ((r2 − r1) L) in a winding and M = Br/μ0 the axial
magnetisation of a magnet (the magnet term is ∫ M·curl v dV, i.e. the bound
surface current M × n of the magnet's mantle, in weak form). A = 0 on the
axis (symmetry). The open boundary is truncated at the arc |x| = R_air
with the first-order asymptotic (Bayliss–Turkel-type) condition matched
to a dipole: there A_φ = m sin θ /(4π R²) gives H_θ = A/(μ0 R), i.e.
n × H = A/(μ0 R) e_φ, which adds ∮ A v/(μ0 R) r dl to the left side and is
exact for the dipole part of the far field (``open_boundary = "dirichlet"``:
A = 0 there instead). The truncation error of both is measured in
docs/field.md.

Recovery of B and ∇B. B is computed from A_h (Lagrange degree p) by an
r-weighted L² projection over the air onto continuous degree-p Lagrange
functions, B_h = P(B(A_h)) with ∫_air B_h·w r = ∫_air B(A_h)·w r (the
weight r keeps A/r integrable, so no NaN at r = 0; B_r = 0 is imposed on
the axis; the sources, across whose surfaces B or ∇B jump, are weighted
out: :func:`magfem.field.recovery.air_indicator`; values inside a source
are not meaningful). The
gradient is the r-weighted projection of ∇B_h (∂B_r/∂z = ∂B_z/∂r = 0 on
the axis), a continuous field that converges at order p − 1 (measured in
tests/test_field_axisymmetric.py) — no finite differences. In 3D, with
e_r = (cos φ, sin φ, 0) in the source frame,

    ∇B = ∂B_r/∂r e_r⊗e_r + (B_r/r) e_φ⊗e_φ + ∂B_r/∂z e_r⊗e_z
         + ∂B_z/∂r e_z⊗e_r + ∂B_z/∂z e_z⊗e_z,

with B_r/r → ∂B_r/∂r on the axis; B and ∇B are rotated by the source's
rigid placement (B = Q B_loc, ∇B = Q ∇B_loc Qᵀ). ∇∇B (``hessian``) is
the central difference of this continuous recovered gradient with a step
``hessian_step`` of the order of the workspace (error O(step²) plus the
gradient error divided by the step; used only by the ``taylor2`` model).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from mpi4py import MPI

from magfem.field.analytic import MU0
from magfem.field.model import SourceField, hessian_from_gradient
from magfem.field.points import PointEvaluator
from magfem.field.recovery import Projector, air_indicator, pack
from magfem.field.spec import frame
from magfem.geometry.sources import RectRegion, axisymmetric_builder

__all__ = ["AxisymmetricField", "AxisymmetricSource", "solve_axisymmetric"]


@dataclass(frozen=True)
class AxisymmetricSource:
    """One region of an axisymmetric problem.

    ``current_density``: J_φ, A/m² (coils); ``magnetization``: M_z, A/m (magnets).
    """

    region: RectRegion
    current_density: float = 0.0
    magnetization: float = 0.0


class AxisymmetricField(SourceField):
    """B and ∇B of an axisymmetric FE solution, rigidly placed in 3D (module docstring).

    Attributes:
        A: the potential A_φ (Function on the (r, z) mesh), T·m.
        B: recovered [B_r, B_z] (Functions), T.
        dB: recovered [∂rBr, ∂zBr, ∂rBz, ∂zBz] (Functions), T/m.
        timings: wall times, s: ``mesh``, ``solve``, ``recover``.
        ndofs: number of A dofs (global).
    """

    def __init__(
        self,
        A: Any,
        B: list[Any],
        dB: list[Any],
        *,
        center: np.ndarray,
        axis: np.ndarray,
        r_air: float,
        hessian_step: float,
        name: str,
        timings: dict[str, float],
    ):
        self.A, self.B, self.dB = A, B, dB
        self.center = np.asarray(center, dtype=float)
        self.Q = frame(np.asarray(axis, dtype=float))
        self.r_air = r_air
        self.hessian_step = hessian_step
        self.name = name
        self.timings = timings
        self.mesh = A.function_space.mesh
        self.ndofs = A.function_space.dofmap.index_map.size_global
        self._eval = PointEvaluator(self.mesh, f"air region of {name} (radius {r_air:g} m)")
        self._packed = pack([*B, *dB], "B_gradB")

    def _local(self, points: np.ndarray) -> tuple[np.ndarray, ...]:
        p = (np.atleast_2d(points).reshape(-1, 3) - self.center) @ self.Q
        r = np.hypot(p[:, 0], p[:, 1])
        safe = np.where(r > 0, r, 1.0)
        c = np.where(r > 0, p[:, 0] / safe, 1.0)
        s = np.where(r > 0, p[:, 1] / safe, 0.0)
        rz = np.column_stack([r, p[:, 2], np.zeros(len(p))])
        return rz, c, s, r

    def _values(self, points: np.ndarray, gradient: bool = True) -> tuple[np.ndarray, ...]:
        rz, c, s, r = self._local(points)
        (v,) = self._eval([self._packed], rz)
        return v[:, :2], v[:, 2:], c, s, r

    def covers(self, points: np.ndarray) -> np.ndarray:
        # the outer boundary is a polygon inscribed in the circle/sphere of radius r_air
        d = np.atleast_2d(points).reshape(-1, 3) - self.center
        return np.linalg.norm(d, axis=1) < 0.99 * self.r_air

    def flux_density(self, points: np.ndarray) -> np.ndarray:
        return self.field_and_gradient(points, gradient=False)[0]

    def gradient(self, points: np.ndarray) -> np.ndarray:
        return self.field_and_gradient(points)[1]

    def field_and_gradient(
        self, points: np.ndarray, *, gradient: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        b, d, c, s, r = self._values(points, gradient)
        n = len(b)
        B = np.column_stack([b[:, 0] * c, b[:, 0] * s, b[:, 1]]) @ self.Q.T
        if not gradient:
            return B, np.zeros((n, 3, 3))
        z = np.zeros(n)
        er = np.column_stack([c, s, z])
        ephi = np.column_stack([-s, c, z])
        tiny = 1e-9 * self.r_air
        br_over_r = np.where(r > tiny, b[:, 0] / np.where(r > tiny, r, 1.0), d[:, 0])
        G = d[:, 0, None, None] * (er[:, :, None] * er[:, None, :]) + br_over_r[:, None, None] * (
            ephi[:, :, None] * ephi[:, None, :]
        )
        G[:, :, 2] += d[:, 1, None] * er  # ∂B_r/∂z e_r ⊗ e_z
        G[:, 2, :] += d[:, 2, None] * er  # ∂B_z/∂r e_z ⊗ e_r
        G[:, 2, 2] += d[:, 3]
        return B, self.Q @ G @ self.Q.T

    def hessian(self, points: np.ndarray) -> np.ndarray:
        return hessian_from_gradient(self.gradient, points, self.hessian_step)


def _check_ksp(ksp: Any, what: str) -> None:
    reason = int(ksp.getConvergedReason())
    if reason <= 0:
        raise RuntimeError(f"{what}: linear solve failed (KSP converged reason {reason})")


def solve_axisymmetric(
    sources: Sequence[AxisymmetricSource],
    comm: MPI.Comm,
    *,
    degree: int = 3,
    h_source: float,
    r_air: float,
    center: np.ndarray,
    axis: np.ndarray,
    workspace: np.ndarray | None = None,
    h_workspace: float | None = None,
    hessian_step: float = 2e-3,
    open_boundary: str = "robin",
    name: str = "axisymmetric",
) -> AxisymmetricField:
    """Mesh, solve and recover one axisymmetric problem (collective).

    Args:
        sources: windings and magnets in the source frame (r, z), m.
        comm: communicator of the distributed (r, z) mesh.
        degree: Lagrange degree p of A_φ (and of the recovered B, ∇B).
        h_source: element size at the sources, m. r_air: air radius, m.
        center, axis: rigid placement (3,), m and unit vector.
        workspace: (2, 2) box [[r_min, z_min], [r_max, z_max]] in the source
            frame refined to ``h_workspace`` (m).
        hessian_step: step of the central difference of ∇B for ∇∇B, m.
        open_boundary: ``robin`` (dipole-matched, module docstring) or
            ``dirichlet`` (A = 0) on the outer arc.
        name: label for messages.

    Returns:
        The placed field (numpy B, ∇B, ∇∇B at 3D points).
    """
    import ufl
    from dolfinx import fem, mesh
    from dolfinx.fem.petsc import LinearProblem

    from magfem.geometry.gmshio import build_mesh

    t0 = time.perf_counter()
    builder = axisymmetric_builder(
        [s.region for s in sources],
        r_air,
        h_source=h_source,
        workspace=workspace,
        h_workspace=h_workspace,
    )
    data = build_mesh(builder, comm, gdim=2, name=name)
    msh, cell_tags = data.mesh, data.cell_tags
    t1 = time.perf_counter()

    q = 2 * degree + 1
    dx = ufl.Measure("dx", domain=msh, subdomain_data=cell_tags, metadata={"quadrature_degree": q})
    x = ufl.SpatialCoordinate(msh)
    r = x[0]
    V = fem.functionspace(msh, ("Lagrange", degree))
    A, v = ufl.TrialFunction(V), ufl.TestFunction(V)

    def curl_z(f: Any) -> Any:  # (1/r) ∂(r f)/∂r
        return f.dx(0) + f / r

    a = (1.0 / MU0) * (A.dx(1) * v.dx(1) + curl_z(A) * curl_z(v)) * r * dx
    L: Any = fem.Constant(msh, 0.0) * v * r * dx
    for s in sources:
        tag = data.physical_groups[s.region.name][1]
        if s.current_density:
            L = L + fem.Constant(msh, s.current_density) * v * r * dx(tag)
        if s.magnetization:
            L = L + fem.Constant(msh, s.magnetization) * curl_z(v) * r * dx(tag)
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, msh.topology.dim)
    boundary = mesh.exterior_facet_indices(msh.topology)
    mid = mesh.compute_midpoints(msh, fdim, boundary)
    on_axis = mid[:, 0] < 1e-6 * r_air
    dirichlet = boundary if open_boundary == "dirichlet" else boundary[on_axis]
    bc = fem.dirichletbc(0.0, fem.locate_dofs_topological(V, fdim, dirichlet), V)
    if open_boundary == "robin":
        outer = mesh.meshtags(msh, fdim, np.sort(boundary[~on_axis]), 1)
        ds = ufl.Measure("ds", domain=msh, subdomain_data=outer, metadata={"quadrature_degree": q})
        a = a + (1.0 / MU0) * A * v / ufl.sqrt(ufl.dot(x, x)) * r * ds(1)
    problem = LinearProblem(
        a,
        L,
        bcs=[bc],
        petsc_options_prefix=f"magfem_axi_{name}_",
        petsc_options={
            "ksp_type": "preonly",
            "pc_type": "lu",
            "pc_factor_mat_solver_type": "mumps",
        },
    )
    Ah: Any = problem.solve()
    _check_ksp(problem.solver, f"A_phi solve of {name}")
    Ah.name = "A_phi"
    t2 = time.perf_counter()

    axis_facets = mesh.locate_entities_boundary(msh, fdim, lambda p: np.isclose(p[0], 0.0))
    axis_dofs = fem.locate_dofs_topological(V, fdim, axis_facets)
    chi = air_indicator(msh, cell_tags, [data.physical_groups[g.region.name][1] for g in sources])
    proj = Projector(V, dx, r * chi, zero_dofs=axis_dofs, prefix=f"magfem_axiP_{name}_")
    Br = proj(-Ah.dx(1), constrained=True, name="B_r")
    Bz = proj(curl_z(Ah), name="B_z")
    # ∂B_r/∂z = ∂B_z/∂r = 0 on the axis (B_r odd, B_z even in r)
    dB = [
        proj(Br.dx(0), name="dBr_dr"),
        proj(Br.dx(1), constrained=True, name="dBr_dz"),
        proj(Bz.dx(0), constrained=True, name="dBz_dr"),
        proj(Bz.dx(1), name="dBz_dz"),
    ]
    proj.destroy()
    t3 = time.perf_counter()
    timings = {"mesh": t1 - t0, "solve": t2 - t1, "recover": t3 - t2}
    return AxisymmetricField(
        Ah,
        [Br, Bz],
        dB,
        center=center,
        axis=axis,
        r_air=r_air,
        hessian_step=hessian_step,
        name=name,
        timings=timings,
    )
