"""The time loop of a membrane run: :class:`MembraneSimulation` and :func:`simulate`.

Per step (dolfiny-style): choose Δt → stage (integrator predictor, field at
the stage time) → Newton solve → check convergence → advance or cut.

Step control:

* Steps land exactly on the field's switching instants
  (``FieldModel.breakpoints``) and on the end time: a step that would cross
  one is shortened to end on it (and one within 5 % past it is stretched).
  Loads are evaluated at the stage time t_{n+1−αf}, strictly inside the
  step, so a step sees one side of a switch only.
* A failed Newton solve (SNES reason <= 0, NaN) restores u_n, multiplies
  the step by ``cut_factor`` and retries, at most ``max_cuts`` times in a
  row and never below ``min_step``; then :class:`SimulationError` is raised
  (the CSV keeps every accepted step).
* A slow solve (>= ``slow_iterations``) cuts the next step; two easy solves
  in a row (<= ``easy_iterations``) grow it by ``grow_factor`` up to
  ``max_step``. Every change is logged (``SimulationResult.log``, and on
  rank 0 above the progress bar).

The initial acceleration is consistent: M a₀ = −R(u₀, v₀, 0; t₀) (a linear
solve), so gravity and a field switched on at t₀ act from the first step.

Quasi-static runs start from the static equilibrium under gravity at t₀,
reached by load continuation (:meth:`MembraneSimulation.settle_gravity`):
gravity is a constant load, so cutting the pseudo-time step cannot make
the first step smaller, and a thin strip's sag under its own weight is a
large deflection (200 µm × 9 mm arm, μ = 115 kPa: the small-deflection
formula gives w/L ≈ 1.2) that Newton from the flat state does not reach
(DIVERGED_DTOL, then NaN at every step cut: ``cases/active_length.toml``
before this change). The load factor λ of g goes 0 → 1 in increments that
halve after a failed solve (state restored) and double after an easy one.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from dolfinx import fem
from mpi4py import MPI

from magfem import material
from magfem.mechanics.observers import (
    AngleUnwrapper,
    MidlineProbe,
    PointEvaluator,
    StrainProbe,
    arm_angle_points,
    assemble_scalars,
    bending_angle,
    history_summary,
)
from magfem.mechanics.problem import MembraneProblem, build_membrane_problem
from magfem.mechanics.solver import JIT_OPTIONS, NewtonReport, NewtonSolver, solve_linear

STANDARD_GRAVITY = 9.80665
"""g₀ (m/s²), for the force scale of ``[solver] force_tolerance``."""

if TYPE_CHECKING:
    from magfem.case import Case
    from magfem.field.model import FieldModel
    from magfem.geometry.robot_mesh import RobotMesh
    from magfem.mechanics.spec import TimeSpec

__all__ = [
    "MembraneSimulation",
    "SimulationError",
    "SimulationResult",
    "drive_frequency",
    "simulate",
]


class SimulationError(RuntimeError):
    """The time loop could not continue (Newton failed at the smallest step)."""


def _stop_reason(spec: TimeSpec, cuts: int, next_dt: float) -> str:
    """Why a failed step ends the run ("" if the step may be cut and retried)."""
    if not spec.adaptive:
        return "time.adaptive is off"
    if cuts > spec.max_cuts:
        return f"more than time.max_cuts = {spec.max_cuts} cuts in a row"
    if next_dt < spec.smallest_step:
        return f"the next step would be below time.min_step = {spec.smallest_step:.3g} s"
    return ""


def drive_frequency(case: Case) -> float | None:
    """Frequency (Hz) of the first periodic field source, or None."""
    for src in getattr(case.field, "sources", ()):
        wf = getattr(src, "waveform", None)
        f = getattr(wf, "frequency", None) if wf is not None else None
        if f:
            return float(f)
    return None


@dataclass
class SimulationResult:
    """What a run produced (identical on every rank).

    Attributes:
        history: column name -> (steps + 1,) array (SI units; angles in rad).
        summary: scalar results (max angles over the first one/two periods, rad;
            largest strain; energy/power density J/m³, W/m³; step counts).
        paths: name -> written file (csv, vtx, png), possibly empty.
        log: step-control events, one line each.
        timings: wall time split (s) on rank 0: compile, residual, jacobian,
            linear_solve, total.
    """

    history: dict[str, npt.NDArray[np.float64]]
    summary: dict[str, float]
    paths: dict[str, Path] = field(default_factory=dict)
    log: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)


class MembraneSimulation:
    """A membrane run's dolfinx objects, built once and stepped (collective).

    Args:
        case: the validated case.
        comm: communicator.
        robot_mesh: a prebuilt mesh (default: ``create_robot_mesh`` of the case).
        field_model: a prebuilt field model (default: ``create_field_model``).

    Attributes:
        problem, solver, integrator: the pieces (see :mod:`.problem`, :mod:`.solver`).
        arms: arm name -> Arm.
    """

    def __init__(
        self,
        case: Case,
        comm: MPI.Comm = MPI.COMM_WORLD,
        *,
        robot_mesh: RobotMesh | None = None,
        field_model: FieldModel | None = None,
    ):
        t0 = _time.perf_counter()
        self.case = case
        self.comm = comm
        if robot_mesh is None:
            from magfem.geometry.robot_mesh import create_robot_mesh

            robot_mesh = create_robot_mesh(case.robot, case.mesh, comm)
        if field_model is None:
            from magfem.field.model import create_field_model

            field_model = create_field_model(case.field, comm)
        self.robot = robot_mesh
        self.field = field_model
        self.mesh_time = _time.perf_counter() - t0
        self.problem: MembraneProblem = build_membrane_problem(case, robot_mesh, field_model)
        self.integrator = self.problem.integrator
        self.u = self.problem.u
        unknowns = self.problem.unknowns
        self.solver = NewtonSolver(
            self.problem.residual,
            unknowns if len(unknowns) > 1 else self.u,
            self.problem.bcs,
            case.solver,
            name="step",
            homogeneous_bcs=True,
        )
        if case.solver.force_tolerance > 0.0:
            self.solver.set_force_scale(self._weight_scale())
        self.self_contact = self.problem.self_contact
        if self.self_contact is not None:  # coupled contact terms of every Newton iteration
            self.self_contact.attach(self.solver, self.problem.bcs)
        t1 = _time.perf_counter()
        self.energy_forms = {
            k: fem.form(f, jit_options=JIT_OPTIONS) for k, f in self.problem.energy_forms.items()
        }
        self.contact_forms = [
            fem.form(f, jit_options=JIT_OPTIONS) for f in self.problem.contact_forms
        ]
        self.observer_compile_time = _time.perf_counter() - t1
        gdim = robot_mesh.mesh.geometry.dim
        self.gdim = gdim
        self.arms = {arm.name: arm for arm in robot_mesh.arms}
        pts = np.vstack([arm_angle_points(a, gdim) for a in robot_mesh.arms]) if self.arms else None
        self._angle_points = pts
        self._angle_eval = PointEvaluator(self.u.function_space, pts) if pts is not None else None
        self._unwrap = {name: AngleUnwrapper() for name in self.arms}
        self.midline = (
            MidlineProbe(self.u.function_space, robot_mesh.arms, bonded=self._bonded_lengths())
            if self.arms
            else None
        )
        self.strain_probe = StrainProbe(
            self.u,
            self._support_points(),
            radius=robot_mesh.thickness * (1 + 1e-6),
            metrics=self.problem.strain_metrics,
        )
        self.width = self._strip_width()
        self.frequency = drive_frequency(case)
        self.log: list[str] = []
        self.dt = case.time.step
        self.steps = 0
        self.newton_iterations = 0
        self.cuts = 0

    def _bonded_lengths(self) -> dict[str, float]:
        """Arm name -> midline length over the bonded patch (m); {} when the clamp is free."""
        robot = self.case.robot
        if "clamp" not in self.case.environment.clamped or "clamp" not in self.robot.groups:
            return {}
        from magfem.geometry.robots import outline_of
        from magfem.mechanics.observers import bonded_length

        outline = outline_of(robot)
        px, py, pz = robot.position
        offset = (px, py) if self.gdim == 3 else (px, pz)
        return {
            arm.name: bonded_length(arm, outline.in_clamp, offset, self.gdim)
            for arm in self.robot.arms
        }

    def _support_points(self) -> npt.NDArray[np.float64]:
        """Reference coordinates (N, 3) of the clamped dofs, gathered from every rank (m)."""
        V = self.u.function_space
        coords = V.tabulate_dof_coordinates()
        bs = V.dofmap.index_map_bs
        nodes = [np.zeros(0, dtype=np.int64)]
        for bc in self.problem.displacement_bcs:
            dofs, owned = bc.dof_indices()
            nodes.append(np.asarray(dofs[:owned]) // bs)
        mine = coords[np.unique(np.concatenate(nodes))]
        return np.vstack(self.comm.allgather(mine))

    def _strip_width(self) -> float:
        """Width (m) that turns per-unit-width strip quantities into totals (1 for solids)."""
        if self.gdim == 3:
            return 1.0
        width = getattr(self.case.robot, "width", None)
        return float(width) if width else 1.0

    # --- observation ------------------------------------------------------------------------

    def observe(self, t: float) -> dict[str, float]:
        """Observables at the current state u_n (collective). Angles in rad, energies in J."""
        row: dict[str, float] = {"time": t}
        if self.self_contact is not None:  # first: refreshes the contact data at u_n
            row |= self.self_contact.observe(t, self.u, self.width)
        if self._angle_eval is not None and self._angle_points is not None:
            disp = self._angle_eval(self.u)
            x = self._angle_points[:, : self.gdim] + disp[:, : self.gdim]
            for i, (name, arm) in enumerate(self.arms.items()):
                raw = bending_angle(x[2 * i], x[2 * i + 1], arm, self.gdim)
                row[f"angle_{name}"] = self._unwrap[name](raw)
        if self.midline is not None:
            shape = self.midline(self.u)
            row |= shape
            # surface strain of the sharpest midline bend, κ h/2 (bending alone; model-robust,
            # unlike the pointwise largest strain, which 3D corners and free edges raise)
            kappa = max(shape[f"curvature_{name}"] for name in self.arms)
            row["bending_strain"] = kappa * self.robot.thickness / 2
        strain = self.strain_probe()
        row["strain"] = strain
        row["energy_density"] = material.energy_density(self.case.material.shear_modulus, strain)
        self.field.update(t, side="left", u=self.u)
        energies = assemble_scalars(list(self.energy_forms.values()), self.comm)
        for name, value in zip(self.energy_forms, energies, strict=True):
            row[f"energy_{name}"] = value * self.width
        row["energy_total"] = sum(row[f"energy_{n}"] for n in self.energy_forms)
        if self.contact_forms:
            forces = assemble_scalars(self.contact_forms, self.comm)
            row["contact_force"] = forces[-1] * self.width  # vertical component, N
            row["friction_force"] = float(np.linalg.norm(forces[:-1])) * self.width
        root = np.zeros(3)
        if self.arms:
            first = next(iter(self.arms.values()))
            root = np.asarray(first.root, dtype=float)
            if self.gdim == 2:
                root = np.array([root[0], 0.0, root[1]])
        b = self.field.evaluate(root[None, :], t, side="left")[0]
        row["Bx"], row["By"], row["Bz"] = (float(v) for v in b)
        return row

    def columns(self) -> list[str]:
        """CSV column names."""
        cols = ["time", "dt", "newton_iterations", "cuts"]
        cols += [f"angle_{n}" for n in self.arms]
        cols += self.midline.columns() if self.midline is not None else []
        cols += ["bending_strain"] if self.midline is not None else []
        cols += ["strain", "energy_density"]
        cols += [f"energy_{n}" for n in self.energy_forms] + ["energy_total"]
        if self.contact_forms:
            cols += ["contact_force", "friction_force"]
        if self.self_contact is not None:
            cols += self.self_contact.columns()
        return [*cols, "Bx", "By", "Bz"]

    # --- stepping ---------------------------------------------------------------------------

    def initialise(self) -> NewtonReport | None:
        """Set t₀ and the consistent initial acceleration (dynamic schemes)."""
        integ = self.integrator
        integ.set_state(self.case.time.start)
        if not integ.dynamic:
            self.settle_gravity()
            return None
        self.field.update(self.case.time.start, side="right", u=self.u)
        integ.t.value = self.case.time.start  # type: ignore[assignment]
        if self.self_contact is not None:
            self.self_contact.refresh_stage()
        acc = [fem.Function(p.u.function_space) for p in integ.parts]

        def state(functions: list[Any]) -> Any:  # the shell's blocks go as lists
            return functions if len(functions) > 1 else functions[0]

        u0, v0 = state([p.u0 for p in integ.parts]), state([p.v0 for p in integ.parts])
        form = self.problem.continuous_residual(u0, v0, state(acc), integ.t)
        report = solve_linear(form, state(acc), self.problem.bcs, self.case.solver, name="a0")
        if not report.converged:
            raise SimulationError(
                f"initial acceleration solve failed ({report.reason_name}, ‖R‖ = "
                f"{report.residual_norm:.3g})"
            )
        for p, a in zip(integ.parts, acc, strict=True):
            p.a0.x.array[:] = a.x.array
        return report

    def _gravity_constants(self) -> list[fem.Constant]:
        """The residual's gravity Constant, or [] when g = 0."""
        g = self.problem.gravity
        return [] if g is None or not np.any(g.value) else [g]

    def settle_gravity(self, *, smallest: float = 1.0 / 1024) -> int:
        """Quasi-static: solve the equilibrium at t₀ under gravity by load continuation.

        Gravity is scaled by λ from 0 to 1 (module docstring); the field is
        at its value at t₀. Returns the number of accepted load increments
        (0 when there is no gravity or the scheme is dynamic).

        Raises:
            SimulationError: an increment below ``smallest`` failed.
        """
        constants = self._gravity_constants()
        if self.integrator.dynamic or not constants:
            return 0
        full = [np.array(c.value, dtype=float) for c in constants]
        t0 = self.case.time.start
        self.field.update(t0, side="left", u=self.u)
        self._press_onto_ground()
        lam, step, accepted = 0.0, 1.0, 0
        try:
            while lam < 1.0:
                trial = min(1.0, lam + step)
                for c, g in zip(constants, full, strict=True):
                    c.value = trial * g  # type: ignore[assignment]
                self.integrator.begin(0.0)  # quasi-static: u = u_n, loads at t₀
                if self.self_contact is not None:
                    self.self_contact.refresh_stage()
                report = self.solver.solve()
                if report.converged:
                    self.integrator.advance()  # Δt = 0: u_n = u, time unchanged
                    lam, accepted = trial, accepted + 1
                    self.newton_iterations += report.iterations
                    if report.iterations <= self.case.time.easy_iterations:
                        step = min(2 * step, 1.0)
                    continue
                self.integrator.restore()
                step /= 2
                self.log.append(
                    f"gravity continuation: λ = {lam:.4g} -> {trial:.4g} failed "
                    f"({report.reason_name}); increment {step:.3g}"
                )
                if step < smallest:
                    raise SimulationError(
                        f"t = {t0:.6g} s: gravity continuation stalled at λ = {lam:.4g} "
                        f"({report.reason_name}, ‖R‖ = {report.residual_norm:.3g})"
                    )
        finally:
            for c, g in zip(constants, full, strict=True):
                c.value = g  # type: ignore[assignment]
        self.log.append(f"gravity continuation: equilibrium at t₀ in {accepted} increment(s)")
        return accepted

    def _press_onto_ground(self) -> float:
        """Start a quasi-static settle from the resting penetration of a body lying on the ground.

        The penalty ramp has zero slope at zero penetration (contact.py), so at
        u = 0 a membrane lying on the ground has no contact stiffness in the
        Newton tangent and the first gravity increment of a thin cantilever
        goes straight through the ground (100 µm beam: ‖R‖ from 1e-3 to 3e6 N
        in one iteration, every smaller increment likewise). Translating the
        body down by δ* = r⁻¹(ρ |g| h / k_n), the penetration at which the
        penalty carries the membrane's weight per area
        (:func:`magfem.mechanics.contact.penalty_penetration`), starts Newton
        where the tangent has the stiffness of the resting contact. Supports
        stay at zero. Returns δ* (m; 0 when the body does not touch the
        ground, there is no ground contact or gravity does not press down).
        """
        contact, robot, law = self.case.contact, self.robot, self.problem.contact_law
        g = self.problem.gravity
        if law is None or g is None:
            return 0.0
        vertical = self.gdim - 1
        g_v = float(np.asarray(g.value)[vertical])
        x = robot.mesh.geometry.x[:, vertical]
        lowest = self.comm.allreduce(float(x.min()) if x.size else np.inf, op=MPI.MIN)
        lowest -= self.problem.face_offset  # the shell's mesh is its mid-surface
        if g_v >= 0.0 or lowest > contact.ground_height + 1e-9 * robot.thickness:
            return 0.0
        from magfem.mechanics.contact import penalty_penetration

        weight = self.case.material.density * abs(g_v) * robot.thickness  # per area (Pa)
        delta = penalty_penetration(weight, law.stiffness, law.onset)
        for func in (self.integrator.u0, self.u):
            func.x.array.reshape(-1, self.gdim)[:, vertical] -= delta
            for bc in self.problem.displacement_bcs:
                bc.set(func.x.array, alpha=0.0)
        return delta

    def _next_step(self, t: float, end: float) -> tuple[float, bool]:
        """Length of the next step from t and whether it lands on a breakpoint."""
        dt = min(self.dt, end - t)
        stop = t + dt
        ahead = self.field.breakpoints(t, min(t + 1.05 * dt, end))
        ahead = ahead[ahead > t + 1e-9 * dt]
        if ahead.size:
            return float(ahead[0] - t), True
        if end - stop < 0.05 * dt:
            return end - t, False
        return dt, False

    def step(self, dt: float) -> NewtonReport:
        """One attempted step of length dt from t_n (state restored on failure)."""
        integ = self.integrator
        t_stage = integ.begin(dt)
        side = "right" if integ.dynamic else "left"
        self.field.update(t_stage, side=side, u=integ.u0)
        if self.self_contact is not None:
            self.self_contact.refresh_stage()
        report = self.solver.solve()
        if not report.converged and report.iterations <= 1:
            # the predictor (u_n + Δt v_n) can invert thin elements after a sudden load:
            # retry once from u_n before the step is cut
            integ.restore()
            if self.self_contact is not None:
                self.self_contact.refresh_stage()
            retry = self.solver.solve()
            report = NewtonReport(
                retry.converged,
                retry.reason,
                report.iterations + retry.iterations,
                report.linear_iterations + retry.linear_iterations,
                retry.residual_norm,
            )
        if report.converged:
            integ.advance()
            if self.problem.impact_absorber is not None:
                # columns that just landed stop (inelastic impact, see contact.py)
                self.problem.impact_absorber.apply(integ.u0, integ.v0, integ.a0)
        else:
            integ.restore()
        return report

    def _weight_scale(self) -> float:
        """F_ref of ``[solver] force_tolerance`` (N; N/m for strips, collective).

        The norm of the robot's weight load vector ∫ ρ g₀·w dV under standard
        gravity g₀ = 9.80665 m/s² downwards, supports left out: a force scale of
        the robot whether ``[environment] gravity`` is applied or not.
        """
        import ufl

        from magfem.mechanics.solver import load_norm

        V = self.u.function_space
        down = np.zeros(V.mesh.geometry.dim)
        down[-1] = -STANDARD_GRAVITY
        w = ufl.TestFunction(V)
        dx = ufl.dx(domain=V.mesh, metadata={"quadrature_degree": self.problem.quadrature_degree})
        rho = self.problem.mass_density  # per unit of the mesh's measure
        weight = rho * ufl.dot(ufl.as_vector(down.tolist()), w) * dx
        return load_norm(weight, self.problem.displacement_bcs)

    def _say(self, msg: str, bar: Any) -> None:
        self.log.append(msg)
        if self.comm.rank == 0:
            if bar is not None:
                bar.write(msg)
            else:
                print(msg, flush=True)

    def run(self, outdir: Path | None = None, *, progress: bool = True) -> SimulationResult:
        """Integrate from ``time.start`` to ``time.end`` writing outputs to ``outdir``.

        Raises:
            SimulationError: Newton failed ``max_cuts`` times in a row or below ``min_step``.
        """
        from magfem.mechanics.output import (
            CsvHistory,
            MotionSnapshots,
            VtxOutput,
            plot_angles,
            remove_snapshots,
            write_animation,
        )
        from magfem.parallel import progress as progress_bar

        spec = self.case.time
        out = self.case.output
        t_wall = _time.perf_counter()
        paths: dict[str, Path] = {}
        if outdir is not None:
            outdir = Path(outdir)
            if self.comm.rank == 0:
                outdir.mkdir(parents=True, exist_ok=True)
            self.comm.barrier()
        self.initialise()
        csv_out = None
        vtx = None
        if outdir is not None and out.csv:
            paths["csv"] = outdir / "history.csv"
            csv_out = CsvHistory(paths["csv"], self.columns(), self.comm)
        if outdir is not None and out.vtx_every > 0:
            paths["vtx"] = outdir / "displacement.bp"
            vtx = VtxOutput(paths["vtx"], [self.u], self.comm)
        snaps = None
        if outdir is not None and out.animation:
            paths["gif"] = outdir / "motion.gif"
            snaps = MotionSnapshots(
                outdir / "snapshots",
                self.u,
                self.comm,
                frames=out.animation_frames,
                start=spec.start,
                end=spec.end,
            )

        def animate() -> None:
            if snaps is not None and self.comm.rank == 0:
                if write_animation(snaps.directory, paths["gif"], title=self.case.name):
                    remove_snapshots(snaps.directory)

        rows: list[dict[str, float]] = []
        t = spec.start
        row = self.observe(t) | {"dt": 0.0, "newton_iterations": 0, "cuts": 0}
        rows.append(row)
        if csv_out is not None:
            csv_out.write(row)
        if vtx is not None:
            vtx.write(t)
        if snaps is not None:
            snaps.write(t, (row["Bx"], row["By"], row["Bz"]))
        bar = (
            progress_bar(spec.end - spec.start, desc=self.case.name, unit="s", comm=self.comm)
            if progress
            else None
        )
        easy_streak = 0
        try:
            while t < spec.end - 1e-12 * (spec.end - spec.start):
                dt, on_break = self._next_step(t, spec.end)
                cuts = 0
                while True:
                    report = self.step(dt)
                    if report.converged:
                        break
                    cuts += 1
                    self.cuts += 1
                    new_dt = dt * spec.cut_factor
                    why = _stop_reason(spec, cuts, new_dt)
                    if why:
                        raise SimulationError(
                            f"t = {t:.6g} s: Newton failed ({report.reason_name}, "
                            f"{report.iterations} it, ‖R‖ = {report.residual_norm:.3g}) "
                            f"at dt = {dt:.3g} s after {cuts} cut(s): {why}"
                        )
                    self._say(
                        f"t = {t:.6g} s: Newton failed ({report.reason_name}, "
                        f"{report.iterations} it); step cut {dt:.3g} -> {new_dt:.3g} s",
                        bar,
                    )
                    dt, on_break = new_dt, False
                    self.dt = dt
                t_new = t + dt
                if on_break:  # land exactly on the switching instant
                    t_new = float(self.field.breakpoints(t, t + 1.01 * dt)[0])
                if abs(spec.end - t_new) < 1e-9 * dt:
                    t_new = spec.end
                self.integrator.time = t_new
                t = t_new
                self.steps += 1
                self.newton_iterations += report.iterations
                row = self.observe(t) | {
                    "dt": dt,
                    "newton_iterations": report.iterations,
                    "cuts": cuts,
                }
                rows.append(row)
                for msg in self.self_contact.pop_events() if self.self_contact else []:
                    self._say(msg, bar)
                if csv_out is not None:
                    csv_out.write(row)
                if vtx is not None and self.steps % out.vtx_every == 0:
                    vtx.write(t)
                if snaps is not None and snaps.due(t):
                    snaps.write(t, (row["Bx"], row["By"], row["Bz"]))
                if bar is not None:
                    bar.update(dt)
                    bar.set_postfix_str(f"dt={dt:.2e} s, newton={report.iterations}")
                self._control(report, cuts, easy_streak, bar, t)
                easy_streak = (
                    easy_streak + 1
                    if report.iterations <= spec.easy_iterations and cuts == 0
                    else 0
                )
                if easy_streak >= 2 and spec.adaptive and self.dt < spec.largest_step:
                    new_dt = min(self.dt * spec.grow_factor, spec.largest_step)
                    self._say(
                        f"t = {t:.6g} s: easy steps; step grown {self.dt:.3g} -> {new_dt:.3g} s",
                        bar,
                    )
                    self.dt = new_dt
                    easy_streak = 0
        except SimulationError:
            animate()  # the motion up to the failure
            raise
        finally:
            if bar is not None:
                bar.close()
            if csv_out is not None:
                csv_out.close()
            if vtx is not None:
                vtx.close()
        history = {k: np.array([r.get(k, np.nan) for r in rows]) for k in self.columns()}
        summary = self._summary(history)
        if outdir is not None and out.plot:
            paths["png"] = outdir / "angle.png"
            if self.comm.rank == 0:
                plot_angles(
                    paths["png"],
                    history["time"],
                    {n: history[f"angle_{n}"] for n in self.arms},
                    history["time"],
                    np.column_stack([history["Bx"], history["By"], history["Bz"]]),
                    title=self.case.name,
                )
        animate()
        timings = self.timings()
        timings["total"] = _time.perf_counter() - t_wall
        return SimulationResult(history, summary, paths, list(self.log), timings)

    def _control(self, report: NewtonReport, cuts: int, streak: int, bar: Any, t: float) -> None:
        spec = self.case.time
        if spec.adaptive and report.iterations >= spec.slow_iterations:
            new_dt = max(self.dt * spec.cut_factor, spec.smallest_step)
            self._say(
                f"t = {t:.6g} s: slow Newton ({report.iterations} it); "
                f"next step {self.dt:.3g} -> {new_dt:.3g} s",
                bar,
            )
            self.dt = new_dt

    def _summary(self, history: dict[str, npt.NDArray[np.float64]]) -> dict[str, float]:
        out: dict[str, float] = {
            "steps": float(self.steps),
            "newton_iterations": float(self.newton_iterations),
            "mean_newton_iterations": self.newton_iterations / max(self.steps, 1),
            "cuts": float(self.cuts),
        }
        out |= history_summary(history, start=self.case.time.start, frequency=self.frequency)
        if self.self_contact is not None:
            out |= self.self_contact.summary()
        return out

    def timings(self) -> dict[str, float]:
        """Wall-time split (s) on this rank."""
        s = self.solver.timings
        return {
            "mesh_and_field": self.mesh_time,
            "compile": s.compile + self.observer_compile_time,
            "residual": s.residual,
            "jacobian": s.jacobian,
            "linear_solve": s.linear_solve,
        }


def simulate(
    case: Case, outdir: Path, comm: MPI.Comm = MPI.COMM_WORLD, *, progress: bool = True
) -> SimulationResult:
    """Run ``case`` and write its outputs to ``outdir`` (collective).

    Returns:
        the :class:`SimulationResult` (history arrays on every rank, written paths).

    Raises:
        magfem.config.CaseError: the case cannot be simulated (surface model, groups).
        SimulationError: Newton failed at the smallest step (outputs so far are kept).
    """
    sim = MembraneSimulation(case, comm)
    return sim.run(Path(outdir), progress=progress)
