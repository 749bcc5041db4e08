"""The fluid around the robot (``[fluid]``): buoyancy, added mass, pressure drag, skin friction.

A reduced model of a thin plate in a fluid, written per unit plate area
with the coefficients of :mod:`magfem.mechanics.loads.hydrodynamics`
(equations, sources and validity there and in docs/fluid.md). Each face of
the model (:meth:`~magfem.mechanics.models.base.Model.fluid_faces`: the
shell's two faces, taken together at its mid-surface, the rod's two faces,
the boundary of a solid or strip) carries half of the plate's normal terms
and its own skin friction (a face standing for ``count`` faces, that many
times); with n the face's current outward
unit normal, v_r = v − U the velocity relative to the current U,
v_n = v_r·n, v_t = v_r − v_n n, the traction per current area is

    t = −[½ m_a a_n + ½ c_n v_n + ¼ ρ v_n max(k₁ s_n^0.792, C_D∞ s_n − k₂)] n
        − [c_t + 0.664 √(ρμ/L) s_t^½] v_t,

s_n = √(v_n² + ε²), s_t = √(|v_t|² + ε²) (ε: a Reynolds number of 10⁻³, so
that the powers have derivatives at rest), k₁ = 0.138 (64/π) (ν/b)^0.208,
k₂ = (64/π) ν/b. It is multiplied by the face's area ratio (Nanson) and
integrated over the reference face. The added-mass term ½ m_a a_n, which
is exact for a face that translates, is taken from the kinetic energy of
the fluid the faces carry, T = Σ_faces ∫ ¼ m_a (v_r·N)²/|N| dA (N = n da/dA),
by Lagrange's equation d/dt ∂T/∂q̇ − ∂T/∂q (Kirchhoff's equations of a
body in an ideal fluid, Lamb, *Hydrodynamics* 1932, §124–126): on a face
that turns it adds −½ m_a ((v_r·ṅ) n + v_n ṅ) and the terms of ∂T/∂q, so
that the added mass's power is dT/dt and it cannot give the body energy it
never took. It is an inertia-like term (:meth:`FluidLoad.inertia`) at the
integrator's stage values, like the body's own inertia; the others are the
virtual work at the stage point (:meth:`FluidLoad.work`). Everything is UFL
of the unknowns, so Newton's Jacobian is exact.

Buoyancy is the potential +ρ_f/ρ_s ∫ ρ_s g·u of the displaced fluid
(history column ``energy_fluid``); with gravity it makes a body of the
fluid's density weightless.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from ufl.algorithms import expand_derivatives

from magfem.config import CaseError
from magfem.mechanics.fluid_spec import FluidSpec
from magfem.mechanics.loads.base import Load
from magfem.mechanics.loads.hydrodynamics import (
    BLASIUS,
    CLIFT_FACTOR,
    CLIFT_POWER,
    STOKES_DISK,
    FluidCoefficients,
)
from magfem.mechanics.models.base import Face, Model, sum_work

__all__ = ["REYNOLDS_FLOOR", "FluidLoad"]

REYNOLDS_FLOOR = 1e-3
"""ε of the regularised speeds, as a Reynolds number on the chord."""


def _plane(v3: Sequence[float], gdim: int) -> npt.NDArray[np.float64]:
    """The mesh components of a 3-vector ((x, z) for strips)."""
    arr = np.asarray(v3, dtype=float)
    return arr if gdim == 3 else arr[::2].copy()


class FluidLoad(Load):
    """The fluid of a :class:`FluidSpec` on ``model``'s faces, with ``coefficients``.

    Args:
        spec: ``[fluid]``.
        coefficients: the plate's coefficients (chord, frequency resolved).
        model: the structural model.
        gravity: g (m/s², 3 components).
        solid_density: ρ_s of the robot (kg/m³), for the buoyancy.

    Attributes:
        spec: as given. coefficients: as given.
        surfaces: the faces it acts on.
    """

    name = "fluid"

    def __init__(
        self,
        spec: FluidSpec,
        coefficients: FluidCoefficients,
        model: Model,
        *,
        gravity: Sequence[float],
        solid_density: float,
    ):
        mesh = model.robot.mesh
        self.spec = spec
        c = self.coefficients = coefficients
        self.surfaces = tuple(spec.surfaces)
        try:
            model.faces(*model.accepted(), self.surfaces)
        except CaseError as err:
            raise CaseError("fluid.surfaces", list(self.surfaces), err.problem) from None
        self.current = fem.Constant(mesh, _plane(spec.current, model.gdim))
        self.full_gravity = _plane(gravity, model.gdim)
        self.g = fem.Constant(mesh, self.full_gravity.copy())
        self.ratio = c.density / solid_density
        nu = c.kinematic_viscosity
        self.epsilon = REYNOLDS_FLOOR * nu / c.chord
        self.k1 = STOKES_DISK * CLIFT_FACTOR * (nu / c.chord) ** (1.0 - CLIFT_POWER)
        self.k2 = STOKES_DISK * nu / c.chord
        self.blasius = BLASIUS * math.sqrt(c.density * c.viscosity / c.friction_length)

    # --- the load's terms ----------------------------------------------------------------

    def energy(self, model: Model, state: Sequence[Any]) -> ufl.Form:
        displacement = model.displacement(state)
        return self.ratio * model.mass_density * ufl.dot(self.g, displacement) * model.dx

    def work(self, model: Model, state: Sequence[Any], rates: Sequence[Any]) -> list[ufl.Form]:
        faces = model.fluid_faces(state, rates, self.surfaces)
        return sum_work(faces, [face.count * self.drag_traction(face) for face in faces])

    def inertia(
        self, model: Model, state: Sequence[Any], rates: Sequence[Any], accelerations: Sequence[Any]
    ) -> list[ufl.Form]:
        """Lagrange's equation of the added mass's kinetic energy T (module docstring).

        d/dt ∂T/∂q̇ [w] − ∂T/∂q [w], derived at placeholder Functions (q̂, q̂̇, q̂̈)
        and evaluated at the integrator's stage values ``state``, ``rates``,
        ``accelerations`` by replacement.
        """
        q = [fem.Function(f.function_space) for f in model.unknowns]
        r = [fem.Function(f.function_space) for f in model.unknowns]
        a = [fem.Function(f.function_space) for f in model.unknowns]
        kinetic = self.added_mass_energy(model.fluid_faces(q, r, self.surfaces))
        forms = []
        for qi, ri, wi in zip(q, r, model.tests, strict=True):
            momentum = ufl.derivative(kinetic, ri, wi)
            rate = sum(
                ufl.derivative(momentum, qj, rj) + ufl.derivative(momentum, rj, aj)
                for qj, rj, aj in zip(q, r, a, strict=True)
            )
            form = expand_derivatives(rate - ufl.derivative(kinetic, qi, wi))
            mapping = dict(zip(q + r + a, [*state, *rates, *accelerations], strict=True))
            forms.append(ufl.replace(form, mapping))
        return forms

    def added_mass_energy(self, faces: Sequence[Face]) -> Any:
        """T = Σ_faces ∫ ¼ m_a (v·N)²/|N| dA: the fluid's kinetic energy (J; J/m for strips).

        N = n da/dA: each face carries half the plate's m_a (v·n)² per current area.
        """
        total: Any = 0
        for face in faces:
            area, _ = self._frame(face)
            vn_area = ufl.dot(face.velocity - self.current, face.normal)
            density = 0.25 * face.count * self.coefficients.added_mass * vn_area**2 / area
            total = total + density * face.measure
        return total

    def ramp(self, factor: float) -> bool:
        if not np.any(self.full_gravity):
            return False
        self.g.value = factor * self.full_gravity  # type: ignore[assignment]
        return True

    def body_acceleration(self) -> npt.NDArray[np.float64]:
        return -self.ratio * np.asarray(self.g.value, dtype=float)

    # --- tractions per reference area of a face --------------------------------------------

    @staticmethod
    def _frame(face: Face) -> tuple[Any, Any]:
        """(area ratio da/dA, unit outward normal) of a face."""
        area = ufl.sqrt(ufl.dot(face.normal, face.normal))
        return area, face.normal / area

    def normal_drag(self, vn: Any) -> Any:
        """Normal drag per face and current area (Pa) at the relative normal speed v_n (UFL)."""
        c = self.coefficients
        s = ufl.sqrt(vn**2 + self.epsilon**2)
        quadratic = ufl.max_value(self.k1 * s**CLIFT_POWER, c.drag_coefficient * s - self.k2)
        return 0.5 * c.normal_damping * vn + 0.25 * c.density * quadratic * vn

    def drag_traction(self, face: Face) -> Any:
        """Normal drag and skin friction on ``face`` (UFL gdim-vector, Pa per reference area)."""
        area, n = self._frame(face)
        relative = face.velocity - self.current
        vn = ufl.dot(relative, n)
        vt = relative - vn * n
        st = ufl.sqrt(ufl.dot(vt, vt) + self.epsilon**2)
        friction = (self.coefficients.tangential_damping + self.blasius * ufl.sqrt(st)) * vt
        return -area * (self.normal_drag(vn) * n + friction)

    # --- observation ---------------------------------------------------------------------------

    def observed_forms(self, model: Model, direction: Sequence[float]) -> dict[str, ufl.Form]:
        """Scalar forms at the accepted state (t_n): the fluid's force and power on the body.

        ``fluid_force_<x|y|z>`` (N, the strip's (x, z) per unit depth),
        ``fluid_thrust`` (the pressure's force along ``direction``: the normal
        drag and the added mass, N), ``fluid_friction`` (the skin friction's,
        N), ``fluid_power`` (the power the body gives the fluid, W),
        ``fluid_drag_power`` (its part that the drag and skin friction take,
        W), ``fluid_area`` (the wetted faces' current area, m²),
        ``fluid_normal_speed2`` (∫ v_n² da, m⁴/s²) and ``fluid_kinetic`` (the
        added mass's kinetic energy T, J). The added mass's force and power
        are its Lagrange terms (:meth:`inertia`) for a unit translation and for
        the body's velocity.
        """
        state, rates = model.accepted()
        accelerations = [p.a0 for p in model.integrator.parts]
        e = _plane(direction, model.gdim) / np.linalg.norm(direction)
        labels = "xyz" if model.gdim == 3 else "xz"
        forms: dict[str, Any] = {}
        for face in model.fluid_faces(state, rates, self.surfaces):
            area, n = self._frame(face)
            drag = face.count * self.drag_traction(face)
            normal = ufl.dot(drag, n) * n
            vn = ufl.dot(face.velocity - self.current, n)
            terms = {f"fluid_force_{k}": drag[i] for i, k in enumerate(labels)}
            terms |= {
                "fluid_thrust": ufl.dot(normal, ufl.as_vector(e)),
                "fluid_friction": ufl.dot(drag - normal, ufl.as_vector(e)),
                "fluid_power": -ufl.dot(drag, face.velocity),
                "fluid_drag_power": -ufl.dot(drag, face.velocity),
                "fluid_area": face.count * area,
                "fluid_normal_speed2": face.count * area * vn**2,
                "fluid_kinetic": 0.25 * face.count * self.coefficients.added_mass * area * vn**2,
            }
            for key, integrand in terms.items():
                term = integrand * face.measure
                forms[key] = term if key not in forms else forms[key] + term
        inertia = self.inertia(model, state, rates, accelerations)
        translation = inertia[0]  # the displacement's; a translation turns nothing

        def along(vector: npt.NDArray[np.float64]) -> Any:
            return -ufl.replace(translation, {model.tests[0]: ufl.as_vector(vector)})

        for i, k in enumerate(labels):
            forms[f"fluid_force_{k}"] += along(np.eye(model.gdim)[i])
        forms["fluid_thrust"] += along(e)
        for form, test, rate in zip(inertia, model.tests, rates, strict=True):
            forms["fluid_power"] += ufl.replace(form, {test: rate})
        return forms
