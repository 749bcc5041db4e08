"""The sweep driver: runs the points missing from a sweep directory as ``magfem run`` processes."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

from magfem.case import load_case
from magfem.config import CaseError
from magfem.sweep.engines import (
    CLUSTER_ENGINES,
    ENGINES,
    PointJob,
    read_json,
    record_point,
    run_attempts,
    run_on_cluster,
)
from magfem.sweep.points import SYNTAX, Point, build_points, fingerprint, parse_param
from magfem.sweep.summary import plot_sweep, write_summary

__all__ = ["SweepPlan", "SweepResult", "finish_sweep", "plan_sweep", "run_plans", "run_sweep"]


@dataclass
class SweepResult:
    """What a sweep did: every point's record, and which ran in this invocation."""

    records: list[dict[str, Any]]
    ran: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    paths: dict[str, Path] = field(default_factory=dict)


def _read_record(point_dir: Path) -> dict[str, Any] | None:
    return read_json(point_dir / "point.json")


def _mpirun() -> str:
    here = Path(sys.executable).parent / "mpirun"
    found = str(here) if here.is_file() else shutil.which("mpirun")
    if found is None:
        raise CaseError("--np", "mpirun", "no mpirun next to python or on PATH")
    return found


class _Log:
    def __init__(self, path: Path, echo: Callable[[str], None] | None):
        self.path = path
        self.echo = echo
        self.lock = threading.Lock()

    def __call__(self, msg: str) -> None:
        line = f"{time.strftime('%Y-%m-%dT%H:%M:%S')} {msg}"
        with self.lock:
            with self.path.open("a", encoding="utf-8") as fh:
                fh.write(line + "\n")
            if self.echo is not None:
                self.echo(msg)


def _point_job(
    case_path: Path, out: Path, base_overrides: Sequence[str], fprint: str, ranks: int, pt: Point
) -> PointJob:
    """The ``magfem run`` of one point (``mpirun -n ranks`` in front when ranks > 1)."""
    pdir = out / "points" / pt.ident
    prefix = [_mpirun(), "-n", str(ranks)] if ranks > 1 else []
    cmd = [*prefix, sys.executable, "-m", "magfem", "run", str(case_path), "--out", str(pdir)]
    cmd += ["--overwrite", "-q"]  # a rerun (retry, or after a kill) replaces the point's run
    for item in [*base_overrides, *pt.overrides()]:
        cmd += ["--set", item]
    return PointJob(pt.ident, pt.params, cmd, str(pdir), fprint, ranks)


class _LocalRunner:
    """Runs the point jobs of one or more sweeps as local processes, ``jobs`` at a time, in
    the order given, keeping their handles."""

    def __init__(self) -> None:
        self.procs: dict[int, subprocess.Popen[bytes]] = {}
        self.lock = threading.Lock()
        self.ended = 0  # runs of the queue that ended (recorded or stopped)
        self.total = 0

    def run_all(self, todo: Sequence[tuple[PointJob, SweepPlan]], jobs: int) -> None:
        """Run each job of ``todo`` (with the sweep it belongs to, whose log and ``ran`` list
        it updates). Ctrl-C stops the points running (our own child processes, by handle)
        and re-raises."""
        self.total = len(todo)
        pool = ThreadPoolExecutor(max_workers=jobs)
        try:
            for fut in [pool.submit(self.run, job, plan) for job, plan in todo]:
                fut.result()
        except KeyboardInterrupt:
            pool.shutdown(wait=False, cancel_futures=True)
            with self.lock:
                for proc in self.procs.values():
                    proc.terminate()
            pool.shutdown(wait=True)
            raise
        pool.shutdown(wait=True)

    def run(self, job: PointJob, plan: SweepPlan) -> None:
        """One point; a point killed by a signal is left unfinished (no ``point.json``)."""
        pdir = Path(job.point_dir)
        pdir.mkdir(parents=True, exist_ok=True)
        plan.log(f"start {job.ident} {json.dumps(job.params)}")
        t0 = time.perf_counter()
        key = threading.get_ident()

        def start(command: list[str], fh: BinaryIO) -> int:
            proc = subprocess.Popen(command, stdout=fh, stderr=subprocess.STDOUT)
            with self.lock:
                self.procs[key] = proc
            rc = proc.wait()
            with self.lock:
                self.procs.pop(key, None)
            return rc

        rc = run_attempts(job, start, plan.log)
        wall = time.perf_counter() - t0
        status = record_point(job, rc, wall)
        with self.lock:
            self.ended += 1
            count = f"({self.ended} of {self.total} runs ended)"
            if status is not None:
                plan.result.ran.append(job.ident)
        if status is None:  # killed, or stopped by SIGINT/SIGTERM (128 + signal)
            plan.log(f"killed {job.ident} (signal {-rc if rc < 0 else rc - 128}) {count}")
            return
        plan.log(f"{status} {job.ident} rc={rc} wall={wall:.1f}s {count}")


