"""``magfem report``: run (or reuse) the scene studies and write docs/scenes.md.

Every scene of issue 5 has one entry in :data:`STUDIES`: its case file, the
runs that make its prediction (a :mod:`magfem.sweep` over one or more
parameters, so an interrupted report resumes where it stopped) and the
summary scalars to tabulate. ``magfem report --run`` runs what is missing
(``--only ID`` restricts to some scenes); without ``--run`` it only reads
finished runs. The page is rebuilt from scratch each time; for each scene it
gives

* the set-up: the case's description and command, the assumptions (every
  case-file line marked ``# ASSUMED``) and the missing physics (its
  ``# Missing`` comment), the model and why (its ``# Model:`` comment);
* the predicted numbers (one table row per run, from the sweep summary),
  the wall time of each run, and a figure (the sweep plot, or the angle
  history of a single run) copied to ``docs/figures/scenes_<id>.png``;
* for a scene not run or failed, that its prediction is missing and why.

These are predictions: nothing is fitted to the paper's measured numbers
(SCENES.md deliberately omits them).
"""

from __future__ import annotations

import math
import re
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from magfem.case import load_case
from magfem.config import CaseError

__all__ = ["STUDIES", "Study", "build_report"]


@dataclass(frozen=True)
class Study:
    """One scene's prediction: a sweep of ``case`` over ``params`` with ``sets`` applied."""

    ident: str
    title: str
    case: str
    params: tuple[str, ...]
    observe: str
    sets: tuple[str, ...] = ()
    columns: tuple[str, ...] = ()
    notes: str = ""
    paired: bool = False
    """Pair the ``params`` lists element-wise (see :func:`magfem.sweep.build_points`)."""
    pending: str = ""
    """Why the study may not have run yet (its cost), shown while its prediction is missing."""
    unresolved: str = ""
    """Why finished runs are still not predictions (e.g. a mesh coarser than the physics'
    length scale): the scene's status is then "under-resolved" and the reason is shown."""
    compare: tuple[str, ...] = ()
    """Summary scalars whose difference (last point − first, absolute and relative to the
    first) is stated under the table when the first and last points are done."""


_F = "field.sources.0.waveform.frequency"
_B = "field.sources.0.flux_density"
_SOLID_PENDING = (
    "a 3D solid at report resolution, far costlier per step than the strip studies, which "
    "run first (cheapest first, one run at a time on the 2-core machine)"
)

