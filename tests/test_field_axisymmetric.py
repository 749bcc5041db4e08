"""Axisymmetric A_φ solves against the closed forms of magfem.field.analytic.

Each tolerance below states the value measured by the test itself (serial and
``mpirun -n 2`` agree) and the margin taken.
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from magfem.config import from_table
from magfem.field import analytic as an
from magfem.field.axisymmetric import AxisymmetricSource, solve_axisymmetric
from magfem.field.points import OutsideDomainError
from magfem.field.solvers import solve_source
from magfem.field.spec import CoilPairSpec, CoilSpec, CylinderMagnetSpec, SolveSpec
from magfem.geometry.sources import RectRegion

Z = np.array([0.0, 0.0, 1.0])
# a small thick coil: r1 = 10 mm, r2 = 20 mm, 10 mm long, 100 turns, 1 A
R1, R2, LC, NT = 0.01, 0.02, 0.01, 100
S_COIL = float(np.hypot(R2, LC / 2))
# off-axis points around the coil (not in the winding), m
P_COIL = 2 * np.array(
    [[0.004, 0.003, 0.012], [0.0, 0.008, -0.015], [0.012, 0, 0.02], [0.006, 0.006, 0.018]]
)


def _coil_solve(h: float, comm: MPI.Comm, degree: int = 3):
    J = NT / ((R2 - R1) * LC)
    src = [AxisymmetricSource(RectRegion("coil_1", R1, R2, -LC / 2, LC / 2), current_density=J)]
    return solve_axisymmetric(
        src,
        comm,
        degree=degree,
        h_source=h * S_COIL,
        r_air=20 * S_COIL,
        center=np.zeros(3),
        axis=Z,
        workspace=np.array([[0.0, -0.05], [0.05, 0.05]]),
        h_workspace=h * S_COIL,
        name="coil",
    )


def _errors(field, ref, P):
    B, G = ref(P), an.gradient_fd(ref, P, 1e-6)
    eB = np.linalg.norm(field.flux_density(P) - B, axis=1).max() / np.linalg.norm(B, axis=1).max()
    eG = (
        np.linalg.norm(field.gradient(P) - G, axis=(1, 2)).max()
        / np.linalg.norm(G, axis=(1, 2)).max()
    )
    return eB, eG


@pytest.fixture(scope="module")
def coil_levels(comm):
    return [_coil_solve(h, comm) for h in (0.4, 0.2, 0.1)]


def test_coil_convergence_rate_off_axis(coil_levels):
    ref = an.coil_field(np.zeros(3), Z, R1, R2, LC, NT, 1.0)
    errs = np.array([_errors(f, ref, P_COIL) for f in coil_levels])
    hs = np.array([0.4, 0.2, 0.1])
    rate_B = np.polyfit(np.log(hs), np.log(errs[:, 0]), 1)[0]
    rate_G = np.polyfit(np.log(hs), np.log(errs[:, 1]), 1)[0]
    # P3: measured rates 3.3 (B) and 3.1 (∇B) on these graded unstructured meshes; theory
    # gives at least p = 3 for the recovered B and p - 1 = 2 for its gradient: assert with
    # 0.5 margin below theory
    assert rate_B > 2.5, errs
    assert rate_G > 1.5, errs
    # finest level (h = S/10, 17.8k dofs): measured 1.6e-5 (B), 1.9e-4 (∇B); margin 2x
    assert errs[-1, 0] < 3.5e-5
    assert errs[-1, 1] < 4e-4


def test_field_is_divergence_and_curl_free(coil_levels):
    f = coil_levels[-1]
    P = np.array([[0.003, 0.004, 0.02], [0.03, -0.01, 0.002], [0.0, 0.0, 0.03], [0.0, 0.002, 0.0]])
    G = f.gradient(P)
    scale = np.linalg.norm(G, axis=(1, 2)).max()
    # div B and the antisymmetric part (curl B) are discretisation errors of the
    # recovered gradient: measured 8e-4 (div and curl) of max |∇B| at this level,
    # largest on/near the axis, where the r-weighted projection has least weight; bound 2e-3
    assert np.abs(np.trace(G, axis1=1, axis2=2)).max() < 2e-3 * scale
    assert np.abs(G - G.transpose(0, 2, 1)).max() < 2e-3 * scale
    # a coarser level has larger residuals: they are discretisation errors that converge
    G0 = coil_levels[0].gradient(P)
    assert (
        np.abs(np.trace(G0, axis1=1, axis2=2)).max() > np.abs(np.trace(G, axis1=1, axis2=2)).max()
    )


def test_cylinder_magnet_against_closed_form(comm):
    spec = from_table(CylinderMagnetSpec, {"kind": "cylinder_magnet", "center": [0, 0, -0.02]}, "m")
    ws = np.array([[-0.01] * 3, [0.01] * 3])  # 20 mm workspace, 5 mm above the magnet
    field, _ = solve_source(spec, SolveSpec(), comm, workspace=ws)
    ref = an.cylinder_field(np.array(spec.center), Z, spec.radius, spec.length, spec.remanence)
    g = np.linspace(-0.01, 0.01, 4)
    P = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    eB, eG = _errors(field, ref, P)
    # default resolution, degree 3 (13.4k dofs): measured 9.5e-5 (B), 9.0e-4 (∇B); the goals
    # of the issue (0.1 % / 1 %) are the bounds
    assert eB < 1e-3
    assert eG < 1e-2
    # on the axis against the closed-form axial formula
    z = np.array([-0.01, 0.0, 0.01])
    B = field.flux_density(np.column_stack([0 * z, 0 * z, z]))
    bz = an.cylinder_magnet_on_axis(spec.radius, spec.length, spec.remanence, z + 0.02)
    np.testing.assert_allclose(B[:, 2], bz, rtol=1e-3)
    np.testing.assert_allclose(B[:, :2], 0.0, atol=1e-6 * np.abs(bz).max())


@pytest.fixture(scope="module")
def pair(comm):
    spec = from_table(CoilPairSpec, {"kind": "coil_pair", "current": "1 A"}, "pair")
    ws = np.array([[-0.01] * 3, [0.01] * 3])
    field, current = solve_source(spec, SolveSpec(), comm, workspace=ws)
    return spec, field, current


def test_coil_pair_centre_field_and_uniformity(pair):
    spec, field, current = pair
    assert current == 1.0
    ampere_turns = spec.turns * current
    b0 = field.flux_density(np.zeros((1, 3)))[0]
    ref0 = sum(
        an.thick_coil_on_axis(
            spec.inner_radius, spec.outer_radius, spec.length, spec.turns, 1.0, np.array(dz)
        )
        for dz in (-spec.separation / 2, spec.separation / 2)
    )
    # centre field per ampere-turn: 1.375e-5 T/(A turn) (3.71 mT/A, 10 mT at 2.69 A)
    assert b0[2] / ampere_turns == pytest.approx(float(ref0) / ampere_turns, rel=1e-3)
    assert abs(b0[0]) + abs(b0[1]) < 1e-6 * b0[2]
    # uniformity of |B| over the ±10 mm cube, FE vs closed form
    g = np.linspace(-0.01, 0.01, 5)
    P = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    ref = _pair_reference(spec)
    nb_fe = np.linalg.norm(field.flux_density(P), axis=1)
    nb_ref = np.linalg.norm(ref(P), axis=1)
    u_fe = (nb_fe.max() - nb_fe.min()) / nb_fe[len(P) // 2]
    u_ref = (nb_ref.max() - nb_ref.min()) / nb_ref[len(P) // 2]
    assert u_ref == pytest.approx(0.1015, abs=5e-4)  # 10 % at the cube's corners (17 mm out)
    assert u_fe == pytest.approx(u_ref, abs=2e-4)
    eB, eG = _errors(field, ref, P)
    # default resolution (14.0k dofs): measured 2.3e-5 (B), 5.1e-3 (∇B); bounds = the goals
    assert eB < 1e-3 and eG < 1e-2


def _pair_reference(spec):
    def ref(P):
        return sum(
            an.coil_field(
                np.array([0, 0, dz]),
                Z,
                spec.inner_radius,
                spec.outer_radius,
                spec.length,
                spec.turns,
                1.0,
            )(P)
            for dz in (-spec.separation / 2, spec.separation / 2)
        )

    return ref


def test_rotated_coil_gives_rotated_field(comm):
    table = {"kind": "coil", "current": "2 A", "inner_radius": "10 mm", "outer_radius": "20 mm"}
    table |= {"length": "10 mm", "turns": 100, "center": [0.005, 0, 0]}
    solve = from_table(SolveSpec, {"mesh_size": "3 mm", "degree": 2}, "s")
    f_z, _ = solve_source(from_table(CoilSpec, table, "c"), solve, comm)
    f_x, _ = solve_source(from_table(CoilSpec, table | {"axis": [1, 0, 0]}, "c"), solve, comm)
    # rotation by 90 deg about y maps z -> x; both placed at the same centre
    Ry = np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]])
    c = np.array([0.005, 0, 0])
    P = c + np.array([[0.003, 0.004, 0.02], [0.015, -0.01, 0.006]])
    Bz, Bx = f_z.flux_density(P), f_x.flux_density(c + (P - c) @ Ry.T)
    # identical (r, z) meshes: equal to round-off
    np.testing.assert_allclose(Bx, Bz @ Ry.T, atol=1e-12 * np.abs(Bz).max())
    Gz, Gx = f_z.gradient(P), f_x.gradient(c + (P - c) @ Ry.T)
    np.testing.assert_allclose(Gx, Ry @ Gz @ Ry.T, atol=1e-10 * np.abs(Gz).max())


def test_parallel_solve_equals_serial(comm, coil_levels):
    """Distributed (comm) and one-rank (COMM_SELF) solves give the same values."""
    P = P_COIL[:3] + 0.001 * comm.rank  # each rank asks for its own points
    dist = coil_levels[0]
    local = _coil_solve(0.4, MPI.COMM_SELF)
    np.testing.assert_allclose(dist.flux_density(P), local.flux_density(P), rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(dist.gradient(P), local.gradient(P), rtol=1e-7, atol=1e-12)


def test_point_outside_air_region_is_an_error(coil_levels):
    with pytest.raises(OutsideDomainError, match="outside the air region"):
        coil_levels[0].flux_density(np.array([[0.0, 0.0, 30 * S_COIL]]))
