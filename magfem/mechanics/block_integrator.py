"""Several unknowns stepped by one time integrator (the shell's and the rod's u and angles)."""

from __future__ import annotations

import numpy as np
import ufl

from magfem.mechanics.integrator import TimeIntegrator

__all__ = ["BlockIntegrator"]


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

    @property
    def conserving(self) -> bool:
        """ρ∞ = 1 generalized-α, with the average vector field."""
        return self.parts[0].conserving

    def velocity(self) -> ufl.core.expr.Expr:
        """v_{n+1} of the first part (UFL)."""
        return self.parts[0].velocity()

    def potential_points(
        self, free_body: bool = False
    ) -> list[tuple[float, list[ufl.core.expr.Expr]]] | None:
        """(weight, the state of every part) at the average vector field's points, or None."""
        per_part = [p.potential_points(free_body) for p in self.parts]
        first = per_part[0]
        if first is None:
            return None
        return [
            (weight, [points[k][1][0] for points in per_part if points is not None])
            for k, (weight, _) in enumerate(first)
        ]

    def local_error(self) -> float | None:
        """The displacement's (first part's) local error estimate (m), collective."""
        return self.parts[0].local_error()

    def restart_history(self) -> None:
        """:meth:`TimeIntegrator.restart_history` of every part."""
        for p in self.parts:
            p.restart_history()

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

    def set_state(self, t: float, **arrays: np.ndarray | None) -> None:
        """t_n of every part and (optionally) the first part's ``u``, ``v``, ``a`` arrays."""
        self.parts[0].set_state(t, **arrays)
        for p in self.parts[1:]:
            p.set_state(t)
