"""magfem's rod against PyElastica on a dynamic magnetic cantilever: CPU time to 1° and 0.1°.

The problem: the narrow cantilever of benchmarks/rod_vs_shell.py (80 µm thick,
0.25 mm wide, 6.5 mm free, rigidly clamped at the bonded patch's edge,
μ = 115 kPa, K = 100 μ (E = 342.9 kPa), ρ = 2130 kg/m³, M = 123 kA/m through
the thickness), beam bending law, no gravity, in the default case's field for
its first half period: 2 mT along −x from t = 0 to 25 ms (the arm rises past
vertical by 6 ms and swings there). Observable: the tip angle every
millisecond; error: its largest difference over 0–25 ms from the same
code's finest run (each code's converged reference).

magfem: ``[mesh] model = "rod"`` (``root = "rigid"``, ``rod_bending =
"beam"``), implicit generalized-α (ρ∞ = 0.5; ``--rho-inf`` sets it for every
level and the reference), steps of Δt (cut where Newton fails). Every level
but the reference runs as a user after speed would run it
(:data:`FAST`): the kept Jacobian (``[solver] reuse_jacobian``), Newton to
1e-4 of the predictor's residual (``rtol``; default 1e-6) and a history row
every ms (``[output] history_interval``), the samples compared, as
PyElastica's run records its tip angle every ms only; ``--plain`` runs them
with magfem's defaults instead (full Newton to 1e-6, a row every step). The
reference always runs with the defaults.

PyElastica (optional: ``pip install pyelastica``): a Cosserat rod with the
same rectangular section (bending E b t³/12 and E t b³/12, Saint-Venant
torsion, 5/6 μ A shear, rotary inertia ρ I), explicit position Verlet, clamped
by ``OneEndFixedBC``; the magnetic couple is a forcing class (m × B per
element, m = M A Δl along the section normal d₁, in the material frame). Both
run on one core; times are CPU seconds of each code's time loop (on a shared
machine the wall time swings 2x with the other jobs), after a warm-up run that
compiles; each run's set-up (magfem: the mesh and the forms from the JIT cache;
PyElastica: the rod and ``finalize``) is left out of both and printed apart.

``--coil``: the field rises as the experiments' coil current does instead of
switching on at t = 0 (magfem's ``square_rl`` waveform at its defaults, L = 4.5 mH,
R = 1 Ω, V = 20 V, at I0 = 3 A; in PyElastica the same closed form, w = β(1 −
e^(−t/τ)) until it reaches 1, τ = L/R, β = V/(R I0): full field at 0.74 ms). A step
rings every bending mode with a tip angle falling only as 1/n², so a pointwise
history converges as √Δt; the rise leaves the modes far above 1/(0.74 ms) barely
excited.

``--damped``: both codes with the elastomer's Kelvin–Voigt damping of
relaxation time β = tan δ/(2π f), default tan δ = 0.1 at f = 50 Hz
(β = 0.318 ms; ``--loss-tangent``, ``--frequency``): silicone elastomers'
dynamic mechanical analyses give loss tangents of a few hundredths to a few
tenths at tens of Hz, the filler adds to it; 0.1 is that range's middle, not
a measured value of this membrane. magfem: ``[[loads]] kind =
"material_damping"``, the section's stresses n = S(Γ + β Γ̇), m = B(K + β K̇)
with the rod's S = diag(EA, 5/6 μA, 5/6 μA), B = diag(μ J, E b t³/12,
E t b³/12) (:meth:`~magfem.mechanics.models.rod.RodModel.strain_rate_energy`).
PyElastica: the same law, S and B component by component, through its rest
strains (``KelvinVoigt``: σ_rest = −β σ̇, κ_rest = −β κ̇ from the last step's
change). ``--decay`` checks both against ζ = β ω/2. An explicit step with this
damping is stable only while Δt ≲ 2/(β ω_max²) (a damped oscillator's
central-difference bound at ζ = β ω/2 ≫ 1; the rate's lag of 1.5 Δt lowers
it), and PyElastica's highest frequency, its section turning against the
shear stiffness, ω² = (5/6) μ A/(ρ I) = 10 μ/(ρ t²) (2/(β ω²) = 74 ns), does
not fall with coarser elements: the stable step drops from the µs of the
undamped levels to 10–30 ns (``--stability``); each damped level runs at about
0.8 of it. PyElastica's clamp (node 0 and element 0's directors held) shortens
the free arm by about half an element (``--decay``: the fourth mode's
frequency falls as 1/n), so PyElastica converges at first order; the damped
table also extrapolates its two finest levels. From the repository root:

    .venv/bin/python -m benchmarks.pyelastica_comparison [--coil | --damped]
    .venv/bin/python -m benchmarks.pyelastica_comparison [--damped] --decay|--stability|--split

(undamped ~2 min; ``--coil`` ~3 min; ``--damped`` ~7 min; ``--decay`` ~1.5 min; ``--split``:
where magfem's second-finest level spends its time, per step, with the
defaults and with each of :data:`FAST`'s settings added in turn).
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace
from typing import Any

import numpy as np
from mpi4py import MPI
from scipy import optimize

from benchmarks._common import Report
from magfem.case import Case
from magfem.field.waveforms import SquareRL
from magfem.mechanics.models.rod_section import torsion_constant
from magfem.parallel import rank0_print
from magfem.pipeline import build_simulation
from verification import references as ref
from verification import setups as vc

H, W, FREE = vc.THICKNESS, vc.NARROW_WIDTH, vc.FREE_LENGTH
MU, RHO, M_R, B = vc.SHEAR_MODULUS, vc.DENSITY, vc.REMANENCE, 2e-3
E = ref.young_modulus(MU, 100 * MU)
END = vc.HALF_PERIOD
SAMPLES = np.arange(0.0, END + 1e-9, 1e-3)  # s
COMM = MPI.COMM_SELF  # both codes on one core
SETUP: dict[str, list[float]] = {"magfem": [], "PyElastica": []}
"""Each run's set-up CPU s (not in the times compared: :func:`setup_line`)."""