STUDIES: tuple[Study, ...] = (
    Study(
        "one-arm-shapes",
        "One-arm rectangle: max angle in one and two periods vs frequency, 2 mT",
        "cases/one_arm_shapes_rectangle.toml",
        (
            f"{_F}=200Hz,100Hz,50Hz,20Hz,10Hz",
            "time.end=10ms,20ms,40ms,100ms,200ms",
            "time.step=0.05ms,0.1ms,0.25ms,0.25ms,0.25ms",
        ),
        "max angle over 1 and 2 periods vs f; energy and power density",
        columns=(
            "max_angle_halfperiod_arm",
            "max_angle_1period_arm",
            "max_angle_2periods_arm",
            "max_energy_density",
            "power_density",
        ),
        notes="Each frequency runs exactly two periods, with at least 20 steps per half "
        "period (the square wave's switch is resolved the same way at every f); cheapest "
        "first. Trapezoid (cases/one_arm_trapezoid.toml) and triangle "
        "(cases/one_arm_shapes_triangle.toml) are 3D solids; their sweeps are the same "
        "command with those cases.",
        paired=True,
    ),
    Study(
        "one-arm-thickness",
        "One-arm rectangle: max angle vs thickness, 2 mT, 20 Hz",
        "cases/one_arm_shapes_rectangle.toml",
        ("robot.thickness=100um,400um,700um,1000um",),
        "max angle over 1 and 2 periods vs thickness",
        columns=(
            "max_angle_halfperiod_arm",
            "max_angle_1period_arm",
            "max_angle_2periods_arm",
            "max_energy_density",
        ),
    ),
    Study(
        "strip-vs-solid",
        "One-arm rectangle, 2 mT, 50 Hz, one period: 2D strip against the 3D solid",
        "cases/one_arm_shapes_rectangle.toml",
        ("mesh.model=strip,solid", "mesh.size=0.1mm,0.5mm"),
        "difference of the max angle over the first half period and the period",
        sets=(f"{_F}=50Hz", "time.end=20ms"),
        columns=(
            "max_angle_halfperiod_arm",
            "max_angle_1period_arm",
            "max_strain",
            "max_bending_strain",
        ),
        notes="Same robot, field, time step and two element layers through the thickness; "
        "the strip at the report resolution (0.1 mm), the solid on a 0.5 mm hexahedral mesh "
        "(its cost grows with the width, 3 mm here). The difference measures the "
        "plane-strain strip assumption plus the solid's coarser in-plane mesh, not either "
        "alone. `max_strain` is the largest principal nominal strain at any vertex beyond "
        "one thickness from the bonded patch; `max_bending_strain` is κ h/2 of the "
        "sharpest bend of the arm's midline.",
        paired=True,
        compare=(
            "max_angle_halfperiod_arm",
            "max_angle_1period_arm",
            "max_strain",
            "max_bending_strain",
        ),
    ),
    Study(
        "active-length",
        "Straight beam, quasi-static ramp 0 → 4 mT: angle vs field",
        "cases/active_length.toml",
        ("robot.thickness=100um,200um,500um,1000um",),
        "final angle and active length at 4 mT per thickness",
        columns=("final_angle_arm", "final_active_length_arm", "max_strain"),
    ),
    Study(
        "two-arm-20hz",
        "Two-arm strip, 2 mT, 20 Hz",
        "cases/two_arm_20hz.toml",
        ("time.end=50ms",),
        "arm angle history; speed 0° → 90°",
        notes="The bending speed is 90° over the time from the last instant the angle was ≤ 0° "
        "to the first 90° after it (observers.py). Angles beyond 180° are the arm curling over "
        "after the field reversal (self-contact of an arm with itself is not modelled).",
        columns=(
            "max_angle_arm_right",
            "max_angle_arm_left",
            "bending_speed_arm_right",
            "bending_speed_arm_left",
            "max_strain",
        ),
    ),
    Study(
        "two-arm-rect",
        "Two-arm rectangle 6 × 0.8 mm², 45 µm: largest angle per drive",
        "cases/two_arm_rect.toml",
        (f"{_B}=4mT,9mT,2mT", f"{_F}=80Hz,100Hz,200Hz", "time.end=25ms,20ms,10ms"),
        "largest angle at 4 mT/80 Hz, 9 mT/100 Hz, 2 mT/200 Hz",
        columns=(
            "max_angle_halfperiod_arm_right",
            "max_angle_2periods_arm_right",
            "max_angle_2periods_arm_left",
            "max_strain",
        ),
        notes="Each drive runs two periods.",
        paired=True,
    ),
    Study(
        "self-clean",
        "Arm shaken at 4 mT, 30 Hz",
        "cases/self_clean.toml",
        ("time.end=66.7ms",),
        "shaking amplitude = max angle over two periods",
        columns=(
            "max_angle_halfperiod_arm",
            "max_angle_1period_arm",
            "max_angle_2periods_arm",
            "max_strain",
            "max_folds_arm",
        ),
        notes="Angles beyond 180° are the arm curling over (the field reversal at the half "
        "period drives a lifted arm further round, towards the new equilibrium); an arm "
        "touching itself is not modelled (self-contact acts between arms only).",
    ),
    Study(
        "one-arm-triangle",
        "One-arm triangle 4 × 7.5 mm², 80 µm, 4 mT, 60 Hz",
        "cases/one_arm_triangle.toml",
        ("time.end=16.7ms",),
        "angle history over one period",
        columns=("max_angle_halfperiod_arm", "max_angle_1period_arm", "max_strain"),
        pending=_SOLID_PENDING,
    ),
    Study(
        "five-arm",
        "Five-arm star, in-plane 2 mT",
        "cases/five_arm.toml",
        ("time.end=20ms",),
        "rotation of the lifted arm (reaches 90°?)",
        columns=("max_angle_arm_1", "final_angle_arm_1"),
        pending=_SOLID_PENDING,
    ),
    Study(
        "flower",
        "Flower gripper: trigger then 3 mT, 50 Hz",
        "cases/flower.toml",
        ("time.end=25ms",),
        "closing and reopening times (from the petal angles)",
        columns=("max_angle_petal_1", "max_angle_petal_6"),
        notes="Prediction under the assumed magnetisation: no petal closes within 25 ms "
        "(largest petal angle in the table). With M̃ through the thickness and B along z, a "
        "flat petal feels no torque (M̃ × B = 0); it moves only from the tilt the 5 ms "
        "trigger along (1,1,1) gives it, and the 10 ms half periods of the 50 Hz wave are "
        "short for the growth of that tilt when B is reversed. A closing flower needs another "
        "magnetisation pattern (e.g. radial, in-plane), which the paper would have to give.",
        pending=_SOLID_PENDING,
    ),
    Study(
        "failure",
        "Failure triangles I–III at 45, 85, 180 µm, 4 mT",
        "cases/failure.toml",
        (
            "robot.type=" + ",".join(t for t in ("I", "II", "III") for _ in range(3)),
            "robot.thickness=" + ",".join(("180um", "85um", "45um") * 3),
            "mesh.size=" + ",".join(s for s in ("0.5mm", "1mm", "2mm") for _ in range(3)),
        ),
        "collapse vs partial bending (DESIGN.md indicators)",
        columns=(
            "max_angle_arm",
            "max_tip_normal_arm",
            "max_folds_arm",
            "max_spread_arm",
            "collapse",
            "partial_bending",
        ),
        notes="Types I, II, III are similar triangles (5 × 8, 10 × 16, 20 × 32 mm²), each at "
        "every thickness, for one period of the 20 Hz wave (50 ms: the field points both ways "
        "once), with the mesh size scaled with the triangle (0.5, 1, 2 mm: 10 elements across "
        "the base). Only 20 Hz: the paper's range of frequencies is left out.",
        unresolved="the runs finish, but the membrane crumples at the scale of the elements "
        "(the motion.gif of each point) and every run trips both DESIGN.md flags. A "
        "hard-magnetic plate bends over the elastic length ℓ = h √(E/(12 M B)) (E = 3μ; "
        "where the field's torque and the bending stiffness balance): 1.4, 0.65 and 0.34 mm "
        "for 180, 85 and 45 µm at 4 mT, whatever the triangle's size, so scaling the mesh "
        "with the triangle was the wrong choice: these meshes have 0.17 (type III, 45 µm) to "
        "2.8 (type I, 180 µm) elements per ℓ. A prediction needs elements of about ℓ/3 on "
        "every type (0.45 to 0.1 mm; type III at 45 µm ~10⁵ P2 hexahedra), beyond a 3D solid "
        "on this machine (a shell model is the way); the table gives the indicators of the "
        "under-resolved runs",
        paired=True,
        pending=_SOLID_PENDING,
    ),
    Study(
        "bow-tie",
        "Bow-tie at 10–30 Hz, 2 mT",
        "cases/bow_tie.toml",
        (f"{_F}=10Hz,20Hz,30Hz",),
        "arm sequence; arms touching (self-contact force and first touch in the history)",
        columns=(
            "max_angle_arm_left",
            "max_angle_arm_right",
            "first_self_touch",
            "max_self_contact_force",
        ),
        notes="`first_self_touch` (s) is the first sample with an arm–arm contact force, "
        "`max_self_contact_force` (N) the largest. The arms lift in turn: in the first half "
        "period the right arm rises and leans over (105° at the first touch, 16.5 ms, on the "
        "left arm, which the same field presses down to about −15°); the field is the same for "
        "all three frequencies until its first reversal at 1/(2f), so that first touch is "
        "common to all. At 10 Hz the left arm rises to 133° in the second half period and the "
        "right one goes down: the cross-clapping sequence, with contact forces of at most "
        "1.7 µN (light leaning). At 20 and 30 Hz the reversal comes while the right arm is "
        "over (184°, 230°): it flips and strikes the other side (contact force 0.05 N, "
        "1.19 N), and Newton cuts the step until the case's `time.min_step` (2 µs) stops the "
        "run, at 26.9 ms and 20.6 ms: the clap is under-resolved (the tip's end face hits at "
        "metres per second and crushes its elements; magfem/mechanics/self_contact.py). Those "
        "two predictions are missing beyond the first touch.",
        pending=_SOLID_PENDING,
    ),
)
"""The scene studies, cheapest first."""


