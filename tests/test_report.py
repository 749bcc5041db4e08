"""``magfem report`` without running: finished points are tabulated, the rest said missing."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from magfem.cli import main
from magfem.config import CaseError
from magfem.report import build_report
from magfem.report_cost import packed_wall
from magfem.study import load_studies
from magfem.sweep import build_points, fingerprint, parse_param


def test_report_tabulates_finished_points_and_says_what_is_missing(tmp_path, repo, monkeypatch):
    """A finished point is tabulated in SI-derived units (angle in degrees, speed in
    deg/ms), every other scene is listed as missing."""
    monkeypatch.chdir(repo)  # the studies name their case files relative to the repository
    studies = load_studies()
    study = next(s for s in studies if s.ident == "two-arm-20hz")
    fprint = fingerprint(Path(study.case), study.sets)
    points = build_points([parse_param(p) for p in study.params], fprint)  # two mesh sizes
    for pt in points:
        point = tmp_path / "out" / "two-arm-20hz" / "points" / pt.ident
        point.mkdir(parents=True)
        summary = {"max_angle_arm_right": math.pi / 2, "bending_speed_arm_right": 1000.0}
        record = {"params": pt.params, "status": "done", "wall_s": 3.0, "fingerprint": fprint}
        (point / "point.json").write_text(json.dumps(record | {"summary": summary}))
    page = build_report(tmp_path / "out", docs=tmp_path / "docs", echo=None).read_text()
    assert "| [two-arm-20hz](#two-arm-20hz) | predicted | 2/2 | 6 |" in page
    # pi/2 rad -> 90.0 deg; 1000 rad/s -> 57.30 deg/ms
    assert "| 0.1mm | 50ms | done | 3 | 90.0° | – | 57.30 | – |" in page
    # 80 µm, 2 mT, 0.1 mm strip: ℓ = 80 µm √(2.990 μ/(12 M B)) = 0.863 mm, 8.6 elements
    assert "magnetoelastic length 0.863 mm at 2 mT: 8.6 element(s) per length" in page
    assert page.count("**Prediction missing:** not run yet") == len(studies) - 1
    with pytest.raises(CaseError, match="--only"):
        build_report(tmp_path / "out", only=["no-such-scene"], docs=tmp_path / "docs")


def _write_points(
    out: Path, study, summaries: list[dict[str, float]], walls: list[float] | None = None
) -> None:
    """Finished points of ``study`` under ``out`` with the given summaries and wall times
    (default 3 s each), in point order."""
    fprint = fingerprint(Path(study.case), study.sets)
    points = build_points([parse_param(p) for p in study.params], fprint, paired=study.paired)
    assert len(points) == len(summaries)
    walls = walls or [3.0] * len(points)
    for pt, summary, wall in zip(points, summaries, walls, strict=True):
        point = out / study.ident / "points" / pt.ident
        point.mkdir(parents=True)
        record = {"params": pt.params, "status": "done", "wall_s": wall, "fingerprint": fprint}
        (point / "point.json").write_text(json.dumps(record | {"summary": summary}))


def _probe_page(tmp_path: Path, body: str, summaries: list[dict[str, float]]) -> str:
    """The page of a lone study ``probe`` (the self-clean case, the TOML keys ``body``) whose
    finished points have ``summaries``, written under ``tmp_path``."""
    folder = tmp_path / "studies"
    folder.mkdir(exist_ok=True)
    head = 'title = "Probe"\ncase = "cases/self_clean.toml"\nobserve = "x"\n'
    (folder / "probe.toml").write_text(head + body, encoding="utf-8")
    out = tmp_path / "out"
    if not (out / "probe").exists():
        _write_points(out, load_studies(folder)[0], summaries)
    kwargs = {"docs": tmp_path / "docs", "studies": folder, "echo": None}
    return build_report(out, **kwargs).read_text()


def test_report_difference_lines_use_the_units_of_the_table(tmp_path, repo, monkeypatch):
    """The difference between the two resolutions of two-arm-20hz is written in the unit of
    the table's column: the bending speed in °/ms, not rad/s."""
    monkeypatch.chdir(repo)
    study = next(s for s in load_studies() if s.ident == "two-arm-20hz")
    coarse = {"max_angle_arm_right": math.pi / 2, "bending_speed_arm_right": 1000.0}
    fine = {"max_angle_arm_right": math.pi / 2 + 0.01, "bending_speed_arm_right": 1100.0}
    _write_points(tmp_path / "out", study, [coarse, fine])
    page = build_report(tmp_path / "out", docs=tmp_path / "docs", echo=None).read_text()
    # 1000 and 1100 rad/s are 57.30 and 63.03 °/ms in the table: the difference 100 rad/s is
    # 5.73 °/ms; 0.01 rad is 0.57°, 0.6 % of 90°
    assert "| 0.05mm | 50ms | done | 3 | 90.6° | – | 63.03 | – |" in page
    line = next(x for x in page.splitlines() if x.startswith("**Difference** (0.05mm, 50ms"))
    assert "max_angle_arm_right +0.6° (+0.6 %)" in line
    assert "bending_speed_arm_right +5.73 °/ms (+10.0 %)" in line


