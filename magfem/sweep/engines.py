"""Where sweep points run: local processes (the default) or jobs of a cluster through submitit.

Every point is one ``magfem run`` process (``mpirun -n K`` in front for
``--np K``). :func:`run_point` runs it and records it in the point's
``point.json``; the local engine calls it from threads, ``--jobs`` at a time,
and keeps the processes' handles to stop them on Ctrl-C. The cluster engines
submit the same function as one job per point through submitit
(https://github.com/facebookincubator/submitit), chosen over Dask because a
sweep point is an MPI job that wants its own allocation, which a SLURM job
array gives directly (Dask workers would hold cores between points):

* ``slurm``: a SLURM job array, one task per point with ``cpus_per_task = K``
  (the point's ``mpirun -n K`` runs inside that allocation; ``use_srun`` is
  off so that mpirun, not srun, starts the ranks), at most ``--jobs`` running
  at once (``array_parallelism``). ``--engine-option KEY=VALUE`` sets any
  other SLURM parameter of submitit's ``SlurmExecutor`` (``partition``,
  ``time`` in minutes, ``mem``, ``account``, ...). The cluster's nodes must see
  the sweep directory, the case file and this Python environment at the same
  paths (a shared file system).
* ``submitit-local``: the same jobs as local processes (submitit's
  ``LocalExecutor``): what the tests use, and a dry run of a cluster sweep.

The job itself writes ``point.json``, so a point that a cluster finished is
kept even if the driver was stopped meanwhile; resuming works as for local
sweeps. A point whose run was stopped or killed continues from the
checkpoint it left (:func:`attempts`), on either engine. submitit's own files
(job scripts, logs) go to ``DIR/submitit/``.
"""

from __future__ import annotations

import json
import os
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from magfem.config import CaseError
from magfem.errors import EXIT_INPUT
from magfem.rundir import CHECKPOINT
from magfem.sweep.summary import summarize_history

__all__ = [
    "CLUSTER_ENGINES",
    "ENGINES",
    "PointJob",
    "attempts",
    "parse_engine_options",
    "run_attempts",
    "run_point",
]

ENGINES = ("local", "slurm", "submitit-local")
CLUSTER_ENGINES = ("slurm", "submitit-local")
LOCAL_OPTIONS = ("timeout_min", "tasks_per_node", "signal_delay_s")
"""The options of submitit's local executor (it ignores any other silently)."""


@dataclass(frozen=True)
class PointJob:
    """One point's run, picklable (a cluster job receives it).

    Attributes:
        ident: the point's id (its directory name).
        params: its parameters, name -> value as given.
        command: the ``magfem run`` command line.
        point_dir: the point's directory.
        fingerprint: the base case's fingerprint, recorded with the result.
        ranks: MPI ranks of the run.
    """

    ident: str
    params: dict[str, str]
    command: list[str]
    point_dir: str
    fingerprint: str
    ranks: int


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write ``data`` to ``path`` atomically (a temporary file, then ``os.replace``)."""
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True), encoding="utf-8")
    os.replace(tmp, path)


def read_json(path: Path) -> dict[str, Any] | None:
    """The JSON object in ``path``, or None when it is missing or unreadable."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


STOPPED_WALL = "stopped_wall.json"
"""In a point's folder: the wall time (s) its stopped runs spent, until it is recorded."""


def record_point(job: PointJob, returncode: int, wall: float) -> str | None:
    """Write the point's ``point.json`` after its process ended; its status, or None.

    A process ended by a signal (negative status, or 130/143 from magfem's own
    SIGINT/SIGTERM handling) leaves the point unfinished: no record, None; its
    ``wall`` is kept in :data:`STOPPED_WALL`, and the record's ``wall_s`` is
    the wall time of every run of the point, the stopped ones included.
    """
    pdir = Path(job.point_dir)
    earlier = float((read_json(pdir / STOPPED_WALL) or {}).get("wall_s", 0.0))
    if returncode < 0 or returncode in (130, 143):
        write_json(pdir / STOPPED_WALL, {"wall_s": earlier + wall})
        return None
    status = "done" if returncode == 0 else "failed"
    record = {
        "params": job.params,
        "fingerprint": job.fingerprint,
        "status": status,
        "returncode": returncode,
        "wall_s": earlier + wall,
        "ranks": job.ranks,
        "summary": summarize_history(pdir),
    }
    write_json(pdir / "point.json", record)
    (pdir / STOPPED_WALL).unlink(missing_ok=True)
    return status


def _failed(pdir: Path) -> bool:
    """The point's ``point.json`` records a failed run (rerun by ``--retry-failed``)."""
    return (read_json(pdir / "point.json") or {}).get("status") == "failed"


def attempts(job: PointJob) -> list[list[str]]:
    """The commands that run a point, in order: the point continues from its checkpoint
    when a stopped, killed or failed run left one (``magfem run --resume``: a point's folder
    is named by its parameters and base case, so the checkpoint is of the same run), then
    the fresh run, tried only when the resume is refused (exit status ``EXIT_INPUT``, e.g.
    the checkpoint was written by another number of ranks). A failed point (rerun by
    ``--retry-failed``) thus keeps the steps it had computed; to rerun it from the start,
    remove its folder."""
    pdir = Path(job.point_dir)
    left = (not (pdir / "point.json").exists() or _failed(pdir)) and any(
        (pdir / name / "meta.json").is_file() for name in (CHECKPOINT, f"{CHECKPOINT}.old")
    )
    if not left:
        return [job.command]
    i = job.command.index("--out")
    resume = [*job.command[:i], "--resume", job.point_dir]
    resume += [a for a in job.command[i + 2 :] if a != "--overwrite"]
    return [resume, job.command]


