"""Verification set-ups shared by the tests and the benchmarks.

One place for the case tables the mechanics is verified with, parameterised
by what the tests and the convergence benchmarks vary (mesh model and size,
section, plane law, supports), the runs built on them and the observables
compared with :mod:`verification.references`:

* the cantilever: an 80 µm arm, 7.5 mm long with a 1 mm root strip bonded to
  the substrate (``clamp_length``), μ = 115 kPa, ρ = 2130 kg/m³,
  M = 123 kA/m through the thickness. Static: a uniform field along −x (the
  sign that lifts the arm) ramped quasi-statically, against the hard-magnetic
  elastica (:func:`static_tip_angles`, :func:`elastica_reference_angles`).
  Dynamic: no field, a push with the velocity of the first Euler–Bernoulli
  mode, the frequency of the free vibration (:func:`measured_frequency`).
* the ground membrane: a free 2 × 1 mm, 100 µm membrane (μ = 115 kPa,
  ρ = 2130 kg/m³, no magnetization) on the ground under gravity, resting
  (:func:`rest_on_ground`) or sliding (:func:`slide_on_ground`).

SI units throughout. The runs are collective: call them on every rank of
``comm``.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from mpi4py import MPI

from magfem.case import Case, parse_case
from magfem.geometry.gmshio import build_mesh
from magfem.geometry.robot_mesh import RobotMesh
from magfem.mechanics.contacts.penalty import create_penalty_law
from magfem.mechanics.observers import TIP_OFFSET
from magfem.mechanics.simulation import Simulation
from magfem.pipeline import build_simulation
from verification import references as ref

# --- cantilever --------------------------------------------------------------------------------

THICKNESS = 80e-6  # m
LENGTH = 7.5e-3  # m, root strip included
CLAMP_LENGTH = 1e-3  # m, bonded root strip
FREE_LENGTH = LENGTH - CLAMP_LENGTH  # m, the rod of the reference solutions
SHEAR_MODULUS = 115e3  # Pa
DENSITY = 2130.0  # kg/m³
REMANENCE = 123e3  # A/m, through the thickness
B_MAX = 0.4e-3  # T, end of the static ramp
FRACTIONS = (0.25, 0.5, 0.75, 1.0)  # of the ramp, where the static angles are sampled


STRIP_CANTILEVER: dict[str, Any] = {
    "name": "strip",
    "robot": {
        "shape": "rectangle",
        "thickness": "80 um",
        "length": "7.5 mm",
        "width": "4 mm",
        "clamp_length": "1 mm",
    },
    "mesh": {"size": "0.5 mm", "model": "strip"},
    "material": {"shear_modulus": "115 kPa", "density": "2130 kg/m^3", "remanence": "123 kA/m"},
    "field": {
        "sources": [
            {
                "kind": "uniform",
                "flux_density": "2 mT",
                "direction": [-1, 0, 0],
                "waveform": {"kind": "square", "frequency": "20 Hz"},
            }
        ]
    },
    "time": {"end": "5 ms", "step": "0.25 ms"},
    "output": {"csv": False, "vtx_every": 0, "plot": False},
}
"""A 7.5 mm, 80 µm strip bonded over 1 mm, in a 2 mT 20 Hz square wave (the dynamics tests'
case table: plane strain, P2 at 0.5 mm, 5 ms)."""

SWEEP_PROBE: dict[str, Any] = STRIP_CANTILEVER | {
    "name": "sweep_probe",
    "robot": STRIP_CANTILEVER["robot"]
    | {"thickness": "100 um", "length": "4 mm", "width": "1 mm", "clamp_length": "0.5 mm"},
    "field": {
        "sources": [
            STRIP_CANTILEVER["field"]["sources"][0]
            | {"flux_density": "4 mT", "waveform": {"kind": "square", "frequency": "100 Hz"}}
        ]
    },
    "time": {"end": "2 ms", "step": "0.25 ms"},
    "environment": {"gravity": [0, 0, 0]},
    "output": {"vtx_every": 0, "plot": False},
}
"""The sweep tests' point: a 4 mm strip arm (4 × 0.5 mm P2 quads), 8 steps of a 4 mT square
wave: ~3 s per point with a warm form cache."""

_NO_OUTPUT = {"csv": False, "vtx_every": 0, "plot": False}
_NO_GRAVITY = {"gravity": [0, 0, 0]}


def cantilever_case(
    model: str,
    size: float | None,
    width: float,
    plane: str,
    *,
    name: str = "cantilever",
    remanence: float = REMANENCE,
    bulk_modulus: float | None = None,
    environment: dict[str, Any] | None = None,
    size_across: float | None = None,
    layers: int | None = 1,
    mesh_options: dict[str, Any] | None = None,
    root: str = "bonded",
    **tables: Any,
) -> Case:
    """The cantilever's case; ``tables`` (``field``, ``time``, ...) are added as they are.

    Args:
        model: ``mesh.model`` (``strip``, ``solid``, ...). size: mesh size (m); None
            leaves it out (for ``[solver] accuracy`` to choose).
        width: arm width (m). plane: ``material.plane`` (``strain``/``stress``).
        remanence: M (A/m). bulk_modulus: K (Pa); None keeps the case default (100 μ).
        environment: the ``[environment]`` table; default no gravity and the
            bonded root strip as the support.
        size_across: ``mesh.size_across`` (m), None: ``size``.
        layers: ``mesh.layers`` (elements through the thickness); None leaves it out.
        mesh_options: further ``[mesh]`` keys (``rod_bending``).
        root: ``mesh.root``: ``bonded`` (the glued bottom face) or ``rigid``
            (the whole root block, every node of x <= CLAMP_LENGTH).
    """
    material: dict[str, Any] = {
        "shear_modulus": SHEAR_MODULUS,
        "density": DENSITY,
        "remanence": remanence,
        "plane": plane,
    }
    if bulk_modulus is not None:
        material["bulk_modulus"] = bulk_modulus
    return parse_case(
        {
            "name": name,
            "robot": {
                "shape": "rectangle",
                "thickness": THICKNESS,
                "length": LENGTH,
                "width": width,
                "clamp_length": CLAMP_LENGTH,
            },
            "mesh": {"model": model, "root": root}
            | ({} if size is None else {"size": size})
            | ({} if layers is None else {"layers": layers})
            | ({} if size_across is None else {"size_across": size_across})
            | (mesh_options or {}),
            "material": material,
            "environment": environment or _NO_GRAVITY,
            "output": _NO_OUTPUT,
            **tables,
        }
    )


def field_ramp(b_max: float) -> dict[str, Any]:
    """A uniform source along −x whose flux density rises linearly from 0 at t = 0 to ``b_max``
    (T) at t = 1 (the quasi-static load parameter)."""
    return {
        "kind": "uniform",
        "flux_density": b_max,
        "direction": [-1, 0, 0],
        "waveform": {"kind": "table", "times": [0, 1], "values": [0, 1]},
    }


def elastica_chord_angle(load: float, free_length: float = FREE_LENGTH) -> float:
    """Reference observable (rad): angle of the chord over the last TIP_OFFSET·L of the arm.

    The hard-magnetic elastica of the free length at load λ, field along −x,
    observed like the simulation's ``angle_arm`` (TIP_OFFSET is a fraction of
    the whole length L, root strip included). ``free_length`` (m): the rod's
    length, default the arm beyond the bonded patch.
    """
    sol = ref.hard_magnetic_elastica(load, field_angle=math.pi)
    s1 = 1.0 - 1e-9 * LENGTH / free_length
    s0 = s1 - TIP_OFFSET * LENGTH / free_length
    x = np.interp([s0, s1], sol.s, sol.x)
    y = np.interp([s0, s1], sol.s, sol.y)
    return math.atan2(y[1] - y[0], x[1] - x[0])


def elastica_reference_angles(
    modulus: float, fields: Any, free_length: float = FREE_LENGTH
) -> npt.NDArray[np.float64]:
    """Elastica chord angles (rad) at the flux densities ``fields`` (T), bending modulus E' (Pa),
    of a rod ``free_length`` long (m)."""
    loads = [ref.elastica_load(REMANENCE, b, free_length, THICKNESS, modulus) for b in fields]
    return np.array([elastica_chord_angle(lam, free_length) for lam in loads])


def clamp_inset_of(modulus: float, field: float, angle: float) -> float:
    """Root compliance of a static run as a clamp inset (thicknesses): the α for which the
    elastica of free length FREE_LENGTH + α·THICKNESS has the chord angle ``angle`` (rad) at
    ``field`` (T), bending modulus ``modulus`` (Pa). α = 0: the rod's rigid clamp at the edge
    of the bonded patch."""
    from scipy.optimize import brentq

    def mismatch(alpha: float) -> float:
        free = FREE_LENGTH + alpha * THICKNESS
        return elastica_reference_angles(modulus, [field], free)[0] - angle

    return float(brentq(mismatch, -2.0, 3.0, xtol=1e-6))


def static_tip_angles(
    comm: MPI.Comm,
    *,
    model: str,
    size: float | None,
    width: float,
    plane: str,
    b_max: float = B_MAX,
    fractions: tuple[float, ...] = FRACTIONS,
    bulk_modulus: float = 100 * SHEAR_MODULUS,
    environment: dict[str, Any] | None = None,
    step: float | None = None,
    size_across: float | None = None,
    layers: int = 1,
    mesh_options: dict[str, Any] | None = None,
    root: str = "bonded",
    accuracy: str | None = None,
) -> tuple[Simulation, npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(simulation, B in T, tip angles in rad) at the steps nearest ``fractions`` of the ramp.

    Adaptive steps may not land on the fractions exactly; the reference is
    then evaluated at the field the step did reach (B = t × b_max).
    ``environment`` replaces the default support (the bonded root strip);
    ``step`` is the first quasi-static step (default: the first fraction);
    ``size_across``, ``layers``, ``root`` and ``mesh_options`` as in :func:`cantilever_case`;
    ``accuracy``: ``[solver] accuracy`` (then ``size`` None, ``layers`` not set by the case).
    """
    extra: dict[str, Any] = {}
    if accuracy is not None:
        extra["solver"] = {"accuracy": accuracy}
    case = cantilever_case(
        model,
        size,
        width,
        plane,
        name="elastica",
        bulk_modulus=bulk_modulus,
        environment=environment,
        size_across=size_across,
        layers=None if accuracy is not None else layers,
        mesh_options=mesh_options,
        root=root,
        field={"sources": [field_ramp(b_max)]},
        time={"scheme": "quasi_static", "end": 1.0, "step": step or fractions[0]},
        **extra,
    )
    sim = build_simulation(case, comm)
    history = sim.run(progress=False).history
    t, angle = history["time"], history["angle_arm"]
    rows = [int(np.argmin(np.abs(t - f))) for f in fractions]
    return sim, t[rows] * b_max, angle[rows]


