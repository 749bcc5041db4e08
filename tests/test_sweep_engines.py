"""``magfem sweep --engine``: points as cluster jobs (submitit's local executor), resume across
engines, engine options.

The reference for the cluster engine is the local engine: a point is the
same ``magfem run`` process either way, so a point run as a job must give the
history the local engine gives, to the last digit.
"""

from __future__ import annotations

import csv
import itertools
import re
import shutil
import sys
from dataclasses import replace

import pytest
import tomli_w

from magfem.config import CaseError
from magfem.sweep import parse_engine_options, plan_sweep, run_plans, run_sweep
from magfem.sweep.engines import PointJob, record_point
from verification import setups as vc

pytest.importorskip("submitit")  # the "cluster" extra; part of the test extra

CASE = vc.SWEEP_PROBE | {"name": "engine_probe"}
PARAM = "field.sources.0.waveform.frequency"


def _history(point_dir):
    with (point_dir / "history.csv").open(newline="") as fh:
        return list(csv.reader(fh))


@pytest.mark.serial
@pytest.mark.slow
def test_cluster_jobs_resume_a_local_sweep_and_match_its_runs(tmp_path):
    case = tmp_path / "engine_probe.toml"
    case.write_text(tomli_w.dumps(CASE))
    out = tmp_path / "sweep"
    local = run_sweep(case, [f"{PARAM}=100Hz"], out, echo=None)
    assert [r["status"] for r in local.records] == ["done"]
    (first,) = local.records
    jobs = run_sweep(case, [f"{PARAM}=100Hz,200Hz"], out, engine="submitit-local", echo=None)
    # the point the local engine finished is reused, the other one ran as a job
    assert jobs.skipped == [first["point"]] and len(jobs.ran) == 1
    assert [r["status"] for r in jobs.records] == ["done", "done"]
    assert list((out / "submitit").iterdir()), "submitit wrote no job files"
    # the job's run is the local engine's: rerun the new point locally into a copy
    (job_point,) = jobs.ran
    again = run_sweep(case, [f"{PARAM}=200Hz"], tmp_path / "again", echo=None)
    (local_point,) = again.ran
    # same parameters and case: the same id but for the index in the sweep
    assert local_point.split("_")[1] == job_point.split("_")[1]
    assert _history(out / "points" / job_point) == _history(
        tmp_path / "again" / "points" / local_point
    )
    # physics, as in the local sweep's test: 2 ms of a square drive lifts the arm
    assert all(r["summary"]["max_angle_arm"] > 0.01 for r in jobs.records)


def test_a_point_stopped_by_a_signal_is_not_recorded(tmp_path):
    job = PointJob("p0000_x", {"a": "1"}, ["true"], str(tmp_path), "f", 1)
    assert record_point(job, -9, 1.0) is None
    assert record_point(job, 130, 1.0) is None
    assert not (tmp_path / "point.json").exists()
    assert record_point(job, 3, 1.0) == "failed"
    assert (tmp_path / "point.json").is_file()


@pytest.mark.parametrize(
    ("kwargs", "key"),
    [
        ({"engine": "pbs"}, "--engine"),
        ({"engine_options": {"partition": "short"}}, "--engine-option"),  # local engine
        ({"engine": "submitit-local", "engine_options": {"partition": "x"}}, "--engine-option"),
        pytest.param(
            {"engine": "slurm"},
            "--engine",
            marks=pytest.mark.skipif(shutil.which("srun") is not None, reason="a SLURM machine"),
        ),
    ],
)
def test_bad_engine_settings_are_case_errors(tmp_path, kwargs, key):
    case = tmp_path / "engine_probe.toml"
    case.write_text(tomli_w.dumps(CASE))
    with pytest.raises(CaseError) as err:
        run_sweep(case, [f"{PARAM}=100Hz"], tmp_path / "s", echo=None, **kwargs)
    assert err.value.key == key


def test_engine_options_parse_numbers_and_reject_bad_items():
    assert parse_engine_options(["partition=short", "time=60", "mem_gb = 1.5"]) == {
        "partition": "short",
        "time": 60,
        "mem_gb": 1.5,
    }
    with pytest.raises(CaseError) as err:
        parse_engine_options(["partition"])
    assert err.value.key == "--engine-option"


_POINT = """
import sys, time
from pathlib import Path
name, seconds, log = sys.argv[1], float(sys.argv[2]), Path(sys.argv[3])
with log.open("a") as fh:
    fh.write(f"start {name}\\n")
time.sleep(seconds)
with log.open("a") as fh:
    fh.write(f"end {name}\\n")
"""


@pytest.mark.serial
def test_sweeps_in_one_queue_share_the_cores_in_order(tmp_path):
    """Two sweeps in one queue on 2 workers (as ``magfem report --run`` runs its scenes):
    the second sweep's points take the core the first sweep's long point leaves free, in
    their order, never more than 2 at once, each recorded in its own sweep. The points are
    stand-in processes (a 4 s one, three 0.2 s ones), so the order is the schedule's; the
    three short ones end more than 2 s before the long one even at 0.5 s per start. Each end
    is logged with the queue's count of ended runs."""
    case = tmp_path / "engine_probe.toml"
    case.write_text(tomli_w.dumps(CASE))
    log = tmp_path / "order.log"
    plans = []
    for name, seconds in (("long", [4.0]), ("short", [0.2, 0.2, 0.2])):
        values = ",".join(f"{10 * (k + 1)}Hz" for k in range(len(seconds)))
        plan = plan_sweep(case, [f"{PARAM}={values}"], tmp_path / name, echo=None)
        plan.todo = [
            replace(job, command=[sys.executable, "-c", _POINT, f"{name}{k}", str(s), str(log)])
            for k, (job, s) in enumerate(zip(plan.todo, seconds, strict=True))
        ]
        plans.append(plan)
    run_plans(plans, 2)
    events = log.read_text().split()
    order = [f"{what} {who}" for what, who in zip(events[::2], events[1::2], strict=True)]
    # long0 and short0 start together: which writes its line first is the OS's choice.
    assert sorted(order[:2]) == ["start long0", "start short0"] and order[-1] == "end long0"
    assert [e for e in order if e.startswith("start short")] == [
        "start short0",
        "start short1",
        "start short2",
    ]
    running = [1 if e.startswith("start") else -1 for e in order]
    assert max(itertools.accumulate(running)) == 2
    ended = []
    for plan in plans:
        assert sorted(plan.result.ran) == sorted(job.ident for job in plan.todo)
        assert all((plan.out / "points" / job.ident / "point.json").is_file() for job in plan.todo)
        ended += re.findall(r"\((\d) of 4 runs ended\)", (plan.out / "sweep.log").read_text())
    assert sorted(ended) == ["1", "2", "3", "4"]  # the queue's progress, across its sweeps
    with pytest.raises(CaseError, match="--jobs"):
        run_plans(plans, 0)
