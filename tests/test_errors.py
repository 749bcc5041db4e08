"""How commands end: one line and an exit status per kind of failure, on one rank or many.

The in-process tests run serially and under mpirun -n 2 (main() is collective there): every
rank must return the status, rank 0 alone prints the line. The subprocess tests time whole
commands under mpirun: a failure on one rank must end the job, not leave the others waiting.
"""

from __future__ import annotations

import copy
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
import tomli_w
from petsc4py import PETSc

from magfem.cli import main
from magfem.config import CaseError
from magfem.errors import (
    EXIT_INPUT,
    EXIT_INTERNAL,
    EXIT_IO,
    EXIT_SOLVER,
    RunInterrupted,
    describe,
)
from magfem.mechanics.stepping import SimulationError
from verification.setups import STRIP_CANTILEVER

TINY = copy.deepcopy(STRIP_CANTILEVER) | {"name": "tiny"}
TINY["time"] = {"end": "1 ms", "step": "0.25 ms"}
TINY["output"] = {"plot": False, "animation": False, "vtx_every": 0, "vtu_every": 0}


def _write(shared_tmp, comm, data, name="tiny.toml"):
    path = shared_tmp / name
    if comm.rank == 0:
        path.write_text(tomli_w.dumps(data), encoding="utf-8")
    comm.barrier()
    return path


def _one_line(capsys, comm, start: str) -> None:
    err = capsys.readouterr().err
    if comm.rank == 0:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(start), err
        assert "Traceback" not in err
    else:
        assert err == ""


@pytest.mark.parametrize(
    ("err", "status", "start"),
    [
        (CaseError("robot.thickness", "8e-5", "needs a unit"), EXIT_INPUT, "magfem: error: robot"),
        (SimulationError("t = 1 s: Newton\nfailed"), EXIT_SOLVER, "magfem: error: solver: t = 1"),
        (PETSc.Error(76), EXIT_SOLVER, "magfem: error: PETSc error 76"),
        (PermissionError(13, "Permission denied", "/x"), EXIT_IO, "magfem: error: I/O: /x:"),
        (RunInterrupted(signal.SIGTERM, "at t = 1 s"), 143, "magfem: stopped by SIGTERM"),
        (RunInterrupted(signal.SIGINT, "at t = 1 s"), 130, "magfem: stopped by SIGINT"),
        (ZeroDivisionError("x"), EXIT_INTERNAL, "magfem: internal error: ZeroDivisionError"),
    ],
)
def test_every_kind_of_failure_has_its_status_and_one_line(err, status, start):
    code, line = describe(err)
    assert code == status and line.startswith(start) and "\n" not in line


def test_output_folder_that_is_a_file_is_an_io_error_on_every_rank(shared_tmp, comm, capsys):
    """rank 0 creates the folder; its failure reaches every rank (no barrier waits for it)."""
    case = _write(shared_tmp, comm, TINY)
    blocker = shared_tmp / "a_file"
    if comm.rank == 0:
        blocker.write_text("x")
    comm.barrier()
    for command in (["run"], ["field"], ["mesh"]):
        argv = [*command, str(case), "--out", str(blocker / "out")]
        assert main(argv) == EXIT_IO, command
        _one_line(capsys, comm, "magfem: error: I/O: ")


def test_newton_failure_ends_the_run_with_status_3(shared_tmp, comm, capsys):
    data = copy.deepcopy(TINY)
    data["solver"] = {"max_iterations": 1}
    data["time"] |= {"max_cuts": 0}
    case = _write(shared_tmp, comm, data, "stall.toml")
    assert main(["run", str(case), "--out", str(shared_tmp / "stall"), "-q"]) == EXIT_SOLVER
    _one_line(capsys, comm, "magfem: error: solver: t = 0 s: Newton failed")


def test_unknown_or_malformed_petsc_options_are_input_errors(shared_tmp, comm, capsys):
    for options, words in (
        ({"snes_lnesearch_type": "bt"}, "does not use this option"),
        ({"snes_rtol": "abc"}, "cannot read this value"),
    ):
        data = copy.deepcopy(TINY) | {"solver": {"petsc_options": options}}
        case = _write(shared_tmp, comm, data, "petsc.toml")
        for argv in (["check", str(case)], ["run", str(case), "--out", str(shared_tmp / "p")]):
            assert main(argv) == EXIT_INPUT
            err = capsys.readouterr().err
            if comm.rank == 0:
                assert err.count("\n") == 1 and words in err and "solver.petsc_options." in err


def test_a_previous_run_is_kept_unless_resumed_or_overwritten(shared_tmp, comm, capsys):
    case = _write(shared_tmp, comm, TINY)
    out = shared_tmp / "again"
    assert main(["run", str(case), "--out", str(out), "-q"]) == 0
    assert main(["run", str(case), "--out", str(out), "-q"]) == EXIT_INPUT
    _one_line(capsys, comm, f"magfem: error: --out = '{out}': holds the outputs of a previous run")
    assert main(["run", str(case), "--resume", str(out), "-q"]) == EXIT_INPUT  # no checkpoint
    _one_line(capsys, comm, "magfem: error: --resume")
    assert main(["run", str(case), "--out", str(out), "--overwrite", "-q"]) == 0


_ALONE = """
import os, sys, time
import magfem
from mpi4py import MPI
from magfem.errors import end_with
comm = MPI.COMM_WORLD
failures = comm.Dup()
if comm.rank == {rank}:
    try:
        raise OSError(28, "No space left on device", "history.csv")
    except OSError as err:
        end_with(err, comm, failures)
comm.barrier()  # the healthy rank waits here for the one that failed
"""


@pytest.mark.slow
@pytest.mark.serial
@pytest.mark.parametrize("rank", [0, 1])
def test_a_rank_that_fails_alone_ends_the_job_with_one_line(rank):
    """A failure on one rank while the other waits in a collective call: the job ends after
    the agreement timeout (2 s here, 10 s by default) with the failing rank's line and its
    status (no hang)."""
    t0 = time.monotonic()
    mpirun = str(Path(sys.executable).parent / "mpirun")
    proc = subprocess.run(
        [mpirun, "-n", "2", sys.executable, "-c", _ALONE.format(rank=rank)],
        capture_output=True,
        text=True,
        timeout=60,
        env=os.environ | {"MAGFEM_FAILURE_TIMEOUT": "2"},
    )
    elapsed = time.monotonic() - t0
    assert proc.returncode == EXIT_IO, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines == [
        f"magfem: error: I/O: history.csv: No space left on device "
        f"(rank {rank}; the other ranks are stopped)"
    ]
    assert 2.0 <= elapsed < 30.0, elapsed


def test_docstring_table_lists_every_status():
    import magfem.errors as errors

    table = textwrap.dedent(errors.__doc__ or "")
    for status in (0, 1, 2, 3, 4, 70, 130, 143):
        assert f"\n{status} " in table, status