def run_attempts(
    job: PointJob,
    start: Callable[[list[str], BinaryIO], int],
    log: Callable[[str], None] | None = None,
) -> int:
    """Run the point's :func:`attempts` with ``start(command, log file) -> exit status`` until
    one is not a refused resume; its exit status. ``run.log`` keeps the stopped run's lines
    when the point continues."""
    commands = attempts(job)
    returncode = EXIT_INPUT
    for k, command in enumerate(commands):
        resuming = k < len(commands) - 1
        if resuming and log:
            log(f"resume {job.ident} from its checkpoint")
        with (Path(job.point_dir) / "run.log").open("ab" if resuming else "wb") as fh:
            returncode = start(command, fh)
        if not (resuming and returncode == EXIT_INPUT):
            break
        if log:
            log(f"refused {job.ident}: its checkpoint does not continue (run.log); fresh run")
    return returncode


def run_point(job: PointJob) -> str | None:
    """Run one point's process (its output in ``run.log``) and record it (:func:`record_point`)."""
    pdir = Path(job.point_dir)
    pdir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()

    def start(command: list[str], fh: BinaryIO) -> int:
        return subprocess.run(command, stdout=fh, stderr=subprocess.STDOUT).returncode

    returncode = run_attempts(job, start)
    return record_point(job, returncode, time.perf_counter() - t0)


def parse_engine_options(items: Sequence[str]) -> dict[str, Any]:
    """``KEY=VALUE`` texts to a dict; integer and decimal values become numbers.

    Raises:
        CaseError: key ``--engine-option``, an item without ``=`` or with an empty key.
    """
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = (s.strip() for s in item.partition("="))
        if not sep or not key:
            raise CaseError("--engine-option", item, "expected KEY=VALUE, e.g. partition=short")
        out[key] = _number_or_text(value)
    return out


def _number_or_text(value: str) -> Any:
    for convert in (int, float):
        try:
            return convert(value)
        except ValueError:
            continue
    return value


def _submitit(engine: str) -> Any:
    """The submitit module, or a CaseError naming the engine that needs it."""
    try:
        import submitit  # optional dependency: pip install "magfem[cluster]"
    except ImportError:
        raise CaseError(
            "--engine", engine, 'needs submitit: pip install "magfem[cluster]"'
        ) from None
    return submitit


def _executor(
    submitit: Any, engine: str, folder: Path, jobs: int, ranks: int, options: Mapping[str, Any]
) -> Any:
    """A submitit executor for ``engine`` with the sweep's defaults and the user's options."""
    if engine == "slurm":
        try:
            executor: Any = submitit.SlurmExecutor(folder=folder)
        except RuntimeError:  # submitit looks for srun
            raise CaseError(
                "--engine", engine, "no SLURM here (srun not found); submitit-local runs the jobs"
            ) from None
        defaults = {"ntasks_per_node": 1, "cpus_per_task": ranks, "use_srun": False}
        params = {**defaults, "array_parallelism": jobs, **options}
    else:
        unknown = sorted(set(options) - set(LOCAL_OPTIONS))
        if unknown:
            allowed = ", ".join(LOCAL_OPTIONS)
            raise CaseError("--engine-option", ", ".join(unknown), f"{engine} takes {allowed}")
        executor = submitit.LocalExecutor(folder=folder)
        params = dict(options)
    try:
        executor.update_parameters(**params)
    except (TypeError, ValueError) as err:
        raise CaseError("--engine-option", ", ".join(options) or engine, str(err)) from None
    return executor


def run_on_cluster(
    engine: str,
    todo: Sequence[PointJob],
    folder: Path,
    *,
    jobs: int,
    ranks: int,
    options: Mapping[str, Any],
    log: Callable[[str], None],
) -> list[str]:
    """Submit ``todo`` as one job each (a job array where the engine has them); wait for all.

    Returns the ids of the points recorded. Ctrl-C cancels the jobs not yet
    finished and re-raises.
    """
    if not todo:
        return []
    submitit = _submitit(engine)
    executor = _executor(submitit, engine, folder, jobs, ranks, options)
    with executor.batch():
        futures = [executor.submit(run_point, job) for job in todo]
    for job, future in zip(todo, futures, strict=True):
        log(f"submitted {job.ident} as {engine} job {future.job_id} {json.dumps(job.params)}")
    job_errors = (submitit.core.utils.FailedJobError, submitit.core.utils.UncompletedJobError)
    ran = []
    try:
        for job, future in zip(todo, futures, strict=True):
            try:
                status = future.result()
            except job_errors as err:  # the job itself failed (time limit, node lost)
                log(f"lost {job.ident} ({engine} job {future.job_id}): {str(err).splitlines()[0]}")
                continue
            log(f"{status or 'killed'} {job.ident} ({engine} job {future.job_id})")
            if status is not None:
                ran.append(job.ident)
    except KeyboardInterrupt:
        for future in futures:
            future.cancel(check=False)
        raise
    return ran