@dataclass
class SweepPlan:
    """A sweep ready to run (:func:`plan_sweep`): its points, the jobs of those not finished,
    its log, and the result that :func:`run_plans` and :func:`finish_sweep` fill in."""

    out: Path
    points: list[Point]
    names: list[str]
    paired: bool
    todo: list[PointJob]
    log: _Log
    result: SweepResult


def plan_sweep(
    case_path: str | Path,
    params: Sequence[str],
    outdir: str | Path,
    *,
    base_overrides: Sequence[str] = (),
    ranks: int = 1,
    retry_failed: bool = False,
    paired: bool = False,
    echo: Callable[[str], None] | None = print,
) -> SweepPlan:
    """Check a sweep and find its points not yet finished, without running any
    (arguments as for :func:`run_sweep`).

    Raises:
        CaseError: bad ``--param`` syntax or ranks, or a point whose case does not validate
            (checked for every point).
    """
    case_path, out = Path(case_path), Path(outdir)
    if ranks < 1:
        raise CaseError("--np", ranks, "must be >= 1")
    if not params:
        raise CaseError("--param", "(none)", "give at least one --param " + SYNTAX)
    load_case(case_path, base_overrides)  # file, syntax and base overrides
    parsed = [parse_param(p) for p in params]
    fprint = fingerprint(case_path, base_overrides)
    points = build_points(parsed, fprint, paired=paired)
    for pt in points:
        load_case(case_path, [*base_overrides, *pt.overrides()])
    (out / "points").mkdir(parents=True, exist_ok=True)
    log = _Log(out / "sweep.log", echo)
    _adopt_moved(points, out, log)
    result = SweepResult(records=[])
    todo = [
        _point_job(case_path, out, base_overrides, fprint, ranks, pt)
        for pt in _unfinished(points, out, fprint, retry_failed, result.skipped)
    ]
    log(
        f"sweep {case_path}: {len(points)} point(s), {len(result.skipped)} finished, "
        f"{len(todo)} to run, ranks={ranks}"
    )
    return SweepPlan(out, points, [n for n, _ in parsed], paired, todo, log, result)


def run_plans(plans: Sequence[SweepPlan], jobs: int) -> None:
    """Run the unfinished points of ``plans`` as local processes in one queue, ``jobs`` at a
    time: each sweep's points in order after the previous sweep's, each starting as soon as a
    process ends, so that the last long run of one sweep shares the machine with the next
    sweep's first runs rather than leaving cores idle.

    Raises:
        CaseError: ``jobs`` below 1.
    """
    if jobs < 1:
        raise CaseError("--jobs", jobs, "must be >= 1")
    _LocalRunner().run_all([(job, plan) for plan in plans for job in plan.todo], jobs)


def finish_sweep(plan: SweepPlan) -> SweepResult:
    """Gather every point's record into the plan's result; write summary.csv and sweep.png."""
    _summarise(plan.result, plan.points, plan.names, plan.out, plan.paired, plan.log)
    return plan.result