def test_report_compares_the_resolutions_at_each_value_of_the_others(tmp_path, repo, monkeypatch):
    """``compare_by``: one difference line per value of the other parameters, between that
    value's first and last run (two mesh sizes paired with two end times)."""
    monkeypatch.chdir(repo)
    angles = [1.0, 1.0 + math.radians(2.0), 2.0, 2.0 - math.radians(0.5)]
    page = _probe_page(
        tmp_path,
        'paired = true\nparams = ["time.end=10ms,10ms,20ms,20ms", '
        '"mesh.size=0.1mm,0.05mm,0.1mm,0.05mm"]\ncompare = ["max_angle_arm"]\n'
        'compare_by = "mesh.size"\n',
        [{"max_angle_arm": a} for a in angles],
    )
    folder = tmp_path / "studies"
    kwargs = {"docs": tmp_path / "docs", "studies": folder, "echo": None}
    lines = [x for x in page.splitlines() if x.startswith("**Difference**")]
    # 2° of 57.3° (1 rad) is 3.5 %; −0.5° of 114.6° is −0.4 %
    assert lines == [
        "**Difference** (10ms: mesh.size 0.05mm vs 0.1mm): max_angle_arm +2.0° (+3.5 %).",
        "**Difference** (20ms: mesh.size 0.05mm vs 0.1mm): max_angle_arm -0.5° (-0.4 %).",
    ]
    # ``compare_also``: the step halved with the mesh still pairs the runs of each end time
    (folder / "probe.toml").write_text(
        'title = "Probe"\ncase = "cases/self_clean.toml"\nobserve = "x"\npaired = true\n'
        'params = ["time.end=10ms,10ms,20ms,20ms", "mesh.size=0.1mm,0.05mm,0.1mm,0.05mm",\n'
        '"time.step=0.2ms,0.1ms,0.2ms,0.1ms"]\ncompare = ["max_angle_arm"]\n'
        'compare_by = "mesh.size"\ncompare_also = ["time.step"]\n',
        encoding="utf-8",
    )
    study = load_studies(folder)[0]
    _write_points(tmp_path / "out2", study, [{"max_angle_arm": a} for a in angles])
    page = build_report(tmp_path / "out2", **kwargs).read_text()
    lines = [x for x in page.splitlines() if x.startswith("**Difference**")]
    assert lines == [
        "**Difference** (10ms: mesh.size 0.05mm vs 0.1mm, time.step 0.1ms vs 0.2ms): "
        "max_angle_arm +2.0° (+3.5 %).",
        "**Difference** (20ms: mesh.size 0.05mm vs 0.1mm, time.step 0.1ms vs 0.2ms): "
        "max_angle_arm -0.5° (-0.4 %).",
    ]


