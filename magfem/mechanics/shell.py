r"""Shell model of the membrane: a finite-rotation Reissner–Mindlin (Naghdi) shell.

``[mesh] model = "surface"`` meshes the robot's mid-surface (z = t/2) and the
mechanics solves for two fields on it: the mid-surface displacement u (P2,
3 components, m) and two director angles θ (P2, rad). The director, the
material normal of the deformed shell, is

.. math::

    \mathbf d = R_\alpha\,(\sin\theta_1\cos\theta_0,\ -\sin\theta_0,\
    \cos\theta_1\cos\theta_0)^T ,

with R_α the rotation about z by the *bending frame* angle α(X): 0 for the
beam-like robots (arms along ±x: θ₁ bends an arm about y, without limit, so
the tip can turn past 270°) and the polar angle about the robot's centre for
radial robots (each arm bends about its own tangential axis). The angles are
singular only where d lies along the frame's second axis (θ₀ = ±90°: an arm
twisted by 90° about its own axis), which the robots here never reach.

Strains (reference mid-surface flat, in the xy plane; F₀ = ∂φ/∂(x, y) the
3×2 surface deformation gradient of φ = X + u, ∇d its 3×2 director gradient):

.. math::

    \mathbf e = \tfrac12(F_0^T F_0 - I),\quad
    \mathbf k = \tfrac12(F_0^T\nabla\mathbf d + \nabla\mathbf d^T F_0),\quad
    \boldsymbol\gamma = F_0^T\mathbf d ,

membrane, bending and transverse shear, each zero in the flat rest state.
Energy per reference area (small strain, large rotation; plane-stress
isotropic with μ and ν of the case's μ and K, λ̂ = 2ν/(1 − ν)):

.. math::

    \psi = \tfrac t2 \mu\big(\hat\lambda(\mathrm{tr}\,\mathbf e)^2 + 2\,\mathbf e{:}\mathbf e\big)
         + \tfrac{t^3}{24} \mu\big(\hat\lambda(\mathrm{tr}\,\mathbf k)^2
           + 2\,\mathbf k{:}\mathbf k\big)
         + \tfrac56\,\tfrac{\mu t}2\,\boldsymbol\gamma\cdot\boldsymbol\gamma
         - t\,(F\tilde{\mathbf M})\cdot\mathbf B(\boldsymbol\varphi)
         - \rho t\,\mathbf g\cdot\mathbf u ,

with F M̃ = F₀ M̃_∥ + M̃_z d (the solid's F M̃ at the mid-surface for a
director that stays normal). This is the neo-Hookean solid of
:mod:`magfem.material` to first order in the strain, which stays at a few
per cent in the scenes (largest strain column of the history); the shell
model is not for the 50 % strains of the thick, strong-field extremes.
Kinetic energy ½ρt|u̇|² + ½(ρt³/12)|θ̇|² (the rotary term is exact for
bending about one axis and negligible, t²/12 against the arm length², but
gives the angles a mass).

Ground contact acts on both faces x± = φ ± (t/2) d (velocity v ± (t/2) ḋ),
through the law of :mod:`magfem.mechanics.contact` integrated over the
mid-surface, like the solid's top and bottom faces. Supports: a clamped
patch fixes u and θ (the bonded face cannot rotate); ``fixed_point`` fixes u.

Why a shell: on the 3D solid a P2 hexahedron has 3 nodes through the
thickness (9 dofs per in-plane node, 81 × 81 element matrices at 27
points); the shell has 5 dofs per node and 45 × 45 matrices at 9 points.
On the default case the Newton iteration is ~4× cheaper and Newton needs
fewer iterations (docs/mechanics.md, "Shell model").

P2 quadrilaterals with full (3 × 3) quadrature: reduced integration of the
membrane and shear terms made hourglass modes at the free tip (tip angle
150° instead of 71° after 6 ms on the default case), and the fully
integrated P2 element is within the solid's mesh error of the solid
(docs/verification.md), so there is no visible shear locking at the
thickness-to-element ratios used (t/h ≥ 0.05).
"""

from __future__ import annotations

import functools
import operator
from typing import TYPE_CHECKING, Any