def first_mode(x: Any, clamp: float = CLAMP_LENGTH) -> tuple[Any, Any]:
    """Clamped–free mode φ₁ (1) and φ₁' (1/m) at x (m), zero on the root x <= ``clamp`` (m).

    The rod runs from ``clamp`` to the arm's end (LENGTH). Normalised to φ₁ = 1
    at the tip (Euler–Bernoulli; eigenvalue from :func:`references.cantilever_eigenvalue`).
    """
    free = LENGTH - clamp
    b = ref.cantilever_eigenvalue(1) / free
    bl = b * free
    sig = (math.cosh(bl) + math.cos(bl)) / (math.sinh(bl) + math.sin(bl))
    s = np.maximum(x - clamp, 0.0)
    phi = 0.5 * (np.cosh(b * s) - np.cos(b * s) - sig * (np.sinh(b * s) - np.sin(b * s)))
    dphi = 0.5 * b * (np.sinh(b * s) + np.sin(b * s) - sig * (np.cosh(b * s) - np.cos(b * s)))
    return phi, dphi


def free_vibration_frequency(time: Any, angle: Any) -> float:
    """Frequency (Hz): inverse mean spacing of the downward zero crossings of ``angle(time)``.

    Crossing times are interpolated linearly between samples.

    Raises:
        ValueError: fewer than two downward crossings (less than one period seen).
    """
    t, a = np.asarray(time), np.asarray(angle)
    down = np.flatnonzero((a[:-1] > 0) & (a[1:] <= 0))
    crossings = t[down] - a[down] * (t[down + 1] - t[down]) / (a[down + 1] - a[down])
    if crossings.size < 2:
        raise ValueError(
            f"expected two periods of free vibration, found {crossings.size} downward crossing(s)"
        )
    return float(1.0 / np.mean(np.diff(crossings)))