def test_report_difference_line_of_a_study_of_resolutions_alone(tmp_path, repo, monkeypatch):
    """``compare_by`` with no other parameter: one line naming the resolutions only."""
    monkeypatch.chdir(repo)
    page = _probe_page(
        tmp_path,
        'paired = true\nparams = ["mesh.size=0.1mm,0.05mm", "time.step=0.2ms,0.1ms"]\n'
        'compare = ["max_angle_arm"]\ncompare_by = "mesh.size"\ncompare_also = ["time.step"]\n',
        [{"max_angle_arm": 1.0}, {"max_angle_arm": 1.01}],
    )
    lines = [x for x in page.splitlines() if x.startswith("**Difference**")]
    assert lines == [
        "**Difference** (mesh.size 0.05mm vs 0.1mm, time.step 0.1ms vs 0.2ms): "
        "max_angle_arm +0.6° (+1.0 %)."
    ]
    assert "| [probe](#probe) | predicted | 2/2 | 6 |" in page


def test_report_difference_line_names_values_that_a_run_did_not_reach(tmp_path, repo, monkeypatch):
    """A blank (nan) summary value, such as the field for 90° of a beam that stops short of
    90°, is named as blank in the difference line, not written as a nan difference."""
    monkeypatch.chdir(repo)
    page = _probe_page(
        tmp_path,
        'paired = true\nparams = ["time.end=10ms,10ms,20ms,20ms", '
        '"mesh.size=0.1mm,0.05mm,0.1mm,0.05mm"]\ncompare = ["field_90_arm"]\n'
        'compare_by = "mesh.size"\n',
        [{"field_90_arm": v} for v in (math.nan, math.nan, 2.5e-3, math.nan)],
    )
    lines = [x for x in page.splitlines() if x.startswith("**Difference**")]
    assert lines == [
        "**Difference** (10ms: mesh.size 0.05mm vs 0.1mm): field_90_arm – in both.",
        "**Difference** (20ms: mesh.size 0.05mm vs 0.1mm): field_90_arm – vs 2.50 mT.",
    ]


def test_report_calls_finished_runs_predicted_only_with_their_uncertainty(
    tmp_path, repo, monkeypatch
):
    """One resolution, nothing compared and no ``uncertainty``: the runs finished, yet the
    scene is not predicted; the same study stating its uncertainty is, and shows it."""
    monkeypatch.chdir(repo)
    text = 'params = ["time.end=10ms"]\n'
    page = _probe_page(tmp_path, text, [{"max_angle_arm": 1.0}])
    assert "| [probe](#probe) | no uncertainty | 1/1 | 3 |" in page
    assert "**Prediction missing:** the runs finished, but the study states no numerical" in page
    stated = 'uncertainty = """±2° from the mesh study of the same strip."""\n'
    page = _probe_page(tmp_path, text + stated, [])  # the same finished point
    assert "| [probe](#probe) | predicted | 1/1 | 3 |" in page
    assert "- uncertainty: ±2° from the mesh study of the same strip." in page
    assert "**Prediction missing:**" not in page


def test_report_windows_tabulate_the_history_up_to_their_end(tmp_path, repo, monkeypatch):
    """``windows``: a column ``<scalar>@LABEL`` is the scalar over the history up to the
    window's end, from each run's history. An arm turning at a constant rate to 90° in 2 ms has
    turned 45° at 1 ms; the two runs differ only in the window, so the difference line shows
    what each window saw."""
    monkeypatch.chdir(repo)
    body = (
        'params = ["mesh.size=0.1mm,0.05mm"]\nwindows = ["early=1ms", "past=3ms"]\n'
        'columns = ["max_angle_arm@early", "max_angle_arm@past"]\n'
        'compare = ["max_angle_arm@early", "max_angle_arm"]\n'
    )
    _probe_page(tmp_path, body, [{}, {}])  # the two finished points, without histories
    points = sorted((tmp_path / "out/probe/points").iterdir())
    for rate, point in zip((1.0, 0.5), points, strict=True):
        rows = [f"{k * 2e-4:.4f},{rate * math.pi / 2 * k / 10}" for k in range(11)]
        (point / "history.csv").write_text("time [s],angle_arm [rad]\n" + "\n".join(rows))
    page = _probe_page(tmp_path, body, [])
    head = "| mesh.size | status | wall (s) | max_angle_arm@early | max_angle_arm@past |"
    assert head + " max_angle_arm | end_time (s) |" in page
    assert "| 0.1mm | done | 3 | 45.0° | – | 90.0° | 0.002 |" in page
    assert "| 0.05mm | done | 3 | 22.5° | – | 45.0° | 0.002 |" in page
    assert "max_angle_arm@early -22.5° (-50.0 %); max_angle_arm -45.0° (-50.0 %)" in page