import basix.ufl
import numpy as np
import ufl
from dolfinx import fem

from magfem import material
from magfem.config import CaseError
from magfem.mechanics.integrator import BlockIntegrator, TimeIntegrator

if TYPE_CHECKING:
    from magfem.case import Case
    from magfem.field.model import FieldModel
    from magfem.geometry.robot_mesh import RobotMesh
    from magfem.mechanics.problem import MembraneProblem

__all__ = [
    "SHEAR_CORRECTION",
    "ShellKinematics",
    "build_shell_problem",
    "director",
    "director_jacobian",
    "shell_energy_density",
]

SHEAR_CORRECTION = 5.0 / 6.0
"""Transverse shear correction factor of a homogeneous plate (Reissner)."""


def director(theta: Any, frame: Any | None = None) -> Any:
    """Director d(θ) (UFL 3-vector) of the angles θ = (θ₀, θ₁) in the frame rotated by α.

    Args:
        theta: UFL 2-vector of angles (rad).
        frame: α (rad, UFL scalar) or None for α = 0.
    """
    c0 = ufl.cos(theta[0])
    d1, d2, d3 = ufl.sin(theta[1]) * c0, -ufl.sin(theta[0]), ufl.cos(theta[1]) * c0
    if frame is None:
        return ufl.as_vector([d1, d2, d3])
    ca, sa = ufl.cos(frame), ufl.sin(frame)
    return ufl.as_vector([ca * d1 - sa * d2, sa * d1 + ca * d2, d3])


def director_jacobian(theta: Any, frame: Any | None = None) -> Any:
    """∂d/∂θ (UFL 3×2 matrix) of :func:`director`: columns ∂d/∂θ₀ and ∂d/∂θ₁."""
    s0, c0, s1, c1 = ufl.sin(theta[0]), ufl.cos(theta[0]), ufl.sin(theta[1]), ufl.cos(theta[1])
    rows = [[-s1 * s0, c1 * c0], [-c0, 0.0], [-c1 * s0, -s1 * c0]]
    if frame is not None:
        ca, sa = ufl.cos(frame), ufl.sin(frame)
        r0, r1 = rows[0], rows[1]
        rows = [
            [ca * r0[j] - sa * r1[j] for j in range(2)],
            [sa * r0[j] + ca * r1[j] for j in range(2)],
            rows[2],
        ]
    return ufl.as_matrix(rows)


def _in_plane(grad3: Any) -> Any:
    """The 3×2 in-plane columns of a 3×3 gradient on the flat (xy) reference surface."""
    return ufl.as_matrix([[grad3[i, 0], grad3[i, 1]] for i in range(3)])


class ShellKinematics:
    """Strains of the shell at a displacement u and angles θ (UFL expressions).

    Attributes:
        F0: 3×2 surface deformation gradient. d: director. grad_d: 3×2.
        membrane, bending, shear: e (2×2), k (2×2, 1/m), γ (2).
    """

    def __init__(self, u: Any, theta: Any, frame: Any | None):
        I3 = ufl.Identity(3)
        self.F0 = _in_plane(I3 + ufl.grad(u))
        self.d = director(theta, frame)
        self.grad_d = _in_plane(ufl.grad(self.d))
        F0, G = self.F0, self.grad_d
        self.membrane = 0.5 * (F0.T * F0 - ufl.Identity(2))
        self.bending = 0.5 * (F0.T * G + G.T * F0)
        self.shear = F0.T * self.d

    def face_metric(self, side: float, thickness: float) -> Any:
        """2×2 metric (right Cauchy–Green tensor in the plane) of the face at z = side·t/2."""
        Fs = self.F0 + side * 0.5 * thickness * self.grad_d
        return Fs.T * Fs


def shell_energy_density(
    kin: ShellKinematics, shear_modulus: Any, poisson: float, thickness: float
) -> Any:
    """Elastic energy per reference area (J/m²) of the module's constitutive law."""
    mu, t = shear_modulus, thickness
    lam = 2.0 * poisson / (1.0 - poisson)  # λ̂ = λ_s/μ

    def quad(s: Any) -> Any:
        return mu * (lam * ufl.tr(s) ** 2 + 2.0 * ufl.inner(s, s))

    return (
        0.5 * t * quad(kin.membrane)
        + t**3 / 24.0 * quad(kin.bending)
        + 0.5 * SHEAR_CORRECTION * mu * t * ufl.dot(kin.shear, kin.shear)
    )


