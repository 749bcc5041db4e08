"""Summary scalars of history columns (magfem/mechanics/observers/summary.py): the cargo's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.mechanics.observers.summary import history_summary, summarize_cargo


def test_cargo_held_time_first_held_and_released_from_the_held_column():
    """Held at the samples 0.3, 0.4, 0.5 and 0.8 s (steps of 0.1 s, then of 0.2 s): first held
    at 0.3 s; released at 1.0 s, after the last held sample (the flicker at 0.6 s is not a
    release); held for 0.2 s (the two intervals held at both ends; a lone held sample adds
    nothing)."""
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0])
    held = np.array([0, 0, 0, 1, 1, 1, 0, 1, 0], dtype=float)
    out = summarize_cargo({"time": t, "cargo_foam_held": held, "cargo_foam_z": t})
    assert out == pytest.approx(
        {"cargo_foam_first_held": 0.3, "cargo_foam_released": 1.0, "cargo_foam_held_time": 0.2}
    )
    assert history_summary({"time": t, "cargo_foam_held": held}, start=0.0, frequency=None) == out


def test_cargo_never_held_or_never_released():
    t = np.linspace(0.0, 1.0, 11)
    never = summarize_cargo({"time": t, "cargo_a_held": np.zeros(11)})
    assert math.isnan(never["cargo_a_first_held"]) and math.isnan(never["cargo_a_released"])
    assert never["cargo_a_held_time"] == 0.0
    kept = summarize_cargo({"time": t, "cargo_a_held": (t >= 0.5).astype(float)})
    assert kept["cargo_a_first_held"] == 0.5 and math.isnan(kept["cargo_a_released"])
    assert kept["cargo_a_held_time"] == pytest.approx(0.5)