def measured_frequency(
    comm: MPI.Comm,
    *,
    model: str,
    size: float,
    width: float,
    plane: str,
    expected: float,
    amplitude: float = 1e-3,
) -> tuple[Simulation, float]:
    """(simulation, first bending frequency in Hz) of :func:`free_vibration`."""
    sim, history = free_vibration(
        comm,
        model=model,
        size=size,
        width=width,
        plane=plane,
        expected=expected,
        amplitude=amplitude,
    )
    return sim, free_vibration_frequency(history["time"], history["angle_arm"])


def free_vibration(
    comm: MPI.Comm,
    *,
    model: str,
    size: float,
    width: float,
    plane: str,
    expected: float,
    amplitude: float = 1e-3,
    periods: float = 2.2,
    loads: tuple[dict[str, Any], ...] = (),
) -> tuple[Simulation, dict[str, Any]]:
    """(simulation, history) of the unmagnetised cantilever's first mode after a modal push.

    The push is the velocity of the first mode with Kirchhoff kinematics:
    v_z = A φ₁(x), v_x = −(z − h/2) A φ₁'(x), A = ``amplitude`` (m/s; 1 mm/s
    gives a tip amplitude of ~0.4°, linear); the shell (``surface``) gets
    v_z on its mid-surface and the director rate θ̇₁ = −A φ₁' instead, the
    rod v_z on its midline and the rate θ̇₀ = −A φ₁' of its angle about y,
    both with the mode of a rod clamped at the inset patch edge
    (:data:`magfem.geometry.robot_mesh.SHELL_CLAMP_INSET`). Generalized-α with ρ∞ = 1 (no
    numerical dissipation) at Δt = T/80 for ``periods`` periods T = 1/``expected``;
    ``loads`` are ``[[loads]]`` tables.
    """
    from magfem.geometry.robot_mesh import SHELL_CLAMP_INSET

    period = 1.0 / expected
    case = cantilever_case(
        model,
        size,
        width,
        plane,
        name="frequency",
        remanence=0.0,
        size_across=min(size, width) if model == "surface" else None,
        time={"end": periods * period, "step": period / 80, "adaptive": False, "rho_inf": 1.0},
        loads=list(loads),
    )
    sim = build_simulation(case, comm)
    vertical = sim.gdim - 1
    shell = model in ("surface", "rod")
    clamp = CLAMP_LENGTH - (SHELL_CLAMP_INSET * THICKNESS if shell else 0.0)

    def push(X: Any) -> Any:
        phi, dphi = first_mode(X[0], clamp)
        v = np.zeros((sim.gdim, X.shape[1]))
        v[0] = -(X[vertical] - THICKNESS / 2) * amplitude * dphi
        v[vertical] = amplitude * phi
        return v

    sim.integrator.v0.interpolate(push)
    if shell:  # the director turns with the midline's slope: d_x = sin θ₁ ≈ −w'
        angle = 1 if model == "surface" else 0  # the rod: d₁ = R_y(θ₀) e_x, w' ≈ −θ₀

        def turn(X: Any) -> Any:
            rate = np.zeros((3 if model == "rod" else 2, X.shape[1]))
            rate[angle] = -amplitude * first_mode(X[0], clamp)[1]
            return rate

        sim.integrator.parts[1].v0.interpolate(turn)
    return sim, sim.run(progress=False).history