def _case_notes(path: Path) -> dict[str, list[str]]:
    """Comment lines of a case file: ASSUMED keys, Model and Missing notes."""
    notes: dict[str, list[str]] = {"assumed": [], "model": [], "missing": [], "head": []}
    current: str | None = None
    for line in path.read_text(encoding="utf-8").splitlines():
        stripped = line.strip()
        code, _, comment = line.partition("#")
        if "ASSUMED" in comment and code.strip():
            key, _, value = code.partition("=")
            why = comment.replace("ASSUMED", "").strip(" :;,").removeprefix("(").removesuffix(")")
            notes["assumed"].append(
                f"`{key.strip()} = {value.strip()}`" + (f" ({why})" if why else "")
            )
            current = None
        elif stripped.startswith("# Model:"):
            notes["model"].append(stripped.removeprefix("# Model:").strip())
            current = "model"
        elif stripped.startswith("# Missing"):
            notes["missing"].append(stripped.removeprefix("#").strip())
            current = "missing"
        elif stripped.startswith("#") and current and not stripped.startswith("# Run"):
            notes[current][-1] += " " + stripped.lstrip("# ").strip()
        else:
            current = None
    return notes


def _fmt(key: str, value: Any) -> str:
    if not isinstance(value, int | float) or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if "bending_speed" in key:
        return f"{math.degrees(value) / 1e3:.2f}"
    if "active_length" in key:
        return f"{1e3 * value:.2f}"
    if "angle" in key:
        return f"{math.degrees(value):.1f}°"
    return f"{value:.3g}"


