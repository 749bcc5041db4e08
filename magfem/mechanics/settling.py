"""Quasi-static runs: the equilibrium at t₀ under the constant loads, by load continuation.

A quasi-static run starts from the static equilibrium under its constant loads
(gravity) at t₀: a thin strip's sag under its own weight is a large
deflection that Newton from the flat state does not reach, and a constant
load does not shrink when the time step is cut. The load factor λ goes
0 → 1 in increments that halve after a failed solve (state restored) and
double after an easy one.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from magfem.mechanics.solver import NewtonReport
from magfem.mechanics.stepping import SimulationError

__all__ = ["settle"]


def settle(sim: Any, *, smallest: float = 1.0 / 1024) -> int:
    """Solve a quasi-static :class:`~magfem.mechanics.simulation.Simulation`'s equilibrium at
    t₀ by load continuation of its constant loads (collective).

    Returns the number of accepted load increments (0 when no load ramps, and for
    dynamic runs).

    Raises:
        SimulationError: an increment below ``smallest`` failed.
    """
    loads = [load for load in sim.problem.loads if load.ramp(1.0)]
    if sim.integrator.dynamic or not loads:
        return 0
    t0 = sim.time_spec.start
    sim.update_loads(t0, "left", sim.u)
    acceleration = sum(
        (a for a in (load.body_acceleration() for load in loads) if a is not None),
        np.zeros(sim.gdim),
    )
    for contact in sim.problem.contacts:
        contact.press(sim.model, acceleration)
    lam, step, accepted = 0.0, 1.0, 0
    try:
        while lam < 1.0:
            trial = min(1.0, lam + step)
            for load in loads:
                load.ramp(trial)
            report = _increment(sim)
            if report.converged:
                lam, accepted = trial, accepted + 1
                sim.controller.newton_iterations += report.iterations
                if report.effort <= sim.time_spec.easy_iterations:
                    step = min(2 * step, 1.0)
                continue
            step /= 2
            sim.log.append(
                f"load continuation: λ = {lam:.4g} -> {trial:.4g} failed "
                f"({report.reason_name}); increment {step:.3g}"
            )
            if step < smallest:
                raise SimulationError(
                    f"t = {t0:.6g} s: load continuation stalled at λ = {lam:.4g} "
                    f"({report.reason_name}, ‖R‖ = {report.residual_norm:.3g})"
                )
    finally:
        for load in loads:
            load.ramp(1.0)
    sim.log.append(f"load continuation: equilibrium at t₀ in {accepted} increment(s)")
    return accepted


def _increment(sim: Any) -> NewtonReport:
    """One load increment at t₀ (loads as they are, no retry): accepted, or the state
    restored."""
    report: NewtonReport = sim.attempt(0.0, settling=True)
    if report.converged:
        sim.accept()
    else:
        sim.integrator.restore()
    return report
