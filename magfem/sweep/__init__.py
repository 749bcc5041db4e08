"""Parameter sweeps: many independent ``magfem run`` processes, resumable, one summary table.

    magfem sweep CASE --param NAME=VALUES [--param NAME=VALUES ...]
                      [--set KEY=VALUE ...] [--jobs N] [--np K] [--out DIR] [--retry-failed]
                      [--engine local|slurm|submitit-local] [--engine-option KEY=VALUE ...]

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
-n K`` in front with ``--np K``), at most ``--jobs`` at a time, as local
processes or as the jobs of a cluster (``--engine slurm``: a SLURM job array
through submitit; :mod:`magfem.sweep.engines`).

Resuming. A point is *finished* when ``DIR/points/<id>/point.json`` exists
and records the same parameters and the same base-case fingerprint (SHA-256
of the case file's parsed content, comments left out, and the ``--set``
overrides); ``<id>`` is itself a hash of those, so a changed case gives
new points rather than stale ones. ``point.json`` is written atomically
(``os.replace``) only after the run
process has exited, so a sweep killed at any moment leaves every point
either finished or not started/partial, and running the same command again
computes only what is missing. A point whose run failed (exit status ≠ 0,
e.g. Newton failure) is also recorded and not redone, unless
``--retry-failed`` (from its checkpoint when it left one). Every start and
end is appended to ``DIR/sweep.log``.

Outputs: ``DIR/summary.csv`` (one row per point: parameters as given and in
SI, status, wall time, and the point's summary scalars) and
``DIR/sweep.png`` (max angle over the first one and two periods against the
first parameter, one line per combination of the others).

Summary scalars (:func:`summarize_history`) are computed from each run's
``history.csv`` by :func:`magfem.mechanics.observers.history_summary`: per arm
the largest angle over the first half period, one and two periods of the
first periodic source and over the run, the final angle, the midline
observables; the largest strain, energy and power density, self-contact
times and forces, the end time. Names and definitions: docs/physics.md,
"Observables".
"""

from magfem.sweep.engines import ENGINES, parse_engine_options
from magfem.sweep.points import Point, build_points, fingerprint, parse_param
from magfem.sweep.runner import (
    SweepPlan,
    SweepResult,
    finish_sweep,
    plan_sweep,
    run_plans,
    run_sweep,
)
from magfem.sweep.summary import plot_sweep, summarize_history, write_summary

__all__ = [
    "ENGINES",
    "Point",
    "SweepPlan",
    "SweepResult",
    "build_points",
    "fingerprint",
    "finish_sweep",
    "parse_engine_options",
    "parse_param",
    "plan_sweep",
    "plot_sweep",
    "run_plans",
    "run_sweep",
    "summarize_history",
    "write_summary",
]
