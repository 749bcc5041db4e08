"""Parameter sweeps: many independent ``magfem run`` processes, resumable, one summary table.

    magfem sweep CASE --param NAME=VALUES [--param NAME=VALUES ...]
                      [--set KEY=VALUE ...] [--jobs N] [--np K] [--out DIR] [--retry-failed]

``NAME`` is a case key as for ``--set`` (``robot.thickness``,
``field.sources.0.waveform.frequency``). ``VALUES`` is either

* a list ``V1,V2,...``: each item is a value exactly as ``--set`` takes it
  (``10Hz,20Hz,50Hz``; ``"80 um",1mm``; ``I,II,III``), or
* a range ``START:STOP:STEP[UNIT]`` of numbers, STOP included when it is hit
  to within 10⁻⁹ STEP, the optional unit appended to every value:
  ``10:200:20Hz`` is 10, 30, ..., 190 Hz; ``100:1000:300um`` is 100, 400,
  700, 1000 µm.

The points are the Cartesian product of all ``--param`` lists, in the order
given (the last parameter varies fastest); ``run_sweep(..., paired=True)``
pairs the lists element-wise instead (a frequency with its two-period end
time; drive amplitudes with their frequencies). Each point runs as its own
process ``python -m magfem run CASE --out DIR/points/<id> --set ...`` (``mpirun
-n K`` in front with ``--np K``), at most ``--jobs`` at a time.

Resuming. A point is *finished* when ``DIR/points/<id>/point.json`` exists
and records the same parameters and the same base-case fingerprint (SHA-256
of the case file text and the ``--set`` overrides); ``<id>`` is itself a hash
of those, so a changed case gives new points rather than stale ones.
``point.json`` is written atomically (``os.replace``) only after the run
process has exited, so a sweep killed at any moment leaves every point
either finished or not started/partial, and running the same command again
computes only what is missing. A point whose run failed (exit status ≠ 0,
e.g. Newton failure) is also recorded and not redone, unless
``--retry-failed``. Every start and end is appended to ``DIR/sweep.log``.

Outputs: ``DIR/summary.csv`` (one row per point: parameters as given and in
SI, status, wall time, and the point's summary scalars) and
``DIR/sweep.png`` (max angle over the first one and two periods against the
first parameter, one line per combination of the others).

Summary scalars (:func:`summarize_history`) are computed from each run's
``history.csv`` (:func:`magfem.mechanics.columns.read_history`) by
:func:`magfem.mechanics.observers.history_summary`: per arm
the largest angle over the first half period, one and two periods of the
first periodic source and over the run, the final angle, the midline
observables; the largest strain, energy and power density, self-contact
times and forces, the end time. Names and definitions: docs/physics.md,
"Observables".
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import os
import re
import shutil
import subprocess
import sys
import threading
import time
import tomllib
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from magfem.case import load_case
from magfem.config import CaseError
from magfem.mechanics.columns import read_history
from magfem.mechanics.observers import history_summary

__all__ = [
    "Point",
    "SweepResult",
    "build_points",
    "fingerprint",
    "parse_param",
    "plot_sweep",
    "run_sweep",
    "summarize_history",
    "write_summary",
]

_RANGE = re.compile(
    r"^\s*([+-]?[\d.]+(?:[eE][+-]?\d+)?)\s*:\s*([+-]?[\d.]+(?:[eE][+-]?\d+)?)\s*:"
    r"\s*([+-]?[\d.]+(?:[eE][+-]?\d+)?)\s*([A-Za-zµμ%][\w/^*µμ]*)?\s*$"
)
_NAME = re.compile(r"^[A-Za-z_]\w*(\.\w+)*$")
_SYNTAX = (
    "expected NAME=V1,V2,... or NAME=START:STOP:STEP[unit], e.g. robot.thickness=100:400:100um"
)
MAX_POINTS = 10_000


def _fmt_number(x: float) -> str:
    return f"{x:.12g}"


def parse_param(text: str) -> tuple[str, list[str]]:
    """Parse one ``--param NAME=VALUES`` argument into (NAME, [value strings]).

    Raises:
        CaseError: key ``--param``, naming the text and the accepted syntax.
    """
    if "=" not in text:
        raise CaseError("--param", text, _SYNTAX)
    name, values = (s.strip() for s in text.split("=", 1))
    if not _NAME.match(name):
        raise CaseError("--param", text, "NAME must be a dotted case key; " + _SYNTAX)
    if not values:
        raise CaseError("--param", text, "no values; " + _SYNTAX)
    if ":" in values and not values.startswith(("[", '"')):
        m = _RANGE.match(values)
        if m is None:
            raise CaseError("--param", text, "bad range; " + _SYNTAX)
        start, stop, step = (float(m.group(i)) for i in (1, 2, 3))
        unit = m.group(4) or ""
        if step <= 0 or stop < start:
            raise CaseError("--param", text, "a range needs STEP > 0 and STOP >= START")
        n = math.floor((stop - start) / step + 1e-9) + 1
        if n > MAX_POINTS:
            raise CaseError("--param", text, f"more than {MAX_POINTS} values")
        return name, [_fmt_number(start + i * step) + unit for i in range(n)]
    items = [v.strip() for v in values.split(",")]
    if any(not v for v in items):
        raise CaseError("--param", text, "empty list item; " + _SYNTAX)
    return name, items


@dataclass(frozen=True)
class Point:
    """One sweep point: its parameters (name -> value as given) and its directory id."""

    index: int
    params: dict[str, str]
    ident: str

    def overrides(self) -> list[str]:
        """``--set`` arguments of this point."""
        return [f"{k}={v}" for k, v in self.params.items()]


def fingerprint(case_path: Path, base_overrides: Sequence[str]) -> str:
    """SHA-256 (hex) of the case file text and the ``--set`` overrides: a point's base case."""
    h = hashlib.sha256(case_path.read_bytes())
    for item in base_overrides:
        h.update(b"\0" + item.encode())
    return h.hexdigest()