MAGFEM_LEVELS = [  # (size m, degree, step s); the last is the reference
    (1e-3, 2, 0.5e-3),
    (0.5e-3, 2, 0.25e-3),
    (0.5e-3, 2, 0.125e-3),
    (0.5e-3, 3, 0.0625e-3),
    (0.5e-3, 3, 0.03125e-3),
    (0.25e-3, 3, 0.0625e-3),
    (0.25e-3, 3, 0.03125e-3),
    (0.125e-3, 3, 0.015625e-3),
]
MAGFEM_COIL_LEVELS = [  # --coil: the same, three more at smaller steps, the reference at Δt/4
    *MAGFEM_LEVELS[:-1],
    (0.5e-3, 3, 0.015625e-3),
    (0.25e-3, 3, 0.015625e-3),
    (0.25e-3, 3, 0.0078125e-3),
    (0.125e-3, 3, 0.00390625e-3),
]
ELASTICA_LEVELS = [(25, 4e-6), (50, 2e-6), (100, 1e-6), (200, 5e-7), (400, 2.5e-7)]  # (n, Δt s)
ELASTICA_COIL_LEVELS = [*ELASTICA_LEVELS, (800, 1.25e-7)]  # --coil: one more, as reference

LOSS_TANGENT, LOSS_FREQUENCY = 0.1, 50.0  # tan δ at Hz: β = 0.318 ms (module docstring)
MAGFEM_DAMPED_LEVELS = [
    (1e-3, 2, 0.5e-3),
    (0.5e-3, 2, 0.125e-3),
    (0.5e-3, 3, 0.125e-3),
    (0.5e-3, 3, 0.0625e-3),
    (0.25e-3, 3, 0.125e-3),
    (0.25e-3, 3, 0.0625e-3),
    (0.25e-3, 3, 0.03125e-3),
    (0.125e-3, 3, 0.015625e-3),
]
ELASTICA_DAMPED_LEVELS = [(25, 2.5e-8), (50, 1.6e-8), (100, 8e-9)]  # (n, Δt s)
ELASTIC_STEP = {25: 4e-6, 50: 2e-6, 100: 1e-6}  # s, the undamped levels' steps
DECAY_MODE, DECAY_PUSH, DECAY_END, DECAY_EVERY = 4, 1e-3, 15e-3, 2e-5  # 133 Hz; m/s; s; s
CLAMP = vc.CLAMP_LENGTH  # m, where magfem's rigid root ends (x of s = 0)
FAST: dict[str, dict[str, Any]] = {
    "solver": {"reuse_jacobian": True, "rtol": 1e-4},
    "output": {"history_interval": 1e-3},
}
"""The settings of magfem's levels but the reference (module docstring; ``--plain``: none).
Together they move no level's error by more than 0.001° but the two coarsest, 7–9° off, by
up to 0.6° (the tables with and without ``--plain``; ``--split``; docs/verification.md 6c)."""
PLAIN: dict[str, dict[str, Any]] = {"solver": {}, "output": {}}
"""magfem's defaults (the reference, ``--plain``)."""
RHO_INF = {"magfem": 0.5}
"""magfem's spectral radius at infinity, every level and the reference (``--rho-inf``)."""
COIL = {"inductance": 4.5e-3, "resistance": 1.0, "voltage": 20.0, "current": 3.0}
"""``--coil``: the experiments' coil (``square_rl``'s defaults) at 3 A (H, Ω, V, A)."""
DRIVES: dict[str, Any] = {"field": vc.DRIVE, "coil": False}
"""The field of every run (magfem's ``[field]``), and whether it rises with the coil's
current (``--coil``; else it switches on at t = 0)."""