# --- energy of free vibration -----------------------------------------------------------------

STEP_PATTERN = (1.0, 1.0, 0.5, 0.5, 1.3, 0.7, 1.0, 1.6)
"""Multiples of the nominal step, cycled: the step changes on most steps."""


SWITCH_OFF = 3e-3
"""s: the end of the push of :func:`switch_off_case`."""


def switch_off_case(
    model: str,
    size: float,
    width: float,
    dt: float,
    *,
    steps: int,
    solver: dict[str, Any] | None = None,
) -> Case:
    """The case of :func:`switch_off_energies`: pushed by 2 mT along −x until
    :data:`SWITCH_OFF`, ρ∞ = 1, Newton rtol 1e-10 (and the ``solver`` keys given), first
    step ``dt``, time for ``steps`` free steps of the step pattern."""
    field = {
        "sources": [
            {
                "kind": "uniform",
                "flux_density": "2 mT",
                "direction": [-1, 0, 0],
                "waveform": {"kind": "dc", "duration": SWITCH_OFF},
            }
        ]
    }
    return cantilever_case(
        model,
        size,
        width,
        "strain",
        name="energy",
        field=field,
        size_across=width if model == "surface" else None,
        solver={"rtol": 1e-10, **(solver or {})},
        time={"end": SWITCH_OFF + 4 * steps * dt, "step": dt, "rho_inf": 1.0},
    )


