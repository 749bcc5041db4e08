"""Checkpoints of a run, and what the time loop does at the end of each step to stop or save.

A checkpoint holds everything a run needs to go on exactly as if it had
never stopped, on the same number of ranks: the state of every part that
remembers something between steps. Parts give it through a small protocol,
``state() -> dict`` (plain values, lists, dicts with string keys and NumPy
arrays) and ``load_state(dict)``: the step controller, the observers and
contacts with memory (angle unwrapping, the ground's touching columns,
self-contact's touching pairs), the writers (rows written, files of a
series). The time integrator's arrays of every unknown (u_n, v_n, a_n and
the iterate, owned and ghost entries) and its constants are read from its
``fem.Function``/``fem.Constant`` attributes (:func:`plain_state`) unless it
has ``state()`` of its own.

On disk, ``<outdir>/checkpoint/``: ``meta.json`` (step, time, ranks, the
resolved case, why it was written) and one ``rank_NNNNN.npz`` per rank
(its arrays, and the rest of its state as JSON, floats written exactly).
A new checkpoint is written into ``checkpoint.tmp/`` and swapped in, the
previous one kept as ``checkpoint.old/`` until the swap is done, so that a
run killed while writing keeps a whole checkpoint.

:class:`RunControl` is what the time loop asks after every accepted step:
one collective call agrees on a stop signal (:class:`magfem.signals.StopSignals`)
and on whether a checkpoint is due (``[output] checkpoint_every`` steps or
``checkpoint_interval`` seconds of wall time, measured on rank 0).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from magfem.config import CaseError
from magfem.parallel import root_call

__all__ = [
    "FORMAT",
    "Checkpointer",
    "RunControl",
    "check_resumable",
    "load_part_state",
    "part_state",
    "plain_state",
    "read_checkpoint",
    "restore_plain_state",
    "restore_run",
    "run_state",
]

FORMAT = 1
"""Version of the checkpoint layout."""
RESUMABLE_CHANGES = ("time.end", "output.checkpoint_every", "output.checkpoint_interval")
"""Case keys that may differ between a checkpoint and the case that resumes it."""

_PLAIN = (bool, int, float, str, type(None), np.generic)


def plain_state(obj: Any, skip: Sequence[str] = ()) -> dict[str, Any]:
    """The attributes of ``obj`` that are data: numbers, strings, arrays, Functions, Constants.

    ``fem.Function`` attributes give a copy of their local array (owned and
    ghost entries), ``fem.Constant`` ones their value; lists, tuples and
    dicts of plain values are kept; anything else (specs, callables, PETSc
    objects) is left out, as are the names in ``skip``.
    """
    out: dict[str, Any] = {}
    for name, value in vars(obj).items():
        if name in skip:
            continue
        if isinstance(value, fem.Function):
            out[name] = {"function": value.x.array.copy()}
        elif isinstance(value, fem.Constant):
            out[name] = {"constant": np.array(value.value, copy=True)}
        elif isinstance(value, np.ndarray) or _is_plain(value):
            out[name] = value
    return out


def _is_plain(value: Any) -> bool:
    if isinstance(value, _PLAIN):
        return True
    if isinstance(value, list | tuple):
        return all(_is_plain(v) for v in value)
    if isinstance(value, dict):
        return all(isinstance(k, str) and _is_plain(v) for k, v in value.items())
    return False


def restore_plain_state(obj: Any, state: Mapping[str, Any]) -> None:
    """Set what :func:`plain_state` took back on ``obj`` (Functions and Constants in place)."""
    for name, value in state.items():
        current = getattr(obj, name)
        if isinstance(value, dict) and "function" in value:
            current.x.array[:] = value["function"]
        elif isinstance(value, dict) and "constant" in value:
            current.value = value["constant"]
        elif isinstance(current, tuple) and isinstance(value, list):
            setattr(obj, name, tuple(value))
        else:
            setattr(obj, name, value)


def part_state(part: Any) -> dict[str, Any] | None:
    """``part.state()``, or None for a part without memory (no ``state`` method)."""
    method = getattr(part, "state", None)
    return method() if callable(method) else None


def load_part_state(part: Any, state: Mapping[str, Any] | None) -> None:
    """``part.load_state(state)`` when the part has memory."""
    if state is not None:
        part.load_state(state)


def run_state(sim: Any) -> dict[str, Any]:
    """A simulation's state on this rank at its last accepted step (:func:`restore_run`).

    The integrator's arrays and constants of every unknown, the step
    controller, every load, contact and observer with memory, the rows of
    the history so far and the event log.
    """
    integ = sim.integrator
    columns = sim.columns()
    rows = np.array([[r.get(k, np.nan) for k in columns] for r in sim.rows], dtype=float)
    return {
        "layout": layout([p.u for p in integ.parts]),
        "integrator": [part_state(p) or plain_state(p) for p in integ.parts],
        "controller": sim.controller.state(),
        "parts": [part_state(p) for p in [*sim.problem.loads, *sim.observers]],
        "columns": columns,
        "rows": rows,
        "log": list(sim.log),
    }


def restore_run(sim: Any, state: Mapping[str, Any]) -> float:
    """Set :func:`run_state` back on ``sim`` (same case, same ranks); returns the time t_n (s).

    Raises:
        CaseError: the state is of another mesh partition or another set of
            history columns (collective check).
    """
    integ = sim.integrator
    same = state["layout"] == layout([p.u for p in integ.parts])
    same = same and list(state["columns"]) == sim.columns()
    if not sim.comm.allreduce(same, op=MPI.LAND):
        raise CaseError(
            "--resume",
            "checkpoint",
            "written for another mesh partition or other outputs (same case and ranks needed)",
        )
    for part, saved in zip(integ.parts, state["integrator"], strict=True):
        if callable(getattr(part, "state", None)):
            load_part_state(part, saved)
        else:
            restore_plain_state(part, saved)
    sim.controller.load_state(state["controller"])
    for part, saved in zip([*sim.problem.loads, *sim.observers], state["parts"], strict=True):
        load_part_state(part, saved)
    columns = list(state["columns"])
    sim.rows = [dict(zip(columns, map(float, r), strict=True)) for r in state["rows"]]
    sim.events.lines[:] = list(state["log"])
    return float(integ.time)


# --- files -------------------------------------------------------------------------------------


def _split(tree: Any, arrays: dict[str, np.ndarray]) -> Any:
    """``tree`` with its arrays replaced by references into ``arrays`` (JSON-ready)."""
    if isinstance(tree, np.ndarray):
        key = f"a{len(arrays)}"
        arrays[key] = tree
        return {"__array__": key}
    if isinstance(tree, dict):
        return {str(k): _split(v, arrays) for k, v in tree.items()}
    if isinstance(tree, list | tuple):
        return [_split(v, arrays) for v in tree]
    if isinstance(tree, np.generic):
        return tree.item()
    return tree


def _join(tree: Any, arrays: Mapping[str, np.ndarray]) -> Any:
    if isinstance(tree, dict):
        if set(tree) == {"__array__"}:
            return np.array(arrays[tree["__array__"]])
        return {k: _join(v, arrays) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_join(v, arrays) for v in tree]
    return tree


def _all_ranks(comm: MPI.Comm, fn: Callable[[], Any]) -> Any:
    """``fn()`` on every rank; when it fails on any rank it raises on all (collective)."""
    failure: BaseException | None = None
    result = None
    try:
        result = fn()
    except (OSError, ValueError, KeyError) as err:
        failure = err
    failed = comm.allgather(None if failure is None else " ".join(str(failure).split()))
    if failure is not None:
        raise failure
    for rank, message in enumerate(failed):
        if message is not None:
            raise OSError(f"rank {rank}: {message}")
    return result


def layout(functions: Sequence[fem.Function]) -> str:
    """A fingerprint of this rank's part of the mesh and its dofs (resumes need the same)."""
    digest = hashlib.sha256()
    for f in functions:
        V = f.function_space
        digest.update(np.ascontiguousarray(V.tabulate_dof_coordinates()).tobytes())
        digest.update(str(f.x.array.size).encode())
    return digest.hexdigest()


