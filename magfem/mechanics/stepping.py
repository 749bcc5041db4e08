"""Step control of the time loop: step lengths, switching instants, cuts and growth.

* Steps land exactly on the loads' switching instants (a square wave's
  switches, ``breakpoints``) and on the end time: a step that would cross
  one is shortened to end on it (and one within 5 % past it is stretched).
  Loads are evaluated at the stage time t_{n+1−αf}, strictly inside the
  step, so a step sees one side of a switch only.
* A failed Newton solve cuts the step by ``cut_factor`` and retries, at
  most ``max_cuts`` times in a row and never below ``min_step``; then
  :class:`SimulationError` is raised.
* A slow solve (>= ``slow_iterations``) cuts the next step; two easy solves
  in a row (<= ``easy_iterations``) grow it by ``grow_factor`` up to
  ``max_step``. A solve's cost is its Newton iterations, or, with
  ``[solver] reuse_jacobian``, its Jacobian assemblies
  (:attr:`~magfem.mechanics.solver.NewtonReport.effort`). Every change is reported through ``say``.
* With ``tolerance`` (error control) the easy-solve rule gives way to the
  integrator's local error estimate e (m,
  :meth:`~magfem.mechanics.integrator.TimeIntegrator.local_error`) against
  tolerance × L, L the size of the body: η = e/(tolerance L). A step with
  η > 1 is rejected and retried with Δt·max(0.2, 0.8 η^(−1/3)) (the local
  error is O(Δt³)); an accepted one sets the next step to
  Δt·min(grow_factor, max(0.2, 0.8 η^(−1/3))) within [min_step, max_step].
  A step shortened to land on a switch never grows the nominal step; at
  ``min_step`` a step is accepted whatever its error (and said so). The
  estimate needs three accepted states since the start or the last switch:
  until then the step keeps its length.
* A contact may bound the next step (``limit``, e.g. self-contact while
  two surfaces approach faster than its search can follow,
  :meth:`~magfem.mechanics.contacts.base.Contact.step_limit`); the nominal
  step is kept.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from mpi4py import MPI

from magfem.mechanics.solver import NewtonReport
from magfem.mechanics.spec import TimeSpec

__all__ = [
    "SimulationError",
    "StepController",
    "body_size",
    "error_factor",
    "stop_reason",
    "switching_instants",
]

SAFETY = 0.8
"""Fraction of the step that the error estimate allows which the controller takes."""
SHRINK_LIMIT = 0.2
"""Smallest step multiplier after one error estimate."""


class SimulationError(RuntimeError):
    """The time loop could not continue (Newton failed at the smallest step)."""


Breakpoints = Callable[[float, float], npt.NDArray[np.float64]]
"""(t0, t1) -> switching instants in (t0, t1] (s), sorted."""


def error_factor(eta: float, grow: float) -> float:
    """Step multiplier for the scaled local error η (O(Δt³)), within [0.2, grow]."""
    if eta <= 0.0:
        return grow
    return min(grow, max(SHRINK_LIMIT, SAFETY * eta ** (-1.0 / 3.0)))


def stop_reason(spec: TimeSpec, cuts: int, next_dt: float) -> str:
    """Why a failed step ends the run ("" if the step may be cut and retried)."""
    if not spec.adaptive:
        return "time.adaptive is off"
    if cuts > spec.max_cuts:
        return f"more than time.max_cuts = {spec.max_cuts} cuts in a row"
    if next_dt < spec.smallest_step:
        return f"the next step would be below time.min_step = {spec.smallest_step:.3g} s"
    return ""


class StepController:
    """Chooses the step lengths of a run (module docstring).

    Args:
        spec: the ``[time]`` table.
        breakpoints: switching instants of the loads.
        say: reports a step-control event (one line).
        length: L, the size of the body (m) that ``tolerance`` is relative to.
        limit: the longest next step the contacts allow (s; inf: any), at the accepted state.

    Attributes:
        dt: the nominal length of the next step (s).
        steps, cuts, rejections, newton_iterations: totals over the run
            (``cuts`` counts the rejections too).
        last_error: η of the last estimate (None before the first).
    """

    def __init__(
        self,
        spec: TimeSpec,
        breakpoints: Breakpoints,
        say: Callable[[str], None],
        *,
        length: float = 1.0,
        limit: Callable[[], float] = lambda: np.inf,
    ):
        self.spec = spec
        self.breakpoints = breakpoints
        self.say = say
        self.length = length
        self.limit = limit
        self.dt = spec.step
        self.steps = 0
        self.cuts = 0
        self.rejections = 0
        self.newton_iterations = 0
        self.last_error: float | None = None
        self._easy = 0

    @property
    def controls_error(self) -> bool:
        """Steps are chosen from the local error estimate (``tolerance`` set, adaptive)."""
        return self.spec.tolerance is not None and self.spec.adaptive

    def judge(self, t: float, dt: float, error: float | None, cuts: int) -> float | None:
        """Accept a converged step of length dt from t (None) or return the step to retry.

        ``error``: the local error estimate (m) or None (no estimate: accepted);
        ``cuts``: cuts of this step so far.

        Raises:
            SimulationError: the step may not be cut again (``stop_reason``).
        """
        if error is None or not self.controls_error:
            return None
        eta = error / (self._tolerance * self.length)
        self.last_error = eta
        if eta <= 1.0:
            return None
        new_dt = max(dt * error_factor(eta, 1.0), self.spec.smallest_step)
        if new_dt >= dt:  # already at min_step: the tolerance is out of reach
            self.say(f"t = {t:.6g} s: local error {eta:.3g} × tolerance at time.min_step: accepted")
            return None
        self.cuts += 1
        self.rejections += 1
        why = stop_reason(self.spec, cuts + 1, new_dt)
        if why:
            raise SimulationError(
                f"t = {t:.6g} s: local error {eta:.3g} × tolerance at dt = {dt:.3g} s "
                f"after {cuts} cut(s): {why}"
            )
        self.say(
            f"t = {t:.6g} s: local error {eta:.3g} × tolerance; step cut {dt:.3g} -> {new_dt:.3g} s"
        )
        self.dt = new_dt
        return new_dt

    @property
    def _tolerance(self) -> float:
        if self.spec.tolerance is None:
            raise RuntimeError("no time.tolerance")
        return self.spec.tolerance

    def next_step(self, t: float) -> tuple[float, bool]:
        """Length of the next step from t and whether it lands on a switching instant."""
        end = self.spec.end
        dt = min(self.dt, end - t, max(self.limit(), self.spec.min_step or 0.0))
        stop = t + dt
        ahead = self.breakpoints(t, min(t + 1.05 * dt, end))
        ahead = ahead[ahead > t + 1e-9 * dt]
        if ahead.size:
            return float(ahead[0] - t), True
        if end - stop < 0.05 * dt:
            return end - t, False
        return dt, False

    def cut(self, t: float, dt: float, cuts: int, report: NewtonReport) -> float:
        """The step after the ``cuts``-th failure in a row of a step of length dt at t.

        Raises:
            SimulationError: the step may not be cut again (``stop_reason``).
        """
        self.cuts += 1
        new_dt = dt * self.spec.cut_factor
        why = stop_reason(self.spec, cuts, new_dt)
        if why:
            raise SimulationError(
                f"t = {t:.6g} s: Newton failed ({report.reason_name}, "
                f"{report.iterations} it, ‖R‖ = {report.residual_norm:.3g}) "
                f"at dt = {dt:.3g} s after {cuts} cut(s): {why}"
            )
        self.say(
            f"t = {t:.6g} s: Newton failed ({report.reason_name}, "
            f"{report.iterations} it); step cut {dt:.3g} -> {new_dt:.3g} s"
        )
        self.dt = new_dt
        return new_dt

    def land(self, t: float, dt: float, on_break: bool) -> float:
        """The end time of an accepted step of length dt from t (exact switch or end time)."""
        t_new = t + dt
        if on_break:
            t_new = float(self.breakpoints(t, t + 1.01 * dt)[0])
        if abs(self.spec.end - t_new) < 1e-9 * dt:
            t_new = self.spec.end
        return t_new

    def accepted(
        self, t: float, report: NewtonReport, cuts: int, dt: float, error: float | None = None
    ) -> None:
        """Count an accepted step of length dt ending at t and choose the next step.

        From the local error estimate ``error`` (m) under error control, else
        from the Newton cost; a slow solve cuts the next step in both.
        """
        spec = self.spec
        self.steps += 1
        self.newton_iterations += report.iterations
        if self.controls_error:
            self._from_error(t, dt, error)
        if spec.adaptive and report.effort >= spec.slow_iterations:
            new_dt = max(self.dt * spec.cut_factor, spec.smallest_step)
            self.say(
                f"t = {t:.6g} s: slow Newton ({_effort(report)}); "
                f"next step {self.dt:.3g} -> {new_dt:.3g} s"
            )
            self.dt = new_dt
        easy = report.effort <= spec.easy_iterations and cuts == 0
        self._easy = self._easy + 1 if easy else 0
        if self.controls_error:
            return
        if self._easy >= 2 and spec.adaptive and self.dt < spec.largest_step:
            new_dt = min(self.dt * spec.grow_factor, spec.largest_step)
            self.say(f"t = {t:.6g} s: easy steps; step grown {self.dt:.3g} -> {new_dt:.3g} s")
            self.dt = new_dt
            self._easy = 0

    def state(self) -> dict[str, Any]:
        """Its memory (step length, counts, streaks: every plain attribute), for checkpoints."""
        return {
            k: v
            for k, v in vars(self).items()
            if isinstance(v, bool | int | float | str | np.ndarray | list | tuple)
        }

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`state`."""
        for k, v in state.items():
            setattr(self, k, v)

    def _from_error(self, t: float, dt: float, error: float | None) -> None:
        """The next nominal step from the accepted step's error estimate (module docstring)."""
        if error is None:
            return
        spec = self.spec
        factor = error_factor(error / (self._tolerance * self.length), spec.grow_factor)
        proposal = min(max(dt * factor, spec.smallest_step), spec.largest_step)
        if dt < self.dt:  # shortened to land on a switch: never grows the nominal step
            proposal = min(proposal, self.dt)
        self.dt = proposal

    def summary(self) -> dict[str, float]:
        """Step counts of the run."""
        return {
            "steps": float(self.steps),
            "newton_iterations": float(self.newton_iterations),
            "mean_newton_iterations": self.newton_iterations / max(self.steps, 1),
            "cuts": float(self.cuts),
            "rejected_steps": float(self.rejections),
        }


