"""Run pytest on every MPI rank; rank 0 reports, the others write a log.

Usage: ``mpirun -n N python -m verification.mpi_pytest LOG [pytest args]`` from the
repository root.
All ranks must run the same tests in the same order because the tests make
collective calls; the exit status is non-zero if any rank failed.
"""

from __future__ import annotations

import gc
import sys

import pytest
from mpi4py import MPI

import magfem  # noqa: F401  (MPI before dolfinx)


def main(argv: list[str]) -> int:
    comm = MPI.COMM_WORLD
    # garbage is collected only between tests (tests/conftest.py), at the same point on every
    # rank: the collector's own timing differs between ranks, and the destruction of some
    # parallel objects (PETSc, MPI communicators) must happen on all ranks alike
    gc.disable()
    log, args = argv[0], argv[1:]
    if comm.rank == 0:
        status = int(pytest.main(args))
    else:
        with open(f"{log}.rank{comm.rank}", "w") as out:
            sys.stdout = sys.stderr = out
            status = int(pytest.main(["-q", *args]))
            sys.stdout, sys.stderr = sys.__stdout__, sys.__stderr__
    worst = comm.allreduce(status, op=MPI.MAX)
    return worst


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
