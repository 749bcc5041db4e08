"""The rod's section law: Ashwell's anticlastic bending energy and the torsion constant.

References: :func:`verification.references.anticlastic_energy_ratio` (the
cross-section's energy minimised by solving its beam-on-foundation equation
and integrating the energy by quadrature, independent of the closed form),
and the thin-strip and square limits of Saint-Venant torsion.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from magfem.mechanics.models.rod_section import (
    ashwell_phi,
    ashwell_phi_ufl,
    bending_energy,
    torsion_constant,
)
from verification import references as ref

NU = 0.495


@pytest.mark.parametrize("x", [0.05, 0.5, 1.0, 1.999, 2.001, 3.0, 6.0, 15.0, 39.0, 41.0, 200.0])
def test_ashwell_energy_equals_minimised_cross_section(x):
    """W/(D b κ²/2) = 1 − ν² φ(x) to the quadrature of the reference (Simpson, 2e4 points)."""
    expected = ref.anticlastic_energy_ratio(x, NU)
    assert 1.0 - NU**2 * ashwell_phi(x) == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_ashwell_limits_are_beam_and_plate():
    """x → 0: the beam (φ → 1, φ = 1 − x⁴/180 + ...); x → ∞: the plate (φ ≈ 2/x)."""
    assert ashwell_phi(1e-3) == pytest.approx(1.0, abs=1e-14)
    assert 1 - ashwell_phi(0.5) == pytest.approx(0.5**4 / 180, rel=1e-3)
    assert ashwell_phi(1e3) * 1e3 == pytest.approx(2.0, rel=1e-12)


def test_ufl_phi_matches_numpy_on_both_branches():
    """The UFL law (series below x = 2, closed form above, 2/x beyond 40) at points of a mesh."""
    comm = MPI.COMM_WORLD
    domain = mesh.create_interval(comm, 8, [0.0, 1.0])
    xs = np.array([0.0, 0.3, 1.9, 2.1, 5.0, 30.0, 45.0])
    total = 0.0
    for x in xs:
        u = fem.Constant(domain, x**4)
        value = fem.assemble_scalar(fem.form(ashwell_phi_ufl(u) * ufl.dx(domain)))
        total += abs(comm.allreduce(value, op=MPI.SUM) - float(ashwell_phi(x)))
    assert total < 1e-12


def test_bending_energy_laws_are_ordered():
    """beam < anticlastic < plate at any curvature; anticlastic → beam as κ → 0 (UFL)."""
    comm = MPI.COMM_WORLD
    domain = mesh.create_interval(comm, 4, [0.0, 1.0])
    b, t, E = 2e-3, 80e-6, 3.4e5

    def energy(kappa: float, law: str) -> float:
        k = fem.Constant(domain, kappa)
        form = fem.form(bending_energy(k, fem.Constant(domain, b), t, E, NU, law) * ufl.dx)
        return comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)

    for kappa in (1.0, 100.0, 1000.0):
        beam, mid, plate = (energy(kappa, law) for law in ("beam", "anticlastic", "plate"))
        assert beam < mid < plate
    assert energy(1e-3, "anticlastic") == pytest.approx(energy(1e-3, "beam"), rel=1e-9)


def test_torsion_constant_limits():
    """Thin strip: b t³/3 (1 − 0.63 t/b); square: 0.1406 a⁴ (Saint-Venant), within 0.5 %."""
    b, t = 4e-3, 80e-6
    assert torsion_constant(b, t) == pytest.approx(b * t**3 / 3 * (1 - 0.63 * t / b), rel=1e-3)
    assert torsion_constant(1.0, 1.0) == pytest.approx(0.1406, rel=5e-3)
    assert torsion_constant(t, b) == torsion_constant(b, t)
    assert math.isfinite(torsion_constant(0.0 + 1e-12, t))
