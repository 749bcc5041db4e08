"""Time integrators that discretise a residual written in continuous time.

The mechanics residual is written once as R(u, u̇, ü; t) (a UFL form, see
:mod:`magfem.mechanics.problem`). An integrator turns it into the residual
of one step in the unknown u_{n+1} (a ``dolfinx.fem.Function``):

* **generalized-α** (Chung & Hulbert, J. Appl. Mech. 60 (1993) 371–375).
  Equilibrium is enforced at intermediate points,
  ``M a_{n+1−αm} + f(u_{n+1−αf}, v_{n+1−αf}; t_{n+1−αf}) = 0`` with
  ``x_{n+1−α} = (1 − α) x_{n+1} + α x_n``, and the Newmark updates

      u_{n+1} = u_n + Δt v_n + Δt² ((1/2 − β) a_n + β a_{n+1})
      v_{n+1} = v_n + Δt ((1 − γ) a_n + γ a_{n+1}).

  For a user spectral radius ρ∞ ∈ [0, 1]:
  αm = (2ρ∞ − 1)/(ρ∞ + 1), αf = ρ∞/(ρ∞ + 1), γ = 1/2 − αm + αf,
  β = (1 − αm + αf)²/4. Second-order accurate, unconditionally stable for
  linear problems, with optimal high-frequency dissipation. ρ∞ = 1 gives
  αm = αf = 1/2, β = 1/4, γ = 1/2: no numerical dissipation.
* **HHT-α** (Hilber, Hughes & Taylor, EESD 5 (1977) 283–292) is the case
  αm = 0, αf = (1 − ρ∞)/(1 + ρ∞) ∈ [0, 1/3], γ = 1/2 + αf, β = (1 + αf)²/4.
* **Newmark** average acceleration: αm = αf = 0, β = 1/4, γ = 1/2.
* **quasi-static**: no inertia, R(u, 0, 0; t_{n+1}) = 0.

Solving the update for a_{n+1} in terms of the unknown u_{n+1}:

    a_{n+1} = (u_{n+1} − u_n − Δt v_n)/(β Δt²) − (1/(2β) − 1) a_n
    v_{n+1} = v_n + Δt ((1 − γ) a_n + γ a_{n+1}).

Δt is a ``fem.Constant`` so that changing the step never recompiles forms;
the state (u_n, v_n, a_n) lives in ``Function`` objects updated in place.
Loads are evaluated at the stage time t_{n+1−αf} (``stage_time``): with
step boundaries on the switching instants of a square wave, the stage time
lies strictly inside a step and sees the new value.

The step is stage → solve → check convergence → :meth:`advance` (or
:meth:`restore` after a failed solve, then retry with a smaller step).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem

__all__ = [
    "AlphaParameters",
    "BlockIntegrator",
    "Residual",
    "TimeIntegrator",
    "alpha_parameters",
]

Residual = Callable[
    [ufl.core.expr.Expr, ufl.core.expr.Expr, ufl.core.expr.Expr, ufl.core.expr.Expr], ufl.Form
]
"""R(u, v, a, t) -> UFL form linear in the test function (continuous-time residual)."""


@dataclass(frozen=True)
class AlphaParameters:
    """Coefficients of the generalized-α family (dimensionless)."""

    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float


def alpha_parameters(scheme: str, rho_inf: float = 1.0) -> AlphaParameters:
    """Generalized-α coefficients for ``scheme`` and spectral radius ``rho_inf``.

    Args:
        scheme: ``generalized_alpha``, ``hht``, ``newmark`` (average acceleration).
        rho_inf: spectral radius at infinite frequency, [0, 1] ([0.5, 1] for HHT).

    Raises:
        ValueError: unknown scheme or ρ∞ out of range (the case validation
            catches these first; this is a programming error).
    """
    if not 0.0 <= rho_inf <= 1.0:
        raise ValueError(f"rho_inf must be in [0, 1], got {rho_inf}")
    if scheme == "generalized_alpha":
        am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        af = rho_inf / (rho_inf + 1.0)
        gamma = 0.5 - am + af
        return AlphaParameters(am, af, 0.25 * (1.0 - am + af) ** 2, gamma)
    if scheme == "hht":
        if rho_inf < 0.5:
            raise ValueError(f"HHT-α needs rho_inf in [0.5, 1], got {rho_inf}")
        af = (1.0 - rho_inf) / (1.0 + rho_inf)
        return AlphaParameters(0.0, af, 0.25 * (1.0 + af) ** 2, 0.5 + af)
    if scheme == "newmark":
        return AlphaParameters(0.0, 0.0, 0.25, 0.5)
    raise ValueError(f"unknown scheme {scheme!r}")


class TimeIntegrator:
    """Discretises R(u, u̇, ü; t) = 0 in time for the unknown ``u`` (= u_{n+1}).

    Args:
        u: the unknown displacement at t_{n+1} (m); also the Newton iterate.
        scheme: ``generalized_alpha``, ``hht``, ``newmark`` or ``quasi_static``.
        rho_inf: spectral radius ρ∞ (ignored by ``newmark``/``quasi_static``).
        dt: initial step (s).

    Attributes:
        u0, v0, a0: state at t_n (m, m/s, m/s²), same space as ``u``.
        dt: ``fem.Constant`` step (s). t: ``fem.Constant`` stage time (s).
        params: the α coefficients (None for quasi-static).
    """

    def __init__(self, u: fem.Function, scheme: str, *, rho_inf: float = 1.0, dt: float = 1.0):
        self.u = u
        self.scheme = scheme
        self.dynamic = scheme != "quasi_static"
        self.params = alpha_parameters(scheme, rho_inf) if self.dynamic else None
        V = u.function_space
        mesh = V.mesh
        self.u0 = fem.Function(V, name="u_n")
        self.v0 = fem.Function(V, name="velocity")
        self.a0 = fem.Function(V, name="acceleration")
        self.dt = fem.Constant(mesh, float(dt))
        self.t = fem.Constant(mesh, 0.0)
        self.time = 0.0  # t_n (s)
        self.parts = [self]  # as BlockIntegrator.parts

    # --- UFL -------------------------------------------------------------------------------

    def acceleration(self) -> ufl.core.expr.Expr:
        """a_{n+1} as a UFL expression of the unknown u (m/s²)."""
        p = self._alpha()
        dt = self.dt
        return (self.u - self.u0 - dt * self.v0) / (p.beta * dt**2) - (
            1.0 / (2.0 * p.beta) - 1.0
        ) * self.a0

    def velocity(self) -> ufl.core.expr.Expr:
        """v_{n+1} as a UFL expression of the unknown u (m/s)."""
        p = self._alpha()
        return self.v0 + self.dt * ((1.0 - p.gamma) * self.a0 + p.gamma * self.acceleration())

    def stage(self) -> tuple[ufl.core.expr.Expr, ufl.core.expr.Expr, ufl.core.expr.Expr]:
        """(u, v, a) at the stage point, where the residual is enforced."""
        if not self.dynamic:
            zero = ufl.zero(*ufl.shape(self.u))
            return self.u, zero, zero
        p = self._alpha()
        u = (1.0 - p.alpha_f) * self.u + p.alpha_f * self.u0
        v = (1.0 - p.alpha_f) * self.velocity() + p.alpha_f * self.v0
        a = (1.0 - p.alpha_m) * self.acceleration() + p.alpha_m * self.a0
        return u, v, a

    def discretise(self, residual: Residual) -> ufl.Form:
        """The step residual: ``residual`` evaluated at the stage point and stage time."""
        u, v, a = self.stage()
        return residual(u, v, a, self.t)

    # --- numbers ---------------------------------------------------------------------------

    def stage_time(self, t0: float, dt: float) -> float:
        """Time at which loads are evaluated for the step t0 → t0 + dt (s)."""
        if not self.dynamic:
            return t0 + dt
        return t0 + (1.0 - self._alpha().alpha_f) * dt

    def begin(self, dt: float) -> float:
        """Set Δt, the stage time and the predictor u = u_n + Δt v_n.

        Returns the stage time (s); the caller updates time-dependent loads to it.
        """
        self.dt.value = dt  # type: ignore[assignment]
        t_stage = self.stage_time(self.time, dt)
        self.t.value = t_stage  # type: ignore[assignment]
        x = self.u.x.array
        if self.dynamic:
            x[:] = self.u0.x.array + dt * self.v0.x.array
        else:
            x[:] = self.u0.x.array
        return t_stage

    def restore(self) -> None:
        """Undo a failed solve: the iterate goes back to u_n."""
        self.u.x.array[:] = self.u0.x.array

    def advance(self) -> None:
        """Accept the solved u_{n+1}: update (u_n, v_n, a_n) and t_n in place."""
        dt = float(self.dt.value)
        u1 = self.u.x.array
        if self.dynamic:
            p = self._alpha()
            u0, v0, a0 = self.u0.x.array, self.v0.x.array, self.a0.x.array
            a1 = (u1 - u0 - dt * v0) / (p.beta * dt * dt) - (1.0 / (2.0 * p.beta) - 1.0) * a0
            v1 = v0 + dt * ((1.0 - p.gamma) * a0 + p.gamma * a1)
            self.a0.x.array[:] = a1
            self.v0.x.array[:] = v1
        else:
            if dt > 0:
                self.v0.x.array[:] = (u1 - self.u0.x.array) / dt
        self.u0.x.array[:] = u1
        self.time += dt

    def set_state(
        self,
        t: float,
        u: np.ndarray | None = None,
        v: np.ndarray | None = None,
        a: np.ndarray | None = None,
    ) -> None:
        """Set t_n and (optionally) the local arrays (owned + ghost) of u_n, v_n, a_n."""
        self.time = float(t)
        for func, arr in ((self.u0, u), (self.v0, v), (self.a0, a)):
            if arr is not None:
                func.x.array[:] = arr
        self.u.x.array[:] = self.u0.x.array

    def _alpha(self) -> AlphaParameters:
        if self.params is None:
            raise RuntimeError("the quasi-static integrator has no velocity or acceleration")
        return self.params


class BlockIntegrator:
    """One time integrator over several unknowns (the shell's u and θ), stepped together.

    The parts share the step Δt and the stage time t (the first part's
    Constants), so forms built from any part's :meth:`TimeIntegrator.stage`
    see the same step. ``u``, ``u0``, ``v0``, ``a0`` are the first part's
    (the displacement: what the observers, the contact absorber and the
    supports act on); ``parts`` holds all of them.

    Args:
        parts: integrators of the unknowns, created with the same scheme and
            ρ∞, before any form is built from them.
    """

    def __init__(self, parts: list[TimeIntegrator]):
        if not parts or len({(p.scheme, p.params) for p in parts}) != 1:
            raise ValueError("BlockIntegrator needs integrators of one scheme and ρ∞")
        first = parts[0]
        for p in parts[1:]:
            p.dt, p.t = first.dt, first.t
        self.parts = parts
        self.scheme = first.scheme
        self.dynamic = first.dynamic
        self.params = first.params
        self.u, self.u0, self.v0, self.a0 = first.u, first.u0, first.v0, first.a0
        self.dt, self.t = first.dt, first.t

    @property
    def time(self) -> float:
        """t_n (s)."""
        return self.parts[0].time

    @time.setter
    def time(self, value: float) -> None:
        for p in self.parts:
            p.time = value

    def stage_time(self, t0: float, dt: float) -> float:
        """Time at which loads are evaluated for the step t0 → t0 + dt (s)."""
        return self.parts[0].stage_time(t0, dt)

    def velocity(self) -> ufl.core.expr.Expr:
        """v_{n+1} of the first part (UFL)."""
        return self.parts[0].velocity()

    def begin(self, dt: float) -> float:
        """:meth:`TimeIntegrator.begin` of every part; returns the stage time (s)."""
        stages = [p.begin(dt) for p in self.parts]  # every part, not just the first
        return stages[0]

    def restore(self) -> None:
        """Every part's iterate back to its u_n."""
        for p in self.parts:
            p.restore()

    def advance(self) -> None:
        """Accept the step in every part."""
        for p in self.parts:
            p.advance()

    def set_state(
        self,
        t: float,
        u: np.ndarray | None = None,
        v: np.ndarray | None = None,
        a: np.ndarray | None = None,
    ) -> None:
        """t_n of every part and (optionally) the first part's arrays."""
        self.parts[0].set_state(t, u, v, a)
        for p in self.parts[1:]:
            p.set_state(t)
