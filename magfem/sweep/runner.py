"""The sweep driver: runs the points missing from a sweep directory as ``magfem run`` processes."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from magfem.case import load_case
from magfem.config import CaseError
from magfem.sweep.points import SYNTAX, Point, build_points, fingerprint, parse_param
from magfem.sweep.summary import plot_sweep, summarize_history, write_summary

__all__ = ["SweepResult", "run_sweep"]


@dataclass
class SweepResult:
    """What a sweep did: every point's record, and which ran in this invocation."""

    records: list[dict[str, Any]]
    ran: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    paths: dict[str, Path] = field(default_factory=dict)


def _read_record(point_dir: Path) -> dict[str, Any] | None:
    path = point_dir / "point.json"
    if not path.is_file():
        return None
    try:
        record: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None
    return record


def _write_json(path: Path, data: dict[str, Any]) -> None:
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True), encoding="utf-8")
    os.replace(tmp, path)


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


class _PointRunner:
    """Runs sweep points as ``magfem run`` processes and records each in its ``point.json``."""

    def __init__(
        self,
        case_path: Path,
        out: Path,
        base_overrides: Sequence[str],
        fprint: str,
        ranks: int,
        log: _Log,
    ) -> None:
        self.case_path, self.out, self.base_overrides = case_path, out, base_overrides
        self.fprint, self.ranks, self.log = fprint, ranks, log
        self.prefix = [_mpirun(), "-n", str(ranks)] if ranks > 1 else []
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self.lock = threading.Lock()
        self.ran: list[str] = []

    def run_all(self, todo: Sequence[Point], jobs: int) -> list[str]:
        """Run ``todo``, ``jobs`` at a time; the ids of the points recorded. Ctrl-C stops
        the points running (our own child processes, by handle) and re-raises."""
        pool = ThreadPoolExecutor(max_workers=jobs)
        try:
            for fut in [pool.submit(self.run, pt) for pt in todo]:
                fut.result()
        except KeyboardInterrupt:
            pool.shutdown(wait=False, cancel_futures=True)
            with self.lock:
                for proc in self.procs.values():
                    proc.terminate()
            pool.shutdown(wait=True)
            raise
        pool.shutdown(wait=True)
        return self.ran

    def run(self, pt: Point) -> None:
        """One point; a point killed by a signal is left unfinished (no ``point.json``)."""
        pdir = self.out / "points" / pt.ident
        pdir.mkdir(parents=True, exist_ok=True)
        cmd = [*self.prefix, sys.executable, "-m", "magfem", "run", str(self.case_path)]
        cmd += ["--out", str(pdir), "-q"]
        for item in [*self.base_overrides, *pt.overrides()]:
            cmd += ["--set", item]
        self.log(f"start {pt.ident} {json.dumps(pt.params)}")
        t0 = time.perf_counter()
        with (pdir / "run.log").open("wb") as fh:
            proc = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT)
            with self.lock:
                self.procs[pt.ident] = proc
            rc = proc.wait()
            with self.lock:
                self.procs.pop(pt.ident, None)
        wall = time.perf_counter() - t0
        if rc < 0:
            self.log(f"killed {pt.ident} (signal {-rc})")
            return
        record = {
            "params": pt.params,
            "fingerprint": self.fprint,
            "status": "done" if rc == 0 else "failed",
            "returncode": rc,
            "wall_s": wall,
            "ranks": self.ranks,
            "summary": summarize_history(pdir),
        }
        _write_json(pdir / "point.json", record)
        self.log(f"{record['status']} {pt.ident} rc={rc} wall={wall:.1f}s")
        with self.lock:
            self.ran.append(pt.ident)


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
        echo: progress printer (None: silent).

    Raises:
        CaseError: bad ``--param`` syntax, or a point whose case does not validate
            (checked for every point before anything runs).
    """
    case_path = Path(case_path)
    if jobs < 1:
        raise CaseError("--jobs", jobs, "must be >= 1")
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
    out = Path(outdir)
    (out / "points").mkdir(parents=True, exist_ok=True)
    log = _Log(out / "sweep.log", echo)
    runner = _PointRunner(case_path, out, base_overrides, fprint, ranks, log)
    result = SweepResult(records=[])
    todo: list[Point] = []
    for pt in points:
        rec = _read_record(out / "points" / pt.ident)
        done = (
            rec is not None
            and rec.get("params") == pt.params
            and rec.get("fingerprint") == fprint
            and (rec.get("status") == "done" or not retry_failed)
        )
        if done:
            result.skipped.append(pt.ident)
        else:
            todo.append(pt)
    log(
        f"sweep {case_path}: {len(points)} point(s), {len(result.skipped)} finished, "
        f"{len(todo)} to run, jobs={jobs}, ranks={ranks}"
    )
    result.ran = runner.run_all(todo, jobs)
    for pt in points:
        rec = _read_record(out / "points" / pt.ident)
        result.records.append(
            {"point": pt.ident, "index": pt.index, "params": pt.params}
            | ({"status": "missing"} if rec is None else rec)
        )
    result.paths["csv"] = write_summary(result.records, [n for n, _ in parsed], out)
    png = plot_sweep(result.records, [n for n, _ in parsed], out / "sweep.png", paired=paired)
    if png is not None:
        result.paths["png"] = png
    log(f"wrote {result.paths['csv']}" + (f" and {png}" if png else ""))
    return result
