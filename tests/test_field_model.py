"""Field models for the mechanics: UFL expressions, time, motions, linearisation, auto."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI
from petsc4py import PETSc

from magfem.config import from_table
from magfem.field.build import build_terms
from magfem.field.choice import FieldResolutionWarning, model_errors, workspace_points
from magfem.field.model import create_field_model
from magfem.field.source import CylinderMagnetField
from magfem.field.spec import FieldSpec

# explicit Taylor models over a strongly varying field warn (tested below); silence them elsewhere
pytestmark = pytest.mark.filterwarnings("ignore::magfem.field.choice.FieldResolutionWarning")

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
}
CYL = CylinderMagnetField(np.array([0, 0, -0.01]), np.array([0, 0, 1.0]), 0.005, 0.01, 1.3)


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
    assert model.gradient(np.zeros((2, 3)), 0.002).shape == (2, 3, 3)


@pytest.fixture(scope="module")
def magnet(comm):
    spec = from_table(FieldSpec, MAGNET, "field")
    return spec, build_terms(spec, comm)


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


def test_nodal_model_follows_the_robot_and_linearises_exactly(comm, magnet):
    spec, terms = magnet
    model = create_field_model(dataclasses.replace(spec, model="nodal"), comm, sources=terms)
    domain = _robot(comm)
    u, E, F, J = _energy_forms(model, domain)
    u.interpolate(lambda X: np.vstack([0.3e-3 * X[0] / 0.003, 0 * X[0], 1e-3 + 0 * X[0]]))
    t = 0.05  # sine at 5 Hz: w = 1
    model.update(t, u=u)
    # energy vs the exact field at the displaced robot (midpoint rule on a fine grid of the box;
    # ∂u/∂X_2 = 0, so F m = m)
    e_model = comm.allreduce(fem.assemble_scalar(E))
    g = (np.arange(12) + 0.5) / 12
    X = np.stack(
        np.meshgrid(
            -0.003 + 0.006 * g, -0.002 + 0.004 * g, 0.0005 * (np.arange(4) + 0.5) / 4, indexing="ij"
        ),
        -1,
    ).reshape(-1, 3)
    x = X + np.column_stack([0.3e-3 * X[:, 0] / 0.003, 0 * X[:, 0], np.full(len(X), 1e-3)])
    e_ref = -1e5 * CYL.flux_density(x)[:, 2].mean() * 0.006 * 0.004 * 0.0005
    # the exact field linearised about the P2 nodes of a 2 mm robot mesh, integrated at degree
    # 2, against a midpoint rule on 0.5 mm cells: measured 5.4e-4
    assert e_model == pytest.approx(e_ref, rel=1.5e-3)
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
    spec, terms = magnet
    for name in ("taylor1", "taylor2"):
        model = create_field_model(dataclasses.replace(spec, model=name), comm, sources=terms)
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


def test_taylor2_hessian_of_the_closed_form(magnet):
    _, terms = magnet
    p = np.array([[0.001, -0.0005, 0.003]])
    H = terms[0].field.hessian(p)[0]
    h = 1e-6  # central difference of the exact gradient, independent of the 4th-order one
    ref = np.stack(
        [(CYL.gradient(p + h * e) - CYL.gradient(p - h * e))[0] / (2 * h) for e in np.eye(3)], -1
    )
    # step 1e-6 m: truncation ~ (h / 3 mm)² / 6 ~ 2e-8 of ∇∇B, round-off ~1e-10
    assert np.abs(H - ref).max() < 1e-6 * np.abs(ref).max()


def test_model_errors_and_auto_choice(comm, magnet):
    spec, terms = magnet
    pts = workspace_points(spec.expansion_point, spec.workspace_size)
    err = model_errors(terms, comm, np.array(spec.expansion_point), pts, spec.workspace_size)
    # 8 mm workspace 3-11 mm above a 10 x 10 mm magnet: each order of the expansion cuts the
    # error (measured B 0.65, 0.42, 0.32)
    assert err["uniform"]["B"] > err["taylor1"]["B"] > err["taylor2"]["B"]
    assert err["taylor1"]["gradB"] > err["taylor2"]["gradB"]

    def auto(tol):
        return create_field_model(
            dataclasses.replace(spec, tolerance=tol), comm, sources=terms
        ).name

    # the uniform model has no gradient: its ∇B error is 1 wherever the gradient matters
    assert err["uniform"]["gradB"] == pytest.approx(1.0)
    assert auto(0.99) == "taylor1"  # measured taylor1: B 0.42, ∇B 0.80
    t2 = max(err["taylor2"].values())
    assert auto(1.01 * t2) in ("uniform", "taylor1", "taylor2")
    assert auto(0.99 * t2) == "nodal"
    # auto judges grad B too: with a tolerance above taylor2's B error (measured 0.32) but below
    # its gradient error (0.68), it must not take taylor2 (the failure: a Taylor-2
    # model chosen while grad B was 6 % off)
    assert err["taylor2"]["B"] < 0.5 < err["taylor2"]["gradB"] < err["taylor1"]["gradB"]
    assert auto(0.5) == "nodal"


def test_superposition_of_sources(comm, magnet):
    spec, _ = magnet
    both = from_table(
        FieldSpec, {**MAGNET, "sources": MAGNET["sources"] + FLOWER["sources"]}, "field"
    )
    model = create_field_model(dataclasses.replace(both, model="nodal"), comm)
    P = workspace_points(spec.expansion_point, spec.workspace_size, 2)
    t = 0.007  # magnet sine w = sin(2π 5 0.007), square +1 after 5 ms, trigger off
    expect = math.sin(2 * math.pi * 5 * t) * CYL.flux_density(P) + np.array([0, 0, 3e-3])
    np.testing.assert_allclose(model.evaluate(P, t), expect, rtol=1e-13, atol=1e-15)


MOVING = {
    "model": "taylor2",
    "expansion_point": [0, 0, 0.004],
    "workspace_size": "2 mm",
    "sources": [
        {"kind": "block_magnet", "center": [0, 0, -0.01], "motion": "approach"},
        {"kind": "block_magnet", "center": [0.03, 0, 0], "axis": [0, 0, -1], "motion": "away"},
    ],
    "motions": [
        {
            "name": "approach",
            "times": [0.0, 0.02, 0.04],
            "offsets": [[0, 0, 0], [0, 0, 0.005], [0, 0, 0]],
        },
        {
            "name": "away",
            "times": ["10 ms", "30 ms"],
            "offsets": [[0, 0, 0], ["10 mm", 0, 0]],
            "angles": ["0 deg", "90 deg"],
            "rotation_axis": [0, 1, 0],
            "pivot": [0.03, 0, 0],
        },
    ],
}


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_moving_magnets_in_every_model(comm):
    spec = from_table(FieldSpec, MOVING, "field")
    terms = build_terms(spec, comm)
    np.testing.assert_allclose(
        create_field_model(spec, comm, sources=terms).breakpoints(0.0, 0.05),
        [0.01, 0.02, 0.03, 0.04],
    )
    t = 0.015  # approach: 3.75 mm up; away: a quarter of the way, turned 22.5° about y
    first = terms[0].field
    shifted = first.field_and_gradient(np.array([[0, 0, 0.004 - 0.00375]]))
    R = terms[1].trajectory.placement(t).R
    assert np.degrees(np.arccos(R[0, 0])) == pytest.approx(22.5)
    x0 = np.array([[0.0, 0.0, 0.004]])
    for name in ("uniform", "taylor1", "taylor2", "nodal"):
        model = create_field_model(dataclasses.replace(spec, model=name), comm, sources=terms)
        domain = _robot(comm, 2)
        model.bind(domain)
        model.update(t)
        B, G = model.field(x0, t)
        Be, Ge = model.field(x0, t, exact=True)
        np.testing.assert_allclose(B, Be, rtol=1e-12, atol=1e-15)  # at x0 every model is exact
        second = terms[1].trajectory.placement(t)
        b2, _ = terms[1].field.field_and_gradient(second.to_reference(x0))
        np.testing.assert_allclose(Be, shifted[0] + second.vectors(b2), rtol=1e-12)
        if name != "uniform":
            np.testing.assert_allclose(G, Ge, rtol=1e-10, atol=1e-12)
        # the bound Constants/Functions hold the moved field
        x = ufl.SpatialCoordinate(domain)
        vol = comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=domain))))
        bz = comm.allreduce(fem.assemble_scalar(fem.form(model.flux_density(x)[2] * ufl.dx)))
        inside = workspace_points([0, 0, 0.00025], 0.0005, 2) * [12, 8, 1]  # robot box corners
        assert bz / vol == pytest.approx(model.evaluate(inside, t)[:, 2].mean(), rel=0.2)


def test_closer_than_resolved_points_warn(comm, magnet):
    spec, terms = magnet
    into_magnet = dataclasses.replace(spec, expansion_point=(0.0, 0.0, -0.004))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        create_field_model(into_magnet, comm, sources=terms)
    hits = [w for w in caught if issubclass(w.category, FieldResolutionWarning)]
    assert len(hits) == (1 if comm.rank == 0 else 0)
    assert "closer to source0" in str(hits[0].message) if hits else True
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        create_field_model(dataclasses.replace(spec, model="uniform"), comm, sources=terms)
    texts = [str(w.message) for w in caught if issubclass(w.category, FieldResolutionWarning)]
    assert (comm.rank != 0) or any("model uniform is off by" in s for s in texts)


def test_serial_and_parallel_model_values_agree(comm, magnet):
    spec, terms = magnet
    model = create_field_model(dataclasses.replace(spec, model="nodal"), comm, sources=terms)
    domain = _robot(comm)
    u, E, _, _ = _energy_forms(model, domain)
    model.update(0.05, u=u)
    e_world = comm.allreduce(fem.assemble_scalar(E))
    self_terms = build_terms(spec, MPI.COMM_SELF)
    model_s = create_field_model(
        dataclasses.replace(spec, model="nodal"), MPI.COMM_SELF, sources=self_terms
    )
    _, E_s, _, _ = _energy_forms(model_s, _robot(MPI.COMM_SELF))
    model_s.update(0.05)
    assert e_world == pytest.approx(fem.assemble_scalar(E_s), rel=1e-10)
