r"""The ``surface`` model: a finite-rotation Reissner–Mindlin (Naghdi) shell.

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
twisted by 90° about its own axis). ``[mesh] turn_axis`` a sets a constant
frame whose second axis is a instead, α = atan2(−a_x, a_y): turns about a are
then unlimited (a propeller rolling about its long axis), and the angles are
singular for a turn of 90° about the in-plane axis across a. A
free body (nothing holds it) has a constant frame angle instead
(:func:`free_frame_roll`): its hub tilts as a whole, which the polar frame
cannot represent (the angles of a rigid tilt would wind about the centre);
its arms bend about axes at most |sin(β − γ)| from the frame's second axis. A
body placed by a rotation Q (``[initial]``, :mod:`magfem.mechanics.pose`)
measures its directors from the placed frame, d = Q R_α (…): θ = 0 is its
placed normal Q e_z, so an upright robot (Q turning e_z into the horizontal)
starts as far from the singularity as a flat one.

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

Contact faces: the two faces x± = φ ± (t/2) d (velocity v ± (t/2) ḋ),
integrated over the mid-surface (``[contact] surfaces``: ``all``, ``bottom``
(with ``clamp``) or ``top``). Supports: a clamped patch fixes u and θ (the
bonded face cannot rotate); ``fixed_point`` fixes u.

P2 quadrilaterals with full (3 × 3) quadrature (docs/mechanics.md, "Shell
model", for the cost against the solid and the element choice).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import ufl
from dolfinx import fem

from magfem import material
from magfem.geometry.robot_mesh import RobotMesh
from magfem.mechanics.models.base import (
    MODELS,
    Face,
    Faces,
    FluxDensity,
    Model,
    ModelInputs,
    Names,
    State,
    director_faces,
    midsurface_sides,
    nodal_metadata,
    rate_of,
)
from magfem.mechanics.models.supports import (
    clamped_entities,
    create_magnetization,
    fixed_point_dofs,
    is_free,
)
from magfem.mechanics.pose import RigidMotion
from magfem.mechanics.spec import EnvironmentSpec

__all__ = [
    "SHEAR_CORRECTION",
    "ShellKinematics",
    "ShellModel",
    "director",
    "director_jacobian",
    "free_frame_roll",
    "shell_energy_density",
    "turn_axis_frame",
]

SHEAR_CORRECTION = 5.0 / 6.0
"""Transverse shear correction factor of a homogeneous plate (Reissner)."""


def _placed(vec: list[Any], pose: Any | None) -> list[Any]:
    """The components of Q v for the placement rotation Q (3×3 floats), or v when None."""
    if pose is None:
        return vec
    Q = np.asarray(pose, dtype=float)
    rows = [[(float(Q[i, k]), vec[k]) for k in range(3) if abs(Q[i, k]) > 1e-15] for i in range(3)]
    return [sum(q * v for q, v in row) for row in rows]


def director(theta: Any, frame: Any | None = None, pose: Any | None = None) -> Any:
    """Director d(θ) (UFL 3-vector) of the angles θ = (θ₀, θ₁) in the frame rotated by α.

    Args:
        theta: UFL 2-vector of angles (rad).
        frame: α (rad, UFL scalar) or None for α = 0.
        pose: the placement rotation Q (3×3 floats) or None for the identity.
    """
    c0 = ufl.cos(theta[0])
    d = [ufl.sin(theta[1]) * c0, -ufl.sin(theta[0]), ufl.cos(theta[1]) * c0]
    if frame is not None:
        ca, sa = ufl.cos(frame), ufl.sin(frame)
        d = [ca * d[0] - sa * d[1], sa * d[0] + ca * d[1], d[2]]
    return ufl.as_vector(_placed(d, pose))


def director_jacobian(theta: Any, frame: Any | None = None, pose: Any | None = None) -> Any:
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
    columns = [_placed([rows[i][j] for i in range(3)], pose) for j in range(2)]
    return ufl.as_matrix([[columns[0][i], columns[1][i]] for i in range(3)])


def _in_plane(grad3: Any) -> Any:
    """The 3×2 in-plane columns of a 3×3 gradient on the flat (xy) reference surface."""
    return ufl.as_matrix([[grad3[i, 0], grad3[i, 1]] for i in range(3)])


class ShellKinematics:
    """Strains of the shell at a displacement u and angles θ (UFL expressions).

    Attributes:
        F0: 3×2 surface deformation gradient. d: director. grad_d: 3×2.
        membrane, bending, shear: e (2×2), k (2×2, 1/m), γ (2).
    """

    def __init__(self, u: Any, theta: Any, frame: Any | None, pose: Any | None = None):
        I3 = ufl.Identity(3)
        self.F0 = _in_plane(I3 + ufl.grad(u))
        self.d = director(theta, frame, pose)
        self.grad_d = _in_plane(ufl.grad(self.d))
        F0, G = self.F0, self.grad_d
        self.membrane = 0.5 * (F0.T * F0 - ufl.Identity(2))
        self.bending = 0.5 * (F0.T * G + G.T * F0)
        self.shear = F0.T * self.d

    def face_metric(self, side: float, thickness: float) -> Any:
        """2×2 metric (right Cauchy–Green tensor in the plane) of the face at z = side·t/2."""
        Fs = self.F0 + side * 0.5 * thickness * self.grad_d
        return Fs.T * Fs


@dataclass(frozen=True)
class StrainRates:
    """Rates ė (2×2), k̇ (2×2, 1/(m s)) and γ̇ (2) of the shell's strains (UFL)."""

    membrane: Any
    bending: Any
    shear: Any


