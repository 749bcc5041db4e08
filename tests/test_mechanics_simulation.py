"""End-to-end membrane dynamics on small 2D strips (plane strain), serial and mpirun -n 2.

Reference-free physics checks: energy conservation/decay of the integrator on
the full nonlinear FE problem, parallel reproducibility, and the extremes of
issue 4 (thickness 45/1000 µm, field 0.5/10 mT, 200 Hz, rotation past 270°),
which must run without divergence and stay physically sane.
"""

from __future__ import annotations

import copy
import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from mpi4py import MPI

from magfem.case import parse_case
from magfem.mechanics.simulation import SimulationError
from magfem.pipeline import build_simulation, simulate
from verification.setups import STRIP_CANTILEVER

BASE: dict[str, Any] = STRIP_CANTILEVER


def _case(**tables: dict[str, Any]) -> Any:
    data = copy.deepcopy(BASE)
    for name, values in tables.items():
        data.setdefault(name, {}).update(values)
    return parse_case(data)


def _free_vibration(comm, rho_inf: float, steps: int, dt: float) -> np.ndarray:
    case = _case(
        field={"sources": []},
        environment={"gravity": [0, 0, 0]},
        time={
            "end": steps * dt,
            "step": dt,
            "adaptive": False,
            "rho_inf": rho_inf,
            "scheme": "generalized_alpha",
        },
    )
    sim = build_simulation(case, comm)
    # initial velocity of a bending motion (Kirchhoff: v_x = −(z − h/2) ∂v_z/∂x), zero on the
    # clamp x <= 1 mm; a velocity uniform through the thickness would excite the stiff
    # shear/thickness modes instead (generalized-α overshoots on those in the first steps)
    c, xr, L, h = 0.005, 1e-3, 6.5e-3, 80e-6
    sim.integrator.v0.interpolate(
        lambda X: np.vstack(
            [
                -(X[1] - h / 2) * 2 * c * np.maximum(X[0] - xr, 0.0) / L**2,
                c * np.maximum(X[0] - xr, 0.0) ** 2 / L**2,
            ]
        )
    )
    result = sim.run(progress=False)
    return result.history["energy_total"]


@pytest.mark.slow
def test_rho_one_conserves_energy_over_1000_steps(comm):
    # ~4 periods of the first bending mode (f1 ≈ 4 Hz), 2° swing, ω Δt ≈ 0.03
    energy = _free_vibration(comm, 1.0, 1000, 1e-3)
    drift = np.max(np.abs(energy - energy[0])) / energy[0]
    assert drift < 1e-3, drift  # issue 4 bound; measured 2.8e-4


def test_rho_below_one_dissipates_energy(comm):
    # under-resolved first mode (ω Δt ≈ 2.7): ρ∞ = 0.5 must remove it; measured 6.6e-5
    # after 40 steps (after a transient overshoot, a known generalized-α property)
    energy = _free_vibration(comm, 0.5, 40, 0.1)
    assert np.all(np.isfinite(energy))
    assert energy[-1] < 1e-2 * energy[0]


def test_mpi_run_reproduces_serial_angle_history(comm):
    """Under mpirun the world run is compared with a COMM_SELF run on rank 0."""
    # adaptive stepping on: the step sequence (cuts at the field switch-on) must match too
    case = _case(time={"end": "5 ms", "step": "0.25 ms"})
    world = build_simulation(case, comm).run(progress=False)
    ok, diff = True, 0.0
    if comm.rank == 0:
        serial = build_simulation(case, MPI.COMM_SELF).run(progress=False)
        a, b = world.history, serial.history
        if a["time"].shape != b["time"].shape or np.any(a["time"] != b["time"]):
            ok, diff = False, float("inf")  # different step sequences
        else:
            diff = float(np.max(np.abs(a["angle_arm"] - b["angle_arm"])))
            ok = diff < 1e-8
    ok, diff = comm.bcast((ok, diff), root=0)
    assert ok, diff
    assert np.max(np.abs(world.history["angle_arm"])) > math.radians(5)  # it did bend