@dataclass
class Checkpointer:
    """Writes checkpoints into ``directory`` (collective).

    Args:
        directory: the checkpoint folder (``<outdir>/checkpoint``).
        comm: the run's communicator.
        every: write one every this many steps (0: not by steps).
        interval: write one when this many seconds of wall time have passed
            since the last (0: not by time).
        case: the resolved case table, stored to check a resume against.
    """

    directory: Path
    comm: MPI.Comm
    every: int = 0
    interval: float = 0.0
    case: Mapping[str, Any] = field(default_factory=dict)
    last_wall: float = field(default_factory=time.monotonic)

    def due(self, step: int) -> bool:
        """Whether a checkpoint is due after step ``step`` (not collective: rank 0's clock)."""
        by_steps = self.every > 0 and step % self.every == 0
        by_time = self.interval > 0 and time.monotonic() - self.last_wall >= self.interval
        return by_steps or by_time

    def write(self, state: Mapping[str, Any], *, step: int, t: float, reason: str) -> Path:
        """Write this rank's ``state`` as the checkpoint of ``step`` at ``t`` (collective)."""
        comm, final = self.comm, Path(self.directory)
        tmp, old = final.with_name(final.name + ".tmp"), final.with_name(final.name + ".old")

        def fresh() -> None:
            shutil.rmtree(tmp, ignore_errors=True)
            tmp.mkdir(parents=True)

        root_call(comm, fresh)
        _all_ranks(comm, lambda: _write_rank(tmp / f"rank_{comm.rank:05d}.npz", state))
        meta = {
            "format": FORMAT,
            "step": int(step),
            "time": float(t),
            "ranks": comm.size,
            "reason": reason,
            "written": time.strftime("%Y-%m-%d %H:%M:%S"),
            "case": self.case,
        }

        def swap() -> None:
            (tmp / "meta.json").write_text(json.dumps(meta, indent=1), encoding="utf-8")
            if final.exists():
                shutil.rmtree(old, ignore_errors=True)
                os.replace(final, old)
            os.replace(tmp, final)
            shutil.rmtree(old, ignore_errors=True)

        root_call(comm, swap)
        self.last_wall = time.monotonic()
        return final