def test_report_marks_finished_but_under_resolved_scene(tmp_path, repo, monkeypatch):
    """A study with ``unresolved`` set: all its runs done, yet not called predicted."""
    monkeypatch.chdir(repo)
    why = "the mesh is coarser than the magnetoelastic length"
    page = _probe_page(
        tmp_path,
        f'params = ["mesh.size=0.1mm,0.05mm"]\nunresolved = "{why}"\n',
        [{"max_angle_arm": 1.0}, {"max_angle_arm": 1.0}],
    )
    assert "| [probe](#probe) | under-resolved | 2/2 | 6 |" in page
    assert f"**Prediction missing:** under-resolved: {why}" in page


def test_report_takes_a_new_study_file_without_code(tmp_path, repo, monkeypatch):
    """A study added as a file (here the only one, in another folder) is a scene of the page."""
    monkeypatch.chdir(repo)
    folder = tmp_path / "studies"
    folder.mkdir()
    (folder / "my-scene.toml").write_text(
        'title = "My scene"\ncase = "cases/self_clean.toml"\nobserve = "the angle"\n'
        'params = ["time.end=10ms,20ms"]\n',
        encoding="utf-8",
    )
    page = build_report(
        tmp_path / "out", docs=tmp_path / "docs", studies=folder, echo=None
    ).read_text()
    assert "| [my-scene](#my-scene) | missing | 0/– | 0 |" in page
    assert "## my-scene" in page and "**My scene.** Observe: the angle." in page
    assert "--param time.end=10ms,20ms" in page


@pytest.mark.serial  # the report driver refuses mpirun before it reads the studies
def test_report_with_a_bad_study_file_exits_2_with_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cases" / "studies").mkdir(parents=True)
    (tmp_path / "cases" / "studies" / "bad.toml").write_text(
        'title = "t"\ncase = "c.toml"\nobserve = "o"\nparams = ["x=1"]\nrepeat = 2\n',
        encoding="utf-8",
    )
    code = main(["report", "--out", str(tmp_path / "out"), "--docs", str(tmp_path / "docs")])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(lines) == 1, lines
    assert lines[0].startswith("magfem: error: cases/studies/bad.toml: repeat = 2: unknown key")


@pytest.mark.slow
@pytest.mark.serial  # each run is its own process; the driver is serial
def test_report_run_runs_the_missing_point_and_tabulates_it(tmp_path, repo, monkeypatch):
    """``run=True`` sweeps the selected study (1 ms of the self-clean strip at the tests'
    0.5 mm, ~5 s) and tabulates the run's history; reading again gives the same row."""
    monkeypatch.chdir(repo)
    (tmp_path / "studies").mkdir()
    (tmp_path / "studies" / "probe.toml").write_text(
        'title = "Probe"\ncase = "cases/self_clean.toml"\nobserve = "the angle"\n'
        'params = ["time.end=1ms"]\ncolumns = ["max_strain"]\nuncertainty = "none: a probe"\n'
        'sets = ["mesh.size=0.5mm", '
        '"output.vtx_every=0", "output.plot=false", "output.animation=false"]\n',
        encoding="utf-8",
    )
    kwargs = {"docs": tmp_path / "docs", "studies": tmp_path / "studies", "echo": None}
    page = build_report(tmp_path / "out", run=True, only=["probe"], **kwargs).read_text()
    assert "| [probe](#probe) | predicted | 1/1 |" in page
    row = next(line for line in page.splitlines() if line.startswith("| 1ms | done |"))
    assert row.endswith("| 0.001 |")  # end_time: the run reached its end, 1 ms
    again = build_report(tmp_path / "out", **kwargs).read_text()  # read only: same table
    assert row in again


