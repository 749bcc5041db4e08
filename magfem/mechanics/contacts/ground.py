"""Contact with the ground plane: penalty and friction, impact absorption, the resting start.

The ground occupies ``x[vertical] < ground_height`` (vertical: z, or the
second axis of a strip). Its law is :mod:`magfem.mechanics.contacts.penalty`;
in dynamic runs it acts at the end of the step and, after each accepted
step, :class:`ImpactAbsorber` makes landings perfectly inelastic in the
normal direction (docs/verification.md, "Impact"). History columns:
``contact_force`` (vertical resultant, N; N/m × depth for strips) and
``friction_force`` (magnitude of the tangential resultant).
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from mpi4py import MPI

from magfem.mechanics.contacts.base import Contact
from magfem.mechanics.contacts.penalty import (
    PenaltyLaw,
    create_penalty_law,
    penalty_penetration,
    penalty_ramp,
)
from magfem.mechanics.forms import ScalarForms
from magfem.mechanics.models.base import Face, Model, sum_work
from magfem.mechanics.spec import ContactSpec

__all__ = ["GroundContact", "GroundPlane", "ImpactAbsorber"]


class GroundPlane:
    """The penalty law against the plane ``x[vertical] = ground_height`` (constants in place).

    The constants can be changed in place with :meth:`update` (tightening the
    penalty in a convergence study) without recompiling forms.

    Args:
        law: the contact constants.
        mesh: the body's dolfinx mesh (gdim 2 or 3).
        vertical: index of the vertical axis (1 for a 2D strip, 2 in 3D).
        ground_height: position of the ground plane along ``vertical`` (m).
    """

    def __init__(
        self,
        law: PenaltyLaw,
        mesh: Any,
        *,
        vertical: int,
        ground_height: float = 0.0,
        time_step: Any = None,
    ) -> None:
        gdim = mesh.geometry.dim
        if not 0 <= vertical < gdim:
            raise ValueError(f"vertical axis {vertical} outside 0..{gdim - 1}")
        self.gdim = gdim
        self.vertical = vertical
        self.law = law
        self.stiffness = fem.Constant(mesh, np.float64(law.stiffness))
        self.onset = fem.Constant(mesh, np.float64(law.onset))
        self.damping = fem.Constant(mesh, np.float64(law.damping))
        self.friction = fem.Constant(mesh, np.float64(law.friction))
        self.regularization_velocity = fem.Constant(mesh, np.float64(law.regularization_velocity))
        self.ground_height = fem.Constant(mesh, np.float64(ground_height))
        self.slip_length = fem.Constant(mesh, np.float64(law.slip_length))
        self.time_step = time_step  # a fem.Constant Δt (s), or None: no ℓ/Δt term

    def update(self, law: PenaltyLaw) -> None:
        """Set new constants in place (compiled forms stay valid)."""
        self.law = law
        for name in (
            "stiffness",
            "onset",
            "damping",
            "friction",
            "regularization_velocity",
            "slip_length",
        ):
            constant: Any = getattr(self, name)
            constant.value = getattr(law, name)

    def pressure(self, x: Any, v: Any) -> Any:
        """Normal contact pressure p_n >= 0 (Pa per reference area), UFL scalar.

        Args:
            x: current position, UFL vector (gdim,) (m).
            v: current velocity, UFL vector (gdim,) (m/s).
        """
        delta = self.ground_height - x[self.vertical]
        r, s = penalty_ramp(delta, self.onset)
        p = self.stiffness * r - self.damping * s * v[self.vertical]
        return ufl.conditional(ufl.gt(p, 0.0), p, 0.0)

    def traction(self, x: Any, v: Any) -> Any:
        """Traction of the ground on the body (Pa per reference area), UFL vector (gdim,)."""
        e_v = ufl.as_vector([1.0 if i == self.vertical else 0.0 for i in range(self.gdim)])
        p_n = self.pressure(x, v)
        v_t = v - v[self.vertical] * e_v
        eps2 = self.regularization_velocity**2
        if self.time_step is not None:
            eps2 = eps2 + (self.slip_length / self.time_step) ** 2
        speed = ufl.sqrt(ufl.dot(v_t, v_t) + eps2)
        return p_n * e_v - self.friction * p_n * v_t / speed

    def work(self, x: Any, v: Any, w: Any, ds: Any) -> Any:
        """Virtual work ∫ t·w dA of the ground traction (J per unit test field), UFL form.

        Subtract it from a residual written as internal minus external work.
        ``ds`` must carry an explicit quadrature degree.
        """
        return ufl.inner(self.traction(x, v), w) * ds

    def force_forms(self, x: Any, v: Any, ds: Any) -> list[Any]:
        """Scalar forms of the resultant ground force components (N; N/m in 2D), length gdim."""
        t = self.traction(x, v)
        return [t[i] * ds for i in range(self.gdim)]


class ImpactAbsorber:
    """Perfectly inelastic normal impact of the membrane's through-thickness columns.

    A thin plate meeting the ground stops within the contact time
    2π sqrt(ρh/k_n), far below any useful time step, and the generalized-α
    velocity update then reverses its velocity whatever the contact law
    (docs/verification.md, "Impact").

    After each accepted step, every through-thickness column of nodes
    (nodes sharing the reference coordinates other than ``vertical``) whose
    contact node has gone below the ground loses its upward normal velocity
    and normal acceleration (at the step it arrives, and later only if it
    rebounds faster than ``rest_velocity``): the
    impact is perfectly inelastic in the normal direction, the limit the
    resolved contact dashpot approaches (ζ >= 1), and the column comes to
    rest as a unit, which is what it does physically (the through-thickness
    wave crosses 100 µm in ~1 µs). Columns resting on the ground, and nodes
    above it, are untouched; tangential motion is
    left to friction. Together with the contact evaluated at the end of the
    step (x_{n+1}, v_{n+1}; the stage point x_{n+1−αf} lets the plate end the
    step below the ground by αf/(1 − αf) of the gap it closed), a dropped
    plate comes to rest in one step at Δt = 0.1 ms; in the spirit of the
    contact-stabilised Newmark scheme (Deuflhard, Krause, Ertel, IJNME 73
    (2008) 1274–1290), which also removes the normal velocity of contacting
    nodes.

    Args:
        V: the displacement space (blocked vector Lagrange, gdim components).
        facets: local indices of the facets that may touch the ground; None:
            every node (the shell, whose nodes are on its mid-surface).
        vertical: index of the vertical axis.
        ground_height: ground plane position (m).
        offset: a node touches when its height minus ``offset`` is below the
            ground (m): 0 for nodes on the faces, t/2 for the shell's
            mid-surface nodes.
        rest_velocity: columns that were already below the ground at the
            previous step are reset only when they move up faster than this
            (m/s; the stored penetration of an impact released over the next
            steps), like the bounce threshold of rigid-body engines. Resting
            contact (vertical velocity ~1e-7 m/s in the sliding benchmark) is
            then left alone: resetting it every step removes upward momentum
            each time, which the ground repays with a mean normal force above
            the weight, and friction with it (a sliding strip decelerated at
            1.04 μ_f g).

    The reference membrane must be flat with its thickness along ``vertical``
    (as every magfem robot is); columns are found by rounding the other
    reference coordinates to 1e-9 of the mesh extent. :meth:`apply` is
    collective.
    """

    def __init__(
        self,
        V: Any,
        facets: Any,
        *,
        vertical: int,
        ground_height: float = 0.0,
        rest_velocity: float = 1e-3,
        offset: float = 0.0,
    ) -> None:
        mesh = V.mesh
        self.comm = mesh.comm
        self.bs = V.dofmap.index_map_bs
        self.vertical = vertical
        self.touch_height = float(ground_height) + float(offset)
        self.rest_velocity = float(rest_velocity)
        X = V.tabulate_dof_coordinates()[:, : mesh.geometry.dim]  # (nodes, gdim), owned + ghost
        others = [i for i in range(X.shape[1]) if i != vertical]
        gdim = X.shape[1]
        lo, hi = np.empty(gdim), np.empty(gdim)
        self.comm.Allreduce(X.min(axis=0) if X.size else np.full(gdim, np.inf), lo, op=MPI.MIN)
        self.comm.Allreduce(X.max(axis=0) if X.size else np.full(gdim, -np.inf), hi, op=MPI.MAX)
        tol = 1e-9 * float(np.max(hi - lo))
        keys = np.round((X[:, others] - lo[others]) / tol).astype(np.int64)
        # one int64 per column: the coordinates fit in 31 bits each (extent / tol = 1e9)
        self.column = keys[:, 0] if keys.shape[1] == 1 else keys[:, 0] * (1 << 31) + keys[:, 1]
        self.reference_height = X[:, vertical]
        if facets is None:
            self.contact_nodes = np.arange(X.shape[0])
        else:
            tdim = mesh.topology.dim
            mesh.topology.create_connectivity(tdim - 1, tdim)
            dofs = fem.locate_dofs_topological(V.sub(vertical), tdim - 1, np.asarray(facets))
            self.contact_nodes = np.unique(np.asarray(dofs) // self.bs)
        self.touching = np.empty(0, dtype=np.int64)  # columns below ground at the last call

    def apply(self, u: Any, v: Any, a: Any) -> int:
        """Remove the upward vertical velocity/acceleration of columns that just hit the ground.

        Columns below the ground now and not at the previous call lose any
        upward velocity; columns already below it, only an upward velocity
        above ``rest_velocity``.

        Args:
            u, v, a: Functions of ``V`` holding the accepted state at t_{n+1}
                (the integrator's u_n, v_n, a_n after ``advance``); v and a are
                changed in place (owned and ghost entries alike).

        Returns:
            the number of columns reset (global).
        """
        k = self.vertical
        nodes = self.contact_nodes
        height = self.reference_height[nodes] + u.x.array[nodes * self.bs + k]
        hit_local = np.unique(self.column[nodes[height < self.touch_height]])
        hit = np.unique(np.concatenate(self.comm.allgather(hit_local)))
        new = np.setdiff1d(hit, self.touching, assume_unique=True)
        self.touching = hit
        if hit.size == 0:
            return 0
        idx = np.flatnonzero(np.isin(self.column, hit)) * self.bs + k
        fresh = np.isin(self.column[idx // self.bs], new)
        vz = v.x.array[idx]
        # new contacts lose any upward velocity; resting ones only a rebound above v_rest
        reset = (vz > 0.0) & (fresh | (vz > self.rest_velocity))
        v.x.array[idx[reset]] = 0.0
        a.x.array[idx[reset]] = 0.0
        done = np.unique(self.column[idx[reset] // self.bs])
        return int(np.unique(np.concatenate(self.comm.allgather(done))).size)


class GroundContact(Contact):
    """The ground of ``[contact]`` (``ground = true``) acting on a model's contact faces.

    Args:
        spec: the ``[contact]`` table.
        model: the body.
        shear_modulus, density: of the membrane (Pa, kg/m³): they scale the
            penalty stiffness and the contact dashpot.
    """

    name = "ground"

    def __init__(self, spec: ContactSpec, model: Model, *, shear_modulus: float, density: float):
        self.model = model
        self.density = density
        self.surfaces = tuple(spec.surfaces)
        self.law: PenaltyLaw = create_penalty_law(
            spec, shear_modulus=shear_modulus, density=density, thickness=model.thickness
        )
        integ = model.integrator
        self.plane = GroundPlane(
            self.law,
            model.robot.mesh,
            vertical=model.gdim - 1,
            ground_height=spec.ground_height,
            time_step=integ.dt if integ.dynamic else None,
        )
        faces = model.faces(*model.accepted(), self.surfaces)  # the state after advance()
        tractions = [self.plane.traction(f.position, f.velocity) for f in faces]
        total = functools.reduce(operator.add, tractions)
        measure = faces[0].measure
        self._force_forms = ScalarForms(
            model.robot.mesh, [total[i] * measure for i in range(model.gdim)]
        )
        self.absorber: ImpactAbsorber | None = None
        if integ.dynamic:
            facets = None if any(f.facets is None for f in faces) else faces[0].facets
            self.absorber = ImpactAbsorber(
                model.u.function_space,
                facets,
                vertical=model.gdim - 1,
                ground_height=spec.ground_height,
                offset=model.face_offset,
            )

    def work(self, faces: Sequence[Face]) -> list[ufl.Form]:
        return sum_work(faces, [self.plane.traction(f.position, f.velocity) for f in faces])

    def after_step(self) -> None:
        if self.absorber is not None:
            integ = self.model.integrator
            self.absorber.apply(integ.u0, integ.v0, integ.a0)

    def state(self) -> dict[str, Any]:
        """The columns below the ground at the last step (the impact absorber's memory)."""
        touching = self.absorber.touching if self.absorber is not None else np.zeros(0, np.int64)
        return {"touching": np.asarray(touching, dtype=np.int64)}

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`state`."""
        if self.absorber is not None:
            self.absorber.touching = np.asarray(state["touching"], dtype=np.int64)

    def press(self, model: Model, acceleration: npt.NDArray[np.float64]) -> None:
        """Start a quasi-static settle from the resting penetration of a body lying on the ground.

        The penalty ramp has zero slope at zero penetration, so at u = 0 a
        membrane lying on the ground has no contact stiffness in the Newton
        tangent and the first gravity increment of a thin cantilever goes
        straight through the ground. Translating the body down by
        δ* = r⁻¹(ρ |g| h / k_n), the penetration at which the penalty carries
        the membrane's weight per area, starts Newton where the tangent has
        the stiffness of the resting contact. Supports stay at zero.
        """
        vertical = model.gdim - 1
        g_v = float(acceleration[vertical])
        comm = model.robot.mesh.comm
        x = model.robot.mesh.geometry.x[:, vertical]
        lowest = comm.allreduce(float(x.min()) if x.size else np.inf, op=MPI.MIN)
        lowest -= model.face_offset
        height = float(self.plane.ground_height.value)
        if g_v >= 0.0 or lowest > height + 1e-9 * model.thickness:
            return
        weight = self.density * abs(g_v) * model.thickness  # per area (Pa)
        delta = penalty_penetration(weight, self.law.stiffness, self.law.onset)
        for func in (model.integrator.u0, model.u):
            func.x.array.reshape(-1, model.gdim)[:, vertical] -= delta
            for bc in model.displacement_bcs:
                bc.set(func.x.array, alpha=0.0)

    def columns(self) -> list[str]:
        return ["contact_force", "friction_force"]

    def observe(self, t: float) -> dict[str, float]:
        forces = self._force_forms.assemble()
        depth = self.model.depth
        return {
            "contact_force": forces[-1] * depth,
            "friction_force": float(np.linalg.norm(forces[:-1])) * depth,
        }