def _write_rank(path: Path, state: Mapping[str, Any]) -> None:
    arrays: dict[str, np.ndarray] = {}
    tree = json.dumps(_split(dict(state), arrays))
    with path.open("wb") as fh:
        save: Any = np.savez
        save(fh, __tree__=np.array(tree), **arrays)
        fh.flush()
        os.fsync(fh.fileno())


def read_checkpoint(directory: Path, comm: MPI.Comm) -> tuple[dict[str, Any], dict[str, Any]]:
    """(meta, this rank's state) of the checkpoint in ``directory`` (collective).

    Reads ``checkpoint.old`` when a run was killed while swapping checkpoints.

    Raises:
        CaseError: not written by as many ranks as ``comm`` has.
        OSError: a file is missing or unreadable.
    """
    directory = Path(directory)

    def find() -> dict[str, Any]:
        for candidate in (directory, directory.with_name(directory.name + ".old")):
            if (candidate / "meta.json").is_file():
                meta = json.loads((candidate / "meta.json").read_text(encoding="utf-8"))
                return meta | {"directory": str(candidate)}
        raise FileNotFoundError(2, "no checkpoint (meta.json)", str(directory))

    meta = comm.bcast(root_call(comm, find), root=0)
    if meta.get("format") != FORMAT or meta.get("ranks") != comm.size:
        raise CaseError(
            "--resume",
            str(directory.parent),
            f"the checkpoint was written by {meta.get('ranks')} rank(s) "
            f"(format {meta.get('format')}): resume on as many ranks "
            f"(mpirun -n {meta.get('ranks')})",
        )
    path = Path(meta["directory"]) / f"rank_{comm.rank:05d}.npz"
    state = _all_ranks(comm, lambda: _read_rank(path))
    return meta, state


