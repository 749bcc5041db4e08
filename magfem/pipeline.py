"""From a case to a run: the only place that reads a whole :class:`~magfem.case.Case`.

Each stage takes its own tables: the robot mesh from ``[robot]`` and
``[mesh]`` (:mod:`magfem.geometry`), the field model from ``[field]``
(:mod:`magfem.field`), the model from ``[material]``, ``[solver]``,
``[time]`` and ``[environment]``, its loads (the field, gravity,
``[[loads]]``), its contacts (``[contact]``, ``[[contacts]]``), the observers
and the writers of ``[output]`` (:mod:`magfem.mechanics`). The parts are
composed declaratively into a :class:`~magfem.mechanics.simulation.Simulation`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt
import ufl
from mpi4py import MPI

from magfem.accuracy import resolve_case
from magfem.case import Case
from magfem.config import CaseError, to_table
from magfem.field.model import FieldModel, create_field_model
from magfem.field.spec import FieldSpec
from magfem.geometry.robot_mesh import RobotMesh, create_robot_mesh
from magfem.geometry.robots import outline_of
from magfem.mechanics.animation import MotionSnapshots
from magfem.mechanics.checkpoint import Checkpointer, RunControl, check_resumable, read_checkpoint
from magfem.mechanics.contacts import Contact, GroundContact, SelfContact
from magfem.mechanics.loads import GravityLoad, Load, MagneticLoad
from magfem.mechanics.loads.fluid import FluidLoad
from magfem.mechanics.loads.hydrodynamics import (
    FluidCoefficients,
    describe_fluid,
    fluid_coefficients,
)
from magfem.mechanics.models import MODELS, BodySetup, Model, ModelInputs
from magfem.mechanics.observers import (
    AppliedField,
    ArmAngles,
    BodyMotion,
    Energies,
    Midline,
    Observer,
    Strain,
    StrainProbe,
    Swimming,
    bonded_length,
)
from magfem.mechanics.output import (
    AnglePlotWriter,
    CsvHistory,
    CsvWriter,
    MotionWriter,
    VtxWriter,
    Writer,
)
from magfem.mechanics.pose import initial_motion
from magfem.mechanics.problem import build_problem
from magfem.mechanics.series import VtuSeries
from magfem.mechanics.simulation import Simulation, SimulationResult
from magfem.parallel import root_call
from magfem.rundir import CHECKPOINT
from magfem.sanity import SUPPORT_FRACTION, SwitchWatch

__all__ = [
    "build_simulation",
    "create_writers",
    "describe_fluid_of",
    "drive_frequency",
    "fluid_coefficients_of",
    "simulate",
]

LOG = logging.getLogger("magfem.pipeline")


def drive_frequency(spec: FieldSpec) -> float | None:
    """Frequency (Hz) of the first periodic field source, or None."""
    for src in spec.sources:
        frequency = getattr(src.waveform, "frequency", None)
        if frequency:
            return float(frequency)
    return None


def fluid_coefficients_of(case: Case) -> FluidCoefficients | None:
    """The fluid model's coefficients of ``case`` (``[fluid]``), or None without a fluid.

    The chord defaults to the robot's area over its arms' total length (an
    arm's mean width), the characteristic frequency to the drive's (0, steady
    flow, without a periodic source).
    """
    spec = case.fluid
    if spec is None:
        return None
    chord = spec.chord
    if chord is None:
        outline = outline_of(case.robot)
        length = sum(arm.length for arm in outline.arms) or outline.scale
        chord = outline.area / length
    frequency = spec.frequency
    if frequency is None:
        frequency = drive_frequency(case.field) or 0.0
    return fluid_coefficients(
        spec.fluid_density,
        spec.fluid_viscosity,
        chord,
        frequency=frequency,
        friction_length=spec.friction_length,
        added_mass_coefficient=spec.added_mass_coefficient,
        drag_coefficient=spec.drag_coefficient,
    )


def describe_fluid_of(case: Case) -> list[str]:
    """``magfem check``'s lines on ``[fluid]``: properties, coefficients, sources, regime."""
    coefficients = fluid_coefficients_of(case)
    if case.fluid is None or coefficients is None:
        return []
    spec, c = case.fluid, coefficients
    outline = outline_of(case.robot)
    amplitude = max((arm.length for arm in outline.arms), default=outline.scale)
    current = float(np.linalg.norm(spec.current))
    head = (
        f"fluid     {spec.medium or 'fluid'}: rho = {c.density:.4g} kg/m^3, mu = "
        f"{c.viscosity:.4g} Pa*s, current {current:.3g} m/s; chord b = {c.chord * 1e3:.3g} mm, "
        f"frequency {c.frequency:g} Hz; buoyancy {c.density / case.material.density:.3g} of the "
        "weight"
    )
    lines = describe_fluid(
        c,
        areal_mass=case.material.density * case.robot.thickness,
        amplitude=amplitude,
        current=current,
    )
    return [head, *("          " + line for line in lines)]


def build_simulation(
    case: Case,
    comm: MPI.Comm = MPI.COMM_WORLD,
    *,
    robot_mesh: RobotMesh | None = None,
    field_model: FieldModel | None = None,
) -> Simulation:
    """The simulation of ``case`` (collective): mesh, field, model, loads, contacts, observers.

    Args:
        robot_mesh: a prebuilt mesh (default: the case's).
        field_model: a prebuilt field model (default: the case's).

    Raises:
        magfem.config.CaseError: the case cannot be simulated (groups, model refusals).
    """
    t0 = time.perf_counter()
    case, choices = resolve_case(case)
    for line in choices:
        LOG.info(line)
    if robot_mesh is None:
        robot_mesh = create_robot_mesh(case.robot, case.mesh, comm)
    if field_model is None:
        field_model = create_field_model(case.field, comm)
    setup_time = time.perf_counter() - t0
    depth = case.robot.uniform_width or 1.0
    pose = case.initial.rotation
    body = BodySetup(
        depth=depth,
        center=tuple(case.robot.position),  # type: ignore[arg-type]
        rotation=tuple(map(tuple, pose)) if case.initial.angle else None,
        turn_axis=case.mesh.turn_axis,
    )
    model_class = MODELS.get(case.mesh.model, "mesh.model")
    inputs = ModelInputs(robot_mesh, case.material, case.solver, case.time, case.environment, body)
    model = model_class(inputs)
    _place(case, model)
    loads: list[Load] = [
        MagneticLoad(field_model, model),
        GravityLoad(case.environment.gravity, model),
        *(spec.build(model) for spec in case.loads),
    ]
    fluid = _fluid_load(case, model)
    if fluid is not None:
        loads.append(fluid)
    problem = build_problem(model, loads, _contacts(case, model))
    _check_supports(model)
    t1 = time.perf_counter()
    observers = _observers(case, model, problem.energy_forms, field_model)
    if fluid is not None:
        observers.append(_swimming(case, model, fluid))
    return Simulation(
        problem,
        case.time,
        case.solver,
        observers=observers,
        frequency=drive_frequency(case.field),
        name=case.name,
        setup_time=setup_time,
        compile_time=time.perf_counter() - t1,
        history_interval=case.output.history_interval,
    )


def _place(case: Case, model: Model) -> None:
    """Start the body in the placement and rigid velocity of ``[initial]`` (if it moves)."""
    if not case.initial.moves:
        return
    if not model.free_body:
        raise CaseError(
            "initial",
            "(a placement)",
            "only a free body can be placed: set environment.clamped = [] and no fixed_point",
        )
    px, py, pz = case.robot.position
    pivot = (px, py, pz + 0.5 * case.robot.thickness)
    model.place(initial_motion(case.initial, pivot, model.gdim))


def _fluid_load(case: Case, model: Model) -> FluidLoad | None:
    coefficients = fluid_coefficients_of(case)
    if case.fluid is None or coefficients is None:
        return None
    return FluidLoad(
        case.fluid,
        coefficients,
        model,
        gravity=case.environment.gravity,
        solid_density=case.material.density,
    )


def _swimming(case: Case, model: Model, fluid: FluidLoad) -> Swimming:
    spec, coefficients = fluid.spec, fluid.coefficients
    state, rates = model.accepted()
    return Swimming(
        mass_density=model.mass_density,
        dx=model.dx,
        position=ufl.SpatialCoordinate(model.robot.mesh) + model.displacement(state),
        velocity=model.displacement(rates),
        fluid_forms=fluid.observed_forms(model, spec.swim_direction),
        direction=spec.swim_direction,
        gdim=model.gdim,
        kinematic_viscosity=coefficients.kinematic_viscosity,
        chord=coefficients.chord,
        depth=model.depth,
        mesh=model.robot.mesh,
    )


def _contacts(case: Case, model: Model) -> list[Contact]:
    mat = case.material
    contacts: list[Contact] = []
    if case.contact.ground:
        contacts.append(
            GroundContact(case.contact, model, shear_modulus=mat.shear_modulus, density=mat.density)
        )
    if case.contact.self_contact:
        contacts.append(SelfContact(case.contact, model, shear_modulus=mat.shear_modulus))
    env, field = case.environment, case.field
    contacts += [spec.build(model, mat, environment=env, field=field) for spec in case.contacts]
    return contacts


def _observers(
    case: Case, model: Model, energy_forms: dict, field_model: FieldModel
) -> list[Observer]:
    arms = model.arms
    observers: list[Observer] = []
    if arms:
        observers.append(ArmAngles(model.u, arms))
        bonded = _bonded_lengths(case, model)
        spacing = case.output.midline_spacing
        observers.append(Midline(model.u, arms, model.thickness, bonded, spacing))
    probe = StrainProbe(
        model.u,
        _support_points(model),
        radius=model.thickness * (1 + 1e-6),
        metrics=model.strain_metrics,
    )
    observers.append(Strain(probe, case.material.shear_modulus))
    observers.append(Energies(energy_forms, model.robot.mesh, model.depth))
    if model.free_body:
        observers.append(BodyMotion(model, case.initial.rotation[:, 2]))
    observers.append(AppliedField(field_model, _field_point(model)))
    return observers


def _bonded_lengths(case: Case, model: Model) -> dict[str, float]:
    """Arm name -> midline length over the bonded patch (m); {} when the clamp is free."""
    if "clamp" not in case.environment.clamped or "clamp" not in model.robot.groups:
        return {}
    outline = outline_of(case.robot)
    px, py, pz = case.robot.position
    offset = (px, py) if model.gdim == 3 else (px, pz)
    return {
        arm.name: bonded_length(arm, outline.in_clamp, offset, model.gdim) for arm in model.arms
    }


def _support_points(model: Model) -> npt.NDArray[np.float64]:
    """Reference coordinates (N, 3) of the held displacement dofs, from every rank (m)."""
    V = model.u.function_space
    coords = V.tabulate_dof_coordinates()
    bs = V.dofmap.index_map_bs
    nodes = [np.zeros(0, dtype=np.int64)]
    for bc in model.displacement_bcs:
        dofs, owned = bc.dof_indices()
        nodes.append(np.asarray(dofs[:owned]) // bs)
    mine = coords[np.unique(np.concatenate(nodes))]
    return np.vstack(model.robot.mesh.comm.allgather(mine))


def _check_supports(model: Model) -> None:
    """Warn when the supports hold most of the body's nodes (collective)."""
    held = len(_support_points(model))
    nodes = model.u.function_space.dofmap.index_map.size_global
    if nodes and held > SUPPORT_FRACTION * nodes:
        LOG.warning(
            f"the supports ([environment] clamped, fixed_point, fixed_radius) hold {held} of "
            f"the {nodes} nodes: most of the body cannot move"
        )


def _field_point(model: Model) -> npt.NDArray[np.float64]:
    """Where the history samples the applied field: the first arm's root (3D, m)."""
    if not model.arms:
        return np.zeros(3)
    root = np.asarray(model.arms[0].root, dtype=float)
    return root if model.gdim == 3 else np.array([root[0], 0.0, root[1]])


def create_writers(
    case: Case, sim: Simulation, outdir: Path
) -> tuple[list[Writer], dict[str, Path]]:
    """The writers of ``[output]`` into ``outdir`` (collective) and the paths they write."""
    out, comm = case.output, sim.comm
    writers: list[Writer] = []
    paths: dict[str, Path] = {}
    if out.csv:
        paths["csv"] = outdir / "history.csv"
        csv = CsvHistory(paths["csv"], sim.columns(), comm, sim.column_units())
        writers.append(CsvWriter(csv))
    if out.vtx_every > 0:
        paths["vtx"] = outdir / "displacement.bp"
        writers.append(VtxWriter(paths["vtx"], [sim.u], comm, out.vtx_every))
    if out.vtu_every > 0:
        paths["pvd"] = outdir / "displacement.pvd"
        writers.append(VtuSeries(paths["pvd"], sim.u, comm, out.vtu_every))
    if out.animation:
        paths["gif"] = outdir / "motion.gif"
        snapshots = MotionSnapshots(
            outdir / "snapshots",
            sim.u,
            comm,
            frames=out.animation_frames,
            start=case.time.start,
            end=case.time.end,
        )
        writers.append(MotionWriter(paths["gif"], snapshots, comm, case.name))
    if out.plot:
        paths["png"] = outdir / "angle.png"
        writers.append(
            AnglePlotWriter(paths["png"], [a.name for a in sim.model.arms], comm, case.name)
        )
    if sim.integrator.dynamic and sim.model.arms:
        arms = [a.name for a in sim.model.arms]
        writers.append(SwitchWatch(arms, sim.controller.breakpoints, LOG.warning))
    return writers, paths


def simulate(
    case: Case,
    outdir: Path,
    comm: MPI.Comm = MPI.COMM_WORLD,
    *,
    progress: bool = True,
    stop: Callable[[MPI.Comm], int] | None = None,
    resume: bool = False,
) -> SimulationResult:
    """Run ``case`` and write its outputs to ``outdir`` (collective).

    Args:
        stop: ``comm -> signal`` agreed by all ranks after each step (0: go on),
            e.g. :meth:`magfem.signals.StopSignals.agreed`; None: never stop.
        resume: continue the run from the checkpoint in ``outdir/checkpoint``
            (same case but for ``time.end``, same number of ranks).

    Returns:
        the :class:`SimulationResult` (history arrays on every rank, written paths).

    Raises:
        magfem.config.CaseError: the case cannot be simulated, or cannot
            continue the checkpoint.
        magfem.mechanics.stepping.SimulationError: Newton failed at the smallest
            step (the outputs so far are kept).
        magfem.errors.RunInterrupted: ``stop`` gave a signal; the checkpoint and
            the outputs so far are written.
    """
    case, choices = resolve_case(case)  # the resolved case names the model and sizes it ran
    for line in choices:
        LOG.info(line)
    outdir = Path(outdir)
    table = to_table(case)
    state = None
    if resume:
        meta, state = read_checkpoint(outdir / CHECKPOINT, comm)
        check_resumable(meta, table, float(meta["time"]))
        LOG.info(f"resuming  step {meta['step']} at t = {meta['time']:.6g} s ({meta['reason']})")
    sim = build_simulation(case, comm)
    root_call(comm, lambda: outdir.mkdir(parents=True, exist_ok=True))
    writers, paths = create_writers(case, sim, outdir)
    out = case.output
    checkpoints = Checkpointer(
        outdir / CHECKPOINT,
        comm,
        every=out.checkpoint_every,
        interval=out.checkpoint_interval,
        case=table,
    )
    control = RunControl(stop=stop, checkpoints=checkpoints, resume=state)
    try:
        result = sim.run(writers, progress=progress, control=control)
    finally:
        if control.written:
            paths["checkpoint"] = control.written[-1]
    result.paths = paths
    return result