def test_report_only_keeps_the_other_scenes_as_the_page_has_them(tmp_path, repo, monkeypatch):
    """``only``: the named scene is rebuilt from its runs, every other scene keeps its row and
    section from the existing page, though its runs are not in ``out``; without ``only``, so
    does a scene without runs in ``out``, and one with a run folder is rebuilt."""
    monkeypatch.chdir(repo)
    docs = tmp_path / "docs"
    page = build_report(tmp_path / "out", docs=docs, echo=None).read_text()
    # another machine's runs: a finished five-arm row and section on the page
    page = page.replace(
        "| [five-arm](#five-arm) | missing | 0/– | 0 |",
        "| [five-arm](#five-arm) | predicted | 1/1 | 7 |",
    ).replace("## five-arm\n", "## five-arm\n\nA row from elsewhere.\n")
    (docs / "scenes.md").write_text(page)
    study = next(s for s in load_studies() if s.ident == "two-arm-20hz")
    fprint = fingerprint(Path(study.case), study.sets)
    for pt in build_points([parse_param(p) for p in study.params], fprint):
        point = tmp_path / "out" / "two-arm-20hz" / "points" / pt.ident
        point.mkdir(parents=True)
        record = {"params": pt.params, "status": "done", "wall_s": 3.0, "fingerprint": fprint}
        (point / "point.json").write_text(json.dumps(record | {"summary": {}}))
    again = build_report(tmp_path / "out", only=["two-arm-20hz"], docs=docs, echo=None)
    text = again.read_text()
    assert "| [two-arm-20hz](#two-arm-20hz) | predicted | 2/2 | 6 |" in text
    assert "| [five-arm](#five-arm) | predicted | 1/1 | 7 |" in text
    assert "## five-arm\n\nA row from elsewhere.\n" in text
    assert text.count("\n## ") == page.count("\n## ")  # every scene once, in its place
    # a full report (no ``only``) rebuilds every scene from its runs in ``out`` and keeps
    # the page's section of a scene without runs there, saying so
    said: list[str] = []
    full = build_report(tmp_path / "out", docs=docs, echo=said.append).read_text()
    assert "| [two-arm-20hz](#two-arm-20hz) | predicted | 2/2 | 6 |" in full
    assert "## five-arm\n\nA row from elsewhere.\n" in full
    assert f"five-arm: no runs in {tmp_path / 'out' / 'five-arm'}" in "\n".join(said)
    (tmp_path / "out" / "five-arm" / "points").mkdir(parents=True)  # its runs, none finished
    full = build_report(tmp_path / "out", docs=docs, echo=None).read_text()
    assert "| [five-arm](#five-arm) | missing | 0/2 | 0 |" in full
    assert "A row from elsewhere." not in full


def test_report_only_keeps_a_section_another_report_wrote_during_the_runs(
    tmp_path, repo, monkeypatch
):
    """Two ``--only`` reports running at once: the one that finishes last keeps the
    section the other wrote while its runs went on (the page is read after the runs)."""
    monkeypatch.chdir(repo)
    docs = tmp_path / "docs"
    page = build_report(tmp_path / "out", docs=docs, echo=None).read_text()
    assert "| [five-arm](#five-arm) | missing | 0/– | 0 |" in page

    def run_plans(plans, jobs):  # meanwhile another report rebuilds five-arm
        assert [plan.out.name for plan in plans] == ["two-arm-20hz"]
        text = (docs / "scenes.md").read_text()
        text = text.replace(
            "| [five-arm](#five-arm) | missing | 0/– | 0 |",
            "| [five-arm](#five-arm) | predicted | 1/1 | 7 |",
        ).replace("## five-arm\n", "## five-arm\n\nWritten during the runs.\n")
        (docs / "scenes.md").write_text(text)

    monkeypatch.setattr("magfem.report_runs.run_plans", run_plans)
    text = build_report(tmp_path / "out", run=True, only=["two-arm-20hz"], docs=docs, echo=None)
    text = text.read_text()
    assert "| [five-arm](#five-arm) | predicted | 1/1 | 7 |" in text
    assert "## five-arm\n\nWritten during the runs.\n" in text


_PROBE = 'title = "Probe"\ncase = "cases/self_clean.toml"\nobserve = "x"\n'
_PROBE += 'params = ["time.end=10ms,20ms"]\n'