def _read_rank(path: Path) -> dict[str, Any]:
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files if k != "__tree__"}
        tree = json.loads(str(data["__tree__"]))
    joined: dict[str, Any] = _join(tree, arrays)
    return joined


def check_resumable(meta: Mapping[str, Any], case: Mapping[str, Any], t: float) -> None:
    """Raise CaseError when ``case`` (resolved table) may not continue the checkpoint ``meta``.

    Only the keys of :data:`RESUMABLE_CHANGES` may differ, and ``time.end``
    must lie after the checkpoint's time ``t``.
    """
    old = _flatten(meta.get("case", {}))
    new = _flatten(case)
    for key in sorted(set(old) | set(new)):
        if key in RESUMABLE_CHANGES or key.startswith("provenance."):
            continue
        if old.get(key) != new.get(key):
            raise CaseError(
                "--resume",
                str(Path(meta.get("directory", "checkpoint")).parent),
                f"the case differs from the checkpointed run's at {key} "
                f"({old.get(key)!r} -> {new.get(key)!r}); only "
                + ", ".join(RESUMABLE_CHANGES)
                + " may change",
            )
    end = new.get("time.end")
    if isinstance(end, float) and end <= t:
        raise CaseError("time.end", end, f"must be after the checkpoint's time {t:.6g} s")


def _flatten(table: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(table, Mapping):
        out: dict[str, Any] = {}
        for k, v in table.items():
            out |= _flatten(v, f"{prefix}{k}.")
        return out
    if isinstance(table, list | tuple):
        out = {}
        for i, v in enumerate(table):
            out |= _flatten(v, f"{prefix}{i}.")
        return out or {prefix.rstrip("."): []}
    return {prefix.rstrip("."): table}


@dataclass
class RunControl:
    """What the time loop does after every accepted step: stop on a signal, save when due.

    Args:
        stop: ``comm -> signal`` agreed by every rank (0: go on), e.g.
            :meth:`magfem.signals.StopSignals.agreed`; None: never stop.
        checkpoints: where checkpoints go; None: none are written.
        resume: the state read from a checkpoint (:func:`read_checkpoint`) to
            continue from, or None for a fresh run.
    """

    stop: Callable[[MPI.Comm], int] | None = None
    checkpoints: Checkpointer | None = None
    resume: dict[str, Any] | None = None
    written: list[Path] = field(default_factory=list)

    def end_of_step(
        self, comm: MPI.Comm, step: int, t: float, state: Callable[[], dict[str, Any]]
    ) -> int:
        """After accepted step ``step`` at ``t``: the agreed stop signal (0: go on), collective.

        Writes a checkpoint (``state()``) when one is due or a signal stops the run.
        """
        due = self.checkpoints is not None and self.checkpoints.due(step)
        signal = self.stop(comm) if self.stop is not None else 0
        due = bool(comm.bcast(due, root=0))
        if self.checkpoints is not None and (due or signal):
            reason = "signal" if signal else "interval"
            self.written.append(self.checkpoints.write(state(), step=step, t=t, reason=reason))
        return signal

    def save(self, step: int, t: float, state: dict[str, Any], reason: str) -> None:
        """Write a checkpoint now (collective), e.g. at the end of a run."""
        if self.checkpoints is not None:
            self.written.append(self.checkpoints.write(state, step=step, t=t, reason=reason))
