"""Checkpoints and resume: a run stopped at a step and resumed gives the uninterrupted run's
history bit for bit, on one rank and on two (serial and mpirun -n 2)."""

from __future__ import annotations

import copy
import itertools
import json
import signal
import time

import numpy as np
import pytest
from mpi4py import MPI

from magfem.case import load_case, parse_case
from magfem.config import CaseError, to_table
from magfem.errors import RunInterrupted
from magfem.mechanics.checkpoint import (
    Checkpointer,
    check_resumable,
    plain_state,
    read_checkpoint,
    restore_plain_state,
)
from magfem.pipeline import simulate
from verification.setups import STRIP_CANTILEVER


def _case(**tables):
    data = copy.deepcopy(STRIP_CANTILEVER)
    # the ground under the strip: the impact absorber's memory is part of the state
    data["contact"] = {"ground": True}
    data["time"] = {"end": "3 ms", "step": "0.25 ms"}
    data["output"] = {"csv": True, "vtx_every": 4, "vtu_every": 3, "plot": False}
    data["output"] |= {"animation": False}
    for name, values in tables.items():
        data.setdefault(name, {}).update(values)
    return parse_case(data)


def _stop_at(call: int):
    """A stop request (SIGINT) agreed at the ``call``-th end of step."""
    calls = itertools.count(1)
    return lambda comm: int(signal.SIGINT) if next(calls) == call else 0


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_resume_gives_the_uninterrupted_history_bit_for_bit(comm, shared_tmp):
    """Stopped after step 7, resumed: every history column, the CSV file and the VTU/PVD
    series equal those of the run that was never stopped (same ranks: the same arithmetic,
    so equality is exact; a state left out of the checkpoint shows as a difference)."""
    case = _case()
    full = simulate(case, shared_tmp / "full", comm, progress=False)
    cut = shared_tmp / "cut"
    with pytest.raises(RunInterrupted) as stopped:
        simulate(case, cut, comm, progress=False, stop=_stop_at(7))
    assert stopped.value.exit_code == 130 and "after step 7" in str(stopped.value)
    comm.barrier()  # rank 0 writes the files
    meta = json.loads((cut / "checkpoint" / "meta.json").read_text())
    assert meta["step"] == 7 and meta["ranks"] == comm.size and meta["reason"] == "signal"
    assert (cut / "displacement" / "000007.vtu").exists()  # the last state is written too
    comm.barrier()
    resumed = simulate(case, cut, comm, progress=False, resume=True)
    comm.barrier()
    assert resumed.history.keys() == full.history.keys()
    for key, values in full.history.items():
        np.testing.assert_array_equal(resumed.history[key], values, err_msg=key)
    assert resumed.summary == pytest.approx(full.summary, nan_ok=True, rel=0, abs=0)
    if comm.rank == 0:
        for name in ("history.csv", "displacement.pvd"):
            assert (cut / name).read_text() == (shared_tmp / "full" / name).read_text(), name
        assert not (cut / "displacement" / "000007.vtu").exists()  # after the checkpoint
        assert (cut / "displacement.1.bp").is_dir()  # the VTX series goes on in a new file
    # a checkpointed run that resumed ends with a current checkpoint
    assert json.loads((cut / "checkpoint" / "meta.json").read_text())["reason"] == "end"


@pytest.mark.slow  # over 0.3 s: not in the fast tier
@pytest.mark.parametrize("scene", ["gripper", "pipette", "rect_water"])
def test_resume_restores_cargo_obstacles_and_swimming(scene, comm, shared_tmp, repo):
    """The gripper's cargo (a rigid body advanced between steps), the pipette's moving
    tip (an obstacle whose impact absorber remembers the nodes inside it) and rect-water's
    swimming and body columns (the start of swim_distance, the drag's work so far, the sign
    of the best-fit normal) resume bit for bit: their state is in the checkpoint.
    SuperLU_dist: MUMPS on two ranks schedules its factorisation dynamically, and two
    uninterrupted shell runs already differ at round-off (docs/running.md)."""
    overrides = ["mesh.size=1.2mm", "time.end=2ms", "time.step=0.25ms", "output.csv=true"]
    overrides += ["solver.linear_solver=superlu_dist"]
    overrides += ["output.vtx_every=0", "output.plot=false", "output.animation=false"]
    case = load_case(repo / "cases" / f"{scene}.toml", overrides)
    full = simulate(case, shared_tmp / "full", comm, progress=False)
    cut = shared_tmp / "cut"
    with pytest.raises(RunInterrupted):
        simulate(case, cut, comm, progress=False, stop=_stop_at(4))
    comm.barrier()
    resumed = simulate(case, cut, comm, progress=False, resume=True)
    assert resumed.history.keys() == full.history.keys()
    for key, values in full.history.items():
        np.testing.assert_array_equal(resumed.history[key], values, err_msg=key)


