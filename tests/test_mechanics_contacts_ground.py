"""Ground contact law (magfem.mechanics.contacts): resultant forces against closed form.

A box whose bottom face is pushed a uniform depth δ into the ground must
carry exactly k_n r(δ) × area (quadrature of a constant), friction
μ_f p A v/sqrt(v² + v_ε²) against the sliding direction, and exactly zero
force for a positive gap of any size (the far-field check that a
sqrt-smoothed penalty fails). Runs serially and under mpirun -n 2 (global
values by allreduce).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from magfem.mechanics.contacts.ground import GroundPlane, ImpactAbsorber
from magfem.mechanics.contacts.penalty import (
    PenaltyLaw,
    contact_stiffness,
    create_penalty_law,
    critical_contact_damping,
    penalty_penetration,
)

LX, LY, H = 2e-3, 1e-3, 1e-4  # box (m)
AREA = LX * LY


@pytest.fixture(scope="module")
def box(comm):
    m = mesh.create_box(comm, [[0.0, 0.0, 0.0], [LX, LY, H]], [4, 2, 1])
    V = fem.functionspace(m, ("Lagrange", 2, (3,)))
    return m, V


def _forces(m, V, law, shift, velocity):
    """Resultant ground force (N) on the box translated by ``shift`` moving at ``velocity``."""
    u, v = fem.Function(V), fem.Function(V)
    u.interpolate(lambda X: np.outer(shift, np.ones(X.shape[1])))
    v.interpolate(lambda X: np.outer(velocity, np.ones(X.shape[1])))
    contact = GroundPlane(law, m, vertical=2, ground_height=0.0)
    x = ufl.SpatialCoordinate(m) + u
    # only the bottom face: side faces would also dip in by δ
    bottom = mesh.locate_entities_boundary(m, 2, lambda X: np.isclose(X[2], 0.0))
    tags = mesh.meshtags(m, 2, bottom, np.full(bottom.size, 1, dtype=np.int32))
    ds = ufl.Measure("ds", m, subdomain_data=tags, metadata={"quadrature_degree": 4})(1)
    forms = contact.force_forms(x, v, ds)
    return np.array([m.comm.allreduce(fem.assemble_scalar(fem.form(f)), op=MPI.SUM) for f in forms])


@pytest.mark.parametrize("delta", [2e-6, 3e-8])  # linear branch, quadratic onset
def test_normal_force_and_friction_match_closed_form(box, delta):
    m, V = box
    law = PenaltyLaw(
        stiffness=1e10, onset=1e-7, damping=0.0, friction=0.5, regularization_velocity=1e-3
    )
    speed = 0.01
    force = _forces(m, V, law, [0.0, 0.0, -delta], [speed, 0.0, 0.0])
    ramp = delta - law.onset / 2 if delta >= law.onset else delta**2 / (2 * law.onset)
    normal = law.stiffness * ramp * AREA
    friction = -law.friction * normal * speed / math.hypot(speed, law.regularization_velocity)
    # the integrands are constant on the face: quadrature is exact to round-off
    assert force[2] == pytest.approx(normal, rel=1e-12)
    assert force[0] == pytest.approx(friction, rel=1e-12)
    assert abs(force[1]) < 1e-15 * normal


def test_penetration_inverts_the_penalty_ramp(box):
    """reference.penalty_penetration is the inverse of the assembled law in both branches."""
    m, V = box
    law = PenaltyLaw(stiffness=1e10, onset=1e-7)
    for pressure in (1e1, 1e4):  # quadratic onset, linear branch
        delta = penalty_penetration(pressure, law.stiffness, law.onset)
        force = _forces(m, V, law, [0.0, 0.0, -delta], [0.0, 0.0, 0.0])
        assert force[2] == pytest.approx(pressure * AREA, rel=1e-12)


@pytest.mark.parametrize("gap", [1e-12, 1e-6, 1e-2])
def test_no_force_at_positive_gap(box, gap):
    """Exactly zero (not small): the ramp must not reach off the ground."""
    m, V = box
    law = PenaltyLaw(stiffness=1e12, onset=1e-9, damping=1e3)
    force = _forces(m, V, law, [0.0, 0.0, gap], [0.1, 0.0, -0.5])
    assert np.all(force == 0.0)


def test_damping_adds_pressure_only_while_pressing(box):
    m, V = box
    k, c, delta = 1e10, 1e4, 2e-6
    law = PenaltyLaw(stiffness=k, onset=1e-7, damping=c)
    spring = k * (delta - 0.5e-7)
    falling = _forces(m, V, law, [0.0, 0.0, -delta], [0.0, 0.0, -1.0])
    assert falling[2] == pytest.approx((spring + c * 1.0) * AREA, rel=1e-12)
    # lifting off faster than the spring holds: bracket keeps p >= 0 (no adhesion)
    lifting = _forces(m, V, law, [0.0, 0.0, -delta], [0.0, 0.0, 10 * spring / c])
    assert np.all(lifting == 0.0)


def test_linearisation_matches_finite_difference(box):
    """ufl.derivative of the contact work is its Jacobian (FD check, both branches active)."""
    m, V = box
    law = PenaltyLaw(stiffness=1e10, onset=1e-6, damping=1e3, friction=0.5)
    u = fem.Function(V)
    # tilted: quadrature points in the onset, the linear branch and off the ground
    u.interpolate(lambda X: np.vstack([0 * X[0], 0 * X[0], 2e-6 * (X[0] / LX) - 1.5e-6]))
    v = fem.Function(V)
    v.interpolate(lambda X: np.vstack([0.01 + 0 * X[0], 0.002 + 0 * X[0], -0.01 + 0 * X[0]]))
    w = ufl.TestFunction(V)
    x = ufl.SpatialCoordinate(m) + u
    ds = ufl.Measure("ds", m, metadata={"quadrature_degree": 4})
    # velocity tied to u as an integrator would: v = v_n + (u - u_n)/dt
    dt = 1e-4
    u_n = fem.Function(V)
    u_n.x.array[:] = u.x.array
    v_u = v + (u - u_n) / dt
    work = GroundPlane(law, m, vertical=2).work(x, v_u, w, ds)
    R = fem.form(work)
    J = fem.form(ufl.derivative(work, u))
    from dolfinx.fem import petsc
    from petsc4py import PETSc

    A = petsc.assemble_matrix(J)
    A.assemble()
    r0 = petsc.assemble_vector(R)
    r0.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    du = fem.Function(V)
    rng = np.random.default_rng(1)
    du.x.array[:] = rng.standard_normal(du.x.array.size) * 1e-9
    du.x.scatter_forward()
    eps = 1e-3  # FD step 1e-12 m: far below the 1e-6 m onset, so no branch switch
    u.x.array[:] += eps * du.x.array
    r1 = petsc.assemble_vector(R)
    r1.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    Jdu = A.createVecLeft()
    A.mult(du.x.petsc_vec, Jdu)
    fd = (r1 - r0) / eps
    err = (fd - Jdu).norm() / Jdu.norm()
    # measured ~1e-7 (FD truncation of the quadratic branch, round-off): 1e-5 has margin
    assert err < 1e-5


def test_law_from_spec_scales_with_membrane():
    class Spec:
        friction = 0.5
        penalty = 10.0
        penalty_onset = 1e-3
        damping = 1.0
        regularization_velocity = 1e-3

    law = create_penalty_law(Spec(), shear_modulus=250e3, density=2130.0, thickness=1e-4)
    assert law.stiffness == pytest.approx(10 * 250e3 / 1e-4)
    assert law.stiffness == contact_stiffness(10.0, 250e3, 1e-4)
    assert law.onset == pytest.approx(1e-7)
    # critical damping of mass ρh on stiffness k: c = 2 sqrt(k m)
    assert law.damping == pytest.approx(2 * math.sqrt(2.5e10 * 2130 * 1e-4))
    assert law.damping == critical_contact_damping(law.stiffness, 2130.0, 1e-4)
    with pytest.raises(ValueError):
        PenaltyLaw(stiffness=1.0, onset=0.0)


def test_impact_absorber_stops_whole_columns_below_ground(comm):
    """Columns whose contact node is below ground lose upward v_z and a_z, all through the
    thickness (two layers here); columns above ground, downward motion and v_x are kept."""

    m = mesh.create_box(comm, [[0.0, 0.0, 0.0], [LX, LY, H]], [4, 2, 2], mesh.CellType.hexahedron)
    V = fem.functionspace(m, ("Lagrange", 2, (3,)))
    bottom = mesh.locate_entities_boundary(m, 2, lambda X: np.isclose(X[2], 0.0))
    absorber = ImpactAbsorber(V, bottom, vertical=2, ground_height=0.0)
    u, v, a = fem.Function(V), fem.Function(V), fem.Function(V)
    # x < 0.3 LX (3 of the 9 P2 node lines along x) is pushed 1 µm into the ground, the rest
    # lifted 1 µm
    u.interpolate(lambda X: np.vstack([0 * X[0], 0 * X[0], np.where(X[0] < 0.3 * LX, -1e-6, 1e-6)]))
    # rebounding everywhere except a strip moving down; sliding along x
    v.interpolate(
        lambda X: np.vstack([0.1 + 0 * X[0], 0 * X[0], np.where(X[1] > 0.8 * LY, -0.2, 0.2)])
    )
    a.interpolate(lambda X: np.vstack([0 * X[0], 0 * X[0], 50.0 + 0 * X[0]]))
    columns = absorber.apply(u, v, a)
    X = V.tabulate_dof_coordinates()
    vz, az = v.x.array[2::3], a.x.array[2::3]
    hit = X[:, 0] < 0.3 * LX
    up = X[:, 1] <= 0.8 * LY
    assert np.all(vz[hit & up] == 0.0) and np.all(az[hit & up] == 0.0)
    assert np.all(vz[hit & ~up] == -0.2)  # still pressing: left to the penalty
    assert np.all(vz[~hit] != 0.0) and np.all(az[~hit] == 50.0)
    assert np.all(v.x.array[0::3] == 0.1)
    # P2 nodes of a 4 x 2 grid: 3 node lines along x below ground, 5 along y, of which
    # the line y = LY moves down (not reset)
    assert columns == 3 * 4
    # the same columns at the next step rest on the ground: slow upward motion (below
    # rest_velocity = 1 mm/s) is left alone, a rebound above it is removed again
    v.x.array[:] = 5e-4
    assert absorber.apply(u, v, a) == 0
    assert np.all(v.x.array == 5e-4)
    v.x.array[:] = 0.3
    assert absorber.apply(u, v, a) == 3 * 5
    assert np.all(v.x.array[2::3][hit] == 0.0)
