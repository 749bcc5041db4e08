"""Error-controlled steps (magfem.mechanics.stepping, ``[time] tolerance``)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from magfem.case import parse_case
from magfem.config import CaseError
from magfem.mechanics.stepping import error_factor
from magfem.pipeline import build_simulation
from verification.setups import STRIP_CANTILEVER


@pytest.mark.parametrize(
    ("time", "message"),
    [
        ({"scheme": "quasi_static", "tolerance": 1e-4}, "dynamic scheme"),
        ({"adaptive": False, "tolerance": 1e-4}, "adaptive"),
        ({"tolerance": 2.0}, "tolerance"),
    ],
)
def test_tolerance_is_validated(time, message):
    data = copy.deepcopy(STRIP_CANTILEVER)
    data["time"].update(time)
    with pytest.raises(CaseError, match=message):
        parse_case(data)


def test_error_factor_is_cube_root_and_bounded():
    # local error O(Δt³): η = 8 asks for half the step (× 0.8 safety); bounded by 0.2 and grow
    assert error_factor(8.0, 1.5) == pytest.approx(0.4)
    assert error_factor(1e9, 1.5) == pytest.approx(0.2)
    assert error_factor(1e-9, 1.5) == pytest.approx(1.5)


def test_error_control_lands_on_switches_and_varies_the_step(comm):
    # 2 mT square wave at 200 Hz: switches every 2.5 ms; with tolerance the steps come from the
    # error estimate (they vary within each half period) and still end on every switch
    data = copy.deepcopy(STRIP_CANTILEVER)
    data["field"]["sources"][0]["waveform"]["frequency"] = "200 Hz"
    data["time"] = {"end": "5 ms", "step": "0.1 ms", "tolerance": 1e-4}
    sim = build_simulation(parse_case(data), comm)
    result = sim.run(progress=False)
    times = result.history["time"]
    assert np.min(np.abs(times - 2.5e-3)) < 1e-12
    assert times[-1] == pytest.approx(5e-3, rel=1e-12)
    steps = np.round(np.diff(times), 12)
    assert len(set(steps)) > 3, steps
    assert sim.controller.last_error is not None


def test_slow_and_easy_steps_count_jacobians_where_newton_kept_some():
    """With ``reuse_jacobian`` a solve's difficulty is its Jacobian assemblies: 12 iterations
    on 2 Jacobians is a cheap, easy step (the kept Jacobian's linear convergence), while
    12 iterations each with its own Jacobian is slow and cuts the next step."""
    from magfem.mechanics.solver import NewtonReport
    from magfem.mechanics.spec import TimeSpec
    from magfem.mechanics.stepping import StepController

    spec = TimeSpec(step=1e-4, max_step=4e-4)  # slow at 10, easy at 4 iterations
    said: list[str] = []
    kept = StepController(spec, lambda t0, t1: np.array([]), said.append)
    for _ in range(2):
        kept.accepted(0.0, NewtonReport(True, 2, 12, 12, 1e-9, jacobians=2), 0, 1e-4)
    assert kept.dt == pytest.approx(1.5e-4)  # two easy steps: grown
    assert kept.newton_iterations == 24  # the count of iterations stays what it was
    full = StepController(spec, lambda t0, t1: np.array([]), said.append)
    full.accepted(0.0, NewtonReport(True, 2, 12, 12, 1e-9), 0, 1e-4)
    assert full.dt == pytest.approx(0.5e-4)  # slow: the next step cut
    assert "slow Newton (12 it)" in said[-1]
    kept.accepted(0.0, NewtonReport(True, 2, 14, 14, 1e-9, jacobians=10), 0, 1e-4)
    assert "slow Newton (14 it, 10 Jacobians)" in said[-1]