def _unit(key: str) -> str:
    if "energy_density" in key:
        return " (J/m³)"
    if "power_density" in key:
        return " (W/m³)"
    if key == "end_time":
        return " (s)"
    if "bending_speed" in key:
        return " (°/ms, 0° → 90°)"
    if "active_length" in key:
        return " (mm)"
    return ""


def build_report(
    out: Path,
    *,
    run: bool = False,
    only: Sequence[str] = (),
    jobs: int = 2,
    retry_failed: bool = False,
    docs: Path = Path("docs"),
    echo: Callable[[str], None] | None = print,
) -> Path:
    """Run (``run=True``) or read the studies and write ``docs/scenes.md``.

    ``retry_failed`` reruns points recorded as failed (passed to
    :func:`magfem.sweep.run_sweep`); ``jobs`` runs that many points at once.

    Raises:
        CaseError: an unknown scene id in ``only``.
    """
    from magfem.sweep import parse_param, plot_sweep, run_sweep, summarize_history, write_summary

    known = {s.ident for s in STUDIES}
    for ident in only:
        if ident not in known:
            raise CaseError("--only", ident, "unknown scene; one of " + ", ".join(sorted(known)))
    figures = docs / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    lines = [
        "# Seed scenes: predictions",
        "",
        "Generated by `magfem report` (magfem/report.py); regenerate the numbers with "
        "`magfem report --run` (resumes finished runs; `--only ID` for one scene). "
        "These are **predictions** of the cases in `cases/`, not fits: no parameter was "
        "tuned to a measured number. Assumptions are listed per scene (the `# ASSUMED` "
        "lines of each case file). Angles are the unwrapped tip bending angle (DESIGN.md). "
        "Wall times are those of each run process (serial, one process per point) on the "
        "machine that ran it, which may have been shared with other work: they are a cost "
        "guide, not a benchmark.",
        "",
        "| scene | status | runs | wall time (s) |",
        "| --- | --- | --- | --- |",
    ]
    body: list[str] = []
    for study in STUDIES:
        sweep_dir = out / study.ident
        selected = not only or study.ident in only
        records: list[dict[str, Any]] = []
        reason = ""
        if (run and selected) or (sweep_dir / "points").is_dir():
            try:
                if run and selected:
                    records = run_sweep(
                        study.case,
                        list(study.params),
                        sweep_dir,
                        base_overrides=list(study.sets),
                        jobs=jobs,
                        retry_failed=retry_failed,
                        paired=study.paired,
                        echo=echo,
                    ).records
                else:
                    records = _read_only(study, sweep_dir)
            except CaseError as err:
                reason = f"case error: {err}"
        else:
            reason = f"not run yet (`magfem report --run --only {study.ident}`)" + (
                f": {study.pending}" if study.pending else ""
            )
        for rec in records:  # summaries from the histories: new scalars for old runs too
            point = sweep_dir / "points" / str(rec.get("point", ""))
            if (point / "history.csv").is_file():
                rec["summary"] = summarize_history(point)
        if records:  # the table and plot of the refreshed summaries
            names = [parse_param(p)[0] for p in study.params]
            write_summary(records, names, sweep_dir)
            plot_sweep(records, names, sweep_dir / "sweep.png", paired=study.paired)
        done = [r for r in records if r.get("status") == "done"]
        failed = [r for r in records if r.get("status") == "failed"]
        unfinished = [r for r in records if r.get("status") == "missing"]
        if unfinished and not reason:
            reason = (
                f"{len(unfinished)} of {len(records)} run(s) not finished; a row with an "
                "`end_time` shows what an interrupted run reached "
                f"(`magfem report --run --only {study.ident}` runs them again)"
            ) + (f": {study.pending}" if study.pending else "")
        wall = sum(float(r.get("wall_s", 0.0)) for r in records)
        status = (
            "predicted"
            if records and len(done) == len(records)
            else ("partial" if done else "missing")
        )
        if done and study.unresolved:
            status = "under-resolved"
            reason = "; ".join(r for r in (reason, f"under-resolved: {study.unresolved}") if r)
        lines.append(
            f"| [{study.ident}](#{study.ident}) | {status} | {len(done)}/{len(records) or '–'} "
            f"| {wall:.0f} |"
        )
        body += _scene_section(study, records, done, failed, reason, sweep_dir, figures, docs)
    text = "\n".join([*lines, "", *body]) + "\n"
    path = docs / "scenes.md"
    path.write_text(text, encoding="utf-8")
    return path


