"""The pressure at the volumetric quadrature points as a Newton unknown (solid, plane-strain strip).

The volumetric energy K/2 (J − 1)² of :mod:`magfem.material` is integrated
with a reduced rule (``volumetric_quadrature_degree``, default 2 for P2). On
quadrilaterals and hexahedra that rule is Gauss–Legendre with m + 1 points
per direction, m = (its degree) // 2: the nodes of the discontinuous Q_m
Lagrange element of the Gauss–Legendre variant. With p in that space and the two
equations

    R_u[w] = … + ∫ p δJ(u)[w] dx_vol,
    R_p[q] = (1/t) ∫ (K (J(u) − 1) − p) q dx_vol        (t: membrane thickness),

the pressure equation says p = K (J − 1) at every volumetric quadrature point,
so the converged (u, p) is exactly the displacement formulation's u: the same
discrete solution, nothing added to the physics. What changes is Newton's
path (the mixed-integration-point Newton of Magisano, Leonetti & Garcea,
CMAME 313 (2017) 986–1005, applied to the pressure): the displacement
formulation recomputes K (J − 1) from every iterate, and a Newton update of a
rotating thin body, linear in the rotation, changes J by the square of the
rotation increment, so its next residual carries K × that; here p follows
the linearised constraint and the residual's second derivative no longer
scales with K: the 2 mm solid in free vibration at K = 100 μ takes the
iterations of the displacement formulation at K = 10 μ (docs/verification.md,
"Newton on the near-incompressible models").

With the average vector field of ρ∞ = 1 (:mod:`magfem.mechanics.integrator`)
the volumetric force is evaluated at several states u_n + s (u − u_n): p has
one component per state. The dividing 1/t makes R_p a force (N; N/m for
strips): a pressure error δp acts on a cell's nodes as δp × (cell volume)/t.

p carries no state between steps: before each Newton solve :meth:`guess`
sets p = K (J − 1) of the predictor, so the first residual and the first
Newton update are the displacement formulation's. As p's nodes are the
volumetric quadrature points, that is an interpolation of K (J − 1) at each
state (one compiled expression, evaluated cell by cell: no assembly).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import basix
import basix.ufl
import ufl
from dolfinx import fem

from magfem.parallel import JIT_WAIT

__all__ = ["MIXED_CELLS", "MixedPressure"]

MIXED_CELLS = ("quadrilateral", "hexahedron")
"""Cells whose reduced Gauss rule is the node set of a discontinuous Lagrange element."""


class MixedPressure:
    """p (Pa) at the volumetric quadrature points, one component per state of the step.

    Args:
        mesh: the continuum mesh (quadrilaterals or hexahedra).
        quadrature_degree: the volumetric rule's degree (p's degree is half of it).
        points: states at which the volumetric force is evaluated (1, or the
            average vector field's Gauss points).
        bulk_modulus: K (Pa), a UFL scalar.
        measure: ``dx`` with the volumetric rule.
        jacobian: J(u) (UFL) of a displacement u.
        thickness: t (m), the scale of R_p.
        other_energy: the model's elastic energy without the volumetric part
            (a form of a state, as ``Model.elastic_energy``).
    """

    def __init__(
        self,
        mesh: Any,
        quadrature_degree: int,
        points: int,
        bulk_modulus: Any,
        measure: ufl.Measure,
        jacobian: Callable[[Any], Any],
        thickness: float,
        other_energy: Callable[[Sequence[Any]], Any],
    ):
        element = basix.ufl.element(
            "Lagrange",
            mesh.basix_cell(),
            quadrature_degree // 2,
            lagrange_variant=basix.LagrangeVariant.gl_warped,
            shape=(points,),
            discontinuous=True,
        )
        self.p = fem.Function(fem.functionspace(mesh, element), name="pressure")
        self.points = points
        self.K = bulk_modulus
        self.dx = measure
        self.jacobian = jacobian
        self.scale = 1.0 / thickness
        self.other_energy = other_energy
        self._guess: fem.Expression | None = None  # K (J − 1) per state at p's nodes

    def residuals(
        self, generic: fem.Function, test: Any, states: Sequence[tuple[float, Any]]
    ) -> tuple[Any, Any]:
        """(the volumetric force's virtual work, R_p) at (weight, displacement) ``states``.

        ``generic`` is the displacement the derivative is taken by, then replaced
        by each state (as the potential's forces in :mod:`magfem.mechanics.problem`).
        Also compiles K (J − 1) of the states for :meth:`guess`.
        """
        if len(states) != self.points:
            raise ValueError(f"{len(states)} states for a pressure of {self.points} components")
        p, q = self.p, ufl.TestFunction(self.p.function_space)
        work: Any = None
        constraint: Any = None
        for k, (weight, u) in enumerate(states):
            dJ = ufl.algorithms.expand_derivatives(
                ufl.derivative(p[k] * self.jacobian(generic) * self.dx, generic, test)
            )
            term = weight * ufl.replace(dJ, {generic: u})
            eq = self.scale * (self.K * (self.jacobian(u) - 1.0) - p[k]) * q[k] * self.dx
            work = term if work is None else work + term
            constraint = eq if constraint is None else constraint + eq
        values = ufl.as_vector([self.K * (self.jacobian(u) - 1.0) for _, u in states])
        points = self.p.function_space.element.interpolation_points
        self._guess = fem.Expression(values, points, jit_options=JIT_WAIT)
        return work, constraint

    def guess(self) -> None:
        """p = K (J − 1) at the quadrature points of the current displacement iterate.

        Interpolates K (J − 1) of each state of the last :meth:`residuals` into
        p's space, whose nodes are the quadrature points of ``measure``: the p
        at which R_p vanishes. Collective (p's ghost values are updated).
        """
        if self._guess is None:
            raise RuntimeError("MixedPressure.guess before residuals: no states to evaluate")
        self.p.interpolate(self._guess)
        self.p.x.scatter_forward()