def switch_off_energies(
    comm: MPI.Comm,
    model: str,
    size: float,
    width: float,
    dt: float,
    *,
    steps: int,
) -> npt.NDArray[np.float64]:
    """Total energy (J; J/m for strips) from the switch-off on, one value per free step.

    The cantilever (:func:`cantilever_case`, plane strain for strips) of ``model``, mesh ``size``
    and ``width`` (m), no gravity, ρ∞ = 1, pushed by 2 mT for 3 ms,
    Newton to rtol 1e-10 (the energy error of an unconverged step is ‖R‖ ‖Δu‖);
    steps of ``dt`` × :data:`STEP_PATTERN` after the switch-off (cut where Newton fails),
    dt during the push; ``steps`` free steps (``steps`` + 1 values; :func:`relative_drift`
    of them is the drift).
    """
    sim = build_simulation(switch_off_case(model, size, width, dt, steps=steps), comm)
    sim.initialise()
    t, k, energy = 0.0, 0, []
    while k <= steps:
        if t > SWITCH_OFF + 1e-9:  # after the first step past the switch: the field is off
            energy.append(sim.observe(t)["energy_total"])
            sim.controller.dt = dt * STEP_PATTERN[k % len(STEP_PATTERN)]
            k += 1
        t = sim.step(t)[0]
    return np.array(energy)


def relative_drift(energy: npt.NDArray[np.float64]) -> float:
    """Largest |E − E₀|/E₀ of an energy history."""
    return float(np.max(np.abs(energy - energy[0])) / energy[0])


def global_dofs(sim: Simulation) -> int:
    """Number of unknowns over all ranks (the shell's director angles included)."""
    return sum(
        int(f.function_space.dofmap.index_map.size_global * f.function_space.dofmap.index_map_bs)
        for f in sim.model.unknowns
    )


# --- ground membrane ---------------------------------------------------------------------------

MEMBRANE_THICKNESS = 100e-6  # m
MEMBRANE_LENGTH = 2e-3  # m, along x
MEMBRANE_WIDTH = 1e-3  # m
FRICTION = 0.5  # Coulomb coefficient μ_f
GRAVITY = 9.8  # m/s²
SLIDE_SPEED = 0.02  # m/s, initial speed of the sliding run


def ground_membrane_case(model: str, contact: dict[str, Any], time: dict[str, Any]) -> Case:
    """The membrane on the ground (0.5 mm mesh); ``contact`` adds to ``ground = true`` and μ_f."""
    return parse_case(
        {
            "name": "ground",
            "robot": {
                "shape": "membrane",
                "thickness": MEMBRANE_THICKNESS,
                "length": MEMBRANE_LENGTH,
                "width": MEMBRANE_WIDTH,
            },
            "mesh": {"size": "0.5 mm", "model": model},
            "material": {"shear_modulus": SHEAR_MODULUS, "density": DENSITY, "remanence": 0.0},
            "contact": {"ground": True, "friction": FRICTION, **contact},
            "environment": {"gravity": [0, 0, -GRAVITY]},
            "time": time,
            "output": _NO_OUTPUT,
        }
    )


