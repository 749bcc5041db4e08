"""Warnings for legal but implausible cases (magfem.sanity): each threshold warns just past
it and stays silent just before it (a test that cannot pass by warning always)."""

from __future__ import annotations

import copy
import logging
import math

import pytest

from magfem.case import load_case, parse_case
from magfem.pipeline import build_simulation
from magfem.sanity import START_STEP_FRACTION, SWITCH_ROTATION, SwitchWatch, implausible
from verification.setups import STRIP_CANTILEVER


def _case(**changes):
    data = copy.deepcopy(STRIP_CANTILEVER)
    for path, value in changes.items():
        node = data
        *head, last = path.split("__")
        for key in head:
            node = node[key][0] if key == "sources" else node[key]
        node[last] = value
    return parse_case(data)


def test_the_strip_case_is_plausible():
    assert implausible(_case()) == []


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"field__sources__flux_density": "1.1 T"}, "a missing unit?"),
        ({"field__sources__waveform": {"kind": "square", "frequency": "500 Hz"}}, "not resolved"),
        ({"mesh__size": "19 um"}, "below 0.25 of the thickness"),
        ({"time__end": "300 s"}, "would take days"),
        (
            {
                "field__sources__waveform": {"kind": "square", "frequency": "100 Hz"},
                "output__history_interval": "0.6 ms",
            },
            "miss the peaks",
        ),
    ],
)
def test_each_implausible_value_warns_with_one_line(changes, words):
    lines = implausible(_case(**changes))
    assert len(lines) == 1 and words in lines[0] and "\n" not in lines[0], lines


@pytest.mark.parametrize(
    "changes",
    [
        {"field__sources__flux_density": "0.9 T"},
        # 10 steps of 0.25 ms per period: at the limit, not below it
        {"field__sources__waveform": {"kind": "square", "frequency": "400 Hz"}},
        {"mesh__size": "21 um"},
        # 20 rows per period of 100 Hz: at the limit
        {
            "field__sources__waveform": {"kind": "square", "frequency": "100 Hz"},
            "output__history_interval": "0.5 ms",
        },
    ],
)
def test_values_inside_the_limits_do_not_warn(changes):
    assert implausible(_case(**changes)) == []


def test_a_turn_after_a_switch_warns_once():
    """An arm that turns more than SWITCH_ROTATION in the step after a switching instant."""
    warnings: list[str] = []
    switches = lambda t0, t1: [t for t in (1.0, 2.0) if t0 < t <= t1]  # noqa: E731
    watch = SwitchWatch(["arm"], switches, warnings.append)
    small = 0.9 * SWITCH_ROTATION
    for step, (t, angle) in enumerate([(0.5, 0.0), (1.0, 0.0), (1.5, small), (1.7, 1.0)]):
        watch.write(step, t, {"angle_arm": angle})
    assert warnings == []  # a large turn not after a switch, a small one after it
    for step, (t, angle) in enumerate([(2.0, 1.0), (2.5, 1.0 + 2 * SWITCH_ROTATION)], 4):
        watch.write(step, t, {"angle_arm": angle})
    watch.write(6, 3.0, {"angle_arm": 0.0})
    assert len(warnings) == 1 and "t = 2 s" in warnings[0]
    assert f"{math.degrees(2 * SWITCH_ROTATION):.3g} deg" in warnings[0]


@pytest.mark.parametrize(("radius", "warns"), [("1 mm", False), ("3 mm", True)])
def test_supports_that_hold_most_of_the_body_warn(radius, warns, comm, caplog):
    """A 7.5 mm strip pinned within a radius of its middle: 1 mm holds ~25 % of the nodes,
    3 mm ~80 % (the threshold is 50 %)."""
    data = copy.deepcopy(STRIP_CANTILEVER) | {"mesh": {"size": "1 mm", "model": "strip"}}
    data["environment"] = {"clamped": [], "fixed_point": [3.75e-3, 0, 0], "fixed_radius": radius}
    case = parse_case(data)
    with caplog.at_level(logging.WARNING, logger="magfem"):
        build_simulation(case, comm)
    found = [r.getMessage() for r in caplog.records if "the supports" in r.getMessage()]
    assert bool(found) == warns, found


@pytest.mark.parametrize(
    ("sets", "warns"),
    [
        ([], False),  # the case's 0.05 ms
        (["time.step=0.25ms"], False),  # just below 0.1 τ, τ = 2.54 ms
        (["time.step=0.26ms"], True),  # just above
        (["time.step=2ms"], True),  # the start that threw the propeller over
        (
            [
                "time.step=2ms",
                "field.sources.0.waveform.start=1ms",
                "field.sources.1.waveform.start=1ms",
            ],
            False,
        ),
        (["time.step=2ms", "time.scheme=quasi_static"], False),
    ],
)
def test_a_long_first_step_of_a_free_robot_in_a_fluid_warns(repo, sets, warns):
    """The propeller (free, in water, field on from t = 0): a first step above 0.1 of the
    magnetoelastic time warns; a field switched on later, or no inertia, does not."""
    case = load_case(repo / "cases" / "propeller.toml", sets)
    lines = implausible(case)
    assert len(lines) == int(warns), lines
    if warns:
        assert f"more than {START_STEP_FRACTION:g} of the magnetoelastic time" in lines[0]
        assert "\n" not in lines[0]
