"""SIGINT and SIGTERM stop a run at the end of a step with a checkpoint, exit 130 / 143.

The subprocess tests signal a real ``magfem run`` of a tiny strip, serially and under
``mpirun -n 2`` (which forwards the signal to every rank), once it has written a few steps.
"""

from __future__ import annotations

import copy
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from magfem.cli import main
from magfem.signals import StopSignals
from verification.setups import STRIP_CANTILEVER

BIN = Path(sys.executable).parent


def test_a_signal_is_a_request_that_every_rank_agrees_on(comm):
    with StopSignals() as stop:
        assert stop.received == 0 and stop.agreed(comm) == 0
        if comm.rank == comm.size - 1:  # one rank only: all must stop at the same step
            os.kill(os.getpid(), signal.SIGTERM)
        assert stop.agreed(comm) == signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) != stop._handle  # the handlers are given back


def _signal_set(field: str) -> set[int]:
    lines = Path("/proc/self/status").read_text().splitlines()
    line = next(x for x in lines if x.startswith(field))
    mask = int(line.split()[1], 16)
    return {s for s in range(1, 32) if mask >> (s - 1) & 1}


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="reads /proc")
def test_petsc_handlers_are_off_while_a_command_runs():
    """PETSc catches SIGTERM (and SIGPIPE, SIGSEGV, ...) from its start: a SIGTERM would end
    the job inside PETSc. While a command runs, SIGTERM is ours, and after it the default."""
    with StopSignals():
        assert signal.getsignal(signal.SIGTERM) not in (signal.SIG_DFL, None)
        assert signal.SIGSEGV not in _signal_set("SigCgt")  # PETSc's handler is gone
        assert signal.SIGPIPE in _signal_set("SigIgn")  # as Python sets it at start-up
    assert signal.SIGTERM not in _signal_set("SigCgt")


def _case_file(directory: Path) -> Path:
    data = copy.deepcopy(STRIP_CANTILEVER) | {"name": "signalled"}
    data["time"] = {"end": "1 s", "step": "0.25 ms"}  # far more steps than the test waits for
    data["output"] = {"plot": False, "animation": False, "vtx_every": 0, "vtu_every": 5}
    path = directory / "signalled.toml"
    path.write_text(tomli_w.dumps(data), encoding="utf-8")
    return path


def _ranks(parent: int) -> list[int]:
    """Process ids of the magfem processes below ``parent`` (mpiexec's ranks), by rank order."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found, todo = [], [parent]
    while todo:
        pid = todo.pop()
        for child in children.get(pid, []):
            todo.append(child)
            try:
                cmdline = (Path("/proc") / str(child) / "cmdline").read_bytes()
            except OSError:
                continue
            if b"magfem" in cmdline and b"mpirun" not in cmdline and b"hydra" not in cmdline:
                found.append(child)
    return sorted(found)


def _signal_when_stepping(
    cmd: list[str], out: Path, signum: int, *, ranks: bool = False
) -> subprocess.CompletedProcess:
    """Start ``cmd``, send ``signum`` once its history has 4 steps, wait for it to end.

    ``ranks``: signal one of the ranks below ``cmd`` (mpiexec) instead of ``cmd`` itself,
    as a batch system does.
    """
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    history = out / "history.csv"
    while not (history.is_file() and len(history.read_text().splitlines()) > 5):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no steps in 120 s"
        time.sleep(0.1)
    if ranks:
        os.kill(_ranks(proc.pid)[-1], signum)
    else:
        proc.send_signal(signum)
    stdout, stderr = proc.communicate(timeout=60)
    return subprocess.CompletedProcess(cmd, proc.returncode, stdout, stderr)


def _check_stopped(done: subprocess.CompletedProcess, out: Path, signum: int, ranks: int) -> None:
    name = signal.Signals(signum).name
    ours = [line for line in done.stderr.splitlines() if line.startswith("magfem")]
    assert done.returncode == 128 + signum, done.stderr
    assert len(ours) == 1 and ours[0].startswith(f"magfem: stopped by {name}: at t = "), ours
    assert "--resume" in ours[0] and "Traceback" not in done.stderr
    meta = json.loads((out / "checkpoint" / "meta.json").read_text())
    assert meta["reason"] == "signal" and meta["ranks"] == ranks and meta["step"] >= 4
    with np.load(out / "checkpoint" / "rank_00000.npz", allow_pickle=False) as data:
        assert "__tree__" in data.files
    rows = (out / "history.csv").read_text().splitlines()
    assert len(rows) == meta["step"] + 2  # header, t0 and every step up to the checkpoint


@pytest.mark.slow
@pytest.mark.serial
def test_sigint_stops_a_serial_run_with_a_checkpoint_and_resume_finishes_it(tmp_path):
    case = _case_file(tmp_path)
    out = tmp_path / "out"
    cmd = [str(BIN / "magfem"), "run", str(case), "--out", str(out), "-q"]
    done = _signal_when_stepping(cmd, out, signal.SIGINT)
    _check_stopped(done, out, signal.SIGINT, ranks=1)
    # the checkpoint continues, here to a nearer end (time.end may change)
    end = json.loads((out / "checkpoint" / "meta.json").read_text())["time"] + 1e-3
    assert main(["run", str(case), "--resume", str(out), "-q", "--set", f"time.end={end}s"]) == 0


@pytest.mark.slow
@pytest.mark.serial
def test_sigterm_stops_a_serial_run_with_a_checkpoint(tmp_path):
    """``kill`` on a serial run (the process that meshes with gmsh, whose initialisation
    resets SIGTERM to its default action in the C library: the run ended at once, without a
    checkpoint, until magfem registered its handler again)."""
    case = _case_file(tmp_path)
    out = tmp_path / "out"
    cmd = [str(BIN / "magfem"), "run", str(case), "--out", str(out), "-q"]
    done = _signal_when_stepping(cmd, out, signal.SIGTERM)
    _check_stopped(done, out, signal.SIGTERM, ranks=1)


@pytest.mark.slow
@pytest.mark.serial
def test_sigterm_to_one_rank_stops_both_ranks_at_the_same_step(tmp_path):
    """A batch system's SIGTERM to the ranks (here: to one of two) stops the job at the end of
    a step. (MPICH's mpiexec ends its ranks at once on a SIGTERM of its own; it forwards SIGINT.)
    """
    case = _case_file(tmp_path)
    out = tmp_path / "out"
    cmd = [str(BIN / "mpirun"), "-n", "2", str(BIN / "magfem"), "run", str(case)]
    cmd += ["--out", str(out), "-q"]
    done = _signal_when_stepping(cmd, out, signal.SIGTERM, ranks=True)
    _check_stopped(done, out, signal.SIGTERM, ranks=2)
    assert (out / "checkpoint" / "rank_00001.npz").is_file()


@pytest.mark.slow
@pytest.mark.serial
def test_sigint_to_mpirun_gives_130(tmp_path):
    case = _case_file(tmp_path)
    out = tmp_path / "out"
    cmd = [str(BIN / "mpirun"), "-n", "2", str(BIN / "magfem"), "run", str(case)]
    cmd += ["--out", str(out), "-q"]
    done = _signal_when_stepping(cmd, out, signal.SIGINT)
    _check_stopped(done, out, signal.SIGINT, ranks=2)