def mean_value(comm: MPI.Comm, integrand: Any, measure: Any) -> float:
    """Mean of a UFL expression over a measure (∫ f dμ / ∫ dμ, summed over the ranks)."""
    num = comm.allreduce(fem.assemble_scalar(fem.form(integrand * measure)), op=MPI.SUM)
    den = comm.allreduce(fem.assemble_scalar(fem.form(1.0 * measure)), op=MPI.SUM)
    return num / den


class RestingRun(NamedTuple):
    """The membrane after settling on the ground."""

    penetration: float  # m, mean sinking of the bottom face below z = 0
    expected: float  # m, closed form of the penalty law under the pressure ρ g h
    contact_force: float  # N, total normal contact force at the end
    weight: float  # N, ρ g h × area


def rest_on_ground(
    comm: MPI.Comm,
    model: str,
    contact: dict[str, Any],
    *,
    end: float = 0.02,
    step: float = 1e-3,
) -> RestingRun:
    """Let the membrane settle for ``end`` (s) and compare its penetration with the penalty law.

    Reference: :func:`references.penalty_penetration` under
    :func:`references.resting_pressure`, with the law the case builds.
    """
    case = ground_membrane_case(model, contact, {"end": end, "step": step})
    sim = build_simulation(case, comm)
    history = sim.run(progress=False).history
    robot = sim.model.robot
    ds = ufl.Measure(
        "ds", robot.mesh, subdomain_data=robot.facet_tags, metadata={"quadrature_degree": 4}
    )
    penetration = -mean_value(comm, sim.u[sim.gdim - 1], ds(robot.groups["bottom"][1]))
    law = create_penalty_law(
        case.contact, shear_modulus=SHEAR_MODULUS, density=DENSITY, thickness=MEMBRANE_THICKNESS
    )
    pressure = ref.resting_pressure(DENSITY, MEMBRANE_THICKNESS, GRAVITY)
    return RestingRun(
        penetration=penetration,
        expected=ref.penalty_penetration(pressure, law.stiffness, law.onset),
        contact_force=float(history["contact_force"][-1]),
        weight=DENSITY * GRAVITY * MEMBRANE_THICKNESS * MEMBRANE_LENGTH * MEMBRANE_WIDTH,
    )


def slide_on_ground(
    comm: MPI.Comm,
    regularization_velocity: float,
    contact: dict[str, Any],
    *,
    speed: float = SLIDE_SPEED,
    end: float = 0.008,
    step: float = 2e-4,
) -> tuple[float, float]:
    """(deceleration m/s² while v > 10 v_ε (NaN if never), distance slid m) of the strip membrane.

    Started at ``speed`` (m/s) along x; ``contact`` adds to the contact table
    beside ``regularization_velocity`` = v_ε (m/s). The speed comes from the
    kinetic energy, the deceleration from a straight-line fit of it, the
    distance is the mean x-displacement after ``end`` (s).
    """
    case = ground_membrane_case(
        "strip",
        {"regularization_velocity": regularization_velocity, **contact},
        {"end": end, "step": step},
    )
    sim = build_simulation(case, comm)

    def push(X: Any) -> Any:
        v = np.zeros((sim.gdim, X.shape[1]))
        v[0] = speed
        return v

    sim.integrator.v0.interpolate(push)
    history = sim.run(progress=False).history
    mass = DENSITY * MEMBRANE_THICKNESS * MEMBRANE_LENGTH * MEMBRANE_WIDTH
    v = np.sqrt(2 * history["energy_kinetic"] / mass)
    t = history["time"]
    sliding = v > 10 * regularization_velocity
    deceleration = -np.polyfit(t[sliding], v[sliding], 1)[0] if sliding.sum() > 2 else np.nan
    dx = ufl.Measure("dx", sim.model.robot.mesh, metadata={"quadrature_degree": 4})
    return float(deceleration), mean_value(comm, sim.u[0], dx)


