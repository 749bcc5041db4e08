"""Shared fixtures. Tests run serially and under ``mpirun -n 2``.

Under MPI every rank runs the same tests in the same order; tests that
only make sense on one rank are marked ``@pytest.mark.serial`` and skipped
when the world communicator has more than one rank; tests that are the
parallel twin of a serial test are marked ``@pytest.mark.parallel`` and
skipped on one rank.
"""

from __future__ import annotations

import gc
import shutil
from pathlib import Path

import pytest
from mpi4py import MPI

import magfem  # noqa: F401  (orders MPI ahead of dolfinx when the wheel is installed)
from magfem.parallel import shared_directory

REPO = Path(__file__).resolve().parents[1]


def pytest_collection_modifyitems(config, items):
    if MPI.COMM_WORLD.size > 1:
        marker, reason = "serial", "serial-only test (MPI world size > 1)"
    else:
        marker, reason = "parallel", "parallel twin of a serial test (runs under mpirun)"
    skip = pytest.mark.skip(reason=reason)
    for item in items:
        if marker in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def comm() -> MPI.Comm:
    return MPI.COMM_WORLD


@pytest.fixture
def shared_tmp(comm):
    """A temporary directory common to all ranks (tmp_path differs per rank)."""
    path = shared_directory(comm, prefix="magfem-test-")
    yield path
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


_TESTS_SINCE_COLLECTION = [0]


@pytest.fixture(autouse=True)
def _free_meshes():
    """Under MPI, collect garbage every 10 tests, on every rank at the same point.

    The MPI runner (verification/mpi_pytest.py) switches the collector off: meshes held
    in reference cycles keep their MPI communicators (a few hundred tests run out of them)
    and must be freed, but on every rank alike (the collector's own timing differs between
    ranks, and destroying some parallel objects then deadlocks). A collection costs ~0.1 s,
    hence every 10 tests; serially the collector runs as usual.
    """
    yield
    _TESTS_SINCE_COLLECTION[0] += 1
    if MPI.COMM_WORLD.size > 1 and _TESTS_SINCE_COLLECTION[0] % 10 == 0:
        gc.collect()