@pytest.mark.parametrize(
    ("thickness", "flux", "frequency"),
    [
        ("45 um", "2 mT", "20 Hz"),
        ("1000 um", "10 mT", "20 Hz"),
        ("80 um", "0.5 mT", "20 Hz"),
        ("80 um", "10 mT", "20 Hz"),
        ("80 um", "2 mT", "200 Hz"),
    ],
)
def test_extremes_run_and_stay_physical(comm, thickness, flux, frequency):
    """Runs two drive periods (or 5 ms) without a solver failure; checks sanity.

    Sanity: finite history; the tip angle stays within the [0°, 180°] a
    magnetization aligning with a horizontal field can reach (with dynamic
    overshoot allowed to 200°); the strain stays below 50 %.
    """
    f = float(frequency.split()[0])
    end = min(2.0 / f, 5e-3)
    source = copy.deepcopy(BASE["field"]["sources"][0])
    source["flux_density"] = flux
    source["waveform"]["frequency"] = frequency
    case = _case(
        robot={"thickness": thickness},
        field={"sources": [source]},
        time={"end": end, "step": min(0.25e-3, 0.05 / f)},
    )
    result = build_simulation(case, comm).run(progress=False)
    angle = result.history["angle_arm"]
    assert np.all(np.isfinite(angle))
    assert result.history["time"][-1] == pytest.approx(end, rel=1e-9)
    assert np.max(np.abs(angle)) < math.radians(200)
    assert np.max(result.history["strain"]) < 0.5


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_rotating_field_curls_arm_past_270_degrees(comm):
    """Axially magnetized clamped strip in a 10 mT field rotating at 2 Hz in its side plane.

    The magnetic torque (M h B L² / D ≈ 200 for 80 µm) dominates bending, so
    the tip tangent follows the field direction 2π f t: past 270° at 0.45 s
    (the arm curls into a loop). Measured lag ≤ 0.8° over the run; 5° bound.
    Kept every 0.3 s only (``history_interval``), the history keeps the every-step rows
    there: the arm turns 216° between two kept rows, which only an unwrapping that sees
    every step follows.
    """

    def source(direction: list[int], phase: Any) -> dict[str, Any]:
        return {
            "kind": "uniform",
            "flux_density": "10 mT",
            "direction": direction,
            "waveform": {"kind": "sine", "frequency": "2 Hz", "phase": phase},
        }

    case = _case(
        field={"sources": [source([1, 0, 0], "90 deg"), source([0, 0, 1], 0.0)]},
        material={"direction": [1, 0, 0]},
        time={"end": 0.45, "step": 2e-3},
    )
    result = build_simulation(case, comm).run(progress=False)
    t, angle = result.history["time"], result.history["angle_arm"]
    assert angle[-1] > math.radians(270)
    lag = np.abs(angle - 2 * np.pi * 2.0 * t)
    assert np.max(lag) < math.radians(5), np.degrees(np.max(lag))
    sampled = build_simulation(
        replace(case, output=replace(case.output, history_interval=0.3)), comm
    )
    kept = sampled.run(progress=False).history
    index = np.searchsorted(t, kept["time"])
    assert len(index) == 3 and kept["angle_arm"][1] - kept["angle_arm"][0] > math.radians(200)
    for key in ("time", "angle_arm", "Bx", "strain"):
        np.testing.assert_array_equal(kept[key], result.history[key][index], err_msg=key)


@pytest.mark.parametrize(("degree", "size", "bound"), [(2, "0.5 mm", 0.5), (2, "1 mm", 2.0)])
def test_static_strip_matches_elastica_and_p1_locks(comm, degree, size, bound):
    """Quasi-static clamped strip (plane strain), field ramped to 0.2 mT against the arm.

    Reference: hard-magnetic elastica θ'' = λ sin(θ + π/2 − π), λ = 12 M B L²/(E' h²)
    (verification.references, solve_bvp). Measured P2: 65.88° (0.5 mm), 64.73°
    (1 mm) vs 65.94°; P1 on the same 0.5 mm mesh: 12.2° (shear locking of one
    element through the thickness), which this test also records.
    """
    from magfem import material
    from verification import references as reference

    B = 0.2e-3
    free_length = 6.5e-3  # 7.5 mm minus the 1 mm clamp
    modulus = material.plane_strain_modulus(115e3, 100 * 115e3)
    load = reference.elastica_load(123e3, B, free_length, 80e-6, modulus)
    exact = math.degrees(reference.hard_magnetic_elastica(load, field_angle=math.pi).tip_angle)

    def tip_angle(deg: int) -> float:
        source = {
            "kind": "uniform",
            "flux_density": B,
            "direction": [-1, 0, 0],
            "waveform": {"kind": "table", "times": [0, 1], "values": [0, 1]},
        }
        case = _case(
            field={"sources": [source]},
            environment={"gravity": [0, 0, 0]},
            mesh={"size": size},
            solver={"degree": deg},
            time={"scheme": "quasi_static", "end": 1.0, "step": 0.25},
        )
        history = build_simulation(case, comm).run(progress=False).history
        return math.degrees(history["angle_arm"][-1])

    assert abs(tip_angle(degree) - exact) < bound
    if size == "0.5 mm":
        assert tip_angle(1) < 0.5 * exact  # P1 locks: measured 12.2° vs 65.9°


