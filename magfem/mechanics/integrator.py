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

**ρ∞ = 1: energy conserving.** With αm = αf = 1/2, β = 1/4, γ = 1/2 the
updates give a_{n+1/2} = (v_{n+1} − v_n)/Δt and (u_{n+1} − u_n)/Δt =
(v_n + v_{n+1})/2 whatever a_n is: the scheme is the implicit midpoint rule
in (u, v), and a_n plays no part (so a change of Δt cannot disturb it). The
midpoint rule conserves the energy of linear systems only; on a
geometrically nonlinear membrane it lets fast, unresolved components (the
volumetric and membrane modes that a switched field sets ringing and that
ρ∞ = 1 never damps) pump energy into the motion. So at ρ∞ = 1 the forces of
the potential Π (elastic energy, conservative loads) are replaced by their
average over the step, the *average vector field* (Quispel & McLaren,
J. Phys. A 41 (2008) 045206; for elastodynamics cf. the energy–momentum
methods of Simo & Tarnow, ZAMP 43 (1992) 757–792, and Gonzalez, CMAME 190
(2000) 1763–1783):

    δΠ(u_{n+1/2}) → ∫₀¹ δΠ(u_n + s (u_{n+1} − u_n)) ds   (Gauss–Legendre in s),

so that ½ v·M v + Π changes by exactly ∫₀¹ δΠ(…)[Δu] ds − ΔΠ = 0 (to the
s-quadrature, exact for energies up to quartic in u with two points: Saint
Venant–Kirchhoff) plus the work of non-conservative loads and contacts. It
stays a symmetric, second-order method. Its velocity v_n carries an
alternating component (undamped fast modes) which makes the usual
predictor u_n + Δt v_n throw near-incompressible bodies far off (inverted
elements, NaN); the predictor is u_n + Δt w_n with w_n = (u_n − u_{n−1})/Δt_{n−1}
= (v_{n−1} + v_n)/2, the mean velocity of the last step, which has none.

