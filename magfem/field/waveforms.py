"""Waveforms: dimensionless time functions w(t) in [-1, 1] that scale a source's nominal strength.

Each waveform exposes

* ``value(t, *, side="right")``: w(t); at a discontinuity ``side`` picks the
  one-sided limit (``"right"``: lim s↓t, ``"left"``: lim s↑t). ``t`` may be a
  float (float returned) or an array (array of the same shape returned).
* ``breakpoints(t0, t1)``: the sorted instants in (t0, t1] where w or its
  slope jumps (switching instants), so a time stepper can land on them and
  use one-sided limits there (a generalised-α step evaluates the load inside
  the step, so a switch must fall on a step boundary).

All kinds are 0 before ``start``; where a ``duration`` is given they are 0
from ``start + duration`` on (the ``square_rl`` current then decays through
the supply instead of jumping).

Square wave with a coil's finite rise time (``square_rl``)
----------------------------------------------------------
A coil of inductance L and resistance R on a bipolar supply of voltage V that
regulates the current to a commanded value ±I0 (a current-mode amplifier:
±20 V, ±10 A in the experiments). After the command switches to c·I0
(c ∈ {−1, 0, 1}), the supply saturates at σV, σ = sign(c − i/I0), and

    L di/dt = σV − R i   ⇒   w(t) = σβ + (w_k − σβ) exp(−(t − s_k)/τ),

with w = i/I0, β = V/(R I0), τ = L/R and w_k the value at the switching
instant s_k, until w reaches c; from then on the regulator holds w = c.
The command must be reachable: β > 1 (V > R I0). Reaching c takes
τ ln((σβ − w_k)/(σβ − c)); for L = 4.5 mH, R = 1 Ω, V = 20 V, I0 = 3 A a
full swing −1 → +1 takes 4.5 ms · ln(23/17) = 1.36 ms. If the half period is
shorter, the current never reaches ±I0 and the waveform is a sequence of
exponentials; it is computed exactly, switch by switch, from the start.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from magfem.config import CaseError
from magfem.field.source_spec import WaveformSpec

__all__ = [
    "DC",
    "Sine",
    "Square",
    "SquareRL",
    "Table",
    "Waveform",
    "build_waveform",
]

_EDGE = 1e-9  # relative tolerance (fraction of a period / of a time) to snap onto an edge


def _check_side(side: str) -> None:
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")


class Waveform(ABC):
    """A dimensionless time function w(t), |w| <= 1 (see the module docstring).

    Args:
        start: switch-on instant, s (w = 0 before it).
        duration: on-time, s, or None for no end.
        amplitude: constant multiplier, |amplitude| <= 1.
    """

    def __init__(
        self, *, start: float = 0.0, duration: float | None = None, amplitude: float = 1.0
    ):
        self.start = float(start)
        self.end = math.inf if duration is None else self.start + float(duration)
        self.amplitude = float(amplitude)

    # -- to be provided by subclasses ------------------------------------------------------
    @abstractmethod
    def _raw(self, tau: np.ndarray, side: str) -> np.ndarray:
        """w at times ``tau = t − start`` (>= 0), ignoring the window."""

    def _raw_breaks(self, tau0: float, tau1: float) -> list[float]:
        """Interior switching instants (in t − start) in (tau0, tau1]."""
        return []

    # -- public API ------------------------------------------------------------------------
    def value(self, t: Any, *, side: str = "right") -> Any:
        """w(t) (float for a scalar t, array of t's shape otherwise)."""
        _check_side(side)
        if isinstance(t, (float, int)):  # the time loop's scalar, without the array steps
            tf = float(t)
            inside = self.start <= tf < self.end if side == "right" else self.start < tf <= self.end
            if not inside:
                return 0.0
            return self.amplitude * float(self._raw(np.array([tf - self.start]), side)[0])
        ta = np.asarray(t, dtype=float)
        flat = np.atleast_1d(ta).ravel()
        if side == "right":
            on = (flat >= self.start) & (flat < self.end)
        else:
            on = (flat > self.start) & (flat <= self.end)
        out = np.zeros_like(flat)
        if np.any(on):
            out[on] = self.amplitude * self._raw(flat[on] - self.start, side)
        if ta.ndim == 0:
            return float(out[0])
        return out.reshape(ta.shape)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Sorted switching instants in (t0, t1], s (shape (K,))."""
        pts: list[float] = []
        if t0 < self.start <= t1:
            pts.append(self.start)
        if t0 < self.end <= t1:
            pts.append(self.end)
        lo, hi = max(t0, self.start), min(t1, self.end)
        if hi > lo:
            pts.extend(self.start + b for b in self._raw_breaks(lo - self.start, hi - self.start))
        arr = np.unique(np.asarray([p for p in pts if t0 < p <= t1], dtype=float))
        return arr

    def __call__(self, t: Any, *, side: str = "right") -> Any:
        return self.value(t, side=side)


class DC(Waveform):
    """w = 1 inside the window (``dc`` and ``trigger``)."""

    def _raw(self, tau: np.ndarray, side: str) -> np.ndarray:
        return np.ones_like(tau)


class Sine(Waveform):
    """w = sin(2π f (t − start) + phase)."""

    def __init__(self, frequency: float, phase: float = 0.0, **window: Any):
        super().__init__(**window)
        self.frequency = float(frequency)
        self.phase = float(phase)

    def _raw(self, tau: np.ndarray, side: str) -> np.ndarray:
        return np.sin(2 * math.pi * self.frequency * tau + self.phase)


class Square(Waveform):
    """Square wave: high (+1) for the first ``duty`` of each period, low (−1, or 0) otherwise.

    The period position is p = f (t − start) + phase / 2π; w is high for
    frac(p) ∈ [0, duty).
    """

    def __init__(
        self,
        frequency: float,
        phase: float = 0.0,
        duty: float = 0.5,
        bipolar: bool = True,
        **window: Any,
    ):
        super().__init__(**window)
        self.frequency = float(frequency)
        self.phase = float(phase)
        self.duty = float(duty)
        self.low = -1.0 if bipolar else 0.0

    def _high(self, tau: np.ndarray, side: str) -> np.ndarray:
        p = self.frequency * tau + self.phase / (2 * math.pi)
        u = p - np.floor(p)
        u = np.where(u > 1.0 - _EDGE, 0.0, u)
        if side == "right":
            return u < self.duty - _EDGE
        return (u > _EDGE) & (u < self.duty + _EDGE)

    def _raw(self, tau: np.ndarray, side: str) -> np.ndarray:
        return np.where(self._high(tau, side), 1.0, self.low)

    def _raw_breaks(self, tau0: float, tau1: float) -> list[float]:
        T = 1.0 / self.frequency
        shift = self.phase / (2 * math.pi)
        out: list[float] = []
        for frac in (0.0, self.duty):
            n0 = math.floor(tau0 / T + shift - frac) - 1
            n1 = math.ceil(tau1 / T + shift - frac) + 1
            for n in range(n0, n1 + 1):
                tb = (n + frac - shift) * T
                if tau0 < tb <= tau1:
                    out.append(tb)
        return out


class Table(Waveform):
    """Piecewise-linear w through (times, values); times relative to ``start``, held outside."""

    def __init__(self, times: np.ndarray, values: np.ndarray, **window: Any):
        super().__init__(**window)
        self.times = np.asarray(times, dtype=float)
        self.values = np.asarray(values, dtype=float)

    def _raw(self, tau: np.ndarray, side: str) -> np.ndarray:
        t, v = self.times, self.values
        i = np.searchsorted(t, tau, side="right" if side == "right" else "left")
        out = np.empty_like(tau)
        first, last = i == 0, i == len(t)
        out[first] = v[0]
        out[last] = v[-1]
        mid = ~(first | last)
        j = i[mid]
        w = (tau[mid] - t[j - 1]) / (t[j] - t[j - 1])
        out[mid] = (1 - w) * v[j - 1] + w * v[j]
        return out

    def _raw_breaks(self, tau0: float, tau1: float) -> list[float]:
        t = self.times
        jumps = [t[k] for k in range(1, len(t)) if t[k] == t[k - 1]]
        return [float(x) for x in jumps if tau0 < x <= tau1]


class SquareRL(Square):
    """Coil current under a square command with the finite rise of an R-L load (module docstring).

    Args:
        frequency, phase, duty: of the commanded square wave (bipolar).
        inductance: L, H. resistance: R, Ω. voltage: supply V, V.
        current: nominal current I0, A (w = ±1 is ±I0); V/R must exceed it.
    """

    def __init__(
        self,
        frequency: float,
        *,
        inductance: float,
        resistance: float,
        voltage: float,
        current: float,
        phase: float = 0.0,
        duty: float = 0.5,
        start: float = 0.0,
        duration: float | None = None,
        amplitude: float = 1.0,
    ):
        super().__init__(frequency, phase, duty, True, start=start, amplitude=amplitude)
        self.tau = inductance / resistance
        self.beta = voltage / (resistance * current)
        self.off = math.inf if duration is None else float(duration)  # relative to start
        # switching states: instants s_k (relative), commands c_k, values w_k at s_k
        self._s: list[float] = [0.0]
        self._c: list[float] = [float(self._command(np.array([0.0]))[0])]
        self._w: list[float] = [0.0]

    def _command(self, tau: np.ndarray) -> np.ndarray:
        c = np.where(self._high(tau, "right"), 1.0, -1.0)
        return np.where(tau >= self.off, 0.0, c)

    def _evolve(self, w0: float, c: float, dt: np.ndarray) -> np.ndarray:
        """w after time dt from w0 under command c (exact, saturated at c)."""
        if w0 == c:
            return np.full_like(dt, c)
        sigma = 1.0 if c > w0 else -1.0
        w = sigma * self.beta + (w0 - sigma * self.beta) * np.exp(-dt / self.tau)
        return np.minimum(w, c) if sigma > 0 else np.maximum(w, c)

    def _extend(self, tau_max: float) -> None:
        """Append switching states up to ``tau_max``."""
        while self._s[-1] <= tau_max and self._c[-1] != 0.0:
            s0 = self._s[-1]
            horizon = s0 + 2.0 / self.frequency
            nxt = list(Square._raw_breaks(self, s0, horizon))
            if self.off <= horizon:
                nxt.append(self.off)
            s1 = min(b for b in nxt if b > s0)
            w1 = float(self._evolve(self._w[-1], self._c[-1], np.array([s1 - s0]))[0])
            c1 = 0.0 if s1 >= self.off else -self._c[-1]
            self._s.append(s1)
            self._c.append(c1)
            self._w.append(w1)

    def _raw(self, tau: np.ndarray, side: str) -> np.ndarray:
        self._extend(float(np.max(tau)))
        s = np.asarray(self._s)
        k = np.searchsorted(s, tau, side="right") - 1  # continuous: side does not matter
        out = np.empty_like(tau)
        for kk in np.unique(k):
            m = k == kk
            out[m] = self._evolve(self._w[kk], self._c[kk], tau[m] - s[kk])
        return out

    def value(self, t: Any, *, side: str = "right") -> Any:
        """Coil current / I0 at t (continuous in t; zero before start)."""
        _check_side(side)
        ta = np.asarray(t, dtype=float)
        flat = np.atleast_1d(ta).ravel()
        out = np.zeros_like(flat)
        on = flat > self.start
        if np.any(on):
            out[on] = self.amplitude * self._raw(flat[on] - self.start, side)
        return float(out[0]) if ta.ndim == 0 else out.reshape(ta.shape)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Command switching instants in (t0, t1] (slope discontinuities of the current)."""
        pts = [self.start] if t0 < self.start <= t1 else []
        lo, hi = max(t0, self.start) - self.start, min(t1, self.start + self.off) - self.start
        if hi > lo:
            pts.extend(self.start + b for b in Square._raw_breaks(self, lo, hi))
        if t0 < self.start + self.off <= t1:
            pts.append(self.start + self.off)
        return np.unique(np.asarray([p for p in pts if t0 < p <= t1], dtype=float))


def build_waveform(
    spec: WaveformSpec, *, nominal_current: float | None = None, key: str = "waveform"
) -> Waveform:
    """Create the :class:`Waveform` described by ``spec``.

    Args:
        spec: validated waveform table.
        nominal_current: the source's nominal current, A (coils); used by
            ``square_rl`` when ``spec.current`` is not given.
        key: table path for error messages.

    Raises:
        CaseError: square_rl without a known nominal current, or V/R <= I0.
    """
    window: dict[str, Any] = {"start": spec.start, "amplitude": spec.amplitude}
    if spec.kind in ("dc", "trigger"):
        return DC(duration=spec.duration, **window)
    if spec.kind == "sine":
        assert spec.frequency is not None  # validated in WaveformSpec
        return Sine(spec.frequency, spec.phase, duration=spec.duration, **window)
    if spec.kind == "square":
        assert spec.frequency is not None
        return Square(
            spec.frequency, spec.phase, spec.duty, spec.bipolar, duration=spec.duration, **window
        )
    if spec.kind == "table":
        assert spec.times is not None and spec.values is not None
        return Table(np.asarray(spec.times), np.asarray(spec.values), **window)
    if spec.kind == "square_rl":
        assert spec.frequency is not None
        current = spec.current if spec.current is not None else nominal_current
        if current is None:
            raise CaseError(
                f"{key}.current",
                None,
                "square_rl needs the coil's nominal current (A) for this source",
            )
        if not spec.voltage > spec.resistance * current:
            raise CaseError(
                f"{key}.voltage",
                spec.voltage,
                f"cannot drive {current:g} A through {spec.resistance:g} Ohm; "
                f"must be > {spec.resistance * current:g} V",
            )
        return SquareRL(
            spec.frequency,
            inductance=spec.inductance,
            resistance=spec.resistance,
            voltage=spec.voltage,
            current=current,
            phase=spec.phase,
            duty=spec.duty,
            duration=spec.duration,
            **window,
        )
    raise CaseError(f"{key}.kind", spec.kind, "unknown waveform")  # unreachable after validation
