"""The runs behind ``magfem report``: the studies' sweeps run in one queue, or read as
they stand on disk, with their summaries refreshed from the runs' histories."""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from magfem.config import CaseError
from magfem.study import Study
from magfem.sweep import (
    SweepPlan,
    SweepResult,
    build_points,
    fingerprint,
    finish_sweep,
    parse_param,
    plan_sweep,
    plot_sweep,
    run_plans,
    summarize_history,
    write_summary,
)
from magfem.sweep.engines import STOPPED_WALL, read_json

__all__ = ["read_records", "run_studies"]


def run_studies(
    studies: Sequence[Study],
    out: Path,
    *,
    jobs: int,
    retry_failed: bool,
    echo: Callable[[str], None] | None,
) -> dict[str, tuple[list[dict[str, Any]], str]]:
    """Run the studies' missing points in one queue, ``jobs`` at a time, scene after scene in
    the page's order (:func:`magfem.sweep.run_plans`: a core that one scene's last long run
    leaves free takes the next scene's first runs); each study's records and why there are
    none (:func:`read_records`). A study whose case does not validate runs nothing and says so."""
    plans: dict[str, SweepPlan] = {}
    errors: dict[str, str] = {}
    for study in studies:
        try:
            plans[study.ident] = plan_sweep(
                study.case,
                list(study.params),
                out / study.ident,
                base_overrides=list(study.sets),
                retry_failed=retry_failed,
                paired=study.paired,
                echo=None if echo is None else functools.partial(_scene_echo, echo, study.ident),
            )
        except CaseError as err:
            errors[study.ident] = f"case error: {err}"
    run_plans(list(plans.values()), jobs)
    return {
        s.ident: ([], errors[s.ident])
        if s.ident in errors
        else read_records(s, out / s.ident, finish_sweep(plans[s.ident]))
        for s in studies
    }


def _scene_echo(echo: Callable[[str], None], ident: str, msg: str) -> None:
    echo(f"{ident}: {msg}")


def read_records(
    study: Study, sweep_dir: Path, ran: SweepResult | None
) -> tuple[list[dict[str, Any]], str]:
    """The study's run records (those of the sweep ``ran``; None: as they stand on disk) with
    their summaries refreshed from the histories, and why there are none, if so."""
    if ran is None and not (sweep_dir / "points").is_dir():
        reason = f"not run yet (`magfem report --run --only {study.ident}`)"
        return [], reason + (f": {study.pending}" if study.pending else "")
    try:
        records = ran.records if ran is not None else _on_disk(study, sweep_dir)
    except CaseError as err:
        return [], f"case error: {err}"
    for rec in records:  # summaries from the histories: new scalars for old runs too
        point = sweep_dir / "points" / str(rec.get("point", ""))
        if (point / "history.csv").is_file():
            rec["summary"] = summarize_history(point, study.window_ends(), study.hold)
    if records:  # the table and plot of the refreshed summaries
        names = [parse_param(p)[0] for p in study.params]
        write_summary(records, names, sweep_dir)
        plot_sweep(
            records, names, sweep_dir / "sweep.png", paired=study.paired, by=study.compare_by
        )
    return records, ""


def _on_disk(study: Study, sweep_dir: Path) -> list[dict[str, Any]]:
    """The study's points as they stand on disk, without running: finished points from
    their ``point.json`` (same parameters and case fingerprint), the others ``missing``,
    with ``stopped_wall_s`` where a stopped run left its wall time until now."""
    points = build_points(
        [parse_param(p) for p in study.params],
        fingerprint(Path(study.case), study.sets),
        paired=study.paired,
    )
    records: list[dict[str, Any]] = []
    for pt in points:
        record: dict[str, Any] = {"status": "missing"}
        pj = sweep_dir / "points" / pt.ident / "point.json"
        if pj.is_file():
            record = json.loads(pj.read_text(encoding="utf-8"))
        elif "wall_s" in (stopped := read_json(pj.parent / STOPPED_WALL) or {}):
            record["stopped_wall_s"] = float(stopped["wall_s"])
        records.append({"point": pt.ident, "params": pt.params} | record)
    return records