def build_points(
    params: Sequence[tuple[str, list[str]]], fingerprint: str, *, paired: bool = False
) -> list[Point]:
    """Points with stable ids: the Cartesian product of the parameter lists (last varies
    fastest), or with ``paired=True`` their element-wise pairing (lists of equal length).

    Raises:
        CaseError: a NAME given twice, or paired lists of different lengths.
    """
    names = [n for n, _ in params]
    if len(set(names)) != len(names):
        raise CaseError("--param", ", ".join(names), "each NAME may be given once")
    lengths = {len(v) for _, v in params}
    if paired and len(lengths) > 1:
        raise CaseError(
            "--param",
            ", ".join(f"{n}: {len(v)} values" for n, v in params),
            "paired parameters need lists of the same length",
        )
    combos: Iterable[tuple[str, ...]] = (
        zip(*(v for _, v in params), strict=True)
        if paired
        else itertools.product(*(v for _, v in params))
    )
    points = []
    for i, combo in enumerate(combos):
        p = dict(zip(names, combo, strict=True))
        digest = hashlib.sha256((fingerprint + json.dumps(p, sort_keys=True)).encode())
        points.append(Point(i, p, f"p{i:04d}_{digest.hexdigest()[:10]}"))
    if len(points) > MAX_POINTS:
        raise CaseError("--param", len(points), f"at most {MAX_POINTS} points")
    return points


def _frequency(resolved: dict[str, Any]) -> float | None:
    for src in resolved.get("field", {}).get("sources", []):
        f = src.get("waveform", {}).get("frequency")
        if f:
            return float(f)
    return None


def _lookup(table: Any, name: str) -> Any:
    node = table
    for part in name.split("."):
        if isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            return None
    return node


def summarize_history(run_dir: Path) -> dict[str, float]:
    """Summary scalars (module docstring) of a run directory's ``history.csv``.

    Needs ``history.csv`` and ``case.resolved.toml`` (for t₀, f, μ); returns {}
    when the history is missing or empty.
    """
    hist = run_dir / "history.csv"
    if not hist.is_file():
        return {}
    cols, _ = read_history(hist)
    if not cols or len(cols.get("time", ())) == 0:
        return {}
    resolved: dict[str, Any] = {}
    if (run_dir / "case.resolved.toml").is_file():
        resolved = tomllib.loads((run_dir / "case.resolved.toml").read_text(encoding="utf-8"))
    t = cols["time"]
    t0 = float(resolved.get("time", {}).get("start", t[0]))
    freq = _frequency(resolved)
    out: dict[str, float] = {"end_time": float(t[-1]), "steps": float(len(t) - 1)}
    out |= history_summary(cols, start=t0, frequency=freq)
    return out


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
        cmd += ["--out", str(pdir), "--overwrite", "-q"]  # a rerun replaces the point's run
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
        if rc < 0 or rc in (130, 143):  # killed, or stopped by SIGINT/SIGTERM (128 + signal)
            self.log(f"killed {pt.ident} (signal {-rc if rc < 0 else rc - 128})")
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
        raise CaseError("--param", "(none)", "give at least one --param " + _SYNTAX)
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


