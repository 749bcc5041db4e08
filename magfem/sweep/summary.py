"""Sweep summaries: each point's scalars from its history, the summary table and the plot."""

from __future__ import annotations

import csv
import math
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from matplotlib.figure import Figure

from magfem.mechanics.columns import read_history
from magfem.mechanics.observers import history_summary
from magfem.sweep.points import format_number

__all__ = [
    "LOG_AXIS_RATIO",
    "WINDOW_END_TOLERANCE",
    "log_axis",
    "plot_sweep",
    "summarize_history",
    "window_summary",
    "write_summary",
]


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


def summarize_history(
    run_dir: Path, windows: Mapping[str, float] | None = None, hold: float = 0.0
) -> dict[str, float]:
    """Summary scalars (module docstring) of a run directory's ``history.csv``.

    Needs ``history.csv`` and ``case.resolved.toml`` (for t₀, f, μ); returns {}
    when the history is missing or empty. ``windows``: label -> end time T (s);
    each adds the summary of the rows up to T as ``<key>@<label>``
    (:func:`window_summary`). ``hold`` > 0 (s) adds the largest angles held that
    long, ``held_angle_*`` (:func:`magfem.mechanics.observers.summary.history_summary`).
    """
    hist = run_dir / "history.csv"
    if not hist.is_file():
        return {}
    cols, _ = read_history(hist)  # headers with units (time [s]) or without
    if not cols or len(cols.get("time", ())) == 0:
        return {}
    resolved: dict[str, Any] = {}
    if (run_dir / "case.resolved.toml").is_file():
        resolved = tomllib.loads((run_dir / "case.resolved.toml").read_text(encoding="utf-8"))
    t = cols["time"]
    t0 = float(resolved.get("time", {}).get("start", t[0]))
    freq = _frequency(resolved)
    out: dict[str, float] = {"end_time": float(t[-1]), "steps": float(len(t) - 1)}
    out |= history_summary(cols, start=t0, frequency=freq, hold=hold)
    for label, end in (windows or {}).items():
        out |= window_summary(cols, label, end, start=t0, frequency=freq, hold=hold)
    return out


WINDOW_END_TOLERANCE = 1e-9
"""Relative tolerance of a window's end time against the history's times (s)."""


def window_summary(
    history: Mapping[str, npt.NDArray[np.float64]],
    label: str,
    end: float,
    *,
    start: float,
    frequency: float | None,
    hold: float = 0.0,
) -> dict[str, float]:
    """The summary of the history's rows up to ``end`` (s), each key as ``<key>@<label>``
    (``hold``: as :func:`summarize_history`).

    What the run would have summarised had it stopped at ``end``: for a square
    wave's held first direction, the first lift of every frequency whose half
    period ends there. Every key is nan when the history ends before ``end``
    (the window is not complete).
    """
    t = np.asarray(history["time"], dtype=float)
    rows = t <= end * (1.0 + WINDOW_END_TOLERANCE)
    rows[0] = True  # the keys, even of a window that ends before the first row
    part = history_summary(
        {k: np.asarray(v)[rows] for k, v in history.items()},
        start=start,
        frequency=frequency,
        hold=hold,
    )
    complete = t[-1] >= end * (1.0 - WINDOW_END_TOLERANCE) and t[0] <= end
    return {f"{key}@{label}": value if complete else math.nan for key, value in part.items()}


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
                    *(format_number(_si_value(rec, n, out)) for n in names),
                    rec.get("status", "missing"),
                    format_number(rec["wall_s"]) if "wall_s" in rec else "",
                    *(format_number(summ[k]) if k in summ else "" for k in keys),
                ]
            )
    for rec in records:
        rec["si"] = {n: _si_value(rec, n, out) for n in names}
    return path


LOG_AXIS_RATIO = 10.0
"""A numeric first parameter spanning this ratio or more is plotted on a log axis."""


def log_axis(values: list[float]) -> bool:
    """Whether values (SI) of a sweep's first parameter go on a log axis: all positive and
    spanning at least :data:`LOG_AXIS_RATIO`."""
    return bool(values) and min(values) > 0 and max(values) >= LOG_AXIS_RATIO * min(values)


def plot_sweep(
    records: list[dict[str, Any]],
    names: list[str],
    path: Path,
    *,
    paired: bool = False,
    by: str = "",
) -> Path | None:
    """Max angle over one and two periods (deg) against the first parameter (PNG): one
    line per combination of the other parameters, or when ``paired`` a single line, or one
    per value of the parameter ``by`` (e.g. two mesh sizes paired with the frequencies)."""
    done = [r for r in records if r.get("summary")]
    keys = sorted(
        {k for r in done for k in r["summary"] if k.startswith("max_angle_")},
        key=lambda k: (not k.startswith("max_angle_1period"), k),
    )
    keys = [k for k in keys if "period" in k] or keys
    if not done or not keys:
        return None
    x_name, others = names[0], ([] if paired else names[1:])
    if by and by != x_name and by not in others:
        others = [*others, by]
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
                color=f"C{(gi if len(groups) > 1 else ki) % 10}",
                label=f"{k.removeprefix('max_angle_')}" + (f" ({tag})" if tag else ""),
            )
    if numeric:  # ticks at the values, labelled as the sweep wrote them ("0.3mm", "20Hz")
        ticks = {r["si"][x_name]: r["params"][x_name] for r in done}
        if log_axis(list(ticks)):
            ax.set_xscale("log")  # e.g. 10-200 Hz: the low values would crowd a linear axis
            ax.minorticks_off()
        ax.set_xticks(list(ticks), list(ticks.values()))
    else:
        ax.set_xticks(range(len(categories)), categories)
    ax.set_xlabel(x_name)
    ax.set_ylabel("max bending angle (deg)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    return path
