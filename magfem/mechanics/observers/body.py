"""Observables of a free body: centre of mass, momentum, orientation, and what they summarise to.

History columns (:class:`BodyMotion`, SI units, every rank alike), from
integrals over the body's mass points x = X + u (the shell's mid-surface,
the strip's side view embedded as (x, 0, z), per unit depth × depth):

* ``com_x``, ``com_y``, ``com_z`` — centre of mass c = ∫ρ x / m (m), and
  ``com_vx``.. its velocity ∫ρ v / m (m/s);
* ``momentum_x``.. — linear momentum P = ∫ρ v (kg·m/s), and
  ``angular_momentum_x``.. — L = ∫ρ x × v about the origin (kg·m²/s): the
  translational part of the shell's (its director spin ρt³/12 d × ḋ, a
  fraction t²/L² of it, is left out);
* ``normal_x``.. — the unit normal n of the best-fit plane of the mass
  points: the eigenvector of the smallest eigenvalue of the second moment
  ∫ρ (x − c)(x − c)ᵀ, its sign continued from the placed normal R e_z;
* ``tilt`` — the angle between n and +z (rad, 0 lying face up, 90° upright,
  180° upside down), and the signed inclinations ``tilt_about_x`` =
  atan2(−n_y, n_z) and ``tilt_about_y`` = atan2(n_x, n_z) (a right-handed
  rotation by that angle about x, resp. y, turns +z into n: seen along −y, a
  positive ``tilt_about_y`` is counter-clockwise).

Summary (:func:`summarize_body`; definitions used in docs/untethered.md):

* ``lay_down_time`` / ``stand_up_time`` — duration of the first transition
  between *standing* (folded tilt acos|n_z| ≥ 60°) and *lying* (≤ 30°):
  from the last sample on the old side to the first sample on the new side,
  both interpolated linearly to the thresholds (nan if none);
* ``travelled_distance`` — length of the path of the centre of mass
  projected on the horizontal (x, y) plane (m); ``net_displacement`` — the
  horizontal distance from the first to the last centre of mass (m);
  ``mean_speed`` — ``net_displacement`` over the run's duration (m/s);
* ``max_tilt``, ``final_tilt`` (rad), ``final_com_z`` (m).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl

from magfem.mechanics.forms import ScalarForms
from magfem.mechanics.models.base import Model
from magfem.mechanics.observers.base import Observer

__all__ = ["LIE_ANGLE", "STAND_ANGLE", "BodyMotion", "summarize_body", "transition_time"]

STAND_ANGLE = math.radians(60.0)
"""A body whose folded tilt acos|n_z| is at least this is standing."""
LIE_ANGLE = math.radians(30.0)
"""A body whose folded tilt is at most this is lying."""

_AXES = "xyz"


def _embed(v: Any, gdim: int) -> Any:
    return v if gdim == 3 else ufl.as_vector([v[0], 0.0, v[1]])


class BodyMotion(Observer):
    """The columns of the module docstring for ``model`` (collective).

    Args:
        model: the body.
        normal: its placed normal R e_z (3,), the sign the best-fit normal starts from.
    """

    def __init__(self, model: Model, normal: npt.ArrayLike = (0.0, 0.0, 1.0)):
        self.depth = model.depth
        state, rates = model.accepted()
        gdim = model.gdim
        X = ufl.SpatialCoordinate(model.robot.mesh)
        x = _embed(X + model.displacement(state), gdim)
        v = _embed(model.displacement(rates), gdim)
        rho, dx = model.mass_density, model.dx
        L = ufl.cross(x, v)
        integrands = [rho * 1.0]
        integrands += [rho * x[i] for i in range(3)]
        integrands += [rho * v[i] for i in range(3)]
        integrands += [rho * L[i] for i in range(3)]
        integrands += [rho * x[i] * x[j] for i in range(3) for j in range(i, 3)]
        self.forms = ScalarForms(model.robot.mesh, [f * dx for f in integrands])
        self.normal = np.asarray(normal, dtype=float)

    def columns(self) -> list[str]:
        cols = [f"com_{a}" for a in _AXES] + [f"com_v{a}" for a in _AXES]
        cols += [f"momentum_{a}" for a in _AXES] + [f"angular_momentum_{a}" for a in _AXES]
        cols += [f"normal_{a}" for a in _AXES]
        return [*cols, "tilt", "tilt_about_x", "tilt_about_y"]

    def observe(self, t: float) -> dict[str, float]:
        values = np.array(self.forms.assemble()) * self.depth
        mass = values[0]
        first, momentum, spin = values[1:4], values[4:7], values[7:10]
        com = first / mass
        second = np.zeros((3, 3))
        second[np.triu_indices(3)] = values[10:16]
        second = second + np.triu(second, 1).T
        spread = second / mass - np.outer(com, com)
        n = np.linalg.eigh(spread)[1][:, 0]
        if n @ self.normal < 0.0:
            n = -n
        self.normal = n
        row = {f"com_{a}": float(c) for a, c in zip(_AXES, com, strict=True)}
        row |= {f"com_v{a}": float(p / mass) for a, p in zip(_AXES, momentum, strict=True)}
        row |= {f"momentum_{a}": float(p) for a, p in zip(_AXES, momentum, strict=True)}
        row |= {f"angular_momentum_{a}": float(s) for a, s in zip(_AXES, spin, strict=True)}
        row |= {f"normal_{a}": float(c) for a, c in zip(_AXES, n, strict=True)}
        row["tilt"] = math.acos(float(np.clip(n[2], -1.0, 1.0)))
        row["tilt_about_x"] = math.atan2(-n[1], n[2])
        row["tilt_about_y"] = math.atan2(n[0], n[2])
        return row

    def state(self) -> dict[str, Any]:
        """The sign the next best-fit normal follows (the last one)."""
        return {"normal": self.normal.tolist()}

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`state`."""
        self.normal = np.asarray(state["normal"], dtype=float)


