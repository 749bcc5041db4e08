"""Swimming observables: the roll and pitch of a rigidly turned body, and the history summary."""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.case import parse_case
from magfem.mechanics.observers import summarize_swimming
from magfem.pipeline import build_simulation


def _plate(model: str):
    return parse_case(
        {
            "name": "turned",
            "robot": {"shape": "membrane", "thickness": "50 um", "length": "4 mm", "width": "2 mm"},
            "mesh": {"size": "1 mm", "model": model},
            "material": {"shear_modulus": "115 kPa", "density": 2130},
            "environment": {"clamped": [], "gravity": [0, 0, 0]},
            "fluid": {"medium": "water", "swim_direction": [1, 1, 0]},
            "output": {"csv": False, "vtx_every": 0, "plot": False, "animation": False},
        }
    )


@pytest.mark.parametrize("model", ["surface", "solid"])
@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_roll_and_pitch_of_a_rigid_rotation(comm, model):
    """u = R X − X turns the body rigidly: roll about e = (1, 1, 0)/√2 by 2.5 rad (beyond π/2,
    so the unwrapping across the steps taken to it counts), then pitch about l = e_z × e."""
    sim = build_simulation(_plate(model), comm)
    e = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    lateral = np.cross([0.0, 0.0, 1.0], e)
    swimming = sim.observers[-1]

    def turn(axis, angle):
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        rot = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
        sim.u.interpolate(lambda X: (rot - np.eye(3)) @ X)
        return swimming.observe(0.0)

    for angle in np.linspace(0.0, 2.5, 6):
        row = turn(e, angle)
    assert row["roll"] == pytest.approx(2.5, abs=1e-12)
    assert row["pitch"] == pytest.approx(0.0, abs=1e-12)
    row = turn(lateral, -0.4)  # a nose-up pitch: e turns towards +z
    assert row["pitch"] == pytest.approx(0.4, abs=1e-12)


def test_summary_of_a_periodic_history():
    """Two periods at 2 Hz: the last period's speed, mean thrust and stroke amplitude."""
    t = np.linspace(0.0, 1.0, 401)
    history = {
        "time": t,
        "swim_distance": 0.003 * t + 1e-4 * np.sin(4 * np.pi * t),
        "fluid_thrust": 2e-6 + 5e-6 * np.cos(4 * np.pi * t),
        "fluid_friction": -1e-6 * np.ones_like(t),
        "cost_of_transport": np.full_like(t, 7.0),
        "angle_fin": 0.3 * np.sin(4 * np.pi * t) + 0.1,
    }
    out = summarize_swimming(history, 2.0)
    assert out["swim_speed"] == pytest.approx(0.003, rel=1e-12)
    assert out["mean_thrust"] == pytest.approx(2e-6, rel=1e-4)  # trapezoidal rule, 200 samples
    assert out["mean_friction"] == pytest.approx(-1e-6, rel=1e-12)
    assert out["stroke_amplitude_fin"] == pytest.approx(0.3, rel=1e-4)
    assert out["swim_distance"] == pytest.approx(0.003, rel=1e-9)
    # at t = 0.5 s (sample 200 of the 2.5 ms grid): 0.003 * 0.5 m, sin(2π) = 0
    assert out["swim_distance_1period"] == pytest.approx(0.0015, rel=1e-12)
    short = summarize_swimming({k: v[:50] for k, v in history.items()}, 2.0)
    assert math.isnan(short["swim_speed"])  # less than one period: no mean
    assert math.isnan(short["swim_distance_1period"])
