"""The time loop: a problem stepped by a controller, observed and written as it goes.

Per step (dolfiny-style): choose Δt (:class:`~magfem.mechanics.stepping.StepController`)
→ stage (integrator predictor, loads at the stage time, contacts refreshed)
→ Newton solve → accept (contacts act on the new state) or cut and retry.
After every accepted step the observers give a history row, which the
writers receive. With a history interval, the row is kept only at the first
step at or after each multiple of the interval, at the last step and where a
writer asks for one (an animation frame); at the other steps only the
contacts and the observers with memory (a ``state`` method: angle unwrapping,
integrals over time, touch events) observe, and the writers get no row. The
loop holds lists of loads, contacts, observers and writers and never names one.

The initial acceleration is consistent: M a₀ = −R(u₀, v₀, 0; t₀) (a linear
solve), so gravity and a field switched on at t₀ act from the first step.

After every step a :class:`~magfem.mechanics.checkpoint.RunControl` may
write a checkpoint and stop the run on a signal (the writers write the last
state first); a run restored from a checkpoint gives the rows the run
would have given without the stop. A failed run (:class:`SimulationError`,
on every rank alike) writes its last state too; any other exception may be
one rank's only and ends the loop without collective calls.

Quasi-static runs start from the static equilibrium under their constant
loads at t₀ (:mod:`.settling`).
"""

from __future__ import annotations

import functools
import time as _time
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from mpi4py import MPI

from magfem.errors import RunInterrupted
from magfem.mechanics.checkpoint import (
    RunControl,
    load_part_state,
    part_state,
    restore_run,
    run_state,
)
from magfem.mechanics.observers import Observer, history_summary
from magfem.mechanics.output import Writer
from magfem.mechanics.problem import Problem
from magfem.mechanics.run_record import EventLog, SimulationResult
from magfem.mechanics.settling import settle
from magfem.mechanics.solver import NewtonReport, NewtonSolver, load_norm, solve_linear
from magfem.mechanics.spec import SolverSpec, TimeSpec
from magfem.mechanics.stepping import (
    SimulationError,
    StepController,
    body_size,
    step_limit,
    switching_instants,
)
from magfem.parallel import progress as progress_bar

__all__ = ["STANDARD_GRAVITY", "Simulation", "SimulationError", "SimulationResult"]

STANDARD_GRAVITY = 9.80665
"""g₀ (m/s²), for the force scale of ``[solver] force_tolerance``."""