# --- the default case's drive on a narrow arm (rod against shell) -----------------------------

NARROW_WIDTH = 0.25e-3  # m, ≈ 3 h: beam-like (Searle's b²/(R h) < 0.3 at the drive's curvatures)
DRIVE = {  # cases/one_arm_trapezoid.toml's field: 2 mT along −x, 20 Hz square wave
    "sources": [
        {
            "kind": "uniform",
            "flux_density": 2e-3,
            "direction": [-1, 0, 0],
            "waveform": {"kind": "square", "frequency": 20.0},
        }
    ]
}
HALF_PERIOD = 25e-3  # s, first half period of the drive


def narrow_drive_history(
    comm: MPI.Comm,
    *,
    model: str,
    size: float,
    degree: int,
    step: float,
    end: float = HALF_PERIOD,
    plane: str = "strain",
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(time in s, tip angle in rad) of the narrow cantilever driven by :data:`DRIVE`.

    The elastica's arm (:func:`cantilever_case`, bonded root, no gravity, no
    ground), NARROW_WIDTH wide (the shell with one element across), fixed
    steps ``step`` (s) with ρ∞ = 0.5, P``degree`` elements of ``size`` (m);
    ``plane`` as in :func:`cantilever_case` (``stress`` for the strip of a narrow arm).
    """
    case = cantilever_case(
        model,
        size,
        NARROW_WIDTH,
        plane,
        name="narrow_drive",
        size_across=NARROW_WIDTH if model == "surface" else None,
        field=DRIVE,
        time={"end": end, "step": step, "adaptive": False, "rho_inf": 0.5},
        solver={"degree": degree},
    )
    history = build_simulation(case, comm).run(progress=False).history
    return history["time"], history["angle_arm"]


FREE_PLATE_DENSITY, FREE_PLATE_REMANENCE, FREE_PLATE_THICKNESS = 2130.0, 123e3, 1e-4
"""ρ (kg/m³), M (A/m), t (m) of the stiff free plates of the free-body checks."""

_NO_OUTPUT_AT_ALL = {"csv": False, "vtx_every": 0, "plot": False, "animation": False}


def free_plate_case(model: str, *, length: Any, width: Any, **tables: Any) -> Case:
    """A free ``membrane`` plate, μ = 100 MPa (rigid: elastica load ~1e-3), no gravity.

    ``tables`` are added (``field``, ``time``, ...); ``robot``, ``material`` and
    ``environment`` entries update the defaults, ``size`` is the mesh size.
    """
    robot = {"shape": "membrane", "thickness": FREE_PLATE_THICKNESS}
    material = {
        "shear_modulus": "100 MPa",
        "density": FREE_PLATE_DENSITY,
        "remanence": FREE_PLATE_REMANENCE,
    }
    return parse_case(
        {
            "name": "free",
            "robot": robot | {"length": length, "width": width} | tables.pop("robot", {}),
            "mesh": {"size": tables.pop("size", "1 mm"), "model": model},
            "material": material | tables.pop("material", {}),
            "environment": {"gravity": [0, 0, 0], "clamped": []} | tables.pop("environment", {}),
            "output": _NO_OUTPUT_AT_ALL,
            **tables,
        }
    )


PENDULUM_FIELD_ANGLE = math.radians(60.0)
"""Angle (rad) of the pendulum's uniform field from the plate's initial normal."""


def magnetic_pendulum_error(
    comm: MPI.Comm, model: str, dt: float, *, average_forces: str = "auto"
) -> float:
    """Largest tilt error (rad) of a free 4 × 2 mm plate turning in a 2 mT field, 12 ms.

    Against :func:`verification.references.magnetic_pendulum` (the rigid plate
    about its width axis); ρ∞ = 1, constant steps ``dt``; ``average_forces``
    as ``[time] average_forces``. Checks on the way that the centre of mass
    stays put and that the plate swings through ~2 φ_B.
    """
    L, W, B = 4e-3, 2e-3, 2e-3
    direction = [math.sin(PENDULUM_FIELD_ANGLE), 0, math.cos(PENDULUM_FIELD_ANGLE)]
    source = {"kind": "uniform", "flux_density": B, "direction": direction}
    field = {"sources": [source | {"waveform": {"kind": "dc"}}]}
    time: dict[str, Any] = {"end": 0.012, "step": dt, "adaptive": False, "rho_inf": 1.0}
    time["average_forces"] = average_forces
    case = free_plate_case(model, length=L, width=W, field=field, time=time)
    h = build_simulation(case, comm).run(progress=False).history
    rho, m, t = FREE_PLATE_DENSITY, FREE_PLATE_REMANENCE, FREE_PLATE_THICKNESS
    inertia = rho * L * W * t * (L**2 + t**2) / 12  # about y through the centre
    exact = ref.magnetic_pendulum(h["time"], m * L * W * t * B / inertia, PENDULUM_FIELD_ANGLE)
    if np.max(np.abs(h["com_x"])) > 1e-12 or np.max(np.abs(h["com_z"] - t / 2)) > 1e-12:
        raise AssertionError("the centre of mass moved in a uniform field")
    if h["tilt_about_y"].max() < math.radians(110):
        raise AssertionError("the plate did not swing through 2 phi_B")
    return float(np.max(np.abs(h["tilt_about_y"] - exact)))


def gmsh_robot(
    builder: Any, comm: MPI.Comm, *, gdim: int, name: str, model: str, thickness: float, area: float
) -> RobotMesh:
    """The RobotMesh of a gmsh ``builder`` (tests that build their own geometry): its physical
    groups as the robot's groups, no arms, ``model`` (``"surface"``, ``"strip"``, ...) of
    ``thickness`` (m) and ``area`` (m²), collective."""
    data = build_mesh(builder, comm, gdim=gdim, name=name)
    return RobotMesh(
        mesh=data.mesh,
        cell_tags=data.cell_tags,
        facet_tags=data.facet_tags,
        groups={k: (int(v[0]), int(v[1])) for k, v in data.physical_groups.items()},
        arms=(),
        model=model,
        thickness=thickness,
        min_quality=1.0,
        num_cells=0,
        area=area,
    )


def contact_residual(contact: Any, state: Any) -> Any:
    """The PETSc residual vector of a contact's own Newton terms alone at ``state``."""
    b = state.duplicate()
    b.set(0.0)
    contact.add_residual(state, b)
    return b