def _probe_points(folder: Path, out: Path, text: str, status: str) -> list[Path]:
    """The study ``text`` written to ``folder``/probe.toml and its two points' folders in
    ``out`` with a record of ``status`` (runs of another machine, as the report reads them)."""
    folder.mkdir()
    (folder / "probe.toml").write_text(text, encoding="utf-8")
    study = load_studies(folder)[0]
    fprint = fingerprint(Path(study.case), study.sets)
    points = []
    for pt in build_points([parse_param(p) for p in study.params], fprint):
        point = out / "probe" / "points" / pt.ident
        point.mkdir(parents=True)
        record = {"params": pt.params, "status": status, "wall_s": 1.0, "fingerprint": fprint}
        (point / "point.json").write_text(json.dumps(record | {"summary": {}}))
        points.append(point)
    return points


@pytest.mark.parametrize("status", ["done", "failed"])
def test_report_figure_plots_the_named_history_columns(tmp_path, repo, monkeypatch, status):
    """``figure = [...]``: the scene's figure is those history columns against time, one
    line per run (a failed run's history until it failed); a column no run has is left out,
    and with none left there is no figure."""
    monkeypatch.chdir(repo)
    folder, text = tmp_path / "studies", _PROBE + 'figure = ["com_x", "no_such_column"]\n'
    for point in _probe_points(folder, tmp_path / "out", text, status):
        (point / "history.csv").write_text("time [s],com_x [m]\n0,0\n0.01,0.002\n")
    kwargs = {"docs": tmp_path / "docs", "studies": folder, "echo": None}
    page = build_report(tmp_path / "out", **kwargs).read_text()
    figure = tmp_path / "docs" / "figures" / "scenes_probe.png"
    assert "![probe](figures/scenes_probe.png)" in page
    assert figure.is_file() and figure.stat().st_size > 1000
    (folder / "probe.toml").write_text(text.replace('"com_x", ', ""), encoding="utf-8")
    figure.unlink()
    page = build_report(tmp_path / "out", **kwargs).read_text()
    assert "![probe]" not in page and not figure.exists()


def test_report_animation_shows_the_last_finished_runs_motion(tmp_path, repo, monkeypatch):
    """``animation = true``: the last finished run's motion.gif is copied next to the figures
    and shown in the scene's section; without a gif (or without the key) nothing is."""
    monkeypatch.chdir(repo)
    folder, text = tmp_path / "studies", _PROBE + "animation = true\n"
    points = _probe_points(folder, tmp_path / "out", text, "done")
    for point in points:
        (point / "motion.gif").write_bytes(b"GIF89a" + point.name.encode())
    kwargs = {"docs": tmp_path / "docs", "studies": folder, "echo": None}
    page = build_report(tmp_path / "out", **kwargs).read_text()
    gif = tmp_path / "docs" / "figures" / "scenes_probe.gif"
    shown = f"Animation of the run {points[-1].name}: ![probe motion](figures/scenes_probe.gif)"
    assert shown in page
    assert gif.read_bytes() == b"GIF89a" + points[-1].name.encode()
    (folder / "probe.toml").write_text(text.replace("animation = true\n", ""), encoding="utf-8")
    assert "![probe motion]" not in build_report(tmp_path / "out", **kwargs).read_text()


def test_packed_wall_starts_each_run_on_the_first_free_worker():
    """Runs in order on the first worker to free: the makespan of list scheduling."""
    assert packed_wall([], 2) == 0.0
    assert packed_wall([1.0, 1.0, 1.0, 1.0], 2) == 2.0
    assert packed_wall([2.0, 2.0, 1.0], 2) == 3.0  # the third waits for a worker
    assert packed_wall([3.0, 1.0, 1.0, 1.0], 2) == 3.0  # the short ones share the other
    assert packed_wall([3.0, 1.0], 1) == 4.0
    with pytest.raises(ValueError, match="jobs must be >= 1"):
        packed_wall([1.0], 0)