def _csv_times(path):
    """The time column (s) of a history CSV."""
    lines = path.read_text().splitlines()[1:]
    return [float(line.split(",")[0]) for line in lines]


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_a_history_interval_keeps_the_every_step_rows_and_resumes(comm, shared_tmp):
    """``history_interval = 1 ms`` keeps the rows of the first steps at or after 1, 2, 3 ms
    (and the step after the field's switch at 0, which the switch check reads), equal bit for
    bit to the every-step run's rows there (the ground contact and the angle unwrapping,
    which have memory, still see every step); a run stopped between samples keeps its last
    step too, and resumed gives the uninterrupted sampled history."""
    every = simulate(_case(), shared_tmp / "every", comm, progress=False)
    case = _case(output={"history_interval": "1 ms"})
    sampled = simulate(case, shared_tmp / "sampled", comm, progress=False)
    times = every.history["time"]
    kept = [0, 1] + [int(np.argmax(times >= k * 1e-3 - 1e-12)) for k in (1, 2, 3)]
    assert len(times) > 2 * len(kept) and kept[-1] == len(times) - 1
    assert sampled.history.keys() == every.history.keys()
    for key, values in sampled.history.items():
        np.testing.assert_array_equal(values, every.history[key][kept], err_msg=key)
    cut, stop = shared_tmp / "cut", kept[2] + 2  # two steps past the 1 ms row
    with pytest.raises(RunInterrupted):
        simulate(case, cut, comm, progress=False, stop=_stop_at(stop))
    comm.barrier()
    if comm.rank == 0:  # the stopped run's CSV ends with its last step
        expected = times[[0, 1, kept[2], stop]]
        np.testing.assert_allclose(_csv_times(cut / "history.csv"), expected, rtol=1e-6)
    comm.barrier()
    resumed = simulate(case, cut, comm, progress=False, resume=True)
    for key, values in sampled.history.items():
        np.testing.assert_array_equal(resumed.history[key], values, err_msg=key)
    if comm.rank == 0:
        text = (shared_tmp / "sampled" / "history.csv").read_text()
        assert (cut / "history.csv").read_text() == text


def test_resume_refuses_a_changed_case(comm, shared_tmp):
    """Only time.end and the checkpoint keys may change; the message names the key."""
    case = _case(time={"end": "1 ms"})
    out = shared_tmp / "changed"
    with pytest.raises(RunInterrupted):
        simulate(case, out, comm, progress=False, stop=_stop_at(2))
    other = _case(time={"end": "1 ms", "step": "0.125 ms"})
    with pytest.raises(CaseError, match=r"time\.step \(0\.00025 -> 0\.000125\)"):
        simulate(other, out, comm, progress=False, resume=True)
    meta, _ = read_checkpoint(out / "checkpoint", comm)
    check_resumable(meta, to_table(_case(time={"end": "2 ms"})), meta["time"])  # later end: ok
    with pytest.raises(CaseError, match=r"time\.end"):
        check_resumable(meta, to_table(_case(time={"end": "0.25 ms"})), meta["time"])


@pytest.mark.parallel
def test_a_checkpoint_of_two_ranks_needs_two_ranks(comm, shared_tmp):
    case = _case(time={"end": "1 ms"})
    out = shared_tmp / "ranks"
    with pytest.raises(RunInterrupted):
        simulate(case, out, comm, progress=False, stop=_stop_at(1))
    with pytest.raises(CaseError, match=r"written by 2 rank\(s\).*mpirun -n 2"):
        read_checkpoint(out / "checkpoint", MPI.COMM_SELF)
    comm.barrier()


def test_plain_state_round_trips_functions_constants_and_numbers(comm):
    """The integrator's state is read from its Functions and Constants (plain_state)."""
    from dolfinx import fem, mesh

    domain = mesh.create_unit_interval(comm, 4)

    class Part:
        pass

    part = Part()
    part.f = fem.Function(fem.functionspace(domain, ("Lagrange", 1)))
    part.c = fem.Constant(domain, 2.0)
    part.time, part.name, part.pair = 1.5, "x", (1, 2)
    part.callback = print  # not data: left out
    part.f.x.array[:] = np.arange(part.f.x.array.size)
    saved = plain_state(part)
    assert set(saved) == {"f", "c", "time", "name", "pair"}
    part.f.x.array[:] = 0.0
    part.c.value = 0.0
    part.time, part.pair = 0.0, (0, 0)
    restore_plain_state(part, saved | {"pair": [1, 2]})  # JSON gives lists back
    np.testing.assert_array_equal(part.f.x.array, np.arange(part.f.x.array.size))
    assert float(part.c.value) == 2.0 and part.time == 1.5 and part.pair == (1, 2)


def test_checkpoints_fall_due_by_steps_and_by_wall_time(comm, shared_tmp):
    by_steps = Checkpointer(shared_tmp / "c", comm, every=3)
    assert [s for s in range(1, 10) if by_steps.due(s)] == [3, 6, 9]
    by_time = Checkpointer(shared_tmp / "c", comm, interval=0.5)  # margin for a loaded machine
    assert not by_time.due(1)
    time.sleep(0.55)
    assert by_time.due(2)
    by_time.last_wall = time.monotonic()  # what write() does
    assert not by_time.due(3)
    assert not Checkpointer(shared_tmp / "c", comm).due(1)  # neither: never
