"""Scalar integrals assembled in bundles (magfem.mechanics.forms.ScalarForms).

References are closed forms on the unit square [0, 1]²: the area 1, the first moments
∫x dx = ∫y dx = 1/2, the second moment ∫xy dx = 1/4, the perimeter 4 and ∫_∂Ω x ds = 2,
and ∫ over interior facets of 1 (the total length of the inner edges of the mesh), which
depends only on the mesh: on an n × n grid of squares cut by diagonals it is
2 (n − 1) + n √2. Everything is integrated exactly by the quadrature (degree ≤ 2), so the
tolerance is round-off (1e-12).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import mesh as dmesh
from mpi4py import MPI

from magfem.mechanics.forms import ScalarForms

N = 4


@pytest.fixture(scope="module")
def square():
    return dmesh.create_unit_square(MPI.COMM_WORLD, N, N, dmesh.CellType.triangle)


def test_bundled_integrals_equal_their_closed_forms(square):
    x = ufl.SpatialCoordinate(square)
    dx = ufl.Measure("dx", square, metadata={"quadrature_degree": 2})
    ds = ufl.Measure("ds", square, metadata={"quadrature_degree": 2})
    dS = ufl.Measure("dS", square, metadata={"quadrature_degree": 2})
    forms = [1.0 * dx, x[0] * dx, x[1] * dx, x[0] * x[1] * dx, 1.0 * ds, x[0] * ds, 1.0 * dS]
    values = ScalarForms(square, forms).assemble()
    inner = 2 * (N - 1) + N * math.sqrt(2)
    expected = [1.0, 0.5, 0.5, 0.25, 4.0, 2.0, inner]
    assert np.allclose(values, expected, rtol=0, atol=1e-12)


def test_measures_with_different_tags_and_empty_forms(square):
    """Integrals over two differently tagged boundaries go to separate compiled forms; an
    empty form is 0."""
    fdim = square.topology.dim - 1
    square.topology.create_connectivity(fdim, fdim + 1)
    left = dmesh.locate_entities_boundary(square, fdim, lambda p: np.isclose(p[0], 0.0))
    bottom = dmesh.locate_entities_boundary(square, fdim, lambda p: np.isclose(p[1], 0.0))
    tags = [
        dmesh.meshtags(square, fdim, np.sort(f).astype(np.int32), np.full(len(f), 1, np.int32))
        for f in (left, bottom)
    ]
    x = ufl.SpatialCoordinate(square)
    on_left = ufl.Measure("ds", square, subdomain_data=tags[0], metadata={"quadrature_degree": 2})
    on_bottom = ufl.Measure("ds", square, subdomain_data=tags[1], metadata={"quadrature_degree": 2})
    forms = [x[1] * on_left(1), ufl.Form([]), x[0] * x[0] * on_bottom(1)]
    bundle = ScalarForms(square, forms)
    assert len(bundle.parts) == 2
    assert np.allclose(bundle.assemble(), [0.5, 0.0, 1.0 / 3.0], rtol=0, atol=1e-12)


def test_native_flags_key_the_form_cache_by_cpu():
    """x86-64: -march=native and a define that differs between CPUs (model or instruction
    set) and not between two reads of one CPU; elsewhere the portable flags alone."""
    from magfem.mechanics.forms import native_flags

    epyc = "processor : 0\nmodel name : AMD EPYC\nflags : fpu sse2 avx2 avx512f\n"
    flags = native_flags(epyc + epyc.replace("processor : 0", "processor : 1"), "x86_64")
    assert flags[0] == "-march=native" and flags[1].startswith("-DMAGFEM_CPU=")
    assert native_flags(epyc, "AMD64") == flags
    assert native_flags(epyc.replace(" avx512f", ""), "x86_64") != flags
    assert native_flags(epyc.replace("EPYC", "Xeon"), "x86_64") != flags
    assert native_flags(epyc, "aarch64") == [] and native_flags(epyc, "arm64") == []