def contact_direction(x: Any, seed: int, bc_dofs: Any, displacement_rows: int | None = None) -> Any:
    """A random direction for :func:`contact_jacobian_mismatch`: standard normal entries,
    those of the displacement (the first ``displacement_rows`` owned rows; None: all) scaled
    to 1e-6 m, the Dirichlet entries ``bc_dofs`` zero."""
    d = x.duplicate()
    d.setArray(np.random.default_rng(seed).standard_normal(d.getLocalSize()))
    d.array[:displacement_rows] *= 1e-6  # m
    d.array[bc_dofs] = 0.0
    return d


def contact_jacobian_mismatch(
    contact: Any, A: Any, x: Any, d: Any, bc_dofs: Any, eps: float = 1e-3
) -> tuple[float, Any]:
    """Relative mismatch ‖(R(x + εd) − R(x − εd))/(2ε) − J d‖ / ‖J d‖ of a contact's Newton
    terms (collective), and J d.

    ``A`` is zeroed and gets the contact's Jacobian at ``x``; ``d`` is the direction (its
    Dirichlet entries ``bc_dofs`` zero, whose rows the Jacobian leaves to the solver).
    Central differences are exact to O(ε²) while the step crosses no kink of the ramp.
    """
    A.zeroEntries()
    contact.add_jacobian(x, A)
    Jd = A.createVecLeft()
    A.mult(d, Jd)
    plus, minus = x.copy(), x.copy()
    plus.axpy(eps, d)
    minus.axpy(-eps, d)
    fd = contact_residual(contact, plus)
    fd.axpy(-1.0, contact_residual(contact, minus))
    fd.scale(1.0 / (2.0 * eps))
    fd.array[bc_dofs] = 0.0
    fd.axpy(-1.0, Jd)
    return fd.norm() / Jd.norm(), Jd
