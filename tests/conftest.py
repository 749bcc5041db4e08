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


@pytest.fixture(autouse=True)
def _free_meshes():
    """Collect each test's garbage on every rank at the same point: meshes and PETSc objects
    held in reference cycles keep their MPI communicators, and a few hundred tests in one
    process otherwise run out of MPI communicator contexts (an abort in create_mesh)."""
    yield
    gc.collect()