def test_strain_probe_excludes_the_support_zone(comm):
    """ε_a of a uniform stretch ε plus a spike at the clamp edge: the spike is excluded.

    u_x = ε x + a (x − h)²/h² for x < h (zero beyond; h = 0.5 mm, the cell length) is
    exactly P2, so the stretch is 1 + ε at every vertex except x = 0, where it is
    1 + ε + 2a/h (a < 0 pulls). With the supports at x = 0 and a radius of one
    thickness, the probe must return ε to round-off (1e-9); without them, ε + 2|a|/h.
    """
    from dolfinx import fem

    from magfem.mechanics.observers import StrainProbe

    sim = build_simulation(_case(time={"end": "0.25 ms"}), comm)
    eps, a, h = 0.01, -2e-5, 0.5e-3
    u = fem.Function(sim.u.function_space)
    u.interpolate(
        lambda X: np.vstack(
            [eps * X[0] + a * np.where(X[0] < h, (X[0] - h) ** 2 / h**2, 0.0), 0 * X[1]]
        )
    )
    root = np.array([[0.0, z, 0.0] for z in np.linspace(0, 80e-6, 5)])
    assert StrainProbe(u, root, radius=80e-6)() == pytest.approx(eps, abs=1e-9)
    assert StrainProbe(u)() == pytest.approx(eps + 2 * abs(a) / h, rel=1e-6)


def test_contact_surfaces_name_facet_groups(comm):
    """[contact] surfaces: unknown names and cell groups raise CaseError naming the key."""
    from magfem.config import CaseError

    for bad in (["nowhere"], ["arm"]):
        case = _case(contact={"ground": True, "surfaces": bad})
        with pytest.raises(CaseError, match=r"contact\.surfaces"):
            build_simulation(case, comm)


@pytest.mark.parametrize("model", ["strip", "solid"])
def test_step_jacobian_matches_central_differences(comm, model):
    """The Jacobian Newton assembles is the exact derivative of the step residual.

    Generalized-α inertia, neo-Hookean + magnetic energy, gravity, ground contact with
    penalty, dashpot and regularised friction, all at once, at a perturbed state with
    points pressed into the ground (so every contact branch is active somewhere).
    Reference: central differences of the assembled residual along a random
    direction d, whose error is O(ε²): J d − (R(u + εd) − R(u − εd))/(2ε) must fall
    ~100× per 10× smaller ε (second order) until round-off, and stay below 1e-6 of
    |J d| at ε = 1e-9 m (measured 3e-10 solid / 2e-10 strip; an error in any
    linearised term, e.g. a friction tangent without the Δt dependence of the velocity,
    gives O(1) instead). Slow Newton convergence on this problem (docs/mechanics.md) is
    therefore not a wrong Jacobian. With the mixed pressure the check covers every block
    of the (u, p) Jacobian.
    """
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc

    case = _case(
        mesh={"model": model, "size": "1 mm" if model == "strip" else "2 mm"},
        contact={"ground": True, "friction": 0.5},
        environment={"gravity": [0, 0, "-9.8 m/s^2"]},
    )
    sim = build_simulation(case, comm)
    sim.initialise()
    integ = sim.integrator
    dt = 2.5e-4
    integ.begin(dt)
    sim.update_loads(integ.stage_time(0.0, dt), "right", integ.u0)
    u = sim.u
    rng = np.random.default_rng(comm.rank)
    # push the body down by up to half a thickness (into the ground) with random wiggles
    gdim = sim.gdim
    values = u.x.array.reshape(-1, gdim)
    values[:] = 2e-6 * rng.standard_normal(values.shape)
    values[:, gdim - 1] -= 40e-6 * rng.random(values.shape[0])
    for bc in sim.model.bcs:
        bc.set(u.x.array, alpha=0.0)
    u.x.scatter_forward()
    # Newton's unknowns: u, and the mixed pressure p (set from u as before a solve)
    unknowns = sim.problem.unknowns
    if sim.problem.pressure is not None:
        sim.problem.pressure.guess()
    problem = sim.solver.problem
    x0 = problem.x.duplicate()
    fem_petsc.assign(unknowns if len(unknowns) > 1 else u, x0)
    A = problem.A
    sim.solver.snes.computeFunction(x0, problem.b)  # sets the state as Newton does
    sim.solver.snes.computeJacobian(x0, A, problem.P_mat)
    parts = [fem.Function(f.function_space) for f in unknowns]
    for f in parts:
        f.x.array[:] = rng.standard_normal(f.x.array.size)
    for bc in sim.model.bcs:  # Newton never moves constrained dofs
        bc.set(parts[0].x.array, alpha=0.0)
    d = x0.duplicate()
    fem_petsc.assign(parts if len(parts) > 1 else parts[0], d)
    Jd = d.duplicate()
    A.mult(d, Jd)
    norm = Jd.norm()
    errors = []
    for eps in (1e-7, 1e-8, 1e-9):
        rp, rm = d.duplicate(), d.duplicate()
        sim.solver.snes.computeFunction(x0 + eps * d, rp)
        sim.solver.snes.computeFunction(x0 - eps * d, rm)
        fd = (rp - rm) / (2 * eps)
        errors.append((Jd - fd).norm() / norm)
    assert errors[2] < 1e-6, errors
    assert errors[1] < 0.05 * errors[0] or errors[1] < 1e-8, errors