def coil_drive() -> dict[str, Any]:
    """:data:`vc.DRIVE` with the current of :data:`COIL` (``square_rl``) in place of the square."""
    (source,) = vc.DRIVE["sources"]
    waveform = {"kind": "square_rl", "frequency": source["waveform"]["frequency"], **COIL}
    return {"sources": [{**source, "waveform": waveform}]}


def coil_fraction(t: float) -> float:
    """B(t)/B of ``square_rl`` on its first half period from zero current (closed form):
    β(1 − e^(−t/τ)) until it reaches 1 (τ = L/R, β = V/(R I0))."""
    tau = COIL["inductance"] / COIL["resistance"]
    beta = COIL["voltage"] / (COIL["resistance"] * COIL["current"])
    return min(beta * -math.expm1(-t / tau), 1.0)


def magfem_case(
    size: float,
    degree: int,
    step: float,
    beta: float = 0.0,
    field: Any = None,
    end: float = END,
    settings: dict[str, dict[str, Any]] = PLAIN,
) -> Case:
    """The case of magfem's rod at one level (mesh size m, degree, step s), with the
    material damping of relaxation time ``beta`` (s; 0: none) in ``field`` (default: the drive)
    and the ``[solver]`` and ``[output]`` keys of ``settings`` (:data:`FAST`, :data:`PLAIN`)."""
    damping = [{"kind": "material_damping", "relaxation_time": beta}] if beta else []
    case = vc.cantilever_case(
        "rod",
        size,
        W,
        "strain",
        name="pyelastica_comparison",
        root="rigid",
        mesh_options={"rod_bending": "beam"},
        field=DRIVES["field"] if field is None else field,
        time={"end": end, "step": step, "rho_inf": RHO_INF["magfem"]},
        solver={"degree": degree, **settings["solver"]},
        loads=damping,
    )
    return replace(case, output=replace(case.output, **settings["output"]))


def magfem_run(
    size: float, degree: int, step: float, beta: float = 0.0, **kwargs: Any
) -> tuple[float, np.ndarray]:
    """(CPU s of the time loop, tip angle in degrees at SAMPLES) of magfem's rod (``kwargs``:
    ``field``, ``end``, ``settings`` of :func:`magfem_case`, ``samples`` (s) in place of
    SAMPLES); the set-up's CPU s (mesh, forms from the JIT cache) goes to ``SETUP``."""
    samples = kwargs.pop("samples", SAMPLES)
    start = time.process_time()
    sim = build_simulation(magfem_case(size, degree, step, beta, **kwargs), COMM)
    loop = time.process_time()
    history = sim.run(progress=False).history
    cpu = time.process_time() - loop
    SETUP["magfem"].append(loop - start)
    return cpu, np.interp(samples, history["time"], np.degrees(history["angle_arm"]))


def magfem_split(size: float, degree: int, step: float, beta: float = 0.0) -> None:
    """Print where one level's run spends its time, per step, and its error against the
    reference, with magfem's defaults and :data:`FAST`'s settings added one by one
    (``--split``)."""
    reference = magfem_run(*(MAGFEM_DAMPED_LEVELS if beta else MAGFEM_LEVELS)[-1], beta)[1]
    solver, output = FAST["solver"], FAST["output"]
    variants = [
        ("defaults", PLAIN),
        ("+ reuse_jacobian", {"solver": {"reuse_jacobian": True}, "output": {}}),
        (f"+ rtol {solver['rtol']:g}", {"solver": solver, "output": {}}),
        (f"+ history_interval {output['history_interval'] * 1e3:g} ms", FAST),
    ]
    for label, settings in variants:
        sim = build_simulation(magfem_case(size, degree, step, beta, settings=settings), COMM)
        start = time.process_time()
        result = sim.run(progress=False)
        cpu = time.process_time() - start
        history = result.history
        angles = np.interp(SAMPLES, history["time"], np.degrees(history["angle_arm"]))
        steps, iterations = result.summary["steps"], result.effort["iterations"]
        timings = result.timings
        parts = ", ".join(
            f"{k} {timings[k] / steps * 1e3:.2f}" for k in ("residual", "jacobian", "linear_solve")
        )
        rest = timings["total"] - sum(timings[k] for k in ("residual", "jacobian", "linear_solve"))
        rank0_print(
            f"{size * 1e3:g} mm P{degree}, dt {step * 1e3:g} ms, {label}: {steps:g} steps, "
            f"{iterations} Newton iterations, {result.effort['jacobians']} Jacobians, CPU "
            f"{cpu:.2f} s ({cpu / steps * 1e3:.2f} ms per step); wall ms per step: {parts}, "
            f"the rest (observers, loads, integrator, SNES) {rest / steps * 1e3:.2f}; "
            f"max error 0-25 ms {np.max(np.abs(angles - reference)):.3f} deg"
        )


