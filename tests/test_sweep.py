"""``magfem sweep``: parameter syntax, resume after a kill, summary table and plot."""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import subprocess
import sys
import time

import pytest
import tomli_w

from magfem.cli import main
from magfem.config import CaseError
from magfem.sweep import build_points, fingerprint, parse_param
from verification import setups as vc

CASE = vc.SWEEP_PROBE


def _case_file(directory):
    path = directory / "sweep_probe.toml"
    path.write_text(tomli_w.dumps(CASE))
    return path


@pytest.mark.parametrize(
    ("text", "values"),
    [
        ("f=10:200:20Hz", [f"{v}Hz" for v in range(10, 200, 20)]),
        ("robot.thickness=100:1000:300um", ["100um", "400um", "700um", "1000um"]),
        ("robot.type=I,II,III", ["I", "II", "III"]),
        ("a.b=0.1:0.3:0.1", ["0.1", "0.2", "0.3"]),  # STOP hit despite rounding
        ('x="2 mT", 3mT', ['"2 mT"', "3mT"]),
    ],
)
def test_parse_param(text, values):
    assert parse_param(text)[1] == values


def test_paired_points_zip_the_lists_and_keep_the_crossed_ids():
    params = [("f", ["10Hz", "20Hz"]), ("time.end", ["200ms", "100ms"])]
    paired = build_points(params, "fp", paired=True)
    crossed = build_points(params, "fp")
    assert [p.params for p in paired] == [
        {"f": "10Hz", "time.end": "200ms"},
        {"f": "20Hz", "time.end": "100ms"},
    ]
    assert len(crossed) == 4
    # the hash part of a point's id depends on the fingerprint and its parameters only
    ids = {json.dumps(p.params, sort_keys=True): p.ident for p in crossed}
    assert all(ids[json.dumps(p.params, sort_keys=True)].endswith(p.ident[6:]) for p in paired)
    with pytest.raises(CaseError, match="same length"):
        build_points([("f", ["10Hz", "20Hz"]), ("time.end", ["1ms"])], "fp", paired=True)


def test_fingerprint_ignores_comments_and_layout_but_not_values(tmp_path):
    """Editing a case file's comments keeps its finished points; editing a value does not."""
    path = _case_file(tmp_path)
    before = fingerprint(path, ["time.end=1ms"])
    path.write_text("# a new comment\n\n" + path.read_text().replace(" = ", "   =   "))
    assert fingerprint(path, ["time.end=1ms"]) == before
    assert fingerprint(path, ["time.end=2ms"]) != before
    data = dict(CASE, name="another")
    path.write_text(tomli_w.dumps(data))
    assert fingerprint(path, ["time.end=1ms"]) != before


@pytest.mark.parametrize(
    "text", ["robot.thickness", "=1,2", "a=", "a=1,,2", "a=1:2", "a=5:1:1", "a=1:5:0um", "a b=1"]
)
def test_bad_param_is_a_case_error(text):
    with pytest.raises(CaseError, match="--param"):
        parse_param(text)


def test_bad_param_syntax_exits_2_with_one_line(shared_tmp, comm, capsys):
    path = _case_file(shared_tmp) if comm.rank == 0 else shared_tmp / "sweep_probe.toml"
    comm.barrier()
    code = main(["sweep", str(path), "--param", "robot.thickness=100um:200um"])
    err = capsys.readouterr().err
    assert code == 2
    if comm.rank == 0:
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        assert "--param" in lines[0] and "START:STOP:STEP" in lines[0]