@pytest.mark.parametrize(
    ("model", "thickness"),
    [("strip", "100 um"), ("strip", "400 um"), ("surface", "100 um")],
)
def test_quasi_static_membrane_rests_on_the_ground_under_its_weight(comm, model, thickness):
    """A thin cantilever lying on the ground settles under gravity (quasi-static, no field).

    At 100 µm the gravity continuation used to stall: the penalty ramp has no slope at
    zero penetration, so Newton's first increment bent the beam 6 cm through the ground.
    Reference: a beam on an elastic foundation, clamped at the bonded edge. The ground
    carries the weight q (L − L_c) of the free span (per unit width) less q/β, what the
    clamp carries through the boundary layer of length 1/β = (4 EI/k)^(1/4), k the
    foundation stiffness (penalty slope at the resting penetration). The foundation
    softens towards the clamp (the penalty's quadratic onset) and the 0.5 mm mesh does not
    resolve a layer of 0.2–0.7 mm, so the test admits twice that layer: the ground force
    lies between q (L − L_c − 2/β) and q (L − L_c) (measured 0.960 and 0.891 of the
    latter at 100 and 400 µm, against lower bounds 0.939 and 0.795). The shell model
    (``surface``, its bottom face on the ground, 4 mm wide) carries the same weight per
    width (measured 0.956 at 100 µm).
    The beam stays flat (tip lift below one thickness).
    """
    from magfem.mechanics.contacts.penalty import penalty_penetration

    case = _case(
        robot={"thickness": thickness},
        mesh={"model": model},
        field={"sources": []},
        contact={"ground": True, "friction": 0.5},
        environment={"gravity": [0, 0, "-9.8 m/s^2"]},
        time={"scheme": "quasi_static", "end": "1 s", "step": "1 s"},
    )
    sim = build_simulation(case, comm)
    history = sim.run(progress=False).history
    h, mat = case.robot.thickness, case.material
    width = case.robot.params.width
    free = case.robot.length - case.robot.clamp_length
    q = mat.density * 9.8 * h  # weight per area (Pa)
    law = sim.problem.contacts[0].law
    delta = penalty_penetration(q, law.stiffness, law.onset)
    k = law.stiffness * min(delta / law.onset, 1.0)  # slope of the C1 ramp there (Pa/m)
    K, mu = mat.bulk, mat.shear_modulus
    E = 9 * K * mu / (3 * K + mu)
    nu = (3 * K - 2 * mu) / (2 * (3 * K + mu))
    EI = E / (1 - nu**2) * h**3 / 12  # plane strain, per unit width
    layer = (4 * EI / k) ** 0.25
    force = history["contact_force"][-1] / width  # N per m of width
    assert q * (free - 2 * layer) < force <= q * free * (1 + 1e-6)
    assert abs(history["tip_normal_arm"][-1]) * case.robot.length < h


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_force_tolerance_saves_newton_iterations_not_accuracy(comm):
    """``[solver] force_tolerance``: Newton stops at ‖R‖ <= tol × ‖weight load‖ in the time loop.

    Same steps (adaptive off), so the only difference is where Newton stops:
    fewer iterations in all (a run that ignored the option would use the same
    number), and the angle history within 0.01° of rtol alone: Newton's
    remaining error is far below the time-discretisation error of these steps
    (Δt 0.1 vs 0.2 ms moves the 25 ms history by ~1.6°, docs/mechanics.md).
    """
    runs = {}
    for tol in (0.0, 0.1):
        case = _case(solver={"force_tolerance": tol}, time={"adaptive": False, "step": "0.1 ms"})
        sim = build_simulation(case, comm)
        runs[tol] = (sim.run(progress=False), sim)
    (ref, _), (loose, sim) = runs[0.0], runs[0.1]
    atol = sim.solver.snes.getTolerances()[1]
    assert atol == pytest.approx(0.1 * sim.weight_scale(), rel=1e-12)
    # F_ref leaves out the clamped rows: the strip's conditions are all on the displacement
    assert sim.model.displacement_bcs == sim.model.bcs and sim.model.bcs
    assert atol > 0.1 * 1.2e-3  # F_ref of this 0.5 mm strip: 1.23e-3 N/m (measured)
    its_ref, its = (int(np.sum(r.history["newton_iterations"])) for r in (ref, loose))
    assert its <= 0.95 * its_ref, (its, its_ref)  # measured 160 against 174
    diff = np.max(np.abs(ref.history["angle_arm"] - loose.history["angle_arm"]))
    assert math.degrees(diff) < 0.01, math.degrees(diff)  # measured 5e-4