**ρ∞ < 1: step-size changes.** a_n approximates ü(t_n + δΔt), δ = αm − αf
(Erlicher, Bonaventura & Bursi, Comput. Mech. 28 (2002) 83–104; Arnold &
Brüls, Multibody Syst. Dyn. 18 (2007) 185–202), at the Δt of the step that
computed it. A step of another length Δt' reads it as ü(t_n + δΔt'): an
O(Δt) error in a_n at every change, which makes the scheme first order when
the step changes often. Before a step of length Δt' ≠ Δt the integrator
shifts a_n along the last step's acceleration slope:

    a_n ← a_n + c (a_n − ã_{n−1}),   c = δ (Δt' − Δt)/Δt clipped to [−1, 1],

with ã_{n−1} the (shifted) a that the last step used; the clip keeps the
shift an interpolation on large step growth (it is stable for step ratios
in [1/4, 4]). ρ∞ = 1 and Newmark have δ = 0.

**Local error estimate.** The displacement's local error of the family is
(β + δ/2 − 1/6) Δt³ u⃛ (Taylor expansion of the Newmark update with
a_n ≈ ü(t_n + δΔt); at δ = 0 the estimate of Zienkiewicz & Xie, EESD 20
(1991) 871–887, (β − 1/6) Δt² (a_{n+1} − a_n)). u⃛ is taken as 6 × the
third divided difference of the last four displacements, which neither the
alternating a_n and v_n of ρ∞ = 1 nor a switch (the history restarts at
switching instants) pollute; at ρ∞ = 1 of the midpoints (u_{k−1} + u_k)/2
of the last five, where the undamped fast modes (which alternate in sign
from step to step) keep at most 2/(ωΔt) of their amplitude.
:meth:`TimeIntegrator.local_error` returns its largest nodal value (m).

The step is stage → solve → check convergence → :meth:`advance` (or
:meth:`restore` after a failed solve, then retry with a smaller step).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

__all__ = [
    "AVERAGE_POINTS",
    "AlphaParameters",
    "Residual",
    "TimeIntegrator",
    "alpha_parameters",
]

AVERAGE_POINTS = 2
"""Gauss–Legendre points in s of the average vector field at ρ∞ = 1."""

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

    @property
    def delta(self) -> float:
        """δ = αm − αf: a_n approximates ü(t_n + δΔt)."""
        return self.alpha_m - self.alpha_f

    @property
    def conserving(self) -> bool:
        """αm = αf = 1/2 (generalized-α at ρ∞ = 1): the implicit midpoint rule."""
        return self.alpha_m == 0.5 and self.alpha_f == 0.5

    @property
    def error_constant(self) -> float:
        """C of the displacement's local error C Δt³ u⃛: β + δ/2 − 1/6."""
        return self.beta + 0.5 * self.delta - 1.0 / 6.0


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
        average_forces: at ρ∞ = 1, average the potential's forces over the step
            (``on``), keep them at the midpoint (``off``), or ``auto``: off for a
            free body (:meth:`potential_points`).

    Attributes:
        u0, v0, a0: state at t_n (m, m/s, m/s²), same space as ``u``; during
            a step a0 is a_n as that step uses it (shifted after a step-size change).
        dt: ``fem.Constant`` step (s). t: ``fem.Constant`` stage time (s).
        params: the α coefficients (None for quasi-static).
        conserving: ρ∞ = 1 generalized-α, with the average vector field.
        history: accepted (t, u) pairs since the last restart, latest last
            (at most five; u as local arrays), for :meth:`local_error`.
    """

    def __init__(
        self,
        u: fem.Function,
        scheme: str,
        *,
        rho_inf: float = 1.0,
        dt: float = 1.0,
        average_forces: str = "auto",
    ):
        self.u = u
        self.scheme = scheme
        self.dynamic = scheme != "quasi_static"
        self.params = alpha_parameters(scheme, rho_inf) if self.dynamic else None
        self.conserving = self.params is not None and self.params.conserving
        self.average_forces = average_forces
        V = u.function_space
        mesh = V.mesh
        self.u0 = fem.Function(V, name="u_n")
        self.v0 = fem.Function(V, name="velocity")
        self.a0 = fem.Function(V, name="acceleration")
        self.dt = fem.Constant(mesh, float(dt))
        self.t = fem.Constant(mesh, 0.0)
        self.time = 0.0  # t_n (s)
        self.parts = [self]  # as BlockIntegrator.parts
        # the a the last step used and its length, a_n before this step's shift
        self.a_used: np.ndarray | None = None
        self._a_unshifted: np.ndarray | None = None
        self._restarted = False
        self._failed = False
        self.last_dt: float | None = None
        self.mean_velocity: np.ndarray | None = None  # w_n, the predictor's at ρ∞ = 1
        self.history: list[tuple[float, np.ndarray]] = []

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

    def potential_points(
        self, free_body: bool = False
    ) -> list[tuple[float, list[ufl.core.expr.Expr]]] | None:
        """(weight, [u_n + s (u − u_n)]) at the Gauss points s of the average vector field.

        None unless :attr:`conserving` and ``average_forces`` is on (or ``auto``
        and the body is held: a free body keeps the midpoint rule, which
        conserves its momentum and angular momentum): the potential's forces
        then act at the stage point.
        """
        mode = self.average_forces
        if not self.conserving or mode == "off" or (mode == "auto" and free_body):
            return None
        x, w = np.polynomial.legendre.leggauss(AVERAGE_POINTS)
        return [
            (0.5 * float(wk), [self.u0 + 0.5 * (float(xk) + 1.0) * (self.u - self.u0)])
            for xk, wk in zip(x, w, strict=True)
        ]

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
        """Set Δt, the stage time, a_n for this Δt and the predictor.

        The predictor is u_n + Δt v_n, or u_n + Δt w_n at ρ∞ = 1 (module
        docstring); u_n for quasi-static runs and after a failed attempt.
        Returns the stage time (s); the caller updates time-dependent loads to it.
        """
        self.dt.value = dt  # type: ignore[assignment]
        t_stage = self.stage_time(self.time, dt)
        self.t.value = t_stage  # type: ignore[assignment]
        x = self.u.x.array
        if not self.dynamic:
            x[:] = self.u0.x.array
            return t_stage
        a0 = self.a0.x.array
        if self._a_unshifted is not None:  # the shift of a failed attempt
            a0[:] = self._a_unshifted
            self._a_unshifted = None
        c = self.acceleration_shift(dt)
        if c != 0.0 and self.a_used is not None:
            self._a_unshifted = a0.copy()
            a0 += c * (a0 - self.a_used)
        if self._failed:  # a retry starts from u_n: the extrapolation may be what failed
            x[:] = self.u0.x.array
            return t_stage
        rate = self.v0.x.array if self.mean_velocity is None else self.mean_velocity
        x[:] = self.u0.x.array + dt * rate
        return t_stage

    def acceleration_shift(self, dt: float) -> float:
        """c of the shift of a_n before a step of length dt (0 without a step change)."""
        p = self.params
        if p is None or p.delta == 0.0 or self.last_dt is None or dt == self.last_dt:
            return 0.0
        return float(np.clip(p.delta * (dt - self.last_dt) / self.last_dt, -1.0, 1.0))

    def restore(self) -> None:
        """Undo a failed or rejected solve: the iterate goes back to u_n."""
        self.u.x.array[:] = self.u0.x.array
        self._failed = True

    def advance(self) -> None:
        """Accept the solved u_{n+1}: update (u_n, v_n, a_n), t_n and the history in place."""
        dt = float(self.dt.value)
        u1 = self.u.x.array
        if self.dynamic:
            p = self._alpha()
            u0, v0, a0 = self.u0.x.array, self.v0.x.array, self.a0.x.array
            a1 = (u1 - u0 - dt * v0) / (p.beta * dt * dt) - (1.0 / (2.0 * p.beta) - 1.0) * a0
            v1 = v0 + dt * ((1.0 - p.gamma) * a0 + p.gamma * a1)
            # after a switching instant a_n is the left limit: no slope across it
            self.a_used = None if self._restarted else a0.copy()
            self._a_unshifted = None
            self.a0.x.array[:] = a1
            self.v0.x.array[:] = v1
            if self.conserving:
                self.mean_velocity = (u1 - u0) / dt
        else:
            if dt > 0:
                self.v0.x.array[:] = (u1 - self.u0.x.array) / dt
        self.last_dt = dt
        self._restarted = False
        self._failed = False
        self.u0.x.array[:] = u1
        self.time += dt
        self.history = [*self.history[-4:], (self.time, u1.copy())]

    def restart_history(self) -> None:
        """Forget the steps before t_n (a switching instant): the error estimate and the
        step-change shift start afresh from u_n."""
        self.history = [(self.time, self.u0.x.array.copy())]
        self.a_used = None
        self._restarted = True

    def local_error(self) -> float | None:
        """Estimated local error of the solved step's displacement, largest nodal value (m).

        |β + δ/2 − 1/6| Δt³ |u⃛|, u⃛ from the third divided difference of
        u_{n−2}, u_{n−1}, u_n and the unknown u_{n+1}, at ρ∞ = 1 of the
        midpoints of u_{n−3}, …, u_{n+1} (module docstring). None (on every
        rank) with fewer accepted states since the last restart, and for
        quasi-static runs. Collective.
        """
        need = 4 if self.conserving else 3
        if self.params is None or len(self.history) < need:
            return None
        dt = float(self.dt.value)
        points = [*self.history[-need:], (self.history[-1][0] + dt, self.u.x.array)]
        if self.conserving:  # midpoints: the undamped fast modes cancel there
            points = [
                (0.5 * (t0 + t1), 0.5 * (u0 + u1))
                for (t0, u0), (t1, u1) in itertools.pairwise(points)
            ]
        times = [t for t, _ in points]
        values = [v for _, v in points]
        for level in range(1, 4):  # Newton's divided differences, in place
            values = [
                (values[i + 1] - values[i]) / (times[i + level] - times[i])
                for i in range(len(values) - 1)
            ]
        V = self.u.function_space
        owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        local = float(np.max(np.abs(values[0][:owned]), initial=0.0))
        third = V.mesh.comm.allreduce(local, op=MPI.MAX)
        return abs(self.params.error_constant) * dt**3 * 6.0 * third

    def set_state(
        self,
        t: float,
        u: np.ndarray | None = None,
        v: np.ndarray | None = None,
        a: np.ndarray | None = None,
    ) -> None:
        """Set t_n and (optionally) the local arrays (owned + ghost) of u_n, v_n, a_n.

        The step history (step-change shift, mean velocity, error estimate) starts afresh.
        """
        self.time = float(t)
        for func, arr in ((self.u0, u), (self.v0, v), (self.a0, a)):
            if arr is not None:
                func.x.array[:] = arr
        self.u.x.array[:] = self.u0.x.array
        self.a_used = None
        self._a_unshifted = None
        self._restarted = False
        self._failed = False
        self.last_dt = None
        self.mean_velocity = None
        self.history = [(self.time, self.u0.x.array.copy())]

    def _alpha(self) -> AlphaParameters:
        if self.params is None:
            raise RuntimeError("the quasi-static integrator has no velocity or acceleration")
        return self.params