class Simulation:
    """A problem's dolfinx objects, built once and stepped (collective).

    Args:
        problem: the model with its loads and contacts.
        time: ``[time]``.
        solver: ``[solver]``.
        observers: history columns, evaluated in this order after the
            contacts' own (which refresh their data at the accepted state).
        frequency: the drive frequency (Hz) for the per-period summary, or None.
        name: the run's name (progress bar).
        setup_time: seconds spent before (mesh, field), for the timings.
        compile_time: seconds spent compiling the observers' forms, for the timings.
        history_interval: keep a history row every this many seconds (module
            docstring; 0: every step).
    """

    def __init__(
        self,
        problem: Problem,
        time: TimeSpec,
        solver: SolverSpec,
        *,
        observers: Sequence[Observer] = (),
        frequency: float | None = None,
        name: str = "run",
        setup_time: float = 0.0,
        compile_time: float = 0.0,
        history_interval: float = 0.0,
    ):
        self.problem = problem
        self.model = model = problem.model
        self.comm: MPI.Comm = model.robot.mesh.comm
        self.time_spec = time
        self.solver_spec = solver
        self.frequency = frequency
        self.name = name
        self.setup_time = setup_time
        self.integrator = model.integrator
        self.u = model.u
        self.solver = NewtonSolver(
            problem.residual,
            problem.unknowns if len(problem.unknowns) > 1 else model.u,
            model.bcs,
            solver,
            name="step",
            homogeneous_bcs=True,
            refresh_on=[model.integrator.dt],
        )
        if solver.force_tolerance > 0.0:
            self.solver.set_force_scale(self.weight_scale())
        for contact in problem.contacts:
            contact.attach(self.solver)
        self.observers: list[Any] = [*problem.contacts, *observers]
        self.observer_compile_time = compile_time
        self.history_interval = history_interval
        self.rows: list[dict[str, float]] = []  # the history so far: the rows kept
        self.pending: tuple[int, dict[str, float]] | None = None  # the last step's, if not kept
        self.events = EventLog(self.comm)
        # no reference back to this object from its parts: a cycle through PETSc objects
        # would leave their (collective) destruction to the garbage collector's timing
        self.controller = StepController(
            time,
            functools.partial(switching_instants, [*problem.loads, *problem.contacts]),
            self.events.say,
            length=body_size(model),
            limit=functools.partial(step_limit, problem.contacts),
        )

    @property
    def gdim(self) -> int:
        """Geometric dimension of the mesh."""
        return self.model.gdim

    @property
    def log(self) -> list[str]:
        """Step-control and contact events so far, one line each."""
        return self.events.lines

    # --- observation ------------------------------------------------------------------------

    def columns(self) -> list[str]:
        """History column names."""
        cols = ["time", "dt", "newton_iterations", "cuts"]
        for observer in self.observers:
            cols += observer.columns()
        return cols

    def column_units(self) -> dict[str, str]:
        """Units of the columns whose parts declare them (``units()``); see :mod:`.columns`."""
        out: dict[str, str] = {}
        for observer in self.observers:
            declared = getattr(observer, "units", None)
            if callable(declared):
                out |= declared()
        return out

    def observes_every_step(self, observer: Any) -> bool:
        """Whether ``observer`` observes after every step, its row kept or not: a contact,
        or an observer with memory (a ``state`` method)."""
        return observer in self.problem.contacts or callable(getattr(observer, "state", None))

    def observe(self, t: float, *, keep: bool = True) -> dict[str, float]:
        """Observables at the accepted state u_n (collective). Angles in rad, energies in J.

        ``keep=False``: only the observers that observe every step (:meth:`observes_every_step`).
        """
        self.update_loads(t, "left", self.u)
        row: dict[str, float] = {"time": t}
        for observer in self.observers:
            if keep or self.observes_every_step(observer):
                row |= observer.observe(t)
        return row

    def _keeps_row(self, step: int, t: float, writers: Sequence[Writer]) -> bool:
        """Whether the history keeps the row of accepted step ``step`` ending at t (s)."""
        interval = self.history_interval
        if interval <= 0.0 or any(w.wants_row(step, t) for w in writers):
            return True
        start, end = self.time_spec.start, self.time_spec.end
        if t >= end - 1e-12 * (end - start):
            return True
        last = float(self.rows[-1]["time"]) if self.rows else start
        due = start + (np.floor((last - start) / interval + 1e-9) + 1.0) * interval
        return bool(t >= due - 1e-9 * interval)

    def update_loads(self, t: float, side: str, displacement: Any) -> None:
        """Set every load to time t (s), on the ``side`` of a switch, at ``displacement``."""
        for load in self.problem.loads:
            load.update(t, side=side, displacement=displacement)

    # --- stepping ---------------------------------------------------------------------------

    def initialise(self) -> NewtonReport | None:
        """Set t₀ and the consistent initial acceleration (dynamic schemes) or settle."""
        integ = self.integrator
        t0 = self.time_spec.start
        integ.set_state(t0)
        if not integ.dynamic:
            settle(self)
            return None
        self.update_loads(t0, "right", self.u)
        integ.t.value = t0  # type: ignore[assignment]
        self._before_solve()
        parts = integ.parts
        acc = [fem.Function(p.u.function_space) for p in parts]
        form = self.problem.continuous_residual([p.u0 for p in parts], [p.v0 for p in parts], acc)
        report = solve_linear(
            form, acc if len(acc) > 1 else acc[0], self.model.bcs, self.solver_spec, name="a0"
        )
        if not report.converged:
            raise SimulationError(
                f"initial acceleration solve failed ({report.reason_name}, ‖R‖ = "
                f"{report.residual_norm:.3g})"
            )
        for p, a in zip(parts, acc, strict=True):
            p.a0.x.array[:] = a.x.array
        return report

    def _before_solve(self) -> None:
        for contact in self.problem.contacts:
            contact.before_solve()
        if self.problem.pressure is not None:
            self.problem.pressure.guess()

    def accept(self) -> None:
        """Accept the solved step: the integrator advances, contacts act on the new state."""
        integ = self.integrator
        integ.advance()
        if integ.dynamic:
            for contact in self.problem.contacts:
                contact.after_step()

    def attempt(self, dt: float, *, settling: bool = False) -> NewtonReport:
        """Solve the step of length dt from t_n; the caller accepts it or restores u_n.

        ``settling``: a load-continuation increment at t₀ (loads as they are, no retry).
        """
        integ = self.integrator
        t_stage = integ.begin(dt)
        if not settling:
            self.update_loads(t_stage, "right" if integ.dynamic else "left", integ.u0)
        self._before_solve()
        report = self.solver.solve()
        if not report.converged and report.iterations <= 1 and not settling:
            # the predictor (u_n + Δt v_n) can invert thin elements after a sudden load:
            # retry once from u_n before the step is cut
            integ.restore()
            self._before_solve()
            retry = self.solver.solve()
            report = NewtonReport(
                retry.converged,
                retry.reason,
                report.iterations + retry.iterations,
                report.linear_iterations + retry.linear_iterations,
                retry.residual_norm,
                None if report.jacobians is None else report.jacobians + (retry.jacobians or 0),
            )
        return report

    def step(self, t: float) -> tuple[float, NewtonReport, int]:
        """Advance from t by one accepted step, cutting it after failures.

        Returns (the new time, the accepted solve's report, cuts of this step).

        Raises:
            SimulationError: the step cannot be cut any further.
        """
        control, integ = self.controller, self.integrator
        dt, on_break = control.next_step(t)
        cuts, error = 0, None
        while True:
            report = self.attempt(dt)
            if report.converged:
                error = integ.local_error() if control.controls_error else None
                retry = control.judge(t, dt, error, cuts)
                if retry is None:
                    break
            else:
                retry = control.cut(t, dt, cuts + 1, report)
            integ.restore()
            cuts += 1
            dt, on_break = retry, False
        self.accept()
        t_new = control.land(t, dt, on_break)
        integ.time = t_new
        if on_break:  # the error estimate and the step-change shift restart at a switch
            integ.restart_history()
        control.accepted(t_new, report, cuts, dt, error)
        return t_new, report, cuts

    def weight_scale(self) -> float:
        """F_ref of ``[solver] force_tolerance`` (N; N/m for strips, collective).

        The norm of the robot's weight load vector ∫ ρ g₀·w dV under standard
        gravity g₀ = 9.80665 m/s² downwards, supports left out: a force scale of
        the robot whether gravity is applied or not.
        """
        model = self.model
        down = np.zeros(self.gdim)
        down[-1] = -STANDARD_GRAVITY
        w = model.tests[0]
        weight = model.mass_density * ufl.dot(ufl.as_vector(down.tolist()), w) * model.dx
        return load_norm(weight, model.displacement_bcs)

    def run(
        self,
        writers: Sequence[Writer] = (),
        *,
        progress: bool = True,
        control: RunControl | None = None,
    ) -> SimulationResult:
        """Integrate from ``time.start`` (or a checkpoint) to ``time.end``, handing rows to writers.

        Args:
            control: checkpoints, stop signals, the state to resume from (None: none).

        Raises:
            SimulationError: Newton failed ``max_cuts`` times in a row or below
                ``min_step`` (the writers keep the steps until then).
            RunInterrupted: ``control`` agreed on a stop signal; the checkpoint
                and the outputs of the steps until then are written.
        """
        spec = self.time_spec
        control = control or RunControl()
        t_wall = _time.perf_counter()
        t = self._start(writers, control)
        if progress:
            self.events.bar = progress_bar(
                spec.end - spec.start, desc=self.name, unit="s", comm=self.comm
            )
            self.events.bar.update(t - spec.start)
        stopped = 0

        def snapshot() -> dict[str, Any]:
            return {"simulation": self.state(), "writers": [part_state(w) for w in writers]}

        try:
            while t < spec.end - 1e-12 * (spec.end - spec.start):
                t = self._advance(t, writers)
                stopped = control.end_of_step(self.comm, self.controller.steps, t, snapshot)
                if stopped:
                    break
        except SimulationError:  # raised on every rank alike: write what there is
            self._close_bar()
            self._finish(writers, complete=False)
            raise
        finally:  # another exception may be this rank's alone: nothing collective
            self._close_bar()
        if not stopped and (control.written or control.resume is not None):
            control.save(self.controller.steps, t, snapshot(), "end")  # the folder's is current
        history = self._finish(writers, complete=not stopped)
        if stopped:
            where = control.written[-1] if control.written else None
            raise RunInterrupted(
                stopped,
                f"at t = {t:.6g} s after step {self.controller.steps}"
                + (f"; checkpoint {where}" if where is not None else "; no checkpoint"),
            )
        timings = self.timings()
        timings["total"] = _time.perf_counter() - t_wall
        return SimulationResult(
            history, self.summary(history), {}, list(self.log), timings, self.effort()
        )

    def _start(self, writers: Sequence[Writer], control: RunControl) -> float:
        """The initial state (t₀ or a checkpoint's), written or restored; returns its time (s)."""
        if control.resume is not None:
            t = self.restore(control.resume["simulation"])
            for w, state in zip(writers, control.resume["writers"], strict=True):
                load_part_state(w, state)
            return t
        self.initialise()
        t = self.time_spec.start
        self.rows = [self.observe(t) | {"dt": 0.0, "newton_iterations": 0, "cuts": 0}]
        for w in writers:
            w.write(0, t, self.rows[0])
        return t

    def _advance(self, t: float, writers: Sequence[Writer]) -> float:
        """One accepted step from t, observed and written; returns the new time (s)."""
        t_new, report, cuts = self.step(t)
        dt = t_new - t
        step = self.controller.steps
        keep = self._keeps_row(step, t_new, writers)
        row = self.observe(t_new, keep=keep) | {
            "dt": dt,
            "newton_iterations": report.iterations,
            "cuts": cuts,
        }
        if keep:
            self.rows.append(row)
            self.pending = None
        else:
            self.pending = (step, row)
        for contact in self.problem.contacts:
            for message in contact.events():
                self.events.say(message)
        for w in writers:
            w.write(step, t_new, row if keep else None)
        if self.events.bar is not None:
            self.events.bar.update(dt)
            self.events.bar.set_postfix_str(f"dt={dt:.2e} s, newton={report.iterations}")
        return t_new

    def _close_bar(self) -> None:
        if self.events.bar is not None:
            self.events.bar.close()
            self.events.bar = None

    def _finish(
        self, writers: Sequence[Writer], *, complete: bool
    ) -> dict[str, npt.NDArray[np.float64]]:
        """The writers write the last state, close and finish (collective); returns the history.

        The last accepted step's row is kept if it was not (a stopped or failed run).
        """
        if self.pending is not None:
            step, row = self.pending
            t = float(row["time"])
            self.update_loads(t, "left", self.u)
            for observer in self.observers:
                if not self.observes_every_step(observer):
                    row |= observer.observe(t)
            self.rows.append(row)
            self.pending = None
            for w in writers:
                w.late(step, t, row)
        step, row = self.controller.steps, self.rows[-1]
        for w in writers:
            w.last(step, float(row["time"]), row)
            w.close()
        history = {k: np.array([r.get(k, np.nan) for r in self.rows]) for k in self.columns()}
        for w in writers:
            w.finish(history, complete=complete)
        return history

    # --- checkpoints ------------------------------------------------------------------------

    def state(self) -> dict[str, Any]:
        """This rank's state at the last accepted step (:func:`.checkpoint.run_state`)."""
        return run_state(self)

    def restore(self, state: dict[str, Any]) -> float:
        """Continue from :meth:`state` (:func:`.checkpoint.restore_run`); returns t_n (s)."""
        return restore_run(self, state)

    def summary(self, history: dict[str, npt.NDArray[np.float64]]) -> dict[str, float]:
        """Step counts, the history's summary scalars and the contacts' (identical on all ranks)."""
        out = self.controller.summary()
        out |= history_summary(history, start=self.time_spec.start, frequency=self.frequency)
        for contact in self.problem.contacts:
            out |= contact.summary()
        return out

    def effort(self) -> dict[str, int]:
        """Newton iterations, Jacobians assembled, when kept why each was rebuilt, and the
        GMRES iterations of a Jacobian-free Newton."""
        s = self.solver.timings
        out = {"iterations": s.jacobian_calls + s.jacobian_reuses, "jacobians": s.jacobian_calls}
        if self.solver.reuse is not None:
            out |= {f"rebuilt_{k}": n for k, n in self.solver.reuse.rebuilds.items()}
        if self.solver_spec.jacobian_free:
            out["gmres_iterations"] = s.linear_iterations
        return out

    def timings(self) -> dict[str, float]:
        """Wall-time split (s) on this rank."""
        s = self.solver.timings
        return {
            "mesh_and_field": self.setup_time,
            "compile": s.compile + self.observer_compile_time,
            "residual": s.residual,
            "jacobian": s.jacobian,
            "linear_solve": s.linear_solve,
        }