def body_size(model: Any) -> float:
    """Diagonal of the bounding box of the reference mesh (m; collective)."""
    x = model.robot.mesh.geometry.x
    comm = model.robot.mesh.comm
    lo, hi = np.empty(x.shape[1]), np.empty(x.shape[1])
    comm.Allreduce(np.min(x, axis=0, initial=np.inf), lo, op=MPI.MIN)
    comm.Allreduce(np.max(x, axis=0, initial=-np.inf), hi, op=MPI.MAX)
    return float(np.linalg.norm(hi - lo))


def switching_instants(parts: Sequence[Any], t0: float, t1: float) -> npt.NDArray[np.float64]:
    """Switching instants of the loads and contacts ``parts`` in (t0, t1] (s), sorted."""
    found = [np.asarray(p.breakpoints(t0, t1), dtype=float) for p in parts]
    return np.unique(np.concatenate(found)) if found else np.zeros(0)


def step_limit(contacts: Sequence[Any]) -> float:
    """The longest next step the ``contacts`` allow (s; inf: any; collective)."""
    limits = [c.step_limit() for c in contacts]
    return min((x for x in limits if x is not None), default=np.inf)


def _effort(report: NewtonReport) -> str:
    """A solve's iterations, and its Jacobians where it kept some, for messages."""
    if report.jacobians is None:
        return f"{report.iterations} it"
    return f"{report.iterations} it, {report.jacobians} Jacobians"