def run_sweep(
    case_path: str | Path,
    params: Sequence[str],
    outdir: str | Path,
    *,
    base_overrides: Sequence[str] = (),
    jobs: int = 1,
    ranks: int = 1,
    retry_failed: bool = False,
    paired: bool = False,
    engine: str = "local",
    engine_options: Mapping[str, Any] | None = None,
    echo: Callable[[str], None] | None = print,
) -> SweepResult:
    """Run (or resume) a sweep; serial driver, each point a separate process.

    Args:
        case_path: base case file.
        params: ``--param`` texts (``NAME=VALUES``).
        outdir: sweep directory (points/, sweep.log, summary.csv, sweep.png).
        base_overrides: ``--set`` items applied to every point.
        jobs: points run at the same time. ranks: MPI ranks per point (mpirun -n).
        retry_failed: rerun points recorded as failed.
        paired: pair the ``--param`` lists element-wise (equal lengths) instead of
            taking their Cartesian product, e.g. a frequency with its two-period end time.
        engine: where the points run (:data:`magfem.sweep.engines.ENGINES`).
        engine_options: parameters of a cluster engine (e.g. SLURM ``partition``).
        echo: progress printer (None: silent).

    Raises:
        CaseError: bad ``--param`` syntax or engine, or a point whose case does not
            validate (checked for every point before anything runs).
    """
    if jobs < 1:
        raise CaseError("--jobs", jobs, "must be >= 1")
    if engine not in ENGINES:
        raise CaseError("--engine", engine, "must be one of " + ", ".join(ENGINES))
    if engine_options and engine not in CLUSTER_ENGINES:
        raise CaseError("--engine-option", ", ".join(engine_options), "needs a cluster engine")
    plan = plan_sweep(
        case_path,
        params,
        outdir,
        base_overrides=base_overrides,
        ranks=ranks,
        retry_failed=retry_failed,
        paired=paired,
        echo=echo,
    )
    plan.log(f"running on {engine}, jobs={jobs}")
    if engine == "local":
        run_plans([plan], jobs)
    else:
        options = dict(engine_options or {})
        plan.result.ran = run_on_cluster(
            engine,
            plan.todo,
            plan.out / "submitit",
            jobs=jobs,
            ranks=ranks,
            options=options,
            log=plan.log,
        )
    return finish_sweep(plan)


def _adopt_moved(points: Sequence[Point], out: Path, log: Callable[[str], None]) -> None:
    """Rename the folder of a point whose index changed (a value inserted in a list).

    A point's folder is ``p<index>_<hash of its parameters and base case>``: the hash alone
    names the run. A point without a folder takes over the one folder with its hash that no
    current point names, so inserting or reordering values does not rerun finished points.
    """
    current = {pt.ident for pt in points}
    for pt in points:
        if (out / "points" / pt.ident).exists():
            continue
        digest = pt.ident.split("_", 1)[1]
        moved = [
            d for d in (out / "points").glob(f"p*_{digest}") if d.name not in current and d.is_dir()
        ]
        if len(moved) == 1:
            moved[0].rename(out / "points" / pt.ident)
            log(f"moved {moved[0].name} -> {pt.ident} (same parameters, new position)")


def _unfinished(
    points: Sequence[Point], out: Path, fprint: str, retry_failed: bool, skipped: list[str]
) -> list[Point]:
    """The points without a valid record (appending the others' ids to ``skipped``)."""
    todo = []
    for pt in points:
        rec = _read_record(out / "points" / pt.ident)
        done = (
            rec is not None
            and rec.get("params") == pt.params
            and rec.get("fingerprint") == fprint
            and (rec.get("status") == "done" or not retry_failed)
        )
        if done:
            skipped.append(pt.ident)
        else:
            todo.append(pt)
    return todo


def _summarise(
    result: SweepResult,
    points: Sequence[Point],
    names: list[str],
    out: Path,
    paired: bool,
    log: Callable[[str], None],
) -> None:
    """Gather every point's record into ``result``; write summary.csv and sweep.png."""
    for pt in points:
        rec = _read_record(out / "points" / pt.ident)
        result.records.append(
            {"point": pt.ident, "index": pt.index, "params": pt.params}
            | ({"status": "missing"} if rec is None else rec)
        )
    result.paths["csv"] = write_summary(result.records, names, out)
    png = plot_sweep(result.records, names, out / "sweep.png", paired=paired)
    if png is not None:
        result.paths["png"] = png
    log(f"wrote {result.paths['csv']}" + (f" and {png}" if png else ""))
