"""The membrane's residual in continuous time, its loads and its supports.

Total Lagrangian balance of momentum (DESIGN.md), weak form: for all test
displacements w vanishing on the supports,

    R(u, u̇, ü; t)[w] = ∫ ρ ü·w dV + δΠ(u)[w] − ∫ t_c(x, u̇)·w dA = 0,
    Π(u) = ∫ ψ_el(F) − (F M̃)·B_a(X + u, t) − ρ g·u dV,

with ψ_el and the magnetic energy of :mod:`magfem.material`, M̃ the remanent
magnetization (piecewise constant per cell group), g gravity and t_c the
ground-contact traction of :mod:`magfem.mechanics.contact` (when
``[contact] ground = true``). δΠ is formed by ``ufl.derivative`` of the
energy with respect to a generic displacement that is then replaced by
the integrator's stage displacement, so the integrator's weights multiply
the inertia and the internal force consistently (a derivative taken through
u_{n+1−αf} itself would carry a spurious factor 1 − αf).

Models: ``solid`` (3D, gdim 3) and ``strip`` (2D side view (x, z), gdim 2,
plane strain or plane stress per ``[material] plane``; every integral is
per unit width). Each measure has an explicit quadrature degree
(``[solver] quadrature_degree``, default 2 × degree): UFL's estimate for
B_a(X + u) reaches degree ~100 and kills compilation (FENICSX.md).

Supports: ``[environment] clamped`` groups (facets or cells) have u = 0;
``fixed_point`` pins the nodes nearest to a reference point (or within
``fixed_radius``); with neither the body is free (rigid-body motion is
governed by the mass; the quasi-static scheme then refuses to run).
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import field as dataclass_field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from magfem import material
from magfem.config import CaseError
from magfem.geometry.robot_mesh import RobotMesh, locate
from magfem.mechanics.integrator import TimeIntegrator

if TYPE_CHECKING:
    from magfem.case import Case
    from magfem.field.model import FieldModel
    from magfem.mechanics.self_contact import SelfContact

__all__ = [
    "MembraneProblem",
    "build_membrane_problem",
    "magnetization_vector",
]


def magnetization_vector(direction: str | tuple[float, ...], magnitude: float, gdim: int) -> Any:
    """Remanent magnetization M̃ (A/m) as a numpy vector of length ``gdim``.

    ``"normal"`` is +z (3D) or the second axis of a strip (its z); a vector
    (mx, my, mz) is normalised; strips keep (mx, mz).
    """
    if isinstance(direction, str):
        vec = np.array([0.0, 0.0, -1.0 if direction == "-normal" else 1.0])
    else:
        vec = np.asarray(direction, dtype=float)
        vec = vec / np.linalg.norm(vec)
    vec = magnitude * vec
    return vec if gdim == 3 else np.array([vec[0], vec[2]])


def _embed(v: Any, gdim: int) -> Any:
    """A UFL gdim-vector as the 3D vector the field model expects."""
    return v if gdim == 3 else ufl.as_vector([v[0], 0.0, v[1]])


def _project(v3: Any, gdim: int) -> Any:
    """The in-plane (mesh) components of a UFL 3-vector."""
    return v3 if gdim == 3 else ufl.as_vector([v3[0], v3[2]])


@dataclass
class MembraneProblem:
    """Everything the time loop needs, built once (forms not yet compiled).

    Attributes:
        robot: the robot mesh and its groups.
        u: unknown displacement u_{n+1} (m), Lagrange ``degree``, gdim components.
        integrator: the time integrator holding (u_n, v_n, a_n).
        residual: the step residual (UFL form).
        continuous_residual: R(u, v, a, t) as a callable (for the initial acceleration).
        bcs: Dirichlet conditions (homogeneous).
        magnetization: DG0 vector field M̃ (A/m).
        energy_forms: name -> UFL scalar form at (u_{n+1}, v_{n+1}) (J; J/m for strips).
        contact_forms: resultant ground force components (N; N/m for strips) or [].
        kinematics: ``solid``, ``plane_strain``, ``plane_stress`` or ``shell``.
        quadrature_degree: degree used on every measure.
        field: the bound field model.
        self_contact: arm–arm contact (``[contact] self_contact``) or None; its
            data are refreshed by the time loop and its step terms, not part of
            ``residual``, are added by Newton hooks (``SelfContact.attach``).
        impact_absorber: :class:`~magfem.mechanics.contact.ImpactAbsorber` applied
            after every accepted dynamic step with ground contact, else None.
        gravity: the gravity vector Constant g (m/s², gdim components), scaled in
            place by quasi-static load continuation.
        contact_law: the ground's :class:`~magfem.mechanics.contact.GroundContactLaw`
            (SI constants), None without ground contact.
        unknowns: every unknown of the step, ``[u]`` or the shell's ``[u, θ]``
            (:mod:`magfem.mechanics.shell`); with more than one, ``residual``
            is the list of their block residuals and ``bcs`` holds the
            conditions of all of them.
        strain_metrics: UFL 2×2 or 3×3 right Cauchy–Green tensors whose largest
            stretch is the largest strain (the shell's two faces); None: FᵀF of u.
        mass_density: mass per unit of the mesh's measure: ρ (kg/m³; kg/m² per
            width for strips) or the shell's ρ t (kg/m²).
        face_offset: height of the mesh above the robot's bottom face (m): 0, or
            t/2 for the shell, whose mesh is its mid-surface.
    """

    robot: RobotMesh
    u: fem.Function
    integrator: TimeIntegrator
    residual: ufl.Form
    continuous_residual: Any
    bcs: list[fem.DirichletBC]
    magnetization: fem.Function
    energy_forms: dict[str, ufl.Form]
    contact_forms: list[ufl.Form]
    kinematics: str
    quadrature_degree: int
    field: FieldModel
    free_body: bool
    mass_density: float
    self_contact: SelfContact | None = None
    impact_absorber: Any = None
    gravity: fem.Constant | None = None
    contact_law: Any = None
    unknowns: list[fem.Function] = dataclass_field(default_factory=list)
    strain_metrics: list[Any] | None = None
    face_offset: float = 0.0

    def __post_init__(self) -> None:
        if not self.unknowns:
            self.unknowns = [self.u]

    @property
    def displacement_bcs(self) -> list[fem.DirichletBC]:
        """The conditions of ``bcs`` on the displacement u."""
        V = self.u.function_space._cpp_object  # what DirichletBC.function_space returns
        return [bc for bc in self.bcs if bc.function_space == V]


def _kinematics(case: Case) -> material.Kinematics:
    model = case.mesh.model
    if model == "solid":
        return "solid"
    if model == "strip":
        return "plane_strain" if case.material.plane == "strain" else "plane_stress"
    raise CaseError(
        "mesh.model", model, "the mechanics solves 'solid', 'strip' and 'surface' (shell) models"
    )


def _magnetization(case: Case, robot: RobotMesh) -> fem.Function:
    """DG0 vector field M̃ (A/m): the material's value, overridden per region."""
    domain = robot.mesh
    gdim = domain.geometry.dim
    Q = fem.functionspace(domain, ("DG", 0, (gdim,)))
    M = fem.Function(Q, name="magnetization")
    spec = case.material
    values = M.x.array.reshape(-1, gdim)
    values[:] = magnetization_vector(spec.direction, spec.remanence, gdim)
    for i, region in enumerate(spec.regions):
        try:
            dim, cells = locate(robot, region.group)
        except KeyError:
            raise CaseError(
                f"material.regions[{i}].group",
                region.group,
                "no such group; groups are " + ", ".join(sorted(robot.groups)),
            ) from None
        if dim != domain.topology.dim:
            raise CaseError(f"material.regions[{i}].group", region.group, "is not a cell group")
        direction = region.direction if region.direction is not None else spec.direction
        magnitude = region.remanence if region.remanence is not None else spec.remanence
        values[cells] = magnetization_vector(direction, magnitude, gdim)
    M.x.scatter_forward()
    return M


