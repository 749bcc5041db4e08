"""The shell model (``[mesh] model = "surface"``, :mod:`magfem.mechanics.models.shell`).

Checks against independent references: the hard-magnetic elastica (static,
converging with the mesh), energy conservation of a free vibration (ρ∞ = 1),
the exact derivative of the step residual (central differences, contact and
friction active), and the serial history under ``mpirun -n 2``. Resting on
the ground: tests/test_mechanics_simulation.py (parametrised over strip and shell).
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np
import pytest
import ufl
from mpi4py import MPI
from test_mechanics_simulation import (
    BASE as STRIP_BASE,  # the same arm and drive as the strip tests
)

from magfem.case import parse_case
from magfem.config import CaseError, from_table
from magfem.geometry.robot_mesh import SHELL_CLAMP_INSET
from magfem.geometry.spec import MeshSpec
from magfem.mechanics.models.shell import director, director_jacobian, turn_axis_frame
from magfem.pipeline import build_simulation
from verification import references as ref
from verification import setups as vc

BASE: dict[str, Any] = copy.deepcopy(STRIP_BASE) | {
    "name": "shell",
    "mesh": {"size": "1 mm", "model": "surface"},
}


def _case(**tables: dict[str, Any]) -> Any:
    data = copy.deepcopy(BASE)
    for name, values in tables.items():
        data.setdefault(name, {}).update(values)
    return parse_case(data)


@pytest.mark.slow
def test_shell_converges_to_the_beam_elastica(comm):
    """Narrow arm (0.25 mm ≈ 3 t wide, one element across) ramped to 0.4 mT: beam modulus E.

    The shell clamps u and θ on the bonded patch inset by SHELL_CLAMP_INSET t, the
    rod's clamp at that edge: the reference is the elastica of the free length
    + SHELL_CLAMP_INSET t. Measured errors (first load, 55.0°): −2.65° (1 mm), −0.49°
    (0.5 mm), −0.133° (0.125 mm), −0.126° at 0.0625 mm: converged onto a −0.13° offset,
    the partly suppressed anticlastic curvature of a strip 3 t wide (Searle's b²/(R t)
    ≈ 0.1 here, which stiffens the beam slightly; the offset falls with the load as R
    shrinks: −0.13/−0.09/−0.07/−0.05° at the four loads). Against the elastica of the
    free length alone the same runs are +0.16°: the inset lengthens the arm by 0.41 t.
    """
    E = ref.young_modulus(vc.SHEAR_MODULUS, 100 * vc.SHEAR_MODULUS)
    free = vc.FREE_LENGTH + SHELL_CLAMP_INSET * vc.THICKNESS
    errors = []
    for size in (1e-3, 0.5e-3, 0.125e-3):
        _, fields, fe = vc.static_tip_angles(
            comm, model="surface", size=size, width=0.25e-3, plane="strain", size_across=0.25e-3
        )
        errors.append(np.degrees(np.abs(fe - vc.elastica_reference_angles(E, fields, free))))
    errors = np.array(errors)  # (levels, loads)
    assert np.all(errors[1] < 0.5 * errors[0]), errors
    assert np.all(errors[2] < 0.5 * errors[1]), errors
    assert np.all(errors[2] < 0.2), errors  # the 0.13° offset of the converged shell, above


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_rigid_root_clamps_the_shell_at_the_patch_edge(comm):
    """``[mesh] root = "rigid"`` moves the shell's clamp from the inset line to the patch edge.

    At one mesh (0.5 mm, whose own error, −0.5°, is the same for both roots),
    bonded minus rigid tip angles must equal the difference between the
    elastica of the free length + SHELL_CLAMP_INSET t and of the free length:
    measured 0.281/0.208/0.150/0.111° against 0.286/0.211/0.151/0.111° (1.8 %
    at most); 5 % leaves room for the adaptive steps and still fails if the
    clamp stayed put (0 %) or moved by half the inset (50 %).
    """
    E = ref.young_modulus(vc.SHEAR_MODULUS, 100 * vc.SHEAR_MODULUS)
    angles = {}
    for root in ("bonded", "rigid"):
        _, fields, angles[root] = vc.static_tip_angles(
            comm,
            model="surface",
            size=0.5e-3,
            width=0.25e-3,
            plane="strain",
            size_across=0.25e-3,
            root=root,
        )
    longer = vc.FREE_LENGTH + SHELL_CLAMP_INSET * vc.THICKNESS
    expected = vc.elastica_reference_angles(E, fields, longer) - vc.elastica_reference_angles(
        E, fields, vc.FREE_LENGTH
    )
    found = angles["bonded"] - angles["rigid"]
    assert np.all(np.abs(found / expected - 1) < 0.05), (np.degrees(found), np.degrees(expected))


@pytest.mark.slow
def test_shell_conserves_energy_with_rho_one(comm):
    """Free bending vibration, no load, ρ∞ = 1, 1000 steps: total energy drift < 1e-3 (issue 4).

    Initial velocity of a bending mode: v_z = c s²/L², and the director follows the
    midline slope, θ̇₁ = −∂v_z/∂x (s = x − clamp, zero on the clamp).
    """
    dt, steps = 1e-3, 1000
    case = _case(
        field={"sources": []},
        environment={"gravity": [0, 0, 0]},
        time={"end": steps * dt, "step": dt, "adaptive": False, "rho_inf": 1.0},
    )
    sim = build_simulation(case, comm)
    c, xr, L = 0.005, 1e-3, 6.5e-3
    disp, angles = sim.integrator.parts
    disp.v0.interpolate(
        lambda X: np.vstack([0 * X[0], 0 * X[0], c * np.maximum(X[0] - xr, 0.0) ** 2 / L**2])
    )
    angles.v0.interpolate(
        lambda X: np.vstack([0 * X[0], -2 * c * np.maximum(X[0] - xr, 0.0) / L**2])
    )
    energy = sim.run(progress=False).history["energy_total"]
    drift = np.max(np.abs(energy - energy[0])) / energy[0]
    assert drift < 1e-3, drift


@pytest.mark.serial  # local block arrays; the MPI run test covers the parallel assembly
@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_shell_step_jacobian_matches_central_differences(comm):
    """Each block of the Jacobian is the exact derivative of its block residual.

    Blocks (u rows, θ rows) × (u, θ directions) of the step, with ground contact on
    both faces (penalty, dashpot, friction), gravity, inertia and the magnetic torque,
    at a state pressed into the ground with random angles. Central differences of
    the assembled block residual along a random direction (displacement steps in m,
    angle steps in rad): the error falls as ε² (the penalty's curvature makes it
    1e-2 of |J d| at ε = 1e-7 m on the u block) down to round-off, below 1e-6 of
    |J d| (the angle blocks reach round-off, ~1e-8, already at ε = 1e-8 rad); an
    error in any linearised term gives an ε-independent error instead. Serial: the
    blocks are compared as local arrays.
    """
    import ufl
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc

    case = _case(
        contact={"ground": True, "friction": 0.5},
        environment={"gravity": [0, 0, "-9.8 m/s^2"]},
    )
    sim = build_simulation(case, comm)
    sim.initialise()
    integ = sim.integrator
    dt = 2.5e-4
    integ.begin(dt)
    sim.update_loads(integ.stage_time(0.0, dt), "right", integ.u0)
    unknowns = sim.model.unknowns
    u, theta = unknowns
    rng = np.random.default_rng(0)
    u.x.array[:] = 2e-6 * rng.standard_normal(u.x.array.shape)
    u.x.array[2::3] -= 40e-6 * rng.random(u.x.array.size // 3)  # faces into the ground
    theta.x.array[:] = 0.05 * rng.standard_normal(theta.x.array.shape)
    residuals = [fem.form(F) for F in sim.problem.residual]
    for i, F in enumerate(sim.problem.residual):
        for j, f in enumerate(unknowns):
            A = fem_petsc.assemble_matrix(fem.form(ufl.derivative(F, f)))
            A.assemble()
            d = rng.standard_normal(f.x.array.shape)
            v, Jd = A.createVecRight(), A.createVecLeft()
            v.array[:] = d
            A.mult(v, Jd)
            x0 = f.x.array.copy()
            errors = []
            for eps in (1e-8, 1e-9, 1e-10):
                f.x.array[:] = x0 + eps * d
                rp = fem.assemble_vector(residuals[i]).array.copy()
                f.x.array[:] = x0 - eps * d
                rm = fem.assemble_vector(residuals[i]).array.copy()
                errors.append(np.linalg.norm(Jd.array - (rp - rm) / (2 * eps)))
            f.x.array[:] = x0
            errors = np.array(errors) / np.linalg.norm(Jd.array)
            assert errors.min() < 1e-6, (i, j, errors)
            # second order, unless ε = 1e-8 already reaches round-off (the angle blocks)
            assert errors[1] < 0.05 * errors[0] or errors[0] < 1e-7, (i, j, errors)


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_mpi_shell_run_reproduces_serial_angle_history(comm):
    """Under mpirun the world run equals a COMM_SELF run on rank 0 (to 1e-8 rad)."""
    case = _case(time={"end": "4 ms", "step": "0.25 ms"})
    world = build_simulation(case, comm).run(progress=False)
    ok, diff = True, 0.0
    if comm.rank == 0:
        serial = build_simulation(case, MPI.COMM_SELF).run(progress=False)
        a, b = world.history, serial.history
        if a["time"].shape != b["time"].shape or np.any(a["time"] != b["time"]):
            ok, diff = False, float("inf")
        else:
            diff = float(np.max(np.abs(a["angle_arm"] - b["angle_arm"])))
            ok = diff < 1e-8
    ok, diff = comm.bcast((ok, diff), root=0)
    assert ok, diff
    assert np.max(np.abs(world.history["angle_arm"])) > math.radians(5)


@pytest.mark.parametrize(
    ("tables", "key"),
    [
        (  # one arm: no other group to touch unless it may touch itself
            {"contact": {"ground": True, "self_contact": True, "self_contact_within": False}},
            "contact.self_contact_groups",
        ),
        ({"contact": {"ground": True, "surfaces": ["tip"]}}, "contact.surfaces"),
    ],
)
def test_shell_rejects_what_it_does_not_model(comm, tables, key):
    with pytest.raises(CaseError, match=key.replace(".", r"\.")):
        build_simulation(_case(**tables), comm)


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_shell_fixed_point_holds_the_nodes_within_its_radius(comm):
    """``[environment] fixed_point`` on the shell: the displacement of every mid-surface node
    within ``fixed_radius`` of the point is held (and of no other), the angles stay free, and
    the driven arm moves around it (the same node search as the solid's,
    ``problem.fixed_point_dofs``)."""
    point, radius = [3.75e-3, 2e-3, 40e-6], 0.6e-3
    case = _case(
        robot={"clamp_length": 0.0},
        environment={"clamped": [], "fixed_point": point, "fixed_radius": radius},
        time={"end": "2 ms", "step": "0.25 ms"},
    )
    sim = build_simulation(case, comm)
    Vu = sim.u.function_space
    (bc,) = sim.model.displacement_bcs
    held = np.zeros(Vu.dofmap.index_map.size_local + Vu.dofmap.index_map.num_ghosts, bool)
    held[bc.dof_indices()[0] // 3] = True
    near = np.linalg.norm(Vu.tabulate_dof_coordinates() - point, axis=1) <= radius
    assert np.array_equal(held, near)
    assert comm.allreduce(int(near[: Vu.dofmap.index_map.size_local].sum())) >= 3
    assert len(sim.model.bcs) == 1  # nothing on the angles
    sim.run(progress=False)
    u = sim.u.x.array.reshape(-1, 3)
    assert np.all(u[held] == 0.0)
    moved = comm.allreduce(float(np.abs(u).max(initial=0.0)), op=MPI.MAX)
    assert moved > 1e-6, moved  # the field turns the arm about the held patch


@pytest.mark.parametrize("turn", [0.0, 90.0, 180.0, 270.0])
def test_turn_axis_frame_keeps_a_roll_about_it_regular(turn):
    """A plate along x rolled by φ about x (a propeller): its director R_x(φ) e_z. With the
    default frame (α = 0) the roll is θ₀ = φ, and at 90° ∂d/∂θ₁ vanishes (the director's
    Jacobian loses rank: the angles cannot follow); with ``turn_axis = [1, 0, 0]`` the
    frame's second axis is x, the roll is θ₁ alone, and the Jacobian keeps orthonormal
    columns at every φ (smallest singular value exactly 1)."""
    phi = math.radians(turn)
    rolled = np.array([0.0, -math.sin(phi), math.cos(phi)])  # R_x(φ) e_z
    alpha = turn_axis_frame([1.0, 0.0, 0.0])
    assert alpha == pytest.approx(-math.pi / 2)
    theta = ufl.as_vector([0.0, phi])
    d = director(theta, alpha)
    assert np.allclose([float(d[i]) for i in range(3)], rolled, atol=1e-15)
    J = director_jacobian(theta, alpha)
    values = np.array([[float(J[i, j]) for j in range(2)] for i in range(3)])
    assert np.linalg.svd(values, compute_uv=False)[-1] == pytest.approx(1.0, abs=1e-15)
    default = director_jacobian(ufl.as_vector([phi, 0.0]))
    values = np.array([[float(default[i, j]) for j in range(2)] for i in range(3)])
    smallest = np.linalg.svd(values, compute_uv=False)[-1]
    assert smallest == pytest.approx(abs(math.cos(phi)), abs=1e-15)  # 0 at 90° and 270°


@pytest.mark.parametrize(
    ("mesh", "problem"),
    [({"model": "solid"}, "surface-model"), ({"model": "surface"}, "x-y plane")],
)
def test_turn_axis_rejects_other_models_and_tilted_axes(mesh, problem):
    with pytest.raises(CaseError, match=problem) as err:
        from_table(MeshSpec, {"size": "1 mm", "turn_axis": [1, 0, 0.5], **mesh}, "mesh")
    assert err.value.key == "mesh.turn_axis"
