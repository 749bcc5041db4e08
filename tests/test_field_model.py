"""Field models for the mechanics: UFL expressions, time dependence, linearisation, model error."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI
from petsc4py import PETSc

from magfem.config import CaseError, from_table
from magfem.field import analytic as an
from magfem.field.model import (
    build_source_fields,
    create_field_model,
    model_errors,
    workspace_points,
)
from magfem.field.spec import FieldSpec

Q = {"quadrature_degree": 2}

FLOWER = {
    "sources": [
        {
            "kind": "uniform",
            "flux_density": "2 mT",
            "direction": [1, 1, 1],
            "waveform": {"kind": "trigger", "duration": "5 ms"},
        },
        {
            "kind": "uniform",
            "flux_density": "3 mT",
            "direction": [0, 0, 1],
            "waveform": {"kind": "square", "frequency": "50 Hz", "start": "5 ms"},
        },
    ]
}

MAGNET = {
    "expansion_point": [0, 0, 0.002],
    "workspace_size": "8 mm",
    "sources": [
        {
            "kind": "cylinder_magnet",
            "center": [0, 0, -0.01],
            "waveform": {"kind": "sine", "frequency": 5},
        }
    ],
    "solve": {"degree": 2, "mesh_size": "1 mm"},
}


def _robot(comm, n=3):
    return mesh.create_box(comm, [[-0.003, -0.002, 0.0], [0.003, 0.002, 0.0005]], [n, n, 1])


def test_uniform_sources_trigger_then_square(comm):
    spec = from_table(FieldSpec, FLOWER, "field")
    model = create_field_model(spec, comm)
    assert model.name == "uniform"  # auto: all sources uniform
    domain = _robot(comm)
    model.bind(domain)
    B = model.flux_density(ufl.SpatialCoordinate(domain))
    form = fem.form(B[2] * ufl.dx(metadata=Q))
    vol = comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=domain, metadata=Q))))
    model.update(0.002)
    np.testing.assert_allclose(
        model.evaluate(np.zeros((1, 3)), 0.002)[0], 2e-3 / math.sqrt(3) * np.ones(3)
    )
    assert comm.allreduce(fem.assemble_scalar(form)) / vol == pytest.approx(2e-3 / math.sqrt(3))
    # at the switch: left limit = the trigger, right limit = the square wave (+3 mT along z)
    np.testing.assert_allclose(
        model.evaluate(np.zeros((1, 3)), 0.005, side="left")[0], 2e-3 / math.sqrt(3)
    )
    np.testing.assert_allclose(model.evaluate(np.zeros((1, 3)), 0.005)[0], [0, 0, 3e-3])
    model.update(0.016)  # square low half
    assert comm.allreduce(fem.assemble_scalar(form)) / vol == pytest.approx(-3e-3)
    np.testing.assert_allclose(model.breakpoints(0.0, 0.03), [0.005, 0.015, 0.025])


@pytest.fixture(scope="module")
def magnet(comm):
    spec = from_table(FieldSpec, MAGNET, "field")
    return spec, build_source_fields(spec, comm)


def _energy_forms(model, domain):
    """Magnetic energy −∫ (F m)·B(X + u) dX, F = I + ∇u, residual and Jacobian (m = 1e5 A/m ẑ)."""
    V = fem.functionspace(domain, ("Lagrange", 2, (3,)))
    u = fem.Function(V)
    model.bind(domain)
    x = ufl.SpatialCoordinate(domain) + u
    m = ufl.as_vector([0.0, 0.0, 1e5])
    Fm = ufl.dot(ufl.Identity(3) + ufl.grad(u), m)
    E = -ufl.dot(Fm, model.flux_density(x)) * ufl.dx(metadata=Q)
    F = ufl.derivative(E, u)
    J = ufl.derivative(F, u)
    return u, fem.form(E), fem.form(F), fem.form(J)


def test_fe_model_follows_the_robot_and_linearises_exactly(comm, magnet):
    spec, sources = magnet
    model = create_field_model(dataclasses.replace(spec, model="fe"), comm, sources=sources)
    domain = _robot(comm)
    u, E, F, J = _energy_forms(model, domain)
    u.interpolate(lambda X: np.vstack([0.3e-3 * X[0] / 0.003, 0 * X[0], 1e-3 + 0 * X[0]]))
    t = 0.05  # sine at 5 Hz: w = 1
    model.update(t, u=u)
    # energy vs the exact field at the displaced robot (midpoint rule on a fine grid of the box;
    # ∂u/∂X_2 = 0, so F m = m)
    e_fe = comm.allreduce(fem.assemble_scalar(E))
    g = (np.arange(12) + 0.5) / 12
    X = np.stack(
        np.meshgrid(
            -0.003 + 0.006 * g, -0.002 + 0.004 * g, 0.0005 * (np.arange(4) + 0.5) / 4, indexing="ij"
        ),
        -1,
    )
    X = X.reshape(-1, 3)
    x = X + np.column_stack([0.3e-3 * X[:, 0] / 0.003, 0 * X[:, 0], np.full(len(X), 1e-3)])
    ref = an.cylinder_field(np.array([0, 0, -0.01]), np.array([0, 0, 1.0]), 0.005, 0.01, 1.3)
    e_ref = -1e5 * ref(x)[:, 2].mean() * 0.006 * 0.004 * 0.0005
    # FE field (1 mm at the magnet, P2) and the nodal (P2) linearisation on a 2 mm robot
    # mesh: measured 4.6e-4; bound 2e-3
    assert e_fe == pytest.approx(e_ref, rel=2e-3)
    # Jacobian = derivative of the residual including the ∇B·δu term: central difference
    A = fem.petsc.assemble_matrix(J)
    A.assemble()
    r0 = fem.petsc.assemble_vector(F)
    r0.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    du = u.x.petsc_vec.copy()
    du.setRandom()
    du.scale(1e-4)
    Jdu = A.createVecLeft()
    A.mult(du, Jdu)
    u.x.petsc_vec.axpy(1.0, du)
    u.x.scatter_forward()
    r1 = fem.petsc.assemble_vector(F)
    r1.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    diff = r1 - r0
    # B is linear in x inside a step, so the energy is quadratic and the residual linear in u:
    # the central difference equals J δu to round-off, which includes the ∇B·δu terms
    assert (diff - Jdu).norm() < 1e-9 * Jdu.norm()
    assert Jdu.norm() > 1e-3 * r0.norm()  # the gradient force is not negligible here


def test_taylor_models_match_their_numpy_evaluation(comm, magnet):
    spec, sources = magnet
    for name in ("taylor1", "taylor2"):
        model = create_field_model(dataclasses.replace(spec, model=name), comm, sources=sources)
        domain = _robot(comm)
        model.bind(domain)
        model.update(0.05)
        x = ufl.SpatialCoordinate(domain)
        Bz = fem.assemble_scalar(
            fem.form(model.flux_density(x)[2] * ufl.dx(metadata={"quadrature_degree": 4}))
        )
        # exact integral of the Taylor polynomial (degree <= 2) by numpy Gauss points of the box
        gp, gw = np.polynomial.legendre.leggauss(3)
        lo, hi = np.array([-0.003, -0.002, 0.0]), np.array([0.003, 0.002, 0.0005])
        pts = np.stack(
            np.meshgrid(*[(gp + 1) / 2 * (hi[k] - lo[k]) + lo[k] for k in range(3)], indexing="ij"),
            -1,
        )
        w = np.einsum("i,j,k->ijk", gw, gw, gw).ravel() * np.prod(hi - lo) / 8
        ref = w @ model.evaluate(pts.reshape(-1, 3), 0.05)[:, 2]
        assert comm.allreduce(Bz) == pytest.approx(ref, rel=1e-12)


def test_model_errors_and_auto_choice(comm, magnet):
    spec, sources = magnet
    pts = workspace_points(spec.expansion_point, spec.workspace_size)
    err = model_errors(sources, comm, np.array(spec.expansion_point), pts)
    # 8 mm workspace 3-11 mm above a 10 x 10 mm magnet: the field varies by tens of %; each
    # order of the expansion cuts the error (measured 0.65, 0.42, 0.33; the Taylor expansions
    # of the closed form give 0.65, 0.42, 0.32)
    assert err["uniform"]["B"] > err["taylor1"]["B"] > err["taylor2"]["B"]
    assert err["taylor1"]["gradB"] > err["taylor2"]["gradB"]
    assert (
        create_field_model(dataclasses.replace(spec, tolerance=0.9), comm, sources=sources).name
        == "taylor1"
    )
    tol2 = 0.5 * (err["taylor1"]["B"] + err["taylor2"]["B"])
    assert (
        create_field_model(dataclasses.replace(spec, tolerance=tol2), comm, sources=sources).name
        == "taylor2"
    )
    low = 0.5 * err["taylor2"]["B"]
    assert (
        create_field_model(dataclasses.replace(spec, tolerance=low), comm, sources=sources).name
        == "fe"
    )


def test_superposition_of_sources(comm, magnet):
    spec, sources = magnet
    both = from_table(
        FieldSpec, {**MAGNET, "sources": MAGNET["sources"] + FLOWER["sources"]}, "field"
    )
    uni = build_source_fields(from_table(FieldSpec, FLOWER, "field"), comm)
    model = create_field_model(dataclasses.replace(both, model="fe"), comm, sources=sources + uni)
    P = workspace_points(spec.expansion_point, spec.workspace_size, 2)
    t = 0.007  # magnet sine w = sin(2π 5 0.007), square +1 after 5 ms, trigger off
    expect = math.sin(2 * math.pi * 5 * t) * sources[0][0].flux_density(P) + np.array([0, 0, 3e-3])
    np.testing.assert_allclose(model.evaluate(P, t), expect, rtol=1e-13, atol=1e-15)


def test_serial_and_parallel_model_values_agree(comm, magnet):
    spec, sources = magnet
    model = create_field_model(dataclasses.replace(spec, model="fe"), comm, sources=sources)
    domain = _robot(comm)
    u, E, _, _ = _energy_forms(model, domain)
    model.update(0.05, u=u)
    e_world = comm.allreduce(fem.assemble_scalar(E))
    self_sources = build_source_fields(spec, MPI.COMM_SELF)
    model_s = create_field_model(
        dataclasses.replace(spec, model="fe"), MPI.COMM_SELF, sources=self_sources
    )
    _, E_s, _, _ = _energy_forms(model_s, _robot(MPI.COMM_SELF))
    model_s.update(0.05)
    assert e_world == pytest.approx(fem.assemble_scalar(E_s), rel=1e-10)


def test_bad_field_input():
    with pytest.raises(CaseError, match="model"):
        from_table(FieldSpec, {"model": "dipole"}, "field")
    with pytest.raises(CaseError, match=r"sources\[0\].kind"):
        from_table(FieldSpec, {"sources": [{"kind": "halbach"}]}, "field")
    with pytest.raises(CaseError, match=r"sources\[0\].turns"):
        from_table(FieldSpec, {"sources": [{"kind": "coil", "turns": 0, "current": 1}]}, "field")
    with pytest.raises(CaseError, match=r"sources\[0\].inner_radius"):
        from_table(
            FieldSpec,
            {"sources": [{"kind": "coil", "inner_radius": "6 cm", "current": 1}]},
            "field",
        )
    with pytest.raises(CaseError, match=r"sources\[0\].current"):
        from_table(FieldSpec, {"sources": [{"kind": "coil"}]}, "field")  # neither current nor B
    with pytest.raises(CaseError, match="winding"):
        from_table(
            FieldSpec,
            {
                "sources": [
                    {"kind": "coil_pair", "current": 1},
                    {"kind": "cylinder_magnet", "center": [0.04, 0, 0.035]},
                ]
            },
            "field",
        )
    with pytest.raises(CaseError, match=r"sources\[0\].direction"):
        from_table(
            FieldSpec,
            {"sources": [{"kind": "uniform", "flux_density": 1e-3, "direction": [0, 0, 0]}]},
            "field",
        )
    with pytest.raises(CaseError, match="allowed keys"):
        from_table(
            FieldSpec,
            {"sources": [{"kind": "uniform", "flux_density": 1e-3, "radius": 1}]},
            "field",
        )
    with pytest.raises(CaseError, match=r"sources\[0\].waveform.kind"):
        from_table(
            FieldSpec,
            {"sources": [{"kind": "uniform", "flux_density": 1e-3, "waveform": {"kind": "x"}}]},
            "field",
        )
    # a magnet in the bore of a coil is fine
    from_table(
        FieldSpec,
        {"sources": [{"kind": "coil", "current": 1}, {"kind": "cylinder_magnet"}]},
        "field",
    )