def test_report_states_the_whole_reports_cost_also_for_kept_scenes(tmp_path, repo, monkeypatch):
    """The page sums every run's wall time and packs all runs on two cores in one queue,
    scene after scene in the page's order (a core the first scene's long run leaves free
    takes the next scene's runs); a scene kept from the page (``only`` another) counts with
    the wall times its table shows; a stopped run counts (and shows) its wall time so far."""
    monkeypatch.chdir(repo)
    folder = tmp_path / "studies"
    folder.mkdir()
    head = 'title = "Probe"\ncase = "cases/self_clean.toml"\nobserve = "x"\n'
    for order, name, sizes in ((1, "probe", "0.2mm,0.1mm"), (2, "other", "0.2mm,0.1mm,0.05mm")):
        body = f'order = {order}\nparams = ["mesh.size={sizes}"]\n'
        (folder / f"{name}.toml").write_text(head + body, encoding="utf-8")
    out = tmp_path / "out"
    probe, other = load_studies(folder)
    assert (probe.ident, other.ident) == ("probe", "other")
    _write_points(out, probe, [{"max_angle_arm": 1.0}] * 2, [7200.0, 3600.0])
    _write_points(out, other, [{"max_angle_arm": 1.0}] * 3, [1800.0, 1800.0, 3600.0])
    # one queue: the 1 h run, then other's three, share a core with the 2 h run: 3 h, where
    # scene after scene would take 2 h + 1.5 h
    kwargs = {"docs": tmp_path / "docs", "studies": folder, "echo": None}
    line = (
        "All runs: 5.0 h of one core (the wall times above, summed). `magfem report --run "
        "--jobs 2` runs them in one queue, 2 at a time: about 3.0 h on 2 cores"
    )
    assert line + " at these wall times" in build_report(out, **kwargs).read_text()
    for point in (out / "other" / "points").iterdir():  # its runs now live elsewhere
        (point / "point.json").unlink()
    kept = build_report(out, only=["probe"], **kwargs).read_text()
    assert line + " at these wall times" in kept
    assert "more once the unfinished runs are done" not in kept
    (point / "point.json").write_text("{}")  # a run without a record: not done
    missing = build_report(out, **kwargs).read_text()
    assert "more once the unfinished runs are done." in missing
    (point / "point.json").unlink()
    for point in (out / "other" / "points").iterdir():  # stopped runs: their time so far
        (point / "stopped_wall.json").write_text('{"wall_s": 5400.0}')
    line = (  # 2 h | 1 h + 1.5 h, then 1.5 h after the 2 h run and 1.5 h after the other
        "All runs: 7.5 h of one core (the wall times above, summed). `magfem report --run "
        "--jobs 2` runs them in one queue, 2 at a time: about 4.0 h on 2 cores"
    )
    for page in (build_report(out, **kwargs), build_report(out, only=["probe"], **kwargs)):
        text = page.read_text()
        assert text.count("| 5400 so far |") == 3
        assert line + " at these wall times" in text
        assert "more once the unfinished runs are done." in text


def test_report_hold_tabulates_the_largest_angle_held_and_says_so(tmp_path, repo, monkeypatch):
    """A one-sample flick to 120° over a 90° plateau held 1 ms: with ``hold`` the column
    ``held_angle_arm`` shows the plateau beside the flick and the set-up names the hold;
    without it the column is blank."""
    monkeypatch.chdir(repo)
    params = 'params = ["mesh.size=0.1mm,0.05mm"]\ncolumns = ["held_angle_arm"]\n'
    rows = [f"{k * 1e-4:.4f},{math.radians(90.0 if 10 <= k <= 20 else 10.0)}" for k in range(31)]
    rows[15] = f"{15e-4:.4f},{math.radians(120.0)}"
    for body, shown in ((params, "–"), (params + 'hold = "0.2 ms"\n', "90.0°")):
        folder = tmp_path / ("held" if "hold" in body else "plain")
        folder.mkdir()
        _probe_page(folder, body, [{}, {}])
        for point in (folder / "out/probe/points").iterdir():
            (point / "history.csv").write_text("time [s],angle_arm [rad]\n" + "\n".join(rows))
        page = _probe_page(folder, body, [])
        assert f"| 0.1mm | done | 3 | {shown} | 120.0° | 0.003 |" in page
        said = "- `held_angle_*`: the largest angle held for at least 0.2 ms (the study's `hold`)"
        assert (said in page) == ("hold" in body)
