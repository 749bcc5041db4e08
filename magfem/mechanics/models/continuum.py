"""Continuum models: the 3D ``solid`` and the 2D ``strip`` (side view of a uniform-width arm).

Total Lagrangian, unknown u (Lagrange ``degree``, gdim components). The
energy per reference volume is the hard-magnetic neo-Hookean law of
:mod:`magfem.material`: ψ_el(F) − (F M̃)·B_a(X + u), with the volumetric part
K/2 (J − 1)² integrated at the reduced degree ``volumetric_quadrature_degree``
(default 2 (degree − 1)); on quadrilaterals and hexahedra Newton solves for
the pressure at those quadrature points too (:mod:`.pressure`: the same
solution in fewer iterations; ``[solver] mixed_pressure``, by default for
the solid only). The strip is
plane strain or plane stress (``[material] plane``) and every integral is
per unit depth; its mesh coordinates are (x, z) and its magnetization and
field keep their (x, z) components.

Contact faces: the boundary facets of ``[contact] surfaces`` (``"all"``: the
whole boundary; ``bottom`` and ``clamp`` are skipped where a robot lacks
them).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh

from magfem import material
from magfem.config import CaseError
from magfem.mechanics.models.base import (
    MODELS,
    Face,
    Faces,
    FluxDensity,
    Model,
    ModelInputs,
    Names,
    State,
    nodal_metadata,
    rate_of,
    time_integrator,
)
from magfem.mechanics.models.pressure import MIXED_CELLS, MixedPressure
from magfem.mechanics.models.supports import (
    clamped_entities,
    create_magnetization,
    fixed_point_dofs,
    is_free,
)
from magfem.mechanics.spec import EnvironmentSpec, MaterialSpec

__all__ = ["ContinuumModel", "SolidModel", "StripModel"]


def _embed(v: Any, gdim: int) -> Any:
    """A UFL gdim-vector as the 3D vector the field expects ((x, z) -> (x, 0, z))."""
    return v if gdim == 3 else ufl.as_vector([v[0], 0.0, v[1]])


def _project(v3: Any, gdim: int) -> Any:
    """The mesh components of a UFL 3-vector."""
    return v3 if gdim == 3 else ufl.as_vector([v3[0], v3[2]])


class ContinuumModel(Model):
    """Finite-strain continuum (module docstring); ``solid`` or ``strip`` by subclass.

    ``inputs.robot`` is the robot mesh (gdim 3 solid, gdim 2 strip); the
    ``[solver]`` gives degree and quadrature degrees, ``[time]`` the scheme, ρ∞
    and first step, ``[environment]`` the supports, ``body`` a strip's depth.
    """

    kinematics: material.Kinematics = "solid"

    def __init__(self, inputs: ModelInputs):
        robot = inputs.robot
        self.kinematics = self._kinematics(inputs.material)
        domain = robot.mesh
        self.robot = robot
        self.gdim = gdim = domain.geometry.dim
        degree = inputs.solver.degree
        self.quadrature_degree = q = inputs.solver.quadrature_degree or 2 * degree
        V = fem.functionspace(domain, ("Lagrange", degree, (gdim,)))
        u = fem.Function(V, name="displacement")
        self.unknowns = [u]
        self.tests = [ufl.TestFunction(V)]
        self.integrator = time_integrator(u, inputs.time)
        self.mu = fem.Constant(domain, inputs.material.shear_modulus)
        self.K = fem.Constant(domain, inputs.material.bulk)
        self.mass_density = self.rho = fem.Constant(domain, inputs.material.density)
        self.magnetization = create_magnetization(inputs.material, robot, gdim)
        self.X = ufl.SpatialCoordinate(domain)
        self.dx = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": q})
        q_vol = inputs.solver.volumetric_quadrature_degree
        q_vol = 2 * (degree - 1) if q_vol is None else q_vol
        self.dx_vol = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": q_vol})
        self.volumetric_quadrature_degree = q_vol
        mixed = inputs.solver.mixed_pressure
        self.mixed = mixed == "on" or (mixed == "auto" and gdim == 3)
        self.ds = ufl.Measure(
            "ds", domain=domain, subdomain_data=robot.facet_tags, metadata={"quadrature_degree": q}
        )
        self.ds_nodal = ufl.Measure(
            "ds",
            domain=domain,
            subdomain_data=robot.facet_tags,
            metadata=nodal_metadata(domain, degree, q),
        )
        self.face_offset = 0.0
        self.depth = inputs.body.depth if gdim == 2 else 1.0
        self.bcs = self._supports(inputs.environment, V)
        self.displacement_bcs = list(self.bcs)
        self.free_body = is_free(self.bcs, domain.comm)

    def _kinematics(self, spec: MaterialSpec) -> material.Kinematics:
        return "solid"

    def _supports(self, env: EnvironmentSpec, V: fem.FunctionSpace) -> list[fem.DirichletBC]:
        domain = self.robot.mesh
        zero = np.zeros(self.gdim, dtype=np.float64)
        bcs = []
        for dim, entities in clamped_entities(env, self.robot):
            domain.topology.create_connectivity(dim, domain.topology.dim)
            dofs = fem.locate_dofs_topological(V, dim, entities)
            bcs.append(fem.dirichletbc(zero, dofs, V))
        if env.fixed_point is not None:
            bcs.append(fem.dirichletbc(zero, fixed_point_dofs(env, V), V))
        return bcs

    # --- energies and forces ----------------------------------------------------------------

    def elastic_energy(self, state: Sequence[Any]) -> ufl.Form:
        F = material.deformation_gradient(state[0])
        return (
            self.isochoric_energy(state)
            + material.volumetric_energy(F, self.K, self.kinematics) * self.dx_vol
        )

    def strain_rate_energy(self, state: Sequence[Any], rates: Sequence[Any]) -> ufl.Form:
        """½ ∫ Ė : ℂ₀ : Ė with Ė the rate of the Green strain E = (FᵀF − I)/2.

        ℂ₀ is the small-strain law of :meth:`elastic_energy`: μ |dev Ė|² + K/2 (tr Ė)²
        per volume (dev and tr in 3D; plane strain has no out-of-plane strain), and
        for incompressible plane stress (Ė₃₃ = −tr Ė) μ (Ė : Ė + (tr Ė)²).
        """
        F = material.deformation_gradient(state[0])
        E = 0.5 * (F.T * F - ufl.Identity(ufl.shape(F)[0]))
        Ed = rate_of(E, state[:1], rates[:1])
        tr = ufl.tr(Ed)
        if self.kinematics == "plane_stress":
            return self.mu * (ufl.inner(Ed, Ed) + tr**2) * self.dx
        deviatoric = self.mu * (ufl.inner(Ed, Ed) - tr**2 / 3.0) * self.dx
        return deviatoric + 0.5 * self.K * tr**2 * self.dx_vol

    def isochoric_energy(self, state: Sequence[Any]) -> ufl.Form:
        """The elastic energy without its volumetric part (J; J/m for strips)."""
        F = material.deformation_gradient(state[0])
        return material.isochoric_energy(F, self.mu, self.kinematics) * self.dx

    def mixed_pressure(self, points: int) -> MixedPressure | None:
        """The pressure at the volumetric quadrature points (:mod:`.pressure`), or None.

        None with ``[solver] mixed_pressure`` off (``auto``: off for the strip,
        where the larger system costs more than the iterations it saves), for
        plane stress (no volumetric energy) and on cells other than
        quadrilaterals and hexahedra.
        """
        domain = self.robot.mesh
        if (
            not self.mixed
            or self.kinematics == "plane_stress"
            or domain.topology.cell_name() not in MIXED_CELLS
        ):
            return None
        return MixedPressure(
            domain,
            self.volumetric_quadrature_degree,
            points,
            self.K,
            self.dx_vol,
            lambda u: ufl.det(material.deformation_gradient(u)),
            self.thickness,
            self.isochoric_energy,
        )

    def magnetic_energy_density(self, state: Sequence[Any], flux: FluxDensity) -> Any:
        F = material.deformation_gradient(state[0])
        B = _project(flux(_embed(self.X + state[0], self.gdim)), self.gdim)
        return material.magnetic_energy(F, self.magnetization, B)

    def inertia(self, accelerations: Sequence[Any]) -> list[ufl.Form]:
        return [self.rho * ufl.dot(accelerations[0], self.tests[0]) * self.dx]

    def kinetic_energy(self, rates: Sequence[Any]) -> ufl.Form:
        return 0.5 * self.rho * ufl.dot(rates[0], rates[0]) * self.dx

    def faces(self, state: State, rates: State, surfaces: Names, *, nodal: bool = False) -> Faces:
        measure, facets = self._contact_measure(surfaces, self.ds_nodal if nodal else self.ds)
        w = self.tests[0]
        F = material.deformation_gradient(state[0])
        N = ufl.FacetNormal(self.robot.mesh)
        return [
            Face(
                position=self.X + state[0],
                velocity=rates[0],
                work=lambda t: [ufl.inner(t, w) * measure],
                measure=measure,
                facets=facets,
                normal=ufl.det(F) * ufl.inv(F).T * N,  # Nanson: n da = J F⁻ᵀ N dA
            )
        ]

    def _contact_measure(self, names: Sequence[str], ds: ufl.Measure) -> tuple[ufl.Measure, Any]:
        """Measure (``ds`` restricted) and local facets of the facet groups ``names``
        (``"all"``: the boundary)."""
        robot = self.robot
        tdim = robot.mesh.topology.dim
        if "all" in names:
            robot.mesh.topology.create_connectivity(tdim - 1, tdim)
            return ds, dmesh.exterior_facet_indices(robot.mesh.topology)
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


@MODELS.register("solid")
class SolidModel(ContinuumModel):
    """The 3D solid (gdim 3)."""


@MODELS.register("strip")
class StripModel(ContinuumModel):
    """The 2D strip (gdim 2), plane strain or plane stress per ``[material] plane``."""

    def _kinematics(self, spec: MaterialSpec) -> material.Kinematics:
        return "plane_strain" if spec.plane == "strain" else "plane_stress"