def _frame_angle(robot: RobotMesh, case: Case) -> Any | None:
    """α(X): None when every arm runs along ±x, else the polar angle about the robot's centre."""
    if all(abs(float(a.direction[1])) < 1e-12 for a in robot.arms):
        return None
    X = ufl.SpatialCoordinate(robot.mesh)
    cx, cy, _ = case.robot.position
    return ufl.atan2(X[1] - cy, X[0] - cx)


def _clamp_entities(case: Case, robot: RobotMesh) -> list[tuple[int, Any]]:
    """(dim, local entities) fully fixed by ``[environment] clamped`` on the surface mesh.

    A clamped patch of the surface model is tagged on its edges
    (``create_robot_mesh``); the cells all of whose edges are clamped are
    added, so that the patch's interior nodes are held too.
    """
    from magfem.mechanics.problem import clamped_entities

    domain = robot.mesh
    tdim = domain.topology.dim
    out: list[tuple[int, Any]] = []
    for dim, entities in clamped_entities(case, robot):
        out.append((dim, entities))
        if dim == 1:
            domain.topology.create_connectivity(tdim, 1)
            c2e = domain.topology.connectivity(tdim, 1)
            n_cells = domain.topology.index_map(tdim).size_local
            edges = domain.topology.index_map(1)
            held = np.zeros(edges.size_local + edges.num_ghosts, dtype=bool)
            held[entities] = True
            per_cell = int(c2e.offsets[1] - c2e.offsets[0])  # one cell type: 3 or 4 edges
            rows = held[c2e.array[: n_cells * per_cell]].reshape(n_cells, per_cell)
            out.append((tdim, np.flatnonzero(rows.all(axis=1)).astype(np.int32)))
    return out


def _supports(
    case: Case, robot: RobotMesh, spaces: tuple[fem.FunctionSpace, fem.FunctionSpace]
) -> tuple[list[fem.DirichletBC], list[fem.DirichletBC], bool]:
    """(bcs on u, bcs on θ, free body) of ``[environment]`` for the shell."""
    from mpi4py import MPI

    from magfem.mechanics.problem import fixed_point_dofs

    domain = robot.mesh
    Vu, Vt = spaces
    bcs_u: list[fem.DirichletBC] = []
    bcs_t: list[fem.DirichletBC] = []
    for dim, entities in _clamp_entities(case, robot):
        domain.topology.create_connectivity(dim, domain.topology.dim)
        for V, out in ((Vu, bcs_u), (Vt, bcs_t)):
            dofs = fem.locate_dofs_topological(V, dim, entities)
            zero = np.zeros(V.dofmap.index_map_bs, dtype=np.float64)
            out.append(fem.dirichletbc(zero, dofs, V))
    if case.environment.fixed_point is not None:
        bcs_u.append(fem.dirichletbc(np.zeros(3), fixed_point_dofs(case, Vu), Vu))
    held = sum(len(bc.dof_indices()[0]) for bc in bcs_u)
    free = domain.comm.allreduce(held, op=MPI.SUM) == 0
    return bcs_u, bcs_t, free


def _contact_sides(case: Case) -> list[float]:
    """Faces (−1 bottom, +1 top) of ``[contact] surfaces`` for the shell."""
    names = set(case.contact.surfaces)
    unknown = names - {"all", "bottom", "top", "clamp"}
    if unknown:
        raise CaseError(
            "contact.surfaces",
            list(case.contact.surfaces),
            'the shell model has the faces "all", "bottom" (with "clamp") and "top"',
        )
    if "all" in names:
        return [-1.0, 1.0]
    return [s for s, n in ((-1.0, ("bottom", "clamp")), (1.0, ("top",))) if names & set(n)]