def clamped_entities(case: Case, robot: RobotMesh) -> list[tuple[int, Any]]:
    """(dim, local entities) of each ``[environment] clamped`` group the robot has.

    Raises:
        CaseError: a group the robot does not have (``clamp`` is skipped: robots
            with clamp_length = 0 have none, and it is the default).
    """
    out = []
    for i, name in enumerate(case.environment.clamped):
        if name not in robot.groups and name != "robot":
            if name == "clamp":
                continue
            raise CaseError(
                f"environment.clamped[{i}]",
                name,
                "no such group; groups are " + ", ".join(sorted(robot.groups)),
            )
        out.append(locate(robot, name))
    return out


def fixed_point_dofs(case: Case, V: fem.FunctionSpace) -> npt.NDArray[np.int32]:
    """Local nodes of ``V`` held by ``[environment] fixed_point``/``fixed_radius`` (collective).

    The nodes within ``fixed_radius`` of the point, or the nearest node(s)
    when none is that close. Strip meshes (gdim 2) use (x, z) of the point.
    """
    env = case.environment
    if env.fixed_point is None:
        raise ValueError("fixed_point_dofs: the case has no [environment] fixed_point")
    gdim = V.mesh.geometry.dim
    given = np.asarray(env.fixed_point, dtype=float)
    point = np.zeros(3)
    point[:gdim] = given[:gdim] if gdim == 3 else given[::2]
    dist = np.linalg.norm(V.tabulate_dof_coordinates() - point, axis=1)
    nearest = V.mesh.comm.allreduce(dist.min() if dist.size else np.inf, op=MPI.MIN)
    radius = max(env.fixed_radius, nearest * (1 + 1e-9) + 1e-15)
    return np.flatnonzero(dist <= radius).astype(np.int32)


