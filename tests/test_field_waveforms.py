"""Waveforms: values, one-sided limits, switching instants, the R-L coil current; bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.config import CaseError, from_table
from magfem.field.source_spec import WaveformSpec
from magfem.field.waveforms import build_waveform


def wave(**table):
    return build_waveform(from_table(WaveformSpec, table, "waveform"), nominal_current=3.0)


def test_square_values_limits_and_breakpoints():
    w = wave(kind="square", frequency="20 Hz")  # period 50 ms, high first
    assert w.value(0.0) == 1.0 and w.value(0.010) == 1.0 and w.value(0.030) == -1.0
    np.testing.assert_allclose(w.breakpoints(0.0, 0.1), [0.025, 0.05, 0.075, 0.1], atol=1e-15)
    # one-sided limits at a switching instant
    assert w.value(0.025, side="left") == 1.0 and w.value(0.025, side="right") == -1.0
    assert w.value(0.05, side="left") == -1.0 and w.value(0.05, side="right") == 1.0
    # vectorised, shape preserved
    t = np.linspace(0.001, 0.099, 12).reshape(3, 4)
    v = w.value(t)
    assert v.shape == (3, 4)
    np.testing.assert_array_equal(v, np.where((t % 0.05) < 0.025, 1.0, -1.0))


def test_square_phase_duty_start_and_unipolar():
    # 90 deg phase advances the wave by a quarter period
    w = wave(kind="square", frequency=10.0, phase="90 deg")
    np.testing.assert_allclose(w.breakpoints(0.0, 0.1), [0.025, 0.075], atol=1e-15)
    w = wave(kind="square", frequency=10.0, duty=0.25, start="5 ms", bipolar=False)
    assert w.value(0.004) == 0.0  # before start
    assert w.value(0.005, side="left") == 0.0 and w.value(0.005) == 1.0
    np.testing.assert_allclose(w.breakpoints(0.0, 0.1), [0.005, 0.03], atol=1e-15)
    assert w.value(0.05) == 0.0 and w.value(0.106) == 1.0


def test_sine_and_trigger():
    w = wave(kind="sine", frequency="50 Hz", phase=0.3, amplitude=-0.5)
    t = np.linspace(0, 0.05, 7)
    np.testing.assert_allclose(w.value(t), -0.5 * np.sin(2 * math.pi * 50 * t + 0.3), atol=1e-15)
    assert len(w.breakpoints(0.0, 1.0)) == 0
    # trigger: 5 ms pulse at 10 ms
    w = wave(kind="trigger", start="10 ms", duration="5 ms")
    np.testing.assert_allclose(w.breakpoints(0.0, 1.0), [0.010, 0.015])
    assert w.value(0.015, side="left") == 1.0 and w.value(0.015) == 0.0
    assert w.value(0.0125) == 1.0 and w.value(0.0099) == 0.0


@pytest.mark.parametrize(
    "table",
    [
        {"kind": "square", "frequency": "20 Hz", "start": "5 ms", "duration": "50 ms"},
        {"kind": "sine", "frequency": "50 Hz", "phase": 0.3, "amplitude": -0.5},
        {"kind": "trigger", "start": "10 ms", "duration": "5 ms"},
        {"kind": "table", "times": [0.0, 0.01, 0.01, 0.03], "values": [0.0, 1.0, -1.0, 0.5]},
    ],
    ids=lambda t: t["kind"],
)
def test_a_scalar_time_gives_the_arrays_value_on_both_sides(table):
    """The time loop asks one float at a time (a shortcut past the array path): the same
    value on both sides of every switch, window edge and point in between."""
    w = wave(**table)
    edges = np.concatenate([w.breakpoints(-1.0, 0.1), [0.0, w.start]])
    times = np.concatenate([edges, edges - 1e-9, edges + 1e-9, np.linspace(-0.01, 0.1, 57)])
    for side in ("left", "right"):
        array = w.value(times, side=side)
        scalar = [w.value(float(t), side=side) for t in times]
        assert all(isinstance(v, float) for v in scalar)
        np.testing.assert_array_equal(scalar, array, err_msg=side)


def test_delay_is_an_alias_of_start():
    assert wave(kind="dc", delay="3 ms").breakpoints(0.0, 1.0)[0] == pytest.approx(0.003)
    with pytest.raises(CaseError, match="not both"):
        from_table(WaveformSpec, {"kind": "dc", "delay": 1.0, "start": 1.0}, "waveform")


def test_table_interpolation_and_jump():
    w = wave(kind="table", times=[0.0, 0.01, 0.01, 0.02], values=[0.0, 1.0, -1.0, 0.0])
    assert w.value(0.005) == pytest.approx(0.5)
    assert w.value(0.015) == pytest.approx(-0.5)
    assert w.value(0.01, side="left") == pytest.approx(1.0)
    assert w.value(0.01, side="right") == pytest.approx(-1.0)
    assert w.value(0.5) == 0.0  # held after the table
    np.testing.assert_allclose(w.breakpoints(0.0, 1.0), [0.01])


def _rl_reference(t_end, f, L, R, V, I0, dt=2e-7):
    """Independent check: RK4 on L di/dt = σV − R i with the regulator clamp, fixed small steps."""
    n = round(t_end / dt)
    i, out = 0.0, np.zeros(n + 1)
    for k in range(n):
        t = k * dt
        cmd = I0 if (t * f) % 1.0 < 0.5 else -I0

        def rhs(ii, cmd=cmd):
            return (math.copysign(V, cmd - ii) - R * ii) / L

        k1 = rhs(i)
        k2 = rhs(i + dt / 2 * k1)
        k3 = rhs(i + dt / 2 * k2)
        k4 = rhs(i + dt * k3)
        new = i + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if (new - cmd) * (i - cmd) <= 0:  # reached the command: the regulator holds it
            new = cmd
        i = new
        out[k + 1] = i
    return out / I0


def test_square_rl_against_time_integration():
    # the experiments' coil: 4.5 mH, 1 Ohm, +-20 V, here 3 A nominal, 50 Hz
    w = wave(kind="square_rl", frequency="50 Hz")
    t = np.arange(0, round(0.04 / 2e-7) + 1) * 2e-7
    ref = _rl_reference(0.04, 50.0, 4.5e-3, 1.0, 20.0, 3.0)
    # RK4 with dt = 0.2 us; the clamp lags by up to one step: error <= (V + R I0)/L dt / I0
    # = 3.5e-4 (measured 1.7e-4); bound 5e-4
    assert np.max(np.abs(w.value(t) - ref)) < 5e-4
    # full swing -I0 -> +I0 takes tau ln((beta+1)/(beta-1)), beta = V/(R I0)
    beta, tau = 20.0 / 3.0, 4.5e-3
    t_rise = tau * math.log((beta + 1) / (beta - 1))
    assert t_rise == pytest.approx(1.36e-3, rel=1e-2)
    assert w.value(0.02 + 0.999 * t_rise) < 1.0 and w.value(0.02 + 1.001 * t_rise) == 1.0
    np.testing.assert_allclose(w.breakpoints(0.0, 0.05), [0.01, 0.02, 0.03, 0.04, 0.05])


def test_square_rl_never_reaches_at_high_frequency():
    # half period 0.5 ms < rise time: a triangle-like exponential wave, |w| < 1, continuous
    w = wave(kind="square_rl", frequency="1 kHz")
    t = np.linspace(0.0, 0.01, 20001)
    v = w.value(t)
    assert np.max(np.abs(v)) < 1.0
    # slope |dw/dt| = |σβ − w|/τ <= (β + 1)/τ
    assert np.max(np.abs(np.diff(v))) <= (20.0 / 3.0 + 1.0) / 4.5e-3 * (t[1] - t[0])


@pytest.mark.parametrize(
    "table, key",
    [
        ({"kind": "saw", "frequency": 1.0}, "waveform.kind"),
        ({"kind": "square", "frequency": 0.0}, "waveform.frequency"),
        ({"kind": "square", "frequency": "-2 Hz"}, "waveform.frequency"),
        ({"kind": "square"}, "waveform.frequency"),
        ({"kind": "sine", "frequency": "1 m"}, "waveform.frequency"),
        ({"kind": "trigger"}, "waveform.duration"),
        ({"kind": "dc", "frequency": 3.0}, "waveform.frequency"),
        ({"kind": "square", "frequency": 1.0, "duty": 1.0}, "waveform.duty"),
        ({"kind": "table", "times": [0, 1], "values": [0]}, "waveform.values"),
        ({"kind": "table", "times": [1, 0], "values": [0, 1]}, "waveform.times"),
        ({"kind": "table", "times": [0, 1], "values": [0, 2]}, "waveform.values"),
        ({"kind": "dc", "amplitude": 1.5}, "waveform.amplitude"),
    ],
)
def test_bad_waveform_input(table, key):
    with pytest.raises(CaseError) as err:
        from_table(WaveformSpec, table, "waveform")
    assert err.value.key == key
    assert "\n" not in str(err.value)


def test_square_rl_needs_enough_voltage():
    spec = from_table(WaveformSpec, {"kind": "square_rl", "frequency": 10.0, "voltage": "2 V"}, "w")
    with pytest.raises(CaseError, match="voltage"):
        build_waveform(spec, nominal_current=3.0)
    spec = from_table(WaveformSpec, {"kind": "square_rl", "frequency": 10.0}, "w")
    with pytest.raises(CaseError, match="current"):
        build_waveform(spec)  # a uniform source has no nominal current