def _summary(path):
    with path.open(newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow
@pytest.mark.serial
def test_killed_sweep_resumes_without_recomputing(tmp_path):
    """Kill the whole sweep (driver + running point) after the first point; rerun."""
    case = _case_file(tmp_path)
    out = tmp_path / "sweep"
    cmd = [sys.executable, "-m", "magfem", "sweep", str(case), "--out", str(out), "-q"]
    cmd += ["--param", "field.sources.0.waveform.frequency=100:200:100Hz", "--jobs", "1"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL)
    deadline = time.monotonic() + 240
    try:
        while not list(out.glob("points/*/point.json")):
            assert proc.poll() is None, "sweep ended before the first point finished"
            assert time.monotonic() < deadline, "first point did not finish in 240 s"
            time.sleep(0.2)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the group of the process started above
        proc.wait()
    (first,) = out.glob("points/*/point.json")
    stamps = {p: p.stat().st_mtime_ns for p in first.parent.iterdir()}
    assert main(cmd[3:]) == 0
    # finished point untouched (same files, same modification times), the other one done
    assert {p: p.stat().st_mtime_ns for p in first.parent.iterdir()} == stamps
    log = (out / "sweep.log").read_text()
    ident = first.parent.name
    assert log.count(f"start {ident}") == 1, log
    assert "1 finished, 1 to run" in log
    rows = _summary(out / "summary.csv")
    assert [r["field.sources.0.waveform.frequency"] for r in rows] == ["100Hz", "200Hz"]
    assert [float(r["field.sources.0.waveform.frequency (SI)"]) for r in rows] == [100, 200]
    assert all(r["status"] == "done" for r in rows)
    # both runs cover 2 ms = 1/5 and 2/5 of a period: the arm lifts (torque M x B lifts it)
    assert all(float(r["max_angle_arm"]) > 0.01 for r in rows)
    assert (out / "sweep.png").stat().st_size > 1000
    # a third call reuses everything: no new "start" line
    starts = (out / "sweep.log").read_text().count(" start ")
    assert main(cmd[3:]) == 0
    assert (out / "sweep.log").read_text().count(" start ") == starts


@pytest.mark.slow
@pytest.mark.serial
def test_sigterm_to_a_sweep_stops_its_point_at_a_checkpoint_that_the_rerun_continues(tmp_path):
    """``kill`` (SIGTERM) on the sweep's driver: the driver stops the point it started, which
    writes its checkpoint, and exits with 143 (PETSc's own handler would abort the driver and
    leave the point running); the same command then continues the point from its checkpoint
    and finishes it."""
    case = _case_file(tmp_path)
    out = tmp_path / "sweep"
    cmd = [sys.executable, "-m", "magfem", "sweep", str(case), "--out", str(out), "-q"]
    # ~600 steps (the square wave's switches take small steps): long enough to be caught
    cmd += ["--param", "field.sources.0.waveform.frequency=100Hz", "--set", "time.end=50ms"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 240

    def rows() -> int:
        found = list(out.glob("points/*/history.csv"))
        return len(found[0].read_text().splitlines()) if found else 0

    try:
        while rows() < 20:  # inside the time loop
            assert proc.poll() is None, "sweep ended before its point's time loop"
            assert time.monotonic() < deadline, "the point's time loop did not start in 240 s"
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 143, err.decode()
    assert "stopped by SIGTERM" in err.decode()
    (pdir,) = (out / "points").iterdir()
    assert (pdir / "checkpoint" / "meta.json").is_file()
    assert not (pdir / "point.json").exists()
    assert main(cmd[3:]) == 0
    log = (out / "sweep.log").read_text()
    assert f"resume {pdir.name} from its checkpoint" in log
    summary = _summary(out / "summary.csv")
    assert summary[0]["status"] == "done" and float(summary[0]["end_time"]) == pytest.approx(0.05)


@pytest.mark.serial
def test_a_stopped_point_continues_from_its_checkpoint(tmp_path):
    """A point whose run stopped at 1 ms of 2 ms with a checkpoint (as a signal or the
    checkpoint interval leaves it) continues from there: its history equals an uninterrupted
    point's bit for bit (the generalized-alpha state is restored exactly). A checkpoint that
    does not continue the point's case (here another Newton tolerance) is refused, and the
    point runs afresh to the same history."""
    import numpy as np

    from magfem.mechanics.columns import read_history
    from magfem.sweep import run_sweep

    case = _case_file(tmp_path)
    params = ["field.sources.0.waveform.frequency=100Hz"]
    run_sweep(case, params, tmp_path / "ref", echo=None)
    (ref_dir,) = (tmp_path / "ref" / "points").iterdir()
    reference = read_history(ref_dir / "history.csv")[0]
    (point,) = build_points([parse_param(p) for p in params], fingerprint(case, ()))
    for extra, word in ((), "resume"), (("solver.rtol=1e-7",), "refused"):
        out = tmp_path / word
        pdir = out / "points" / point.ident
        sets = [*point.overrides(), "time.end=1ms", "output.checkpoint_every=4", *extra]
        cmd = ["run", str(case), "--out", str(pdir), "-q"]
        assert main([*cmd, *(a for item in sets for a in ("--set", item))]) == 0
        assert (pdir / "checkpoint" / "meta.json").is_file()
        result = run_sweep(case, params, out, echo=None)
        assert result.records[0]["status"] == "done"
        log = (out / "sweep.log").read_text()
        assert f"resume {point.ident} from its checkpoint" in log
        assert ("refused " in log) == (word == "refused")
        history = read_history(pdir / "history.csv")[0]
        assert history["time"][-1] == pytest.approx(2e-3)
        for key, column in reference.items():
            np.testing.assert_array_equal(history[key], column, err_msg=key)


@pytest.mark.serial
def test_a_failed_point_retried_continues_from_its_checkpoint(tmp_path):
    """A point recorded as failed that left a checkpoint at 1 ms of 2 ms (as a run that
    crashed after a restart leaves it) is skipped by a plain rerun and, with
    ``retry_failed``, continues from the checkpoint: its history equals an uninterrupted
    point's bit for bit, and the computed steps are kept."""
    import numpy as np

    from magfem.mechanics.columns import read_history
    from magfem.sweep import run_sweep
    from magfem.sweep.engines import PointJob, record_point

    case = _case_file(tmp_path)
    params = ["field.sources.0.waveform.frequency=100Hz"]
    run_sweep(case, params, tmp_path / "ref", echo=None)
    (ref_dir,) = (tmp_path / "ref" / "points").iterdir()
    reference = read_history(ref_dir / "history.csv")[0]
    fprint = fingerprint(case, ())
    (point,) = build_points([parse_param(p) for p in params], fprint)
    out = tmp_path / "failed"
    pdir = out / "points" / point.ident
    sets = [*point.overrides(), "time.end=1ms", "output.checkpoint_every=4"]
    cmd = ["run", str(case), "--out", str(pdir), "-q"]
    assert main([*cmd, *(a for item in sets for a in ("--set", item))]) == 0
    job = PointJob(point.ident, point.params, [], str(pdir), fprint, 1)
    assert record_point(job, 70, 1.0) == "failed"
    assert run_sweep(case, params, out, echo=None).records[0]["status"] == "failed"
    result = run_sweep(case, params, out, echo=None, retry_failed=True)
    assert result.records[0]["status"] == "done"
    assert f"resume {point.ident} from its checkpoint" in (out / "sweep.log").read_text()
    history = read_history(pdir / "history.csv")[0]
    for key, column in reference.items():
        np.testing.assert_array_equal(history[key], column, err_msg=key)


def test_a_points_wall_time_counts_its_stopped_runs(tmp_path):
    """A point stopped twice (5 s and 3 s) and then finished (2 s) records 10 s: the cost of
    a study in the report includes the runs that a stop interrupted."""
    from magfem.sweep.engines import STOPPED_WALL, PointJob, record_point

    (tmp_path / "history.csv").write_text("time,angle_arm\n0.0,0.0\n0.001,0.1\n", encoding="utf-8")
    job = PointJob("p0000_x", {"a": "1"}, [], str(tmp_path), "f", 1)
    assert record_point(job, 143, 5.0) is None
    assert record_point(job, -9, 3.0) is None
    assert not (tmp_path / "point.json").exists()
    assert record_point(job, 0, 2.0) == "done"
    record = json.loads((tmp_path / "point.json").read_text(encoding="utf-8"))
    assert record["wall_s"] == pytest.approx(10.0)
    assert not (tmp_path / STOPPED_WALL).exists()


def test_history_summary_reads_first_self_touch(tmp_path):
    """First self-touch = time of the first sample with a positive self-contact force."""
    from magfem.sweep import summarize_history

    rows = ["time,self_contact_force", "0.0,0.0", "0.001,0.0", "0.002,3e-4", "0.003,0.0"]
    (tmp_path / "history.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    out = summarize_history(tmp_path)
    assert out["first_self_touch"] == 0.002
    assert out["max_self_contact_force"] == 3e-4
    (tmp_path / "history.csv").write_text("time,self_contact_force\n0.0,0.0\n", encoding="utf-8")
    assert math.isnan(summarize_history(tmp_path)["first_self_touch"])


@pytest.mark.serial
def test_a_window_of_a_held_step_is_the_run_stopped_at_its_reversal(tmp_path):
    """A square wave holds its first direction for half a period, whatever its frequency: the
    summary of the 100 Hz probe's history up to 1.25 ms (a window) is that of the 400 Hz run,
    which stops at its first reversal there (the same field, the same steps), to round-off.
    A window past the run's end is nan, and a window is not the whole run."""
    from magfem.sweep import summarize_history

    case = _case_file(tmp_path)
    quiet = ["-q", "--set", "output.animation=false"]
    stop = ["--set", "field.sources.0.waveform.frequency=400Hz", "--set", "time.end=1.25ms"]
    assert main(["run", str(case), "--out", str(tmp_path / "stopped"), *quiet, *stop]) == 0
    assert main(["run", str(case), "--out", str(tmp_path / "held"), *quiet]) == 0
    stopped = summarize_history(tmp_path / "stopped")
    held = summarize_history(tmp_path / "held", {"400Hz": 1.25e-3, "later": 3e-3})
    assert stopped["max_angle_arm"] > math.radians(5.0)  # the arm moved in the window
    for key in ("max_angle_arm", "final_angle_arm", "max_strain", "max_folds_arm"):
        assert held[f"{key}@400Hz"] == pytest.approx(stopped[key], rel=1e-9, abs=1e-15), key
    assert held["max_angle_arm"] > 1.1 * held["max_angle_arm@400Hz"]  # it rose on after 1.25 ms
    later = {k: v for k, v in held.items() if k.endswith("@later")}
    whole = {k for k in held if "@" not in k} - {"end_time", "steps"}
    assert {k.removesuffix("@later") for k in later} == whole
    assert all(map(math.isnan, later.values()))


def test_a_value_inserted_in_a_list_keeps_the_finished_points(tmp_path):
    """Folders are named p<index>_<hash>: inserting 5 Hz before 10 and 20 Hz moves their
    indices, and their finished runs must be taken over, not run again."""
    from magfem.sweep.runner import _adopt_moved, _unfinished

    old = build_points([("f", ["10Hz", "20Hz"])], "base")
    new = build_points([("f", ["5Hz", "10Hz", "20Hz"])], "base")
    assert [p.ident for p in old] != [p.ident for p in new[1:]]  # the indices moved
    for pt in old:
        folder = tmp_path / "points" / pt.ident
        folder.mkdir(parents=True)
        record = {"params": pt.params, "fingerprint": "base", "status": "done"}
        (folder / "point.json").write_text(json.dumps(record))
    said: list[str] = []
    _adopt_moved(new, tmp_path, said.append)
    assert sorted(d.name for d in (tmp_path / "points").iterdir()) == [p.ident for p in new[1:]]
    assert len(said) == 2 and all(line.startswith("moved ") for line in said)
    skipped: list[str] = []
    assert _unfinished(new, tmp_path, "base", False, skipped) == [new[0]]  # only 5 Hz runs
    assert skipped == [p.ident for p in new[1:]]


def test_frequencies_over_a_decade_go_on_a_log_axis():
    from magfem.sweep.summary import log_axis

    assert log_axis([10.0, 15.0, 20.0, 200.0])  # 10-200 Hz: 10 and 15 Hz would crowd
    assert not log_axis([100.0, 200.0])  # less than a decade: linear
    assert not log_axis([0.0, 1e-3, 1e-2])  # a zero has no place on a log axis
    assert not log_axis([-1.0, 20.0])