def _supports(case: Case, robot: RobotMesh, V: fem.FunctionSpace) -> tuple[list, bool]:
    """Dirichlet conditions of ``[environment]``; returns (bcs, free_body)."""
    domain = robot.mesh
    gdim = domain.geometry.dim
    env = case.environment
    zero = np.zeros(gdim, dtype=np.float64)
    bcs = []
    for dim, entities in clamped_entities(case, robot):
        domain.topology.create_connectivity(dim, domain.topology.dim)
        dofs = fem.locate_dofs_topological(V, dim, entities)
        bcs.append(fem.dirichletbc(zero, dofs, V))
    if env.fixed_point is not None:
        bcs.append(fem.dirichletbc(zero, fixed_point_dofs(case, V), V))
    has_any = domain.comm.allreduce(sum(len(bc.dof_indices()[0]) for bc in bcs), op=MPI.SUM) > 0
    return bcs, not has_any


def _contact_measure(case: Case, robot: RobotMesh, ds: ufl.Measure) -> tuple[ufl.Measure, Any]:
    """Measure and local facets of ``[contact] surfaces`` (facet groups that may touch the ground).

    ``"all"`` (the default) is the whole boundary. ``bottom`` and ``clamp`` are
    skipped where a robot lacks them (free robots have no clamp); any other
    unknown name, a cell group, or a list that matches no facet group raises.
    """
    names = case.contact.surfaces
    if "all" in names:
        robot.mesh.topology.create_connectivity(
            robot.mesh.topology.dim - 1, robot.mesh.topology.dim
        )
        return ds, dmesh.exterior_facet_indices(robot.mesh.topology)
    tdim = robot.mesh.topology.dim
    tags: list[int] = []
    for i, name in enumerate(names):
        if name not in robot.groups:
            if name in ("bottom", "clamp"):
                continue
            raise CaseError(
                f"contact.surfaces[{i}]",
                name,
                'no such facet group; groups are "all", ' + ", ".join(sorted(robot.groups)),
            )
        dim, tag = robot.groups[name]
        if dim != tdim - 1:
            raise CaseError(f"contact.surfaces[{i}]", name, "is not a facet group")
        tags.append(tag)
    if not tags:
        raise CaseError(
            "contact.surfaces", list(names), 'matches no facet group of this robot; use "all"'
        )
    facets = np.unique(np.concatenate([robot.facet_tags.find(tag) for tag in tags]))
    return ds(tuple(tags)), facets