class _ElasticaForcing:
    """PyElastica's forcing classes of the benchmark (built on first use: optional import)."""

    def __init__(self) -> None:
        import elastica as ea  # optional benchmark dependency

        class MagneticCouple(ea.NoForces):  # type: ignore[misc]
            """The hard-magnetic couple m × B, m = M_r A Δl d₁ (d₁ the section normal)."""

            def __init__(self, moment: float, field: Any, rise: bool = False) -> None:
                super().__init__()
                self.moment, self.field = moment, np.asarray(field, dtype=float)
                self.rise = rise

            def apply_torques(self, system: Any, time: Any = 0.0) -> None:
                directors = system.director_collection  # (3 directors, 3 components, n)
                field = self.field * coil_fraction(float(time)) if self.rise else self.field
                couple = self.moment * np.cross(directors[0].T, field).T  # global (3, n)
                system.external_torques += np.einsum("ijk,jk->ik", directors, couple)

        class KelvinVoigt(ea.NoForces):  # type: ignore[misc]
            """n = S(σ − σ₀ + β σ̇), m = B(κ − κ₀ + β κ̇): the rod's rest strains shifted.

            PyElastica's stresses are S(σ − σ_rest) and B(κ − κ_rest); each step sets
            σ_rest = σ₀ − β σ̇, κ_rest = κ₀ − β κ̇ with the rates the difference of σ, κ
            over the last step (Δt). The internal forces of a step are computed before the
            forcing is called, so the rate in them lags by 1.5 Δt.
            """

            def __init__(self, beta: float, dt: float) -> None:
                super().__init__()
                self.beta, self.dt = beta, dt
                self.rest: tuple[np.ndarray, np.ndarray] | None = None
                self.last: tuple[np.ndarray, np.ndarray] | None = None

            def apply_forces(self, system: Any, time: Any = 0.0) -> None:
                sigma, kappa = system.sigma, system.kappa
                if self.rest is None:
                    self.rest = (system.rest_sigma.copy(), system.rest_kappa.copy())
                if self.last is not None:
                    c = self.beta / self.dt
                    system.rest_sigma[:] = self.rest[0] - c * (sigma - self.last[0])
                    system.rest_kappa[:] = self.rest[1] - c * (kappa - self.last[1])
                self.last = (sigma.copy(), kappa.copy())

        self.ea, self.MagneticCouple, self.KelvinVoigt = ea, MagneticCouple, KelvinVoigt


def elastica_run(
    n: int, dt: float, end: float = END, beta: float = 0.0, **kwargs: Any
) -> tuple[float, np.ndarray]:
    """(CPU s, tip angle in degrees every ``every`` s) of PyElastica's rod of ``n`` elements,
    with the Kelvin–Voigt damping of relaxation time ``beta`` (s; 0: none); ``kwargs``:
    ``field`` (T, 3-vector; default the drive's 2 mT along −x, which is on for 0–25 ms,
    rising as :func:`coil_fraction` with ``--coil``),
    ``every`` (s, default 1 ms), ``push`` (start in mode ``DECAY_MODE``), ``energy`` (a
    list: the kinetic and elastic energy (J) at each sample is appended to it)."""
    setup = time.process_time()
    forcing = _ElasticaForcing()
    ea = forcing.ea

    class Simulator(ea.BaseSystemCollection, ea.Constraints, ea.Forcing):  # type: ignore[misc]
        pass

    sim = Simulator()
    x, z = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    radius = np.sqrt(W * H / np.pi)  # the section's area
    rod = ea.CosseratRod.straight_rod(
        n, np.zeros(3), x, z, FREE, radius, RHO, youngs_modulus=E, shear_modulus=MU
    )
    area, dl = W * H, FREE / n
    i_normal, i_width = W * H**3 / 12, H * W**3 / 12  # about d₂ (across) and d₁ (normal)
    bend = (E * i_width, E * i_normal, MU * torsion_constant(W, H))  # about d₁, d₂, d₃
    inertia = RHO * dl * np.array([i_width, i_normal, i_width + i_normal])
    for k in range(3):
        rod.bend_matrix[k, k, :] = bend[k]
        rod.shear_matrix[k, k, :] = E * area if k == 2 else 5 / 6 * MU * area
        rod.mass_second_moment_of_inertia[k, k, :] = inertia[k]
        rod.inv_mass_second_moment_of_inertia[k, k, :] = 1 / inertia[k]
    sim.append(rod)
    sim.constrain(rod).using(
        ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,)
    )
    field = kwargs.get("field", [-B, 0.0, 0.0])
    rise = "field" not in kwargs and DRIVES["coil"]  # the drive, with --coil
    sim.add_forcing_to(rod).using(forcing.MagneticCouple, M_R * area * dl, field, rise)
    if beta:
        sim.add_forcing_to(rod).using(forcing.KelvinVoigt, beta, dt)
    sim.finalize()
    if kwargs.get("push"):  # the velocity of mode DECAY_MODE, DECAY_PUSH at the tip
        nodes = np.linspace(0.0, FREE, n + 1)
        rod.velocity_collection[2, :] = DECAY_PUSH * mode_shape(nodes)[0]
        rod.omega_collection[1, :] = DECAY_PUSH * mode_shape(nodes[:-1] + dl / 2)[1]  # about d₂
    stepper, now = ea.PositionVerlet(), np.float64(0.0)
    every = round(kwargs.get("every", 1e-3) / dt)
    angles = [0.0]
    start = time.process_time()
    SETUP["PyElastica"].append(start - setup)
    for k in range(round(end / dt)):
        now = stepper.step(sim, now, np.float64(dt))
        if (k + 1) % every == 0:
            tip = rod.position_collection[:, -1] - rod.position_collection[:, -2]
            angles.append(np.degrees(np.arctan2(tip[2], tip[0])))
            if "energy" in kwargs:
                kwargs["energy"].append(_elastica_energy(rod))
    return time.process_time() - start, np.array(angles)


