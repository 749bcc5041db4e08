"""Tabulated B-H curves: the monotone C¹ interpolant, its UFL form, bad tables, and a table of a
linear law against the linear iron sphere's closed form (Newton through the table)."""

from __future__ import annotations

import numpy as np
import pytest
from dolfinx import fem, mesh
from mpi4py import MPI

from magfem.config import CaseError, from_table
from magfem.field import analytic as an
from magfem.field.bh_table import BHCurve
from magfem.field.iron import solve_iron
from magfem.field.iron_spec import IronSpec
from magfem.field.source import UniformField
from magfem.field.spec import FieldSpec, SolveSpec
from verification.field_references import (
    SPHERE_FIELD,
    SPHERE_RADIUS,
    iron_sphere,
    linear_sphere,
    sphere_errors,
)

A = SPHERE_RADIUS
B0 = SPHERE_FIELD

# a knee-shaped steel curve (H A/m, B T) ending on a secant above µ0
H = (0.0, 50.0, 100.0, 200.0, 400.0, 1000.0, 5000.0, 20000.0, 60000.0)
B = (0.0, 0.1, 0.5, 1.0, 1.3, 1.5, 1.7, 1.85, 1.92)


def test_interpolant_passes_through_the_table_monotone_and_c1():
    curve = BHCurve.from_table(H, B)
    x = an.MU0 * np.array(H)
    np.testing.assert_allclose(curve(x), B, rtol=0, atol=1e-15)
    fine = np.linspace(0.0, 1.2 * x[-1], 20001)
    assert np.all(np.diff(curve(fine)) > 0)  # monotone, as the table
    eps = 1e-9 * x[-1]  # one-sided slopes at the knots agree (C¹) to the differences' error
    left = (curve(x[1:]) - curve(x[1:] - eps)) / eps
    right = (curve(x[1:] + eps) - curve(x[1:])) / eps
    np.testing.assert_allclose(left, right, rtol=1e-5)
    # beyond the table: the straight continuation dB/d(µ0 H) = 1
    assert curve(2 * x[-1]) - curve(1.5 * x[-1]) == pytest.approx(0.5 * x[-1], rel=1e-12)


def test_ufl_form_equals_the_numpy_interpolant():
    curve = BHCurve.from_table(H, B)
    msh = mesh.create_unit_interval(MPI.COMM_WORLD, 2)
    nb = fem.Constant(msh, 0.0)
    law = curve.ufl(nb, curve.constant(msh))
    dx = fem.form(law * mesh.ufl.dx(domain=msh, metadata={"quadrature_degree": 0}))
    for value in (1e-6, 3e-5, 2e-4, 1.3e-3, 0.02, 0.1):  # in five intervals and beyond
        nb.value = value
        got = msh.comm.allreduce(fem.assemble_scalar(dx))
        assert got == pytest.approx(float(curve(np.array(value))), rel=1e-13)


IRON = {"kind": "sphere", "radius": "5 mm", "bh_h": list(H), "bh_b": list(B)}


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"bh_b": list(B[:-1])}, r"iron\[0\]\.bh_b = .*as many entries as bh_h \(9\)"),
        ({"bh_h": [1.0, *H[1:]]}, r"iron\[0\]\.bh_h = .*must start at H = 0"),
        ({"bh_h": [0.0, 100.0, 50.0, *H[3:]]}, r"iron\[0\]\.bh_h = .*increase strictly"),
        ({"bh_b": [0.0, 0.5, 0.4, *B[3:]]}, r"iron\[0\]\.bh_b = .*increase strictly with H"),
        ({"saturation": "1.8 T"}, r"iron\[0\]\.saturation = 1\.8: give saturation or a B-H"),
        ({"bh_b": None}, r"iron\[0\]\.bh_b: a B-H table needs both"),
    ],
)
def test_bad_tables(change, match):
    table = {k: v for k, v in (IRON | change).items() if v is not None}
    with pytest.raises(CaseError, match=match):
        from_table(
            FieldSpec,
            {"sources": [{"kind": "uniform", "flux_density": 1}], "iron": [table]},
            "field",
        )


