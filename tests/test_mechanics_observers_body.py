"""Free bodies against closed forms, measured by the body observer (centre of mass, momentum, tilt).

* A free magnetised plate in a uniform field turns as the rigid magnetic
  pendulum I φ'' = −M V B sin(φ − φ_B) (scipy), at second order in Δt.
* In the constant gradient of a Taylor-1 field its centre of mass
  accelerates at (m·∇)B / mass.
* Without loads, linear and angular momentum are conserved to round-off and
  the energy to the integrator's second-order bound.
* Above a cylinder magnet (exact field, ``nodal2``) a plate magnetised against
  the field floats at the height where the force balances the weight and bobs
  at the closed-form frequency.
* The summary's transition times and distances on synthetic histories.

Stiff plates (μ = 100 MPa) make the elastic part of the motion negligible
(the elastica load M B L²/(E t²) ~ 1e-3), so the references are rigid bodies.
The generalized-α runs use ρ∞ = 1 (the midpoint rule: no numerical
dissipation, exact momentum balance).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.field.source import CylinderMagnetField
from magfem.mechanics.observers.body import summarize_body, transition_time
from magfem.pipeline import build_simulation
from verification import references as ref
from verification import setups as vc

RHO, M, T = vc.FREE_PLATE_DENSITY, vc.FREE_PLATE_REMANENCE, vc.FREE_PLATE_THICKNESS
_plate = vc.free_plate_case


# --- pendulum ------------------------------------------------------------------------------


def _pendulum_error(comm, model: str, dt: float) -> float:
    # the free body's default, the implicit midpoint rule; averaging the forces over the
    # step (which conserves energy) has a far larger phase error on this fast rotation of
    # a stiff plate: 3.8, 0.29, 0.024 deg at 0.2, 0.1, 0.05 ms (benchmarks.pendulum_phase)
    return vc.magnetic_pendulum_error(comm, model, dt)


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_free_plate_turns_as_a_magnetic_pendulum(comm):
    coarse = _pendulum_error(comm, "surface", 2e-4)
    fine = _pendulum_error(comm, "surface", 1e-4)
    # the midpoint rule's phase error is second order: measured 0.081° and 0.022° (ratio 3.7);
    # what is left of the plate's bending (load 1e-3) is well below 0.01°
    assert 3.0 < coarse / fine < 4.5
    assert math.degrees(fine) < 0.03


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_free_solid_plate_turns_as_a_magnetic_pendulum(comm):
    # the solid's phase error at Δt = 0.2 ms: 0.094° (the shell's 0.081° plus its
    # thickness modes); 0.15° leaves room and fails a wrong inertia (L² vs L² + t²: 0.6°
    # at the end) or torque
    assert math.degrees(_pendulum_error(comm, "solid", 2e-4)) < 0.15


# --- constant gradient ---------------------------------------------------------------------

MAGNET = {
    "kind": "cylinder_magnet",
    "center": [0, 0, -5e-3],
    "axis": [0, 0, 1],
    "radius": 5e-3,
    "length": 10e-3,
    "remanence": 1.3,
    "waveform": {"kind": "dc"},
}


@pytest.mark.parametrize("model", ["surface", "solid"])
@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_constant_gradient_accelerates_the_centre_of_mass(comm, model):
    height = 30e-3
    x0 = np.array([0.0, 0.0, height + T / 2])
    field = {
        "model": "taylor1",
        "expansion_point": x0.tolist(),
        "workspace_size": "4 mm",
        "tolerance": 0.5,  # the gradient is meant to be constant: no warning for taylor1
        "sources": [MAGNET],
    }
    time = {"end": 0.01, "step": 5e-4, "adaptive": False, "rho_inf": 1.0}
    robot = {"position": [0, 0, height]}
    case = _plate(model, length="4 mm", width="2 mm", field=field, time=time, robot=robot)
    h = build_simulation(case, comm).run(progress=False).history
    magnet = CylinderMagnetField(np.array([0, 0, -5e-3]), np.array([0, 0, 1.0]), 5e-3, 10e-3, 1.3)
    G = magnet.gradient(x0[None])[0]
    a = G @ np.array([0.0, 0.0, M]) / RHO  # (m·∇)B / mass, per unit volume (G symmetric)
    exact = x0[:, None] + 0.5 * np.outer(a, h["time"] ** 2)
    com = np.vstack([h["com_x"], h["com_y"], h["com_z"]])
    drop = float(np.linalg.norm(exact[:, -1] - x0))
    assert drop > 5e-4  # 0.95 mm: the magnet pulls the aligned plate down at 18.9 m/s²
    # constant acceleration is exact for the midpoint rule and a rigid translation feels no
    # stress; what is left is the solid's through-thickness ringing under the field's
    # surface traction (1.6e-6 of the drop measured; the shell 3e-9)
    assert np.max(np.abs(com - exact)) < 1e-5 * drop


# --- momentum and energy -------------------------------------------------------------------


def _spin(comm, model: str, dt: float) -> dict[str, np.ndarray]:
    initial = {"velocity": [0.01, -0.02, 0.03], "angular_velocity": [5.0, 20.0, -10.0]}
    time = {"end": 0.02, "step": dt, "adaptive": False, "rho_inf": 1.0}
    solver = {"rtol": 1e-13, "atol": 1e-20}
    material = {"shear_modulus": "115 kPa", "remanence": 0.0}
    case = _plate(
        model,
        length="4 mm",
        width="2 mm",
        initial=initial,
        time=time,
        solver=solver,
        material=material,
    )
    sim = build_simulation(case, comm)
    v0 = sim.integrator.parts[0].v0  # a bending push on top of the rigid motion
    X = v0.function_space.tabulate_dof_coordinates()
    v0.x.array.reshape(-1, sim.gdim)[:, 2] += 0.05 * (X[:, 0] / 2e-3) ** 2
    return sim.run(progress=False).history


def _drift(h: dict[str, np.ndarray], name: str) -> float:
    v = np.vstack([h[f"{name}_{a}"] for a in "xyz"])
    return float(np.max(np.abs(v - v[:, :1])) / np.max(np.abs(v[:, 0])))


@pytest.mark.slow
def test_free_solid_conserves_momentum_and_energy(comm):
    coarse = _spin(comm, "solid", 2.5e-4)
    fine = _spin(comm, "solid", 1.25e-4)
    # the midpoint rule balances momentum exactly and, the internal forces being objective,
    # angular momentum too (Simo & Tarnow, ZAMP 43 (1992) 757): measured 3e-14 and 5e-14
    for h in (coarse, fine):
        assert _drift(h, "momentum") < 1e-11
        assert _drift(h, "angular_momentum") < 1e-11
        assert np.degrees(h["tilt"]).max() > 20  # it does turn
    energy = [h["energy_kinetic"] + h["energy_elastic"] for h in (coarse, fine)]
    errors = [float(np.max(np.abs(e - e[0])) / e[0]) for e in energy]
    # energy is not conserved by the midpoint rule for nonlinear elasticity, but its error is
    # bounded and at least second order: measured 4.9e-3 and 3.2e-4 (ratio 15)
    assert errors[1] < 1e-3
    assert errors[0] / errors[1] > 4.0


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_free_shell_conserves_momentum(comm):
    h = _spin(comm, "surface", 5e-4)
    # translation invariance of the shell's energy (measured 3e-15); its angular momentum
    # is not exact: the director's rotary inertia ½ρt³/12 |θ̇|² is not objective (2.8e-4)
    assert _drift(h, "momentum") < 1e-11
    assert _drift(h, "angular_momentum") < 1e-3


# --- levitation ----------------------------------------------------------------------------

TRAP = {
    "kind": "cylinder_magnet",
    "center": [0, 0, -1e-3],
    "axis": [0, 0, 1],
    "radius": 1e-3,
    "length": 2e-3,
    "remanence": 1.3,
    "waveform": {"kind": "dc"},
}
HALF_WIDTH = 6e-3


@pytest.mark.slow
def test_plate_levitates_above_a_magnet_and_bobs_at_the_closed_form_frequency(comm):
    magnet = CylinderMagnetField(np.array([0, 0, -1e-3]), np.array([0, 0, 1.0]), 1e-3, 2e-3, 1.3)
    z_eq, omega = ref.levitation_equilibrium(
        magnet.gradient, half_width=HALF_WIDTH, magnetization=M, density=RHO
    )
    # a 12 mm plate 8.5 mm above a 2 mm magnet: wide enough to be stable against tilting
    # (laterally it is not, Earnshaw: e^(38/s t) from round-off stays below 1e-11 m here)
    assert 8e-3 < z_eq < 9e-3
    delta, period, t2 = 1e-4, 2 * math.pi / omega, 2e-4
    dt = period / 40
    case = _plate(
        "surface",
        length=2 * HALF_WIDTH,
        width=2 * HALF_WIDTH,
        size="2 mm",
        robot={"thickness": t2, "position": [0, 0, z_eq + delta - t2 / 2]},
        material={"shear_modulus": "1 GPa", "direction": "-normal"},
        environment={"gravity": [0, 0, -9.8]},
        field={
            "model": "nodal2",
            "expansion_point": [0, 0, z_eq],
            "workspace_size": "14 mm",
            "sources": [TRAP],
        },
        time={"end": 2 * period, "step": dt, "adaptive": False, "rho_inf": 1.0},
    )
    h = build_simulation(case, comm).run(progress=False).history
    z, t = h["com_z"] - z_eq, h["time"]
    up = np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0))
    crossings = t[up] - z[up] * (t[up + 1] - t[up]) / (z[up + 1] - z[up])
    assert crossings.size >= 2
    # the midpoint rule stretches the period of ω by ωΔt / (2 atan(ωΔt/2)) = 1.00206 at
    # Δt = T/40; measured 1.00210 (the rest: the plate's size in the field, its sag)
    discrete = omega * dt / (2 * math.atan(omega * dt / 2)) * period
    assert float(np.diff(crossings)[0]) == pytest.approx(discrete, rel=2e-4)
    # it floats about z*: the centre of the oscillation is off by the anharmonic shift
    # ~δ²/z* ~ 1e-6 m (measured 2.5e-6 m), and keeps its amplitude (energy 1e-8)
    assert abs(0.5 * (z.max() + z.min())) < 0.05 * delta
    assert z.min() == pytest.approx(-delta, rel=0.02)
    energy = h["energy_total"][1:]
    assert np.max(np.abs(energy - energy[0])) < 1e-6 * abs(energy[0])


# --- summary -------------------------------------------------------------------------------


def test_transition_time_interpolates_the_thresholds():
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    tilt = np.radians([90.0, 70.0, 50.0, 20.0, 10.0])
    # last ≥ 60° at t = 1 → crosses 60° at 1.5; first ≤ 30° crosses at 2 + 2/3
    assert transition_time(t, tilt, math.radians(60), math.radians(30)) == pytest.approx(
        (2 + 2 / 3) - 1.5
    )
    assert math.isnan(transition_time(t, tilt, math.radians(30), math.radians(60)))
    # standing at the start, lying, then up again (the walker's first reversal): the stand-up
    # is the second crossing, from the last ≤ 30° sample (t = 5, 20°) to the first ≥ 60°
    # after it (t = 6, 80°): 30° at 5 + 10/60 and 60° at 5 + 40/60
    t = np.arange(8.0)
    tilt = np.radians([90.0, 70.0, 50.0, 20.0, 10.0, 20.0, 80.0, 90.0])
    assert transition_time(t, tilt, math.radians(30), math.radians(60)) == pytest.approx(
        (5 + 40 / 60) - (5 + 10 / 60)
    )


def test_body_summary_distances_and_times():
    t = np.linspace(0.0, 1.0, 11)
    h = {
        "time": t,
        "com_x": 0.01 * t,
        "com_y": np.zeros_like(t),
        "com_z": np.full_like(t, 2e-3),
        "tilt": np.radians(np.linspace(0.0, 100.0, 11)),  # lies, stands, tips over past 90°
    }
    s = summarize_body(h)
    assert s["travelled_distance"] == pytest.approx(0.01)
    assert s["net_displacement"] == pytest.approx(0.01)
    assert s["mean_speed"] == pytest.approx(0.01)
    # folded tilt 0 → 90 → 80°: stands up from 30° (t = 0.3) to 60° (t = 0.6)
    assert s["stand_up_time"] == pytest.approx(0.3)
    assert math.isnan(s["lay_down_time"])
    assert s["max_tilt"] == pytest.approx(math.radians(100))