def transition_time(
    times: npt.NDArray[np.float64], values: npt.NDArray[np.float64], start: float, stop: float
) -> float:
    """Duration (s) of the first crossing of ``values`` from ``start`` to ``stop`` (nan if none).

    The first sample past ``stop`` that follows a sample on ``start``'s side
    (≤ start when start < stop, else ≥ start) ends it; the last sample on
    ``start``'s side before it begins it; both instants interpolated linearly
    to the thresholds. Samples past ``stop`` before the body ever was on
    ``start``'s side (a robot that starts upright, for its stand-up) do not count.
    """
    t = np.asarray(times, dtype=float)
    sign = 1.0 if stop > start else -1.0
    y = sign * np.asarray(values, dtype=float)
    a, b = sign * start, sign * stop
    on_start = np.flatnonzero(y <= a)
    if on_start.size == 0:
        return math.nan
    past = np.flatnonzero(y[on_start[0] :] >= b)
    if past.size == 0:
        return math.nan
    j = int(on_start[0] + past[0])
    i = int(np.flatnonzero(y[:j] <= a)[-1])

    def cross(k: int, level: float) -> float:
        if y[k + 1] == y[k]:
            return float(t[k])
        return float(t[k] + (level - y[k]) * (t[k + 1] - t[k]) / (y[k + 1] - y[k]))

    return cross(j - 1, b) - cross(i, a)


def summarize_body(history: Mapping[str, npt.NDArray[np.float64]]) -> dict[str, float]:
    """The summary entries of the module docstring ({} without the body's columns)."""
    if "tilt" not in history:
        return {}
    t = np.asarray(history["time"], dtype=float)
    tilt = np.asarray(history["tilt"], dtype=float)
    folded = np.arccos(np.clip(np.abs(np.cos(tilt)), 0.0, 1.0))
    xy = np.column_stack([history["com_x"], history["com_y"]])
    steps = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    net = float(np.linalg.norm(xy[-1] - xy[0]))
    duration = float(t[-1] - t[0])
    return {
        "lay_down_time": transition_time(t, folded, STAND_ANGLE, LIE_ANGLE),
        "stand_up_time": transition_time(t, folded, LIE_ANGLE, STAND_ANGLE),
        "travelled_distance": float(np.sum(steps)),
        "net_displacement": net,
        "mean_speed": net / duration if duration > 0 else math.nan,
        "max_tilt": float(np.nanmax(tilt)),
        "final_tilt": float(tilt[-1]),
        "final_com_z": float(history["com_z"][-1]),
    }