def test_parts_share_one_table():
    other = IRON | {"center": [0.0, 0.0, 0.02], "bh_b": [b * 1.01 for b in B]}
    field = {"sources": [{"kind": "uniform", "flux_density": 1}], "iron": [IRON, other]}
    with pytest.raises(
        CaseError, match=r"iron\[1\]\.bh_b = .*share one table \(that of iron\[0\]\)"
    ):
        from_table(FieldSpec, field, "field")
    from_table(FieldSpec, field | {"iron": [IRON, IRON | {"center": [0.0, 0.0, 0.02]}]}, "f")


@pytest.mark.slow  # one (r, z) P3 Newton solve: 4 s with its form compilation, 0.6 s warm
def test_table_of_a_linear_law_gives_the_linear_sphere(comm):
    """B = µ0 µr H tabulated up to far above the interior H (~2.4 A/m): Newton through the
    table from µr = 200 must land on the linear sphere of µr = 1000 (closed form)."""
    h = np.concatenate([np.linspace(0.0, 20.0, 24), [1e3]])  # 25 points: the next test's forms
    table = {
        "kind": "sphere",
        "radius": A,
        "permeability": 200.0,
        "bh_h": h.tolist(),
        "bh_b": (an.MU0 * 1000.0 * h).tolist(),
    }
    part = from_table(IronSpec, table, "iron")
    assert not part.linear
    solve = from_table(SolveSpec, {}, "solve")  # (r, z), P3, as the linear sphere's test
    (reaction,) = solve_iron([part], [UniformField(B0)], solve, comm)
    err = sphere_errors(reaction, *linear_sphere(1000.0))
    # the linear test's bounds; measured the linear solve's own errors (interior 1.4e-7,
    # B 1.6e-4, moment 9.5e-8): the table is exact for a linear law below 20 A/m
    assert err["interior"] < 5e-7
    assert err["B"] < 5e-4
    assert err["moment"] < 3e-7
    # the law is linear where the iron is, so Newton with the exact Jacobian of the UFL
    # table converges in one step from any start (a wrong derivative would take more)
    assert reaction.info["newton_iterations"] == 1


@pytest.mark.slow  # the previous test's forms: 0.6 s
def test_table_of_the_saturating_law_gives_its_saturated_sphere(comm):
    """The arctan law (µr 1000, J_s 1.5 T) sampled at 25 points (H geometric 10 A/m-10 MA/m):
    the sphere in 1 T saturates to the law's exact interior field, 1.9988 T (through the knee:
    Newton takes several steps)."""
    js, mu = 1.5, 1000.0
    h = np.concatenate([[0.0], np.geomspace(10.0, 1e7, 24)])
    b = an.MU0 * h + 2 * js / np.pi * np.arctan(np.pi * (mu - 1) * an.MU0 * h / (2 * js))
    part = from_table(
        IronSpec, {"kind": "sphere", "radius": A, "bh_h": h.tolist(), "bh_b": b.tolist()}, "iron"
    )
    solve = from_table(SolveSpec, {}, "solve")  # the previous test's: its forms are reused
    (reaction,) = solve_iron([part], [UniformField(np.array([0.0, 0.0, 1.0]))], solve, comm)
    b_in, _ = iron_sphere(mu, 1.0, js)
    d = np.random.default_rng(2).normal(size=(20, 3))
    inner = 0.5 * A * d / np.linalg.norm(d, axis=1)[:, None]
    # measured 1.7e-5, the interpolant's error at 25 points through the knee (the arctan law
    # itself on this mesh: 5e-8)
    np.testing.assert_allclose(reaction.iron_flux_density(inner)[:, 2], b_in, rtol=1e-4)
    assert 2 <= reaction.info["newton_iterations"] <= 8  # measured 4