def _elastica_energy(rod: Any) -> float:
    """Kinetic and elastic energy (J) of PyElastica's straight-at-rest rod: its own
    ``compute_*_energy`` would see the damping's shifted rest strains."""
    sigma, kappa = rod.sigma, rod.kappa
    shear = np.einsum("ik,ijk,jk,k->", sigma, rod.shear_matrix, sigma, rod.rest_lengths)
    bend = np.einsum("ik,ijk,jk,k->", kappa, rod.bend_matrix, kappa, rod.rest_voronoi_lengths)
    kinetic = rod.compute_translational_energy() + rod.compute_rotational_energy()
    return float(kinetic + 0.5 * (shear + bend))


def mode_shape(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Euler–Bernoulli clamped–free mode ``DECAY_MODE`` (φ, φ' in 1/m) at s (m from the clamp)."""
    k = ref.cantilever_eigenvalue(DECAY_MODE) / FREE
    kl = k * FREE
    c = (np.cosh(kl) + np.cos(kl)) / (np.sinh(kl) + np.sin(kl))
    s = np.clip(s, 0.0, FREE)
    phi = np.cosh(k * s) - np.cos(k * s) - c * (np.sinh(k * s) - np.sin(k * s))
    dphi = k * (np.sinh(k * s) + np.sin(k * s) - c * (np.cosh(k * s) - np.cos(k * s)))
    return phi, dphi


def decay_fit(t: np.ndarray, angle: np.ndarray, omega: float) -> tuple[float, float]:
    """(ζ, ω rad/s) of a e^(−ζωt) cos(ω√(1 − ζ²) t + φ) fitted to ``angle``."""

    def model(t: np.ndarray, a: float, zeta: float, w: float, phi: float) -> Any:
        return a * np.exp(-zeta * w * t) * np.cos(w * np.sqrt(1 - zeta**2) * t + phi)

    guess = (np.max(np.abs(angle)), 0.1, omega, -np.pi / 2)
    p = optimize.curve_fit(
        model, t, angle, p0=guess, bounds=([-np.inf, 0, 0, -7], [np.inf, 0.9, 2 * omega, 7])
    )[0]
    return float(p[1]), float(p[2])


def magfem_decay(beta: float, t: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(CPU s, tip angle in degrees, energy in J at ``t``) of magfem's rod (0.25 mm P3,
    Δt = 31.25 µs) after the push of ``DECAY_PUSH`` in mode ``DECAY_MODE``, no field."""
    start = time.process_time()
    field = {"sources": [{"kind": "uniform", "flux_density": 0.0, "direction": [-1, 0, 0]}]}
    case = magfem_case(0.25e-3, 3, 31.25e-6, beta, field=field, end=float(t[-1]))
    sim = build_simulation(case, COMM)

    def push(X: np.ndarray) -> np.ndarray:
        return np.stack([0 * X[0], 0 * X[0], DECAY_PUSH * mode_shape(X[0] - CLAMP)[0]])

    def turn(X: np.ndarray) -> np.ndarray:  # θ₀ about y: the slope w' = −θ₀
        return np.stack([-DECAY_PUSH * mode_shape(X[0] - CLAMP)[1], 0 * X[0], 0 * X[0]])

    sim.integrator.v0.interpolate(push)
    sim.integrator.parts[1].v0.interpolate(turn)
    history = sim.run(progress=False).history
    cpu = time.process_time() - start
    angle = np.interp(t, history["time"], np.degrees(history["angle_arm"]))
    return cpu, angle, np.interp(t, history["time"], history["energy_total"])


def envelope_fit(t: np.ndarray, energy: np.ndarray, omega: float) -> float:
    """ζ of the energy's decay e^(−2ζωt): a line through ln E over 1 ms to 1 ms plus three of
    its ripple's periods π/ω (whole periods: the ripple, of size ζ, averages out)."""
    keep = (t >= 1e-3) & (t <= 1e-3 + 3 * np.pi / omega)
    slope = np.polyfit(t[keep], np.log(energy[keep]), 1)[0]
    return float(-slope / (2 * omega))


def decay(beta: float) -> None:
    """The free decay of Euler–Bernoulli mode ``DECAY_MODE`` pushed at its shape (no field),
    both codes, against ζ = βω/2 (``--decay``): ω from a damped sine fitted to the tip
    angle, ζ from the energy's decay (the push also stirs the slow first modes, whose
    large tip angle for little energy would bias a fit of the angle's decay)."""
    omega = 2 * np.pi * ref.cantilever_frequency(E, RHO, H, FREE, DECAY_MODE)
    t = np.arange(0.0, DECAY_END + 1e-9, DECAY_EVERY)
    energy: list[float] = []
    cpu, angle = elastica_run(
        50, 1.6e-8, DECAY_END, beta, field=[0.0] * 3, every=DECAY_EVERY, push=True, energy=energy
    )
    omega_magfem = omega
    runs = {
        "magfem rod 0.25 mm P3, dt 31.25 us": magfem_decay(beta, t),
        "PyElastica 50 elements, dt 16 ns": (cpu, angle, np.array([energy[0], *energy])),
    }
    rank0_print(
        f"mode {DECAY_MODE}, beta {beta * 1e3:.4g} ms; Euler-Bernoulli: f "
        f"{omega / 2 / np.pi:.2f} Hz, zeta = beta omega/2 = {beta * omega / 2:.4f}"
    )
    for name, (cpu, angle, energy_) in runs.items():
        w = decay_fit(t, angle, omega)[1]
        zeta = envelope_fit(t, energy_, w)
        rank0_print(
            f"{name} (CPU {cpu:.1f} s): f {w / 2 / np.pi:.2f} Hz ({w / omega - 1:+.2%}), "
            f"zeta {zeta:.4f} ({zeta / (beta * omega / 2) - 1:+.2%}; against beta w/2 at its "
            f"own w: {zeta / (beta * w / 2) - 1:+.2%})"
        )
        omega_magfem = w if name.startswith("magfem") else omega_magfem
    for n in (50, 100, 200):  # undamped: PyElastica's clamp error
        angle = elastica_run(n, 5e-5 / n, DECAY_END, field=[0.0] * 3, every=DECAY_EVERY, push=True)
        w = decay_fit(t, angle[1], omega)[1]
        rank0_print(
            f"PyElastica undamped, {n} elements: f {w / 2 / np.pi:.2f} Hz, "
            f"{w / omega_magfem - 1:+.2%} from magfem's"
        )


RISE = SAMPLES <= 6e-3  # the rise to vertical, before the swing


def time_to(levels: list[tuple[float, float, float]], tolerance: float, column: int) -> float:
    """Least wall time (s) of a level within ``tolerance`` (deg) of the reference in
    ``column`` (1: 0-25 ms, 2: the rise); inf if none."""
    return min((level[0] for level in levels if level[column] <= tolerance), default=np.inf)


HEADER = "| code | resolution | CPU (s, 1 core) | max error 0-25 ms (deg) | 0-6 ms (deg) |"


REFERENCE_CPU: dict[str, float] = {}
"""CPU s of each code's reference run (by the name :func:`compare` was given)."""


def compare(report: Report, name: str, runs: list[tuple[str, float, np.ndarray]]) -> list:
    """Rows (label, wall, errors) against the last run; returns [(wall, error, rise error)]."""
    reference = runs[-1][2]
    REFERENCE_CPU[name] = runs[-1][1]
    out = []
    for label, wall, angles in runs[:-1]:
        error = np.abs(angles - reference)
        rise = float(np.max(error[RISE]))
        report.row(f"| {name} | {label} | {wall:.2f} | {np.max(error):.3f} | {rise:.3f} |")
        out.append((wall, float(np.max(error)), rise))
    report.row(f"| {name} | {runs[-1][0]} (reference) | {runs[-1][1]:.2f} | - | - |")
    return out


def table(report: Report, beta: float, magfem_levels: list, elastica_levels: list) -> tuple:
    """Both codes' rows at relaxation time ``beta`` (s), magfem's but the reference with the
    settings :data:`FAST` (:data:`PLAIN` with ``--plain``); returns the rows of
    :func:`compare`,
    magfem's reference and every PyElastica run's angles, (magfem, PyElastica, magfem
    reference, [PyElastica angles per level])."""
    for degree in (2, 3):  # compilation
        magfem_run(1e-3, degree, 0.5e-3, beta, end=1e-3)
    runs = [
        (f"{s * 1e3:g} mm P{p}, dt {dt * 1e3:g} ms", *magfem_run(s, p, dt, beta, settings=FAST))
        for s, p, dt in magfem_levels[:-1]
    ]
    s, p, dt = magfem_levels[-1]
    runs.append((f"{s * 1e3:g} mm P{p}, dt {dt * 1e3:g} ms", *magfem_run(s, p, dt, beta)))
    magfem, magfem_reference = compare(report, "magfem rod", runs), runs[-1][2]
    elastica_run(10, 1e-6, 1e-5, beta)  # compilation
    runs = [
        (f"{n} elements, dt {dt:g} s", *elastica_run(n, dt, END, beta)) for n, dt in elastica_levels
    ]
    elastica = compare(report, "PyElastica", runs)
    return magfem, elastica, magfem_reference, [run[2] for run in runs]


def ratios(report: Report, magfem: list, elastica: list, name: str = "PyElastica") -> None:
    """Time to 1° and 0.1° of both codes over 0-25 ms and the rise, and their ratio."""
    for column, window in ((1, "0-25 ms"), (2, "0-6 ms")):
        for tolerance in (1.0, 0.1):
            a, b = time_to(magfem, tolerance, column), time_to(elastica, tolerance, column)
            if np.isinf(a) and np.isinf(b):
                report.add(f"{window}, to {tolerance:g} deg: neither code at these levels")
                continue
            report.add(
                f"{window}, to {tolerance:g} deg: magfem {a:.2f} s, {name} {b:.2f} s, "
                f"{name}/magfem {b / a:.2f}"
            )


def coil_line() -> str:
    """The PyElastica forcing's :func:`coil_fraction` against magfem's ``square_rl``."""
    (source,) = DRIVES["field"]["sources"]
    waveform = SquareRL(source["waveform"]["frequency"], **COIL)
    t = np.linspace(0.0, END, 25001)
    ours = np.array([coil_fraction(x) for x in t])
    gap = np.max(np.abs(ours - np.asarray(waveform.value(t))))
    return f"coil current: PyElastica's closed form vs magfem's square_rl, max {gap:.1e}"


def first_order_estimate(levels: list[tuple[int, float]], rows: list, reference_cpu: float) -> list:
    """PyElastica's CPU s to 1° and 0.1° where no level reached them, estimated: its error
    against its reference of n_ref elements is C (1/n − 1/n_ref) (first order, the clamp's
    half element), C from its finest level; n from C (1/n − 1/n_ref) = tolerance; CPU as
    n² (elements × steps), scaled from the reference's. Lines for :class:`Report`."""
    (n_ref, _), (n, _) = levels[-1], levels[-2]
    lines = []
    for column, window in ((1, "0-25 ms"), (2, "0-6 ms")):
        c = rows[-1][column] / (1 / n - 1 / n_ref)
        for tolerance in (1.0, 0.1):
            if time_to(rows, tolerance, column) < np.inf:
                continue
            needed = 1 / (tolerance / c + 1 / n_ref)
            lines.append(
                f"{window}, to {tolerance:g} deg: PyElastica estimated at first order "
                f"(C = {c:.0f} deg x element): {needed:.0f} elements, "
                f"{reference_cpu * (needed / n_ref) ** 2:.1f} s"
            )
    return lines


def extrapolated_line(magfem: np.ndarray, finest: np.ndarray, coarser: np.ndarray) -> str:
    """PyElastica's two finest runs (n and n/2 elements) extrapolated to zero element length
    at first order, 2 a_n − a_n/2 (its clamp's half element removed), against converged
    magfem: the largest difference, where, and every ms (deg)."""
    gap = np.abs(2 * finest - coarser - magfem)
    return (
        f"PyElastica extrapolated to zero element length (2 a_n - a_n/2, first order) vs "
        f"converged magfem: max {gap.max():.3f} deg at {SAMPLES[int(np.argmax(gap))] * 1e3:g} "
        f"ms; every ms: {np.round(gap, 3).tolist()}"
    )


def setup_line() -> str:
    """The range of each code's set-up time per run, which the compared times leave out."""
    parts = [f"{k} {min(v):.2f}-{max(v):.2f} s" for k, v in SETUP.items() if v]
    head = "set-up per run, not counted (magfem: mesh and forms from the JIT cache; "
    return f"{head}PyElastica: rod and finalize): " + ", ".join(parts)


def gap_line(magfem_reference: np.ndarray, elastica_reference: np.ndarray) -> str:
    """The difference of the two converged answers, largest and every ms (deg)."""
    gap = np.abs(magfem_reference - elastica_reference)
    return (
        f"converged magfem vs converged PyElastica: max {gap.max():.3f} deg at "
        f"{SAMPLES[int(np.argmax(gap))] * 1e3:g} ms; every ms: {np.round(gap, 3).tolist()}"
    )


def undamped() -> None:
    """The undamped comparison (§6c's first table)."""
    coil = DRIVES["coil"]
    drive = "the coil's rising current" if coil else "switched on at t = 0"
    report = Report(
        f"magfem's rho_inf {RHO_INF['magfem']:g}; the field {drive}",
        HEADER,
        "|---|---|---|---|---|",
    )
    levels = ELASTICA_COIL_LEVELS if coil else ELASTICA_LEVELS
    magfem, elastica, a, b = table(
        report, 0.0, MAGFEM_COIL_LEVELS if coil else MAGFEM_LEVELS, levels
    )
    report.add("")
    if coil:
        report.add(coil_line())
    ratios(report, magfem, elastica)
    for line in first_order_estimate(levels, elastica, REFERENCE_CPU["PyElastica"]):
        report.add(line)
    report.add(gap_line(a, b[-1]))
    report.add(extrapolated_line(a, b[-1], b[-2]))
    report.add(setup_line())
    report.print()


def damped(beta: float) -> None:
    """The comparison with the Kelvin–Voigt damping of relaxation time ``beta`` (s).

    PyElastica's explicit step is bounded by the damping of its highest modes
    (module docstring): each level runs at about 0.8 of its measured stable step.
    A line more: PyElastica's CPU time undamped, at its elastic stable step, for the
    same element counts, paired with the damped errors: what any damping that
    left PyElastica's step alone could at best cost (a bound, not a run).
    """
    report = Report(f"relaxation time {beta * 1e3:.4g} ms", HEADER, "|---|---|---|---|---|")
    magfem, elastica, a, b = table(report, beta, MAGFEM_DAMPED_LEVELS, ELASTICA_DAMPED_LEVELS)
    bound = []
    for (n, _), (_, error, rise) in zip(ELASTICA_DAMPED_LEVELS, elastica, strict=False):
        cpu = elastica_run(n, ELASTIC_STEP[n], END)[0]
        report.row(f"| PyElastica undamped | {n} elements, dt {ELASTIC_STEP[n]:g} s | {cpu:.2f} |")
        bound.append((cpu, error, rise))
    report.add("")
    ratios(report, magfem, elastica)
    report.add("bound: the damped errors at the undamped CPU time of PyElastica's elastic step:")
    ratios(report, magfem, bound, "PyElastica bound")
    report.add(gap_line(a, b[-1]))
    report.add(setup_line())
    report.add(extrapolated_line(a, b[-1], b[-2]))
    report.print()


def stability(beta: float) -> None:
    """PyElastica's damped rod over 2 ms at the last stable and first unstable steps
    (``--stability``): an unstable run leaves the rise (38° at 2 ms) within 0.25 ms."""
    for n, steps in ((25, (3e-8, 3.5e-8)), (50, (2e-8, 2.5e-8)), (100, (1e-8, 1.5e-8))):
        for dt in steps:
            angles = np.round(elastica_run(n, dt, 2e-3, beta, every=2.5e-4)[1], 1).tolist()
            rank0_print(f"{n} elements, dt {dt:g} s: tip angle every 0.25 ms {angles}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--damped", action="store_true", help="with the material damping")
    parser.add_argument("--loss-tangent", type=float, default=LOSS_TANGENT, help="tan δ")
    parser.add_argument("--frequency", type=float, default=LOSS_FREQUENCY, help="of tan δ, Hz")
    parser.add_argument("--decay", action="store_true", help="damped free decay, both codes")
    parser.add_argument("--split", action="store_true", help="magfem's time per step")
    parser.add_argument("--stability", action="store_true", help="PyElastica's damped steps")
    parser.add_argument(
        "--plain", action="store_true", help="magfem's levels with its defaults, not FAST's"
    )
    parser.add_argument(
        "--rho-inf", type=float, default=0.5, help="magfem's generalized-alpha rho_inf (0-1)"
    )
    parser.add_argument(
        "--coil", action="store_true", help="the field rising with the coil's current"
    )
    args = parser.parse_args()
    if not 0.0 <= args.rho_inf <= 1.0:
        parser.error(f"--rho-inf must lie in [0, 1], got {args.rho_inf}")
    RHO_INF["magfem"] = args.rho_inf
    if args.coil:
        DRIVES.update(field=coil_drive(), coil=True)
    if args.plain:
        FAST.update(PLAIN)
    beta = args.loss_tangent / (2 * np.pi * args.frequency) if args.damped else 0.0
    if args.split:
        magfem_split(*(MAGFEM_DAMPED_LEVELS if beta else MAGFEM_LEVELS)[-2], beta)
    elif args.stability:
        stability(args.loss_tangent / (2 * np.pi * args.frequency))
    elif args.decay:
        decay(args.loss_tangent / (2 * np.pi * args.frequency))
    elif beta:
        damped(beta)
    else:
        undamped()


if __name__ == "__main__":
    main()