def _read_only(study: Study, sweep_dir: Path) -> list[dict[str, Any]]:
    """The study's points as they stand on disk, without running: finished points from
    their ``point.json`` (same parameters and case fingerprint), the others ``missing``."""
    import json

    from magfem.sweep import build_points, fingerprint, parse_param

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
        records.append({"point": pt.ident, "params": pt.params} | record)
    return records


def _scene_section(
    study: Study,
    records: list[dict[str, Any]],
    done: list[dict[str, Any]],
    failed: list[dict[str, Any]],
    reason: str,
    sweep_dir: Path,
    figures: Path,
    docs: Path,
) -> list[str]:
    case = Path(study.case)
    notes = _case_notes(case)
    params = " ".join(f"--param {p}" for p in study.params)
    sets = " ".join(f"--set {s}" for s in study.sets)
    command = (
        f"`magfem report --run --only {study.ident}` (its lists are paired element-wise, "
        f"not crossed: {params} {sets})".replace("  ", " ").replace(" )", ")")
        if study.paired
        else f"`magfem sweep {study.case} {params} {sets}`".replace(" `", "`")
    )
    out = [
        f"## {study.ident}",
        "",
        f"**{study.title}.** Observe: {study.observe}.",
        "",
        f"- case: `{study.case}`; study: {command}",
        f"- model: {' '.join(notes['model']) or 'see the case file'}",
    ]
    resolution = load_case(case, study.sets).resolution()
    if resolution:
        out.append(f"- resolution (the case with the study's fixed settings): {resolution}")
    if notes["missing"]:
        out.append(f"- {' '.join(notes['missing'])}")
    if study.notes:
        out.append(f"- {study.notes}")
    if notes["assumed"]:
        out.append("- assumed: " + "; ".join(notes["assumed"]))
    out.append("")
    if reason:
        out += [f"**Prediction missing:** {reason}.", ""]
    if records:
        names = list(records[0]["params"])
        arms = sorted(
            {
                k
                for r in records
                for k in r.get("summary", {})
                if k.startswith("max_angle_") and "period" not in k
            }
        )
        cols = list(dict.fromkeys([*study.columns, *arms, "end_time"]))
        out.append(
            "| " + " | ".join([*names, "status", "wall (s)", *(c + _unit(c) for c in cols)]) + " |"
        )
        out.append("|" + " --- |" * (len(names) + 2 + len(cols)))
        for rec in records:
            summ = rec.get("summary", {})
            out.append(
                "| "
                + " | ".join(
                    [
                        *(str(rec["params"][n]) for n in names),
                        str(rec.get("status", "missing")),
                        f"{float(rec['wall_s']):.0f}" if "wall_s" in rec else "–",
                        *(_fmt(c, summ.get(c)) for c in cols),
                    ]
                )
                + " |"
            )
        out.append("")
    if study.compare and len(records) > 1 and records[0] in done and records[-1] in done:
        first, last = records[0], records[-1]
        label = " vs ".join(", ".join(map(str, r["params"].values())) for r in (last, first))
        parts = []
        for key in study.compare:
            a, b = first["summary"].get(key), last["summary"].get(key)
            if isinstance(a, float) and isinstance(b, float) and a != 0.0:
                diff = f"{math.degrees(b - a):+.1f}°" if "angle" in key else f"{b - a:+.3g}"
                parts.append(f"{key} {diff} ({100 * (b - a) / abs(a):+.1f} %)")
        out += [f"**Difference** ({label}): " + "; ".join(parts) + ".", ""]
    if failed:
        out.append(
            f"**{len(failed)} run(s) failed** (solver); the table shows what they reached "
            "before failing (`end_time` in the summary). Last log lines:"
        )
        for rec in failed[:3]:
            log = sweep_dir / "points" / rec["point"] / "run.log"
            last = (
                log.read_text(encoding="utf-8").strip().splitlines()[-1:] if log.is_file() else []
            )
            out.append(f"  - `{rec['params']}`: `{last[0][:200] if last else '?'}`")
        out.append("")
    fig = _figure(study, done, sweep_dir, figures)
    if fig is not None:
        out += [f"![{study.ident}]({fig.relative_to(docs).as_posix()})", ""]
    return out


def _figure(
    study: Study, done: list[dict[str, Any]], sweep_dir: Path, figures: Path
) -> Path | None:
    src = None
    if len(done) == 1:
        src = sweep_dir / "points" / done[0]["point"] / "angle.png"
    elif len(done) > 1:
        src = sweep_dir / "sweep.png"
    if src is None or not src.is_file():
        return None
    dest = figures / f"scenes_{re.sub(r'[^a-z0-9]+', '_', study.ident)}.png"
    shutil.copyfile(src, dest)
    return dest
