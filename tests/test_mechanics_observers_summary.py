"""Summary scalars of history columns (magfem/mechanics/observers/summary.py): the cargo's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.mechanics.observers.summary import held_max, history_summary, summarize_cargo


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


def test_held_max_of_a_densely_sampled_cosine_is_a_cos_of_half_the_hold():
    """A cos ωt keeps |θ| >= A cos(ω τ/2) over the τ around each peak and no more: the
    closed form, to the sampling's error (spacing 1 µs at ω τ/2 = 0.2)."""
    t = np.arange(0.0, 0.2, 1e-6)
    omega, amplitude, hold = 2 * math.pi * 20.0, 3.0, 2 * 0.2 / (2 * math.pi * 20.0)
    held = held_max(t, amplitude * np.cos(omega * t), hold)
    exact = amplitude * math.cos(omega * hold / 2)
    assert held == pytest.approx(exact, abs=amplitude * omega * 1e-6)
    assert held_max(t, amplitude * np.cos(omega * t)) == pytest.approx(amplitude)  # hold 0


def test_held_max_drops_a_spike_shorter_than_the_hold_and_keeps_a_plateau():
    """A one-sample flick of 40 above a plateau at 300 held 0.2 ms: the plateau, not the
    flick; blank samples are skipped; no span of the hold's length gives nan."""
    t = np.arange(0.0, 1e-3, 2.5e-5)
    angle = np.where((t > 0.3e-3) & (t < 0.5e-3 + 1e-9), 300.0, 100.0)
    spike = angle.copy()
    spike[5] = 340.0
    assert held_max(t, spike) == 340.0
    assert held_max(t, spike, 0.1e-3) == 300.0
    assert held_max(t, spike, 0.25e-3) == 100.0  # longer than the plateau
    gappy = spike.copy()
    gappy[14] = np.nan
    assert held_max(t, gappy, 0.1e-3) == 300.0
    assert math.isnan(held_max(t, spike, 2e-3))
    with pytest.raises(ValueError, match="hold must be >= 0"):
        held_max(t, spike, -1e-6)


def test_history_summary_holds_the_largest_angles_in_every_window():
    """``hold`` adds ``held_angle_*`` beside each ``max_angle_*``, the whole run's and each
    period's alike; without it there are none."""
    t = np.arange(0.0, 0.1 + 1e-9, 2.5e-5)
    angle = np.radians(60.0) * np.sin(2 * math.pi * 10.0 * t)
    angle[1000] += np.radians(50.0)  # a flick at the first peak (25 ms)
    history = {"time": t, "angle_arm": angle}
    plain = history_summary(history, start=0.0, frequency=10.0)
    held = history_summary(history, start=0.0, frequency=10.0, hold=1e-4)
    assert math.degrees(plain["max_angle_halfperiod_arm"]) > 100.0
    assert not any(k.startswith("held_") for k in plain)
    for window in ("", "halfperiod_", "1period_"):
        assert held[f"max_angle_{window}arm"] == plain[f"max_angle_{window}arm"]
        assert math.degrees(held[f"held_angle_{window}arm"]) == pytest.approx(60.0, abs=0.01)
