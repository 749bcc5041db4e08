"""Summary scalars of a run's history: largest angles per window, midline indicators, speed.

* **Bending speed** 0° → 90° (:func:`bending_speed`): 90° over the time from
  the last instant the angle was ≤ 0° to the first instant it reaches 90°
  after it (both linearly interpolated between samples), in rad/s
  (reported in °/ms).
* Collapse when an arm's tip moves sideways (across the arm, in the resting
  plane) by more than 0.2 of its length or its midline has more than one
  fold; partial bending when the spread of its out-of-plane displacement
  exceeds 0.1 (:mod:`.arms`). Both over the whole run and, for a periodic
  drive, over the first half period (the first lift).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from magfem.mechanics.observers.body import summarize_body
from magfem.mechanics.observers.swimming import summarize_swimming

__all__ = [
    "COLLAPSE_FOLDS",
    "COLLAPSE_TIP_LATERAL",
    "NEAR_90",
    "PARTIAL_SPREAD",
    "bending_speed",
    "first_crossing",
    "held_max",
    "history_summary",
    "max_over_window",
    "summarize_cargo",
    "summarize_midline",
]

_FIELD = ("Bx", "By", "Bz")
NEAR_90 = math.radians(89.0)
"""Angle at which ``field_90_<arm>`` is read: a tip approaches 90° only asymptotically (the
couple m × B vanishes as its normal turns into the field), so 90° itself is never reached."""
COLLAPSE_TIP_LATERAL = 0.2
"""Sideways tip displacement / L (``tip_lateral_<arm>``, 3D) above which an arm has collapsed."""
COLLAPSE_FOLDS = 1
"""More folds than this: collapse."""
PARTIAL_SPREAD = 0.1
"""std(w)/L above which an arm bends partially."""


def bending_speed(
    times: npt.NDArray[np.float64],
    angles: npt.NDArray[np.float64],
    start: float = 0.0,
    stop: float = math.pi / 2,
) -> float:
    """Mean angular speed (rad/s) of the first rise of ``angles`` from ``start`` to ``stop``.

    (stop − start)/(t_stop − t_start): t_stop the first instant the angle
    reaches ``stop``, t_start the last instant before it at which the angle
    was ≤ ``start`` (both interpolated linearly between samples). nan when the
    angle never reaches ``stop`` or was never ≤ ``start`` before.

    Args:
        times: (N,) s, increasing. angles: (N,) rad (unwrapped).
    """
    t = np.asarray(times, dtype=float)
    th = np.asarray(angles, dtype=float)
    up = np.nonzero(th >= stop)[0]
    if up.size == 0 or up[0] == 0:
        return math.nan
    j = int(up[0])
    t_stop = t[j - 1] + (stop - th[j - 1]) * (t[j] - t[j - 1]) / (th[j] - th[j - 1])
    low = np.nonzero(th[:j] <= start)[0]
    if low.size == 0:
        return math.nan
    i = int(low[-1])
    if th[i + 1] == th[i]:
        t_start = t[i]
    else:
        t_start = t[i] + (start - th[i]) * (t[i + 1] - t[i]) / (th[i + 1] - th[i])
    return (stop - start) / (t_stop - t_start) if t_stop > t_start else math.nan


def first_crossing(
    angles: npt.NDArray[np.float64], values: npt.NDArray[np.float64], stop: float = math.pi / 2
) -> float:
    """``values`` at the first instant |angle| reaches ``stop``, interpolated linearly in the
    angle between the two samples around it (nan when it never does).

    Args:
        angles: (N,) rad (unwrapped). values: (N,) any quantity sampled with them.
    """
    th = np.abs(np.asarray(angles, dtype=float))
    v = np.asarray(values, dtype=float)
    up = np.flatnonzero(th >= stop)
    if up.size == 0:
        return math.nan
    j = int(up[0])
    if j == 0:
        return float(v[0])
    return float(v[j - 1] + (stop - th[j - 1]) * (v[j] - v[j - 1]) / (th[j] - th[j - 1]))


def summarize_midline(
    history: Mapping[str, npt.NDArray[np.float64]],
    *,
    start: float | None = None,
    frequency: float | None = None,
) -> dict[str, float]:
    """Summary entries of the midline and speed observables from a run's history columns.

    Per arm (when its columns exist): ``final_active_length_<arm>`` (m),
    ``max_folds_<arm>``, ``max_tip_normal_<arm>``, ``max_spread_<arm>``,
    ``max_tip_lateral_<arm>`` (3D), ``first_sideways_<arm>`` (s, the first sample
    whose sideways tip displacement exceeds ``COLLAPSE_TIP_LATERAL``, from where the
    side-view bending angle is that of a tip turned across its arm; nan if never, 3D),
    ``bending_speed_<arm>`` (rad/s, 0° → 90°, nan if not reached),
    ``field_90_<arm>`` (T, the field needed for 90°: the applied field's
    magnitude |B| at the first instant the arm reaches ``NEAR_90`` = 89°,
    :func:`first_crossing`; nan if it never does, absent without the ``Bx``,
    ``By``, ``Bz`` columns); and, when any arm has midline columns, the flags
    ``collapse`` (1.0 if an arm's sideways tip displacement exceeds
    ``COLLAPSE_TIP_LATERAL`` = 0.2 or its folds exceed ``COLLAPSE_FOLDS`` = 1,
    else 0.0) and ``partial_bending`` (1.0 if an arm's spread exceeds
    ``PARTIAL_SPREAD`` = 0.1). With a drive ``frequency`` (Hz) and its
    ``start`` (s), the same maxima and flags over [start, start + 1/(2f)] with
    ``_halfperiod`` after the quantity (``max_folds_halfperiod_<arm>``,
    ``collapse_halfperiod``; nan when the run ends before the window does).
    """
    out: dict[str, float] = {}
    t = np.asarray(history["time"], dtype=float)
    for key in history:
        if key.startswith("angle_"):
            arm = key[len("angle_") :]
            out[f"bending_speed_{arm}"] = bending_speed(t, history[key])
            if all(c in history for c in _FIELD):
                field = np.linalg.norm(
                    [np.asarray(history[c], dtype=float) for c in _FIELD], axis=0
                )
                out[f"field_90_{arm}"] = first_crossing(history[key], field, NEAR_90)
    arms = [k[len("active_length_") :] for k in history if k.startswith("active_length_")]
    if not arms:
        return out
    for arm in arms:
        out[f"final_active_length_{arm}"] = float(history[f"active_length_{arm}"][-1])
        if f"tip_lateral_{arm}" in history:
            lateral = np.nan_to_num(np.asarray(history[f"tip_lateral_{arm}"], dtype=float))
            sideways = np.flatnonzero(lateral > COLLAPSE_TIP_LATERAL)
            out[f"first_sideways_{arm}"] = float(t[sideways[0]]) if sideways.size else math.nan
    out |= _failure_indicators(history, arms, np.ones(t.shape, dtype=bool), "")
    if frequency and start is not None:
        rows = _window(t, start, start + 0.5 / frequency)
        lift = _failure_indicators(
            history, arms, np.ones(t.shape, bool) if rows is None else rows, "_halfperiod"
        )
        out |= lift if rows is not None else dict.fromkeys(lift, math.nan)
    return out


def _failure_indicators(
    history: Mapping[str, npt.NDArray[np.float64]],
    arms: list[str],
    rows: npt.NDArray[np.bool_],
    suffix: str,
) -> dict[str, float]:
    """The arms' largest folds, normal and sideways tip displacements and spreads over the
    history ``rows``, and the ``collapse`` / ``partial_bending`` flags they give."""
    out: dict[str, float] = {}
    collapse = partial = False
    for arm in arms:
        peak = {
            q: float(np.nanmax(np.asarray(history[f"{q}_{arm}"], dtype=float)[rows]))
            for q in ("folds", "tip_normal", "spread", "tip_lateral")
            if f"{q}_{arm}" in history
        }
        for q, value in peak.items():
            out[f"max_{q}{suffix}_{arm}"] = value
        collapse |= peak["folds"] > COLLAPSE_FOLDS
        collapse |= peak.get("tip_lateral", 0.0) > COLLAPSE_TIP_LATERAL
        partial |= peak["spread"] > PARTIAL_SPREAD
    out[f"collapse{suffix}"] = float(collapse)
    out[f"partial_bending{suffix}"] = float(partial)
    return out


def history_summary(
    history: Mapping[str, npt.NDArray[np.float64]],
    *,
    start: float,
    frequency: float | None,
    hold: float = 0.0,
) -> dict[str, float]:
    """Summary scalars of a run's history columns (the run's own and the sweep's summary).

    Per arm with an ``angle_<arm>`` column: ``max_angle_<arm>`` (max |θ|, rad),
    ``final_angle_<arm>`` and, for a periodic drive of ``frequency`` (Hz),
    ``max_angle_{halfperiod,1period,2periods}_<arm>`` over [start, start + n/f]
    (nan when the run ends before the window does); with ``hold`` > 0 (s) each
    ``max_angle_*`` also as ``held_angle_*``, the largest |θ| held that long
    (:func:`held_max`); ``max_strain``,
    ``max_bending_strain``, ``max_energy_density`` (J/m³) and ``power_density``
    (f ρE, W/m³); ``first_self_touch`` (s, first sample with a self-contact
    force; nan if none), ``max_self_contact_force`` (N) and, with inelastic
    self-contact, ``self_contact_absorbed`` (J, the energy its impacts lost); and
    :func:`summarize_midline`, for a free body :func:`summarize_body`, for a
    cargo :func:`summarize_cargo` and, in a fluid, :func:`summarize_swimming`.
    Columns that are absent give no entry; blank samples (nan) are skipped.
    """
    t = np.asarray(history["time"], dtype=float)
    out: dict[str, float] = {}
    for key, values in history.items():
        if not key.startswith("angle_"):
            continue
        arm = key[len("angle_") :]
        out[f"final_angle_{arm}"] = float(values[-1])
        holds = {"max": 0.0, "held": hold} if hold else {"max": 0.0}
        for kind, duration in holds.items():
            out[f"{kind}_angle_{arm}"] = held_max(t, values, duration)
            if not frequency:
                continue
            for n, label in ((0.5, "halfperiod"), (1, "1period"), (2, "2periods")):
                end = start + n / frequency
                out[f"{kind}_angle_{label}_{arm}"] = (
                    max_over_window(t, values, start, end, duration)
                    if _window(t, start, end) is not None
                    else math.nan
                )
    out |= summarize_midline(history, start=start, frequency=frequency)
    out |= summarize_body(history)
    out |= summarize_cargo(history)
    for column, key in (("strain", "max_strain"), ("bending_strain", "max_bending_strain")):
        if column in history:
            out[key] = float(np.nanmax(history[column]))
    if "self_contact_force" in history:
        force = np.asarray(history["self_contact_force"], dtype=float)
        touching = np.flatnonzero(force > 0.0)
        out["first_self_touch"] = float(t[touching[0]]) if touching.size else math.nan
        out["max_self_contact_force"] = float(np.nanmax(force))
    if "self_contact_absorbed" in history:
        out["self_contact_absorbed"] = float(history["self_contact_absorbed"][-1])
    if "energy_density" in history:
        out["max_energy_density"] = float(np.nanmax(history["energy_density"]))
        if frequency:
            out["power_density"] = frequency * out["max_energy_density"]
    out |= summarize_swimming(history, frequency)
    return out


def _window(times: npt.NDArray[np.float64], t0: float, t1: float) -> npt.NDArray[np.bool_] | None:
    """The samples with t0 <= t <= t1, or None when the run ends before t1."""
    if times[-1] < t1 - 1e-9:
        return None
    return (times >= t0 - 1e-12) & (times <= t1 + 1e-12)


def max_over_window(
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    t0: float,
    t1: float,
    hold: float = 0.0,
) -> float:
    """:func:`held_max` of the samples with t0 <= t <= t1 (nan when no sample lies there)."""
    mask = (times >= t0 - 1e-12) & (times <= t1 + 1e-12)
    return held_max(times[mask], values[mask], hold) if np.any(mask) else float("nan")


def held_max(
    times: npt.NDArray[np.float64], values: npt.NDArray[np.float64], hold: float = 0.0
) -> float:
    """The largest |value| held for at least ``hold`` (s): the largest a such that |value|
    >= a at every sample of some run of samples t_i .. t_j with t_j − t_i >= hold.

    ``hold`` = 0 gives max |value|. A peak of a smooth history loses little (a cos ωt
    sampled densely: A cos(ω hold/2)); a spike shorter than ``hold`` is not counted. Blank
    samples (nan) are skipped; nan when no run of samples spans ``hold``.
    """
    t = np.asarray(times, dtype=float)
    a = np.abs(np.asarray(values, dtype=float))
    if hold < 0.0 or not math.isfinite(hold):
        raise ValueError(f"hold must be >= 0 and finite, got {hold!r} s")
    if a.size == 0 or np.all(np.isnan(a)):
        return math.nan
    if hold == 0.0:
        return float(np.nanmax(a))
    ends = np.searchsorted(t, t + hold * (1.0 - 1e-12), side="left")
    best = -math.inf
    for i, j in enumerate(ends):
        if j >= t.size:
            break
        span = a[i : j + 1]
        if not np.all(np.isnan(span)):
            best = max(best, float(np.nanmin(span)))
    return best if best > -math.inf else math.nan


def summarize_cargo(history: Mapping[str, npt.NDArray[np.float64]]) -> dict[str, float]:
    """Per ``cargo_<name>_held`` column (1 or 0 per sample): ``cargo_<name>_first_held`` (s, the
    first sample held; nan if never), ``_released`` (s, the first sample after the last held
    one, when the run ends with the cargo not held; nan if it is held at the end or never) and
    ``_held_time`` (s, summed over the intervals held at both ends). A grip that flickers
    (contact forces that dip below half the weight for a step) is not a release."""
    t = np.asarray(history["time"], dtype=float)
    out: dict[str, float] = {}
    for key, values in history.items():
        if not (key.startswith("cargo_") and key.endswith("_held")):
            continue
        name = key.removesuffix("_held")
        held = np.nan_to_num(np.asarray(values, dtype=float)) > 0.5
        both = held[1:] & held[:-1]
        last = int(np.flatnonzero(held)[-1]) if held.any() else -1
        out[f"{name}_first_held"] = float(t[np.argmax(held)]) if held.any() else math.nan
        out[f"{name}_released"] = float(t[last + 1]) if 0 <= last < t.size - 1 else math.nan
        out[f"{name}_held_time"] = float(np.sum(np.diff(t)[both]))
    return out