def build_membrane_problem(
    case: Case, robot: RobotMesh, field: FieldModel, *, dt: float | None = None
) -> MembraneProblem:
    """Build the discretised membrane problem of ``case`` on ``robot`` in ``field``.

    Args:
        case: validated case (material, time, solver, contact, environment).
        robot: robot mesh (``solid``, ``strip``, or ``surface``: the shell of
            :mod:`magfem.mechanics.shell`).
        field: field model; bound to the mesh here.
        dt: initial step (s), default ``case.time.step``.

    Raises:
        CaseError: unknown groups, quasi-static free body (and the shell's
            refusals, :func:`magfem.mechanics.shell.build_shell_problem`).
    """
    if case.mesh.model == "surface":
        from magfem.mechanics.shell import build_shell_problem

        return build_shell_problem(case, robot, field, dt=dt)
    kinematics = _kinematics(case)
    domain = robot.mesh
    gdim = domain.geometry.dim
    degree = case.solver.degree
    q = case.solver.quadrature_degree or 2 * degree
    V = fem.functionspace(domain, ("Lagrange", degree, (gdim,)))
    u = fem.Function(V, name="displacement")
    integ = TimeIntegrator(u, case.time.scheme, rho_inf=case.time.rho_inf, dt=dt or case.time.step)
    mat = case.material
    mu = fem.Constant(domain, mat.shear_modulus)
    K = fem.Constant(domain, mat.bulk)
    rho = fem.Constant(domain, mat.density)
    g3 = np.asarray(case.environment.gravity, dtype=float)
    g = fem.Constant(domain, g3 if gdim == 3 else g3[::2].copy())
    M = _magnetization(case, robot)
    field.bind(domain)
    X = ufl.SpatialCoordinate(domain)
    dx = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": q})
    q_vol = case.solver.volumetric_quadrature_degree
    q_vol = 2 * (degree - 1) if q_vol is None else q_vol
    dx_vol = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": q_vol})
    ds = ufl.Measure(
        "ds", domain=domain, subdomain_data=robot.facet_tags, metadata={"quadrature_degree": q}
    )
    w = ufl.TestFunction(V)
    bcs, free_body = _supports(case, robot, V)
    if free_body and not integ.dynamic:
        raise CaseError(
            "time.scheme",
            case.time.scheme,
            "a free body (no clamped group, no fixed_point) needs a dynamic scheme",
        )

    def potential(v_disp: Any) -> Any:
        """Π (J; J/m for strips) at displacement ``v_disp``: volumetric part reduced-integrated."""
        F = material.deformation_gradient(v_disp)
        B = _project(field.flux_density(_embed(X + v_disp, gdim)), gdim)
        return (
            material.isochoric_energy(F, mu, kinematics)
            + material.magnetic_energy(F, M, B)
            - rho * ufl.dot(g, v_disp)
        ) * dx + material.volumetric_energy(F, K, kinematics) * dx_vol

    u_generic = fem.Function(V)
    internal = ufl.algorithms.expand_derivatives(ufl.derivative(potential(u_generic), u_generic, w))

    contact = law = None
    if case.contact.ground:
        from magfem.mechanics.contact import GroundContact, create_ground_contact_law

        law = create_ground_contact_law(
            case.contact,
            shear_modulus=mat.shear_modulus,
            density=mat.density,
            thickness=robot.thickness,
        )
        contact = GroundContact(
            law,
            domain,
            vertical=gdim - 1,
            ground_height=case.contact.ground_height,
            time_step=integ.dt if integ.dynamic else None,
        )

    ds_contact, contact_facets = _contact_measure(case, robot, ds)
    absorber = None
    if contact is not None and integ.dynamic:
        from magfem.mechanics.contact import ImpactAbsorber

        absorber = ImpactAbsorber(
            V, contact_facets, vertical=gdim - 1, ground_height=case.contact.ground_height
        )

    self_contact = None
    if case.contact.self_contact:
        from magfem.mechanics.self_contact import create_self_contact

        self_contact = create_self_contact(
            case.contact, robot, u, integ, shear_modulus=mat.shear_modulus, quadrature_degree=q
        )

    def residual(u_: Any, v_: Any, a_: Any, t_: Any, *, with_contact: bool = True) -> ufl.Form:
        # self contact is not a UFL term: SelfContact.attach adds it to every Newton
        # evaluation of the step (it couples distant dofs); the initial acceleration
        # solve does without it (bodies start apart or just touching: zero force)
        form = ufl.replace(internal, {u_generic: u_})
        if integ.dynamic:
            form = form + rho * ufl.dot(a_, w) * dx
        if contact is not None and with_contact:
            form = form - contact.work(X + u_, v_, w, ds_contact)
        return form

    if contact is not None and integ.dynamic:
        # impacts: the ground acts at the END of the step (x_{n+1}, v_{n+1}), not at the
        # generalized-α stage point, so a landing column is stopped within the step
        # (with ImpactAbsorber after it, see contact.py and docs/verification.md)
        F_step = integ.discretise(
            lambda u_, v_, a_, t_: residual(u_, v_, a_, t_, with_contact=False)
        ) - contact.work(X + integ.u, integ.velocity(), w, ds_contact)
    else:
        F_step = integ.discretise(residual)

    v1 = integ.v0  # after advance(), (u, v0) is the state at t_{n+1}
    Fu = material.deformation_gradient(u)
    Bu = _project(field.flux_density(_embed(X + u, gdim)), gdim)
    energy_forms = {
        "kinetic": 0.5 * rho * ufl.dot(v1, v1) * dx,
        "elastic": material.isochoric_energy(Fu, mu, kinematics) * dx
        + material.volumetric_energy(Fu, K, kinematics) * dx_vol,
        "magnetic": material.magnetic_energy(Fu, M, Bu) * dx,
        "gravity": -rho * ufl.dot(g, u) * dx,
    }
    if self_contact is not None:
        energy_forms["self_contact"] = self_contact.energy(X + u)
    contact_forms = contact.force_forms(X + u, v1, ds_contact) if contact is not None else []
    return MembraneProblem(
        robot=robot,
        u=u,
        integrator=integ,
        residual=F_step,
        continuous_residual=residual,
        bcs=bcs,
        magnetization=M,
        energy_forms=energy_forms,
        contact_forms=contact_forms,
        kinematics=kinematics,
        quadrature_degree=q,
        field=field,
        free_body=free_body,
        self_contact=self_contact,
        impact_absorber=absorber,
        gravity=g,
        contact_law=law,
        mass_density=mat.density,
    )