def build_shell_problem(
    case: Case, robot: RobotMesh, field: FieldModel, *, dt: float | None = None
) -> MembraneProblem:
    """The shell's :class:`~magfem.mechanics.problem.MembraneProblem` (see the module docstring).

    ``unknowns`` is [u, θ]; ``residual`` the two block residuals (u rows, θ rows).

    Raises:
        CaseError: self-contact (solid model only), unknown groups or contact
            faces, quasi-static free body.
    """
    from magfem.mechanics.problem import MembraneProblem, _magnetization

    if case.contact.self_contact:
        raise CaseError(
            "contact.self_contact", True, "arm-arm contact needs the solid model, not surface"
        )
    domain = robot.mesh
    degree = case.solver.degree
    q = case.solver.quadrature_degree or 2 * degree
    cell = domain.basix_cell()
    Vu = fem.functionspace(domain, basix.ufl.element("Lagrange", cell, degree, shape=(3,)))
    Vt = fem.functionspace(domain, basix.ufl.element("Lagrange", cell, degree, shape=(2,)))
    u = fem.Function(Vu, name="displacement")
    theta = fem.Function(Vt, name="director_angles")
    step = dt or case.time.step
    parts = [
        TimeIntegrator(f, case.time.scheme, rho_inf=case.time.rho_inf, dt=step) for f in (u, theta)
    ]
    integ = BlockIntegrator(parts)
    mat = case.material
    t = robot.thickness
    poisson = material.poisson_ratio(mat.shear_modulus, mat.bulk)
    mu = fem.Constant(domain, mat.shear_modulus)
    rho = fem.Constant(domain, mat.density)
    g = fem.Constant(domain, np.asarray(case.environment.gravity, dtype=float))
    M = _magnetization(case, robot)
    field.bind(domain)
    frame = _frame_angle(robot, case)
    X = ufl.SpatialCoordinate(domain)
    dx = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": q})
    w_u, w_t = ufl.TestFunction(Vu), ufl.TestFunction(Vt)
    bcs_u, bcs_t, free_body = _supports(case, robot, (Vu, Vt))
    if free_body and not integ.dynamic:
        raise CaseError(
            "time.scheme",
            case.time.scheme,
            "a free body (no clamped group, no fixed_point) needs a dynamic scheme",
        )
    M_in = ufl.as_vector([M[0], M[1]])

    def magnetic(kin: ShellKinematics, disp: Any) -> Any:
        B = field.flux_density(X + disp)
        FM = kin.F0 * M_in + M[2] * kin.d
        return -t * ufl.dot(FM, B)

    def potential(disp: Any, angles: Any) -> Any:
        kin = ShellKinematics(disp, angles, frame)
        return (
            shell_energy_density(kin, mu, poisson, t)
            + magnetic(kin, disp)
            - rho * t * ufl.dot(g, disp)
        ) * dx

    u_gen, t_gen = fem.Function(Vu), fem.Function(Vt)
    Pi = potential(u_gen, t_gen)
    internal = [
        ufl.algorithms.expand_derivatives(ufl.derivative(Pi, u_gen, w_u)),
        ufl.algorithms.expand_derivatives(ufl.derivative(Pi, t_gen, w_t)),
    ]
    inertia_t = rho * t**3 / 12.0

    contact = law = None
    sides: list[float] = []
    if case.contact.ground:
        from magfem.mechanics.contact import GroundContact, create_ground_contact_law

        sides = _contact_sides(case)
        law = create_ground_contact_law(
            case.contact, shear_modulus=mat.shear_modulus, density=mat.density, thickness=t
        )
        contact = GroundContact(
            law,
            domain,
            vertical=2,
            ground_height=case.contact.ground_height,
            time_step=integ.dt if integ.dynamic else None,
        )

    def faces(disp: Any, angles: Any, vel: Any, rate: Any) -> list[tuple[Any, Any, Any]]:
        """(x, v, ∂x/∂θ) of each contacting face: position, velocity, and the angle
        derivative of the position (its virtual displacement is δu + ∂x/∂θ δθ)."""
        d = director(angles, frame)
        Jd = director_jacobian(angles, frame)  # 3×2
        out = []
        for s in sides:
            h = s * 0.5 * t
            x = X + disp + h * d  # the reference face is at X + h e_z
            v = vel + h * Jd * rate
            out.append((x, v, h * Jd))
        return out

    def contact_work(disp: Any, angles: Any, vel: Any, rate: Any) -> list[Any]:
        assert contact is not None
        work_u: Any = 0
        work_t: Any = 0
        for x, v, dx_dtheta in faces(disp, angles, vel, rate):
            traction = contact.traction(x, v)
            work_u = work_u + ufl.dot(traction, w_u) * dx
            work_t = work_t + ufl.dot(dx_dtheta.T * traction, w_t) * dx
        return [work_u, work_t]

    def residual(
        disp: Any, angles: Any, vel: Any, rate: Any, acc: Any, ang_acc: Any, *, with_contact: bool
    ) -> list[ufl.Form]:
        forms = [
            ufl.replace(internal[0], {u_gen: disp, t_gen: angles}),
            ufl.replace(internal[1], {u_gen: disp, t_gen: angles}),
        ]
        if integ.dynamic:
            forms[0] = forms[0] + rho * t * ufl.dot(acc, w_u) * dx
            forms[1] = forms[1] + inertia_t * ufl.dot(ang_acc, w_t) * dx
        if contact is not None and with_contact:
            cw = contact_work(disp, angles, vel, rate)
            forms = [forms[0] - cw[0], forms[1] - cw[1]]
        return forms

    def continuous_residual(us: Any, vs: Any, as_: Any, t_: Any) -> list[ufl.Form]:
        """R at lists (u, θ), (u̇, θ̇), (ü, θ̈) (the initial acceleration solve)."""
        return residual(us[0], us[1], vs[0], vs[1], as_[0], as_[1], with_contact=True)

    (su, sv, sa), (tu, tv, ta) = (p.stage() for p in parts)
    if integ.dynamic:
        F_step = residual(su, tu, sv, tv, sa, ta, with_contact=False)
        if contact is not None:
            # the ground acts at the end of the step, as for the solid (problem.py)
            cw = contact_work(u, theta, parts[0].velocity(), parts[1].velocity())
            F_step = [F_step[0] - cw[0], F_step[1] - cw[1]]
    else:
        zero3, zero2 = ufl.zero(3), ufl.zero(2)
        F_step = residual(u, theta, zero3, zero2, zero3, zero2, with_contact=True)

    face_offset = 0.5 * t  # the mesh is the mid-surface
    absorber = None
    if contact is not None and integ.dynamic:
        from magfem.mechanics.contact import ImpactAbsorber

        absorber = ImpactAbsorber(
            Vu, None, vertical=2, ground_height=case.contact.ground_height, offset=face_offset
        )

    v1, w1 = parts[0].v0, parts[1].v0  # after advance(): the state at t_{n+1}
    kin = ShellKinematics(u, theta, frame)
    energy_forms = {
        "kinetic": 0.5 * (rho * t * ufl.dot(v1, v1) + inertia_t * ufl.dot(w1, w1)) * dx,
        "elastic": shell_energy_density(kin, mu, poisson, t) * dx,
        "magnetic": magnetic(kin, u) * dx,
        "gravity": -rho * t * ufl.dot(g, u) * dx,
    }
    contact_forms: list[Any] = []
    if contact is not None:
        tractions = [contact.traction(x, v) for x, v, _ in faces(u, theta, v1, w1)]
        total = functools.reduce(operator.add, tractions)
        contact_forms = [total[i] * dx for i in range(3)]
    return MembraneProblem(
        robot=robot,
        u=u,
        integrator=integ,  # type: ignore[arg-type]
        residual=F_step,  # type: ignore[arg-type]
        continuous_residual=continuous_residual,
        bcs=bcs_u + bcs_t,
        magnetization=M,
        energy_forms=energy_forms,
        contact_forms=contact_forms,
        kinematics="shell",  # type: ignore[arg-type]
        quadrature_degree=q,
        field=field,
        free_body=free_body,
        impact_absorber=absorber,
        gravity=g,
        contact_law=law,
        unknowns=[u, theta],
        mass_density=mat.density * t,
        face_offset=face_offset,
        strain_metrics=[kin.face_metric(-1.0, t), kin.face_metric(1.0, t)],
    )