@pytest.mark.parametrize(
    ("time", "reason"),
    [
        ({"min_step": "0.1 ms"}, "time.min_step"),  # 0.25 -> 0.125 -> (0.0625 < 0.1) ms
        ({"max_cuts": 0}, "time.max_cuts"),
    ],
)
def test_stalled_run_stops_with_its_reason_and_keeps_its_history(comm, shared_tmp, time, reason):
    """One Newton iteration cannot solve a step: the run stops saying why, CSV kept."""
    case = _case(
        solver={"max_iterations": 1},
        time={"step": "0.25 ms", **time},
        output={"csv": True, "vtx_every": 0, "plot": False},
    )
    out = shared_tmp / reason
    with pytest.raises(SimulationError, match=reason.replace(".", r"\.")) as err:
        simulate(case, out, comm, progress=False)
    assert "t = 0 s: Newton failed" in str(err.value)
    rows = (out / "history.csv").read_text().splitlines()
    assert rows[0].startswith("time [s],") and len(rows) >= 2  # header and the t = 0 state


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_run_summary_equals_the_summary_of_its_csv(comm, shared_tmp):
    """The run's own summary and the sweep's summary of its history.csv are one computation:
    they agree on every common key (the CSV stores repr(float), so exactly), nan included."""
    from magfem.case import write_resolved_case
    from magfem.sweep import summarize_history

    wave = {"kind": "square", "frequency": "200 Hz"}  # half and one period inside 5 ms
    source = BASE["field"]["sources"][0] | {"waveform": wave}
    case = _case(field={"sources": [source]}, output={"csv": True, "vtx_every": 0, "plot": False})
    out = shared_tmp / "summary"
    result = simulate(case, out, comm, progress=False)
    if comm.rank == 0:  # as `magfem run` does: the sweep reads t0 and f from it
        write_resolved_case(case, out / "case.resolved.toml")
    comm.barrier()
    from_csv = summarize_history(out)
    common = sorted(set(result.summary) & set(from_csv) - {"steps"})
    assert {"max_angle_arm", "max_angle_halfperiod_arm", "max_angle_2periods_arm"} <= set(common)
    assert "max_strain" in common and "power_density" in common
    assert math.isnan(from_csv["max_angle_2periods_arm"])  # the run ends before 2 periods
    for key in common:
        a, b = result.summary[key], from_csv[key]
        assert (math.isnan(a) and math.isnan(b)) or a == b, (key, a, b)