def _si_value(record: dict[str, Any], name: str, out: Path) -> float:
    """The parameter's SI value from the point's resolved case (nan if not a number)."""
    resolved = out / "points" / record["point"] / "case.resolved.toml"
    if resolved.is_file():
        value = _lookup(tomllib.loads(resolved.read_text(encoding="utf-8")), name)
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
    return math.nan


def write_summary(records: list[dict[str, Any]], names: list[str], out: Path) -> Path:
    """``out/summary.csv``: one row per point (parameters, SI values, status, scalars)."""
    keys: list[str] = []
    for rec in records:
        for k in rec.get("summary", {}):
            if k not in keys:
                keys.append(k)
    path = out / "summary.csv"
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["point", *names, *(f"{n} (SI)" for n in names), "status", "wall_s", *keys])
        for rec in records:
            summ = rec.get("summary", {})
            w.writerow(
                [
                    rec["point"],
                    *(rec["params"][n] for n in names),
                    *(_fmt_number(_si_value(rec, n, out)) for n in names),
                    rec.get("status", "missing"),
                    _fmt_number(rec["wall_s"]) if "wall_s" in rec else "",
                    *(_fmt_number(summ[k]) if k in summ else "" for k in keys),
                ]
            )
    for rec in records:
        rec["si"] = {n: _si_value(rec, n, out) for n in names}
    return path


def plot_sweep(
    records: list[dict[str, Any]], names: list[str], path: Path, *, paired: bool = False
) -> Path | None:
    """Max angle over one and two periods (deg) against the first parameter (PNG): one
    line per combination of the other parameters, or a single line when ``paired``."""
    done = [r for r in records if r.get("summary")]
    keys = sorted(
        {k for r in done for k in r["summary"] if k.startswith("max_angle_")},
        key=lambda k: (not k.startswith("max_angle_1period"), k),
    )
    keys = [k for k in keys if "period" in k] or keys
    if not done or not keys:
        return None
    x_name, others = names[0], ([] if paired else names[1:])
    groups: dict[tuple[str, ...], list[dict[str, Any]]] = {}
    for r in done:
        groups.setdefault(tuple(r["params"][n] for n in others), []).append(r)
    fig = Figure(figsize=(7, 4), dpi=110)
    ax = fig.subplots()
    # a non-numeric first parameter (robot.type, mesh.model) is plotted as categories
    categories = list(dict.fromkeys(r["params"][x_name] for r in done))
    numeric = not all(math.isnan(r["si"][x_name]) for r in done)
    for gi, (label, recs) in enumerate(groups.items()):
        if numeric:
            recs = sorted(recs, key=lambda r: r["si"][x_name])
            x = np.array([r["si"][x_name] for r in recs])
        else:
            x = np.array([categories.index(r["params"][x_name]) for r in recs], dtype=float)
        for ki, k in enumerate(keys):
            y = np.degrees([r["summary"].get(k, np.nan) for r in recs])
            tag = ", ".join(f"{n}={v}" for n, v in zip(others, label, strict=True))
            ax.plot(
                x,
                y,
                marker="o",
                ls=("-", "--", ":", "-.")[ki % 4],
                color=f"C{gi % 10}",
                label=f"{k.removeprefix('max_angle_')}" + (f" ({tag})" if tag else ""),
            )
    if not numeric:
        ax.set_xticks(range(len(categories)), categories)
    ax.set_xlabel(f"{x_name}" + (" (SI)" if numeric else ""))
    ax.set_ylabel("max bending angle (deg)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    return path
