"""The figures of ``magfem report``: a scene's figure and its animation in the docs' figures."""

from __future__ import annotations

import math
import re
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from magfem.mechanics.columns import read_history
from magfem.study import Study

__all__ = ["animation", "figure_path", "history_figure", "scene_figure"]


def figure_path(figures: Path, study: Study, suffix: str) -> Path:
    """``figures``/scenes_<id><suffix>, the id's punctuation as underscores."""
    return figures / f"scenes_{re.sub(r'[^a-z0-9]+', '_', study.ident)}{suffix}"


def animation(
    study: Study, done: list[dict[str, Any]], sweep_dir: Path, figures: Path
) -> Path | None:
    """With ``animation``: the last finished run's motion.gif copied to ``figures`` (None
    without one)."""
    src = sweep_dir / "points" / done[-1]["point"] / "motion.gif" if done else None
    if not (study.animation and src is not None and src.is_file()):
        return None
    return Path(shutil.copyfile(src, figure_path(figures, study, ".gif")))


def scene_figure(
    study: Study,
    done: list[dict[str, Any]],
    failed: list[dict[str, Any]],
    sweep_dir: Path,
    figures: Path,
) -> Path | None:
    """The scene's figure in ``figures``: the study's ``figure`` histories (of the finished
    runs and of the failed ones until they failed), else the sweep plot (several runs) or the
    single run's angle history; None without a run to show."""
    dest = figure_path(figures, study, ".png")
    if study.figure and (done or failed):
        return history_figure(study.figure, [*done, *failed], sweep_dir, dest)
    src = None
    if len(done) == 1:
        src = sweep_dir / "points" / done[0]["point"] / "angle.png"
    elif len(done) > 1:
        src = sweep_dir / "sweep.png"
    if src is None or not src.is_file():
        return None
    shutil.copyfile(src, dest)
    return dest


_SCALES = {"m": (1e3, "mm"), "rad": (180.0 / math.pi, "°"), "m/s": (1e3, "mm/s")}
"""History units shown scaled on the figure: factor and shown unit."""


def history_figure(
    columns: Sequence[str], records: list[dict[str, Any]], sweep_dir: Path, dest: Path
) -> Path | None:
    """One panel per history column against time (ms), a line per run labelled by
    its parameters; columns a run's history lacks are left out (None if all are). Lengths,
    angles and speeds whose unit the history names are shown in mm, ° and mm/s; a column
    without a unit in the history's header in SI."""
    runs = []
    for rec in records:
        history = sweep_dir / "points" / str(rec["point"]) / "history.csv"
        if history.is_file():
            data, units = read_history(history)
            label = ", ".join(f"{k}={v}" for k, v in rec["params"].items())
            runs.append((label, data, units))
    shown = [c for c in columns if any(c in data for _, data, _ in runs)]
    if not shown:
        return None
    fig = Figure(figsize=(7, 1.2 + 2.0 * len(shown)), dpi=110)
    axes = fig.subplots(len(shown), 1, sharex=True, squeeze=False)[:, 0]
    for ax, column in zip(axes, shown, strict=True):
        unit = next((u.get(column) for _, d, u in runs if column in d), None) or ""
        factor, shown_unit = _SCALES.get(unit, (1.0, unit))
        for label, data, _ in runs:
            if column in data:
                ax.plot(1e3 * data["time"], factor * data[column], label=label)
        ax.set_ylabel(f"{column} ({shown_unit or 'SI'})")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize="small")
    axes[-1].set_xlabel("time (ms)")
    fig.tight_layout()
    fig.savefig(dest)
    return dest