def shell_energy_density(
    kin: ShellKinematics | StrainRates, shear_modulus: Any, poisson: float, thickness: float
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


def free_frame_roll(directions: Sequence[Sequence[float]]) -> float:
    """Constant frame angle γ (rad, in [0, π)) of a free body with arms along ``directions``.

    The γ of a 0.5° grid that keeps the arms furthest from the angles'
    singularity: it minimises max_k |sin(β_k − γ)| over the arms' in-plane
    angles β_k (an arm at β − γ = ±90° bent by 90° about its own cross axis
    would put θ₀ at ±90°); the smallest such γ (0 for beams and plates).
    """
    beta = np.array([math.atan2(d[1], d[0]) for d in directions])
    if beta.size == 0:
        return 0.0
    grid = np.radians(np.arange(0.0, 180.0, 0.5))
    worst = np.max(np.abs(np.sin(beta[None, :] - grid[:, None])), axis=1)
    return float(grid[int(np.argmin(worst + 1e-9 * np.arange(grid.size)))])


def turn_axis_frame(axis: Sequence[float]) -> float:
    """The constant frame angle α (rad) whose second axis R_α e_y is the in-plane ``axis``:
    the director turns about it without limit."""
    return math.atan2(-float(axis[0]), float(axis[1]))


def _frame_angle(
    robot: RobotMesh, center: Sequence[float], free: bool, turn_axis: Sequence[float] | None
) -> Any | None:
    """α(X): with ``turn_axis`` a the constant that turns the frame's second axis onto a,
    atan2(−a_x, a_y) (None when 0); else None when every arm runs along ±x; for a free body
    the constant of :func:`free_frame_roll` (None when 0); else the polar angle about ``center``.

    The polar frame turns with each arm of a robot whose hub is held; a free
    hub tilts as a whole, which the polar frame would make a vortex of the
    angles about the centre (θ ∝ (cos α, −sin α) for a rigid tilt): a
    singular field P2 cannot carry.
    """
    if turn_axis is not None:
        alpha = turn_axis_frame(turn_axis)
        return None if alpha == 0.0 else alpha
    if all(abs(float(a.direction[1])) < 1e-12 for a in robot.arms):
        return None
    if free:
        roll = free_frame_roll([tuple(a.direction) for a in robot.arms])
        return None if roll == 0.0 else roll
    X = ufl.SpatialCoordinate(robot.mesh)
    return ufl.atan2(X[1] - center[1], X[0] - center[0])


def _clamp_entities(env: EnvironmentSpec, robot: RobotMesh) -> list[tuple[int, Any]]:
    """(dim, local entities) fully fixed by ``[environment] clamped`` on the surface mesh.

    A clamped patch of the surface model is tagged on its edges; the cells
    all of whose edges are clamped are added, so that the patch's interior
    nodes are held too.
    """
    domain = robot.mesh
    tdim = domain.topology.dim
    out: list[tuple[int, Any]] = []
    for dim, entities in clamped_entities(env, robot):
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


@MODELS.register("surface")
class ShellModel(Model):
    """The shell of the module docstring on the robot's mid-surface mesh.

    ``inputs.robot`` is the surface mesh (tdim 2, gdim 3, at z = t/2);
    ``body.center`` is the robot's centre (bending frame of radial robots).
    """

    kinematics = "shell"

    def __init__(self, inputs: ModelInputs):
        robot = inputs.robot
        domain = robot.mesh
        self.robot = robot
        self.gdim = 3
        Vu, Vt = self._displacement_and_angles(inputs, 2, "director_angles")
        u, theta = self.unknowns
        q = self.quadrature_degree
        t = robot.thickness
        self.poisson = material.poisson_ratio(inputs.material.shear_modulus, inputs.material.bulk)
        self.mu = fem.Constant(domain, inputs.material.shear_modulus)
        self.rho = fem.Constant(domain, inputs.material.density)
        self.mass_density = self.rho * t
        self.rotary_inertia = self.rho * t**3 / 12.0
        self.magnetization = create_magnetization(inputs.material, robot, 3)
        self.frame_center = tuple(inputs.body.center)
        rotation = inputs.body.rotation
        self.pose = None if rotation is None else np.asarray(rotation, dtype=float)
        self.X = ufl.SpatialCoordinate(domain)
        self.dx = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": q})
        nodal = nodal_metadata(domain, inputs.solver.degree, q)
        self.dx_nodal = ufl.Measure("dx", domain=domain, metadata=nodal)
        self.face_offset = 0.5 * t  # the mesh is the mid-surface
        self.depth = 1.0
        self.displacement_bcs, angle_bcs = self._supports(inputs.environment, Vu, Vt)
        self.bcs = self.displacement_bcs + angle_bcs
        self.free_body = is_free(self.displacement_bcs, domain.comm)
        self.frame = _frame_angle(robot, inputs.body.center, self.free_body, inputs.body.turn_axis)
        kin = ShellKinematics(u, theta, self.frame, self.pose)
        self.strain_metrics = [kin.face_metric(-1.0, t), kin.face_metric(1.0, t)]

    def _supports(
        self, env: EnvironmentSpec, Vu: fem.FunctionSpace, Vt: fem.FunctionSpace
    ) -> tuple[list[fem.DirichletBC], list[fem.DirichletBC]]:
        domain = self.robot.mesh
        bcs_u: list[fem.DirichletBC] = []
        bcs_t: list[fem.DirichletBC] = []
        for dim, entities in _clamp_entities(env, self.robot):
            domain.topology.create_connectivity(dim, domain.topology.dim)
            for V, out in ((Vu, bcs_u), (Vt, bcs_t)):
                dofs = fem.locate_dofs_topological(V, dim, entities)
                zero = np.zeros(V.dofmap.index_map_bs, dtype=np.float64)
                out.append(fem.dirichletbc(zero, dofs, V))
        if env.fixed_point is not None:
            bcs_u.append(fem.dirichletbc(np.zeros(3), fixed_point_dofs(env, Vu), Vu))
        return bcs_u, bcs_t

    def place(self, motion: RigidMotion) -> None:
        """:meth:`Model.place`, and the director rates of the spin: ḋ = ω × d at θ = 0.

        At θ = 0, ḋ = Q R_α (θ̇₁, −θ̇₀, 0), so with w = Qᵀω (the spin in the
        placed frame) θ̇₁ = w_y cos α − w_x sin α and θ̇₀ = w_x cos α + w_y sin α.
        """
        Q = np.eye(3) if self.pose is None else self.pose
        if not np.allclose(Q, motion.R, atol=1e-12):
            raise ValueError("ShellModel.place: the motion's rotation is not the model's pose")
        super().place(motion)
        rates = self.integrator.parts[1]
        X = rates.u.function_space.tabulate_dof_coordinates()
        alpha = np.zeros(len(X))
        if isinstance(self.frame, float):
            alpha[:] = self.frame
        elif self.frame is not None:
            cx, cy, _ = self.frame_center
            alpha = np.arctan2(X[:, 1] - cy, X[:, 0] - cx)
        w = Q.T @ motion.omega
        ca, sa = np.cos(alpha), np.sin(alpha)
        theta_rate = np.column_stack([w[0] * ca + w[1] * sa, w[1] * ca - w[0] * sa])
        rates.v0.x.array[:] = theta_rate.ravel()
        rates.u0.x.array[:] = 0.0
        rates.u.x.array[:] = 0.0
        rates.a0.x.array[:] = 0.0

    # --- energies and forces ----------------------------------------------------------------

    def elastic_energy(self, state: Sequence[Any]) -> ufl.Form:
        kin = ShellKinematics(state[0], state[1], self.frame, self.pose)
        return shell_energy_density(kin, self.mu, self.poisson, self.thickness) * self.dx

    def strain_rate_energy(self, state: Sequence[Any], rates: Sequence[Any]) -> ufl.Form:
        """½ ∫ of the shell's energy density (quadratic in its strains) at their rates."""
        kin = ShellKinematics(state[0], state[1], self.frame, self.pose)
        rates_kin = StrainRates(
            rate_of(kin.membrane, state, rates),
            rate_of(kin.bending, state, rates),
            rate_of(kin.shear, state, rates),
        )
        return shell_energy_density(rates_kin, self.mu, self.poisson, self.thickness) * self.dx

    def magnetic_energy_density(self, state: Sequence[Any], flux: FluxDensity) -> Any:
        kin = ShellKinematics(state[0], state[1], self.frame, self.pose)
        M = self.magnetization
        FM = kin.F0 * ufl.as_vector([M[0], M[1]]) + M[2] * kin.d
        return -self.thickness * ufl.dot(FM, flux(self.X + state[0]))

    def inertia(self, accelerations: Sequence[Any]) -> list[ufl.Form]:
        w_u, w_t = self.tests
        return [
            self.mass_density * ufl.dot(accelerations[0], w_u) * self.dx,
            self.rotary_inertia * ufl.dot(accelerations[1], w_t) * self.dx,
        ]

    def kinetic_energy(self, rates: Sequence[Any]) -> ufl.Form:
        v, w = rates
        return (
            0.5
            * (self.mass_density * ufl.dot(v, v) + self.rotary_inertia * ufl.dot(w, w))
            * (self.dx)
        )

    def faces(self, state: State, rates: State, surfaces: Names, *, nodal: bool = False) -> Faces:
        disp, angles = state
        d = director(angles, self.frame, self.pose)
        Jd = director_jacobian(angles, self.frame, self.pose)  # 3×2
        dx = self.dx_nodal if nodal else self.dx
        F0 = _in_plane(ufl.Identity(3) + ufl.grad(disp))
        area_normal = ufl.cross(F0[:, 0], F0[:, 1])  # n da/dA of the mid-surface
        sides = midsurface_sides(surfaces, "shell")
        return director_faces(self, disp, rates, d, Jd, sides, dx, area_normal)

    def fluid_faces(self, state: State, rates: State, surfaces: Names) -> Faces:
        """Both faces as one at the mid-surface (``count`` 2), or the one face named.

        The faces at ±t/2 move as u̇ ± (t/2) ḋ; the fluid's tractions are taken
        at the mid-surface's velocity u̇ instead, where the two faces' normal
        and tangential tractions are equal and their moments about the
        mid-surface cancel. What is left out is relative (t/2)|ḋ|/|u̇|: t/(2s)
        at a distance s from the axis of a turning arm, where the traction,
        ~ (s ω)², is small. The fluid's terms are evaluated once instead of
        once per face.
        """
        if midsurface_sides(surfaces, "shell") != [-1.0, 1.0]:
            return self.faces(state, rates, surfaces)
        disp = state[0]
        F0 = _in_plane(ufl.Identity(3) + ufl.grad(disp))
        w_u, dx = self.tests[0], self.dx

        def work(t: Any) -> list[Any]:
            return [ufl.dot(t, w_u) * dx, 0]

        return [
            Face(
                position=self.X + disp,
                velocity=rates[0],
                work=work,
                measure=dx,
                facets=None,
                normal=ufl.cross(F0[:, 0], F0[:, 1]),
                count=2,
            )
        ]
