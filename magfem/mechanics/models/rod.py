r"""The ``rod`` model: a geometrically exact (Simo–Reissner) rod along every arm's midline.

``[mesh] model = "rod"`` meshes the arms' midlines (:mod:`magfem.geometry.rod_mesh`)
and solves for the midline displacement u (3 components, m) and three
rotation angles θ (rad), both Lagrange of ``[solver] degree`` (P2 default).
The cross-section's frame (directors d₁ along the arm, d₂ across its width,
d₃ its normal) is R = Q(θ) R₀ with R₀ = [e, n × e, n] the reference frame of
the cell (e the arm direction, n = +z) and Q the rotation of Tait–Bryan
angles about the global axes y, z, x:

.. math::

    Q(\theta) = R_y(\theta_0)\,R_z(\theta_1)\,R_x(\theta_2).

Bending of any arm out of the robot's plane (about y for arms along x,
about x for arms along y) and twist turn without limit (an arm can turn past
270°); the angles are singular where θ₁ = ±90°: Q maps x onto ±y, an arm
along x turned by 90° within its own plane (which its width makes very
stiff) or a diagonal arm bent by 180°. Strains in the material frame
(Simo, CMAME 49 (1985) 55–70):

.. math::

    \Gamma = R^T\varphi' - E_1,\qquad K = R_0^T\,T(\theta)\,\theta',\qquad
    T = [R_x^T R_z^T e_y,\ R_x^T e_z,\ e_x],

φ = X + u, ()' = d/ds along the reference midline; Q^T Q' = [Tθ']×, and
the body angular velocity is Ω = R₀ᵀ T θ̇. Energy per unit length (section
constants :mod:`magfem.mechanics.models.rod_section`, small strain, large
rotation)

.. math::

    \psi = \tfrac12 EA\,\Gamma_1^2 + \tfrac12\,\tfrac56\,\mu A\,(\Gamma_2^2 + \Gamma_3^2)
         + \tfrac12 \mu J_t K_1^2 + W_b(K_2) + \tfrac12 \tfrac{E t b^3}{12} K_3^2
         - A\,(F\tilde{\mathbf M})\cdot\mathbf B(\varphi) - \rho A\,\mathbf g\cdot\mathbf u,

with A = b t, W_b the out-of-plane bending law (``[mesh] rod_bending``), and
F M̃ = M̃₁ φ' + M̃₂ d₂ + M̃₃ d₃ (M̃ᵢ = M̃·R₀Eᵢ): the hard-magnetic couple
and, through B at the current position, the gradient force on the
section's centre line. The axial and shear terms are integrated with the
reduced degree 2(p − 1) (p Gauss points), which keeps a thin rod from
shear locking. Inertia: ρA ü·δu plus the rotary inertia of the section,
δπ·(J Ω̇ + Ω × J Ω) with δπ = R₀ᵀ T δθ and J = ρ diag(I_b + I_n, I_b, I_n),
I_b = b t³/12, I_n = t b³/12.

Supports: the ``clamp`` vertex group (the bonded patch less 0.41 t, or the
whole patch: ``[mesh] root``) holds u and θ; ``fixed_point`` holds u.
Hub spokes of radial robots are a rigid hub (:data:`~magfem.geometry.
rod_mesh.HUB_STIFFENING`). Contact faces: the bottom and top surface points
φ ∓ (t/2) d₃ of the midline, their tractions integrated over the width
(``[contact] surfaces``: ``all``, ``bottom`` (with ``clamp``), ``top``);
an arm touching the ground with one edge only (twisted) is not seen.
Self-contact is not modelled (the case is refused).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import ufl
from dolfinx import fem

from magfem import material
from magfem.config import CaseError
from magfem.geometry.rod_mesh import HUB_STIFFENING
from magfem.mechanics.models import base
from magfem.mechanics.models.base import Faces, Model, ModelInputs, Names, State
from magfem.mechanics.models.rod_section import (
    SHEAR_CORRECTION,
    bending_energy,
    torsion_constant,
)
from magfem.mechanics.models.supports import (
    clamped_entities,
    create_magnetization,
    fixed_point_dofs,
    is_free,
)
from magfem.mechanics.pose import RigidMotion
from magfem.mechanics.spec import EnvironmentSpec

__all__ = ["RodKinematics", "RodModel", "WeightedMeasure", "rate_matrix", "rotation"]


def _rx(a: Any) -> Any:
    c, s = ufl.cos(a), ufl.sin(a)
    return ufl.as_matrix([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a: Any) -> Any:
    c, s = ufl.cos(a), ufl.sin(a)
    return ufl.as_matrix([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz(a: Any) -> Any:
    c, s = ufl.cos(a), ufl.sin(a)
    return ufl.as_matrix([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation(theta: Any) -> Any:
    """Q(θ) = R_y(θ₀) R_z(θ₁) R_x(θ₂) (UFL 3×3) of the angles θ (UFL 3-vector, rad)."""
    return _ry(theta[0]) * _rz(theta[1]) * _rx(theta[2])


def rate_matrix(theta: Any) -> Any:
    """T(θ) (UFL 3×3): axial(Qᵀ dQ) = T dθ, in the body frame of Q."""
    s1, c1 = ufl.sin(theta[1]), ufl.cos(theta[1])
    s2, c2 = ufl.sin(theta[2]), ufl.cos(theta[2])
    return ufl.as_matrix([[s1, 0.0, 1.0], [c1 * c2, s2, 0.0], [-c1 * s2, c2, 0.0]])


class WeightedMeasure:
    """``f * measure`` is ∫ f w dx: a measure with a weight (the rod's width on its faces)."""

    def __init__(self, measure: ufl.Measure, weight: Any):
        self.measure = measure
        self.weight = weight

    def __rmul__(self, integrand: Any) -> ufl.Form:
        return integrand * self.weight * self.measure


class RodKinematics:
    """Strains and directors at a displacement u and angles θ (UFL expressions).

    Attributes:
        Q: the rotation (3×3). directors: d₁, d₂, d₃ (3-vectors).
        tangent: φ' (3-vector). strain: Γ (3). curvature: K (3, 1/m), material frame.
    """

    def __init__(self, u: Any, theta: Any, frame: Any):
        e = frame
        n = ufl.as_vector([0.0, 0.0, 1.0])
        R0 = ufl.as_matrix([[e[i], (ufl.cross(n, e))[i], n[i]] for i in range(3)])
        self.R0 = R0
        self.Q = Q = rotation(theta)
        self.directors = [Q * R0[:, i] for i in range(3)]
        self.tangent = e + ufl.grad(u) * e
        self.strain = R0.T * Q.T * self.tangent - ufl.as_vector([1.0, 0.0, 0.0])
        self.curvature = R0.T * rate_matrix(theta) * (ufl.grad(theta) * e)

    def angular_velocity(self, theta: Any, rate: Any) -> Any:
        """Ω = R₀ᵀ T(θ) θ̇ (material frame, rad/s)."""
        return self.R0.T * rate_matrix(theta) * rate


@base.MODELS.register("rod")
class RodModel(Model):
    """The rod of the module docstring on the robot's midline mesh.

    ``inputs.robot`` is the rod mesh (tdim 1, gdim 3, at z = t/2; ``robot.rod``
    its branches); ``inputs.body`` is unused (the frames come from the branches).

    The out-of-plane bending law is the mesh's (``robot.rod.bending``).
    """

    kinematics = "rod"

    def __init__(self, inputs: ModelInputs):
        robot = inputs.robot
        if robot.rod is None:
            raise ValueError("RodModel needs a rod mesh (mesh.model = 'rod')")
        domain = robot.mesh
        self.robot = robot
        self.gdim = 3
        self.bending = robot.rod.bending
        degree = inputs.solver.degree
        Vu, Vt = self._displacement_and_angles(inputs, 3, "rotation_angles")
        u, theta = self.unknowns
        q = self.quadrature_degree
        t = robot.thickness
        mu, bulk = inputs.material.shear_modulus, inputs.material.bulk
        self.poisson = material.poisson_ratio(mu, bulk)
        self.young = fem.Constant(domain, material.youngs_modulus(mu, bulk))
        self.mu = fem.Constant(domain, mu)
        self.rho = fem.Constant(domain, inputs.material.density)
        self.frame, self.width, self.stiffening = self._section_fields(degree)
        self.area = self.width * t
        self.mass_density = self.rho * self.area
        b = self.width
        self.rotary = self.rho * ufl.as_vector(
            [(b * t**3 + t * b**3) / 12.0, b * t**3 / 12.0, t * b**3 / 12.0]
        )
        self.magnetization = create_magnetization(inputs.material, robot, 3)
        self.X = ufl.SpatialCoordinate(domain)
        self.dx = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": q})
        q_red = 2 * (degree - 1)
        self.dx_reduced = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": q_red})
        self.face_measure = WeightedMeasure(self.dx, self.width)
        self.face_offset = 0.5 * t  # the mesh is the midline
        self.depth = 1.0
        self.displacement_bcs, angle_bcs = self._supports(inputs.environment, Vu, Vt)
        self.bcs = self.displacement_bcs + angle_bcs
        self.free_body = is_free(self.displacement_bcs, domain.comm)
        self.strain_metrics = self._strain_metrics(RodKinematics(u, theta, self.frame))

    def _section_fields(self, degree: int) -> tuple[fem.Function, fem.Function, fem.Function]:
        """The cell frame e (DG0), the width b (DG, exact for linear tapers), the stiffening."""
        domain = self.robot.mesh
        geometry = self.robot.rod
        frame = fem.Function(fem.functionspace(domain, ("DG", 0, (3,))), name="rod_direction")
        width = fem.Function(fem.functionspace(domain, ("DG", max(degree, 1))), name="rod_width")
        stiff = fem.Function(fem.functionspace(domain, ("DG", 0)), name="rod_stiffening")
        per_cell = geometry.branch_of_cell
        for i, branch in enumerate(geometry.branches):
            cells = np.flatnonzero(per_cell == i).astype(np.int32)
            start = np.asarray(branch.start, dtype=float)
            d = np.asarray(branch.direction, dtype=float)

            def along(X: Any, start: Any = start, d: Any = d, branch: Any = branch) -> Any:
                s = (X[0] - start[0]) * d[0] + (X[1] - start[1]) * d[1]
                return branch.width(np.clip(s, 0.0, branch.length))

            width.interpolate(along, cells0=cells)
            frame.x.array.reshape(-1, 3)[cells] = [d[0], d[1], 0.0]
            stiff.x.array[cells] = HUB_STIFFENING if branch.rigid else 1.0
        for f in (frame, width, stiff):
            f.x.scatter_forward()
        return frame, width, stiff

    def _supports(
        self, env: EnvironmentSpec, Vu: fem.FunctionSpace, Vt: fem.FunctionSpace
    ) -> tuple[list[fem.DirichletBC], list[fem.DirichletBC]]:
        domain = self.robot.mesh
        bcs_u: list[fem.DirichletBC] = []
        bcs_t: list[fem.DirichletBC] = []
        for dim, entities in self._clamp_entities(env):
            domain.topology.create_connectivity(dim, 1)
            for V, out in ((Vu, bcs_u), (Vt, bcs_t)):
                dofs = fem.locate_dofs_topological(V, dim, entities)
                out.append(fem.dirichletbc(np.zeros(3), dofs, V))
        if env.fixed_point is not None:
            bcs_u.append(fem.dirichletbc(np.zeros(3), fixed_point_dofs(env, Vu), Vu))
        return bcs_u, bcs_t

    def _clamp_entities(self, env: EnvironmentSpec) -> list[tuple[int, Any]]:
        """Clamped vertices, and the cells both of whose vertices are clamped."""
        domain = self.robot.mesh
        out: list[tuple[int, Any]] = []
        for dim, entities in clamped_entities(env, self.robot):
            out.append((dim, entities))
            if dim == 0:
                domain.topology.create_connectivity(1, 0)
                c2v = domain.topology.connectivity(1, 0)
                imap = domain.topology.index_map(0)
                held = np.zeros(imap.size_local + imap.num_ghosts, dtype=bool)
                held[entities] = True
                n_cells = domain.topology.index_map(1).size_local
                rows = held[c2v.array[: 2 * n_cells]].reshape(n_cells, 2)
                out.append((1, np.flatnonzero(rows.all(axis=1)).astype(np.int32)))
        return out

    def _strain_metrics(self, kin: RodKinematics) -> list[Any]:
        """(1 + ε)² at the four edges of the section: ε = Γ₁ ± (t/2) K₂ ± (b/2) K₃."""
        t, b = self.thickness, self.width
        out = []
        for sz in (-1.0, 1.0):
            for sy in (-1.0, 1.0):
                eps = (
                    kin.strain[0]
                    + sz * 0.5 * t * kin.curvature[1]
                    + sy * 0.5 * b * kin.curvature[2]
                )
                out.append(ufl.as_matrix([[(1.0 + eps) ** 2]]))
        return out

    # --- energies and forces ----------------------------------------------------------------

    def elastic_energy(self, state: Sequence[Any]) -> ufl.Form:
        kin = RodKinematics(state[0], state[1], self.frame)
        return self._section_energy(kin.strain, kin.curvature, self.bending)

    def strain_rate_energy(self, state: Sequence[Any], rates: Sequence[Any]) -> ufl.Form:
        """½ ∫ of :meth:`elastic_energy`'s density at the rates of the strain and curvature,
        with the anticlastic law's small-curvature (beam) bending stiffness."""
        kin = RodKinematics(state[0], state[1], self.frame)
        law = "beam" if self.bending == "anticlastic" else self.bending
        G = base.rate_of(kin.strain, state, rates)
        return self._section_energy(G, base.rate_of(kin.curvature, state, rates), law)

    def _section_energy(self, G: Any, K: Any, law: str) -> ufl.Form:
        """The section's energy (J) at strain G and curvature K with bending ``law``."""
        t, b, E, mu = self.thickness, self.width, self.young, self.mu
        A = self.area
        stretch = 0.5 * E * A * G[0] ** 2 + 0.5 * SHEAR_CORRECTION * mu * A * (
            G[1] ** 2 + G[2] ** 2
        )
        bend = (
            0.5 * mu * torsion_constant(b, t) * K[0] ** 2
            + bending_energy(K[1], b, t, E, self.poisson, law)
            + 0.5 * E * t * b**3 / 12.0 * K[2] ** 2
        )
        s = self.stiffening
        return s * stretch * self.dx_reduced + s * bend * self.dx

    def magnetic_energy_density(self, state: Sequence[Any], flux: base.FluxDensity) -> Any:
        kin = RodKinematics(state[0], state[1], self.frame)
        M = kin.R0.T * self.magnetization  # material components M̃ᵢ
        d = kin.directors
        FM = M[0] * kin.tangent + M[1] * d[1] + M[2] * d[2]
        return -self.area * ufl.dot(FM, flux(self.X + state[0]))

    def inertia(self, accelerations: Sequence[Any]) -> list[ufl.Form]:
        """Linear part (state at rest): ρA ü·δu and J θ̈·δθ about the reference frame."""
        w_u, w_t = self.tests
        J = ufl.diag(self.rotary)
        return [
            self.mass_density * ufl.dot(accelerations[0], w_u) * self.dx,
            ufl.dot(J * accelerations[1], w_t) * self.dx,
        ]

    def inertia_at(
        self, states: Sequence[Any], rates: Sequence[Any], accelerations: Sequence[Any]
    ) -> list[ufl.Form]:
        w_u, w_t = self.tests
        theta, rate, acc = states[1], rates[1], accelerations[1]
        kin = RodKinematics(states[0], theta, self.frame)
        th = ufl.variable(theta)
        T = rate_matrix(th)
        T_dot = ufl.dot(ufl.diff(T, th), rate)  # Σₖ ∂T/∂θₖ θ̇ₖ
        R0 = kin.R0
        J = ufl.diag(self.rotary)
        omega = R0.T * T * rate
        omega_dot = R0.T * (T * acc + T_dot * rate)
        moment = J * omega_dot + ufl.cross(omega, J * omega)
        return [
            self.mass_density * ufl.dot(accelerations[0], w_u) * self.dx,
            ufl.dot(T.T * (R0 * moment), w_t) * self.dx,
        ]

    def kinetic_energy(self, rates: Sequence[Any]) -> ufl.Form:
        v, rate = rates
        theta = self.unknowns[1]  # the accepted state (energies are observed after a step)
        omega = RodKinematics(self.unknowns[0], theta, self.frame).angular_velocity(theta, rate)
        J = ufl.diag(self.rotary)
        return 0.5 * (self.mass_density * ufl.dot(v, v) + ufl.dot(omega, J * omega)) * self.dx

    def place(self, motion: RigidMotion) -> None:
        """Start translated (and moving) rigidly; a turned or spinning start is refused.

        Raises:
            CaseError: ``[initial]`` turns or spins the rod (its angles would have
                to start at the rotation, which this model does not set).
        """
        if not np.allclose(motion.R, np.eye(3)) or np.any(motion.omega):
            raise CaseError(
                "initial", "(a rotation)", "the rod model can only start translated: no angle, spin"
            )
        super().place(motion)

    def faces(self, state: State, rates: State, surfaces: Names, *, nodal: bool = False) -> Faces:
        """The rod's bottom and top faces; ``nodal`` does not apply (line cells: one rule).

        Their area normal n da/dA is taken as ±d₃ (the rod's axial strain, below
        1e-3 in bending, is left out of da/dA).
        """
        disp, angles = state
        th = ufl.variable(angles)
        normal = RodKinematics(disp, th, self.frame).directors[2]
        lever = ufl.diff(normal, th)  # ∂d₃/∂θ, 3×3
        d3 = rotation(angles) * ufl.as_vector([0.0, 0.0, 1.0])  # R₀E₃ = +z
        sides = base.midsurface_sides(surfaces, "rod")
        measure = self.face_measure
        return base.director_faces(self, disp, rates, d3, lever, sides, measure, d3)
