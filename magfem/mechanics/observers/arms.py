"""Arm observables: the bending angle of each arm and the shape of its midline.

Definitions (after Wang, Mao et al., Commun. Mater. 1, 67 (2020)):

* **Bending angle** of an arm: angle between the tangent of the deformed
  midline at the tip and the resting plane, seen from the side. With e the
  arm's in-plane direction and n the resting plane's normal (+z; the second
  axis of a strip), and x(s) = X(s) + u(X(s)) the deformed mid-thickness
  midline at arc length s from the root,
  θ = atan2((x(L) − x(L − δ))·n, (x(L) − x(L − δ))·e), δ = 10⁻³ L (a
  one-sided difference inside the last element, exact to O(δ) for the
  tangent of a P2 field). θ is unwrapped in time (:class:`AngleUnwrapper`),
  so it passes 90°, 180° and 270° continuously.
* **Midline shape** of an arm (:class:`MidlineProbe`, :func:`midline_shape`):
  the deformed midline is sampled at N = ``MIDLINE_SAMPLES`` (or more, when
  ``[output] midline_spacing`` asks for closer samples) equally spaced
  reference points X_k = root + s_k e, s_k = k h, h = L/(N − 1), and written
  in the arm's side frame relative to the reference root: a_k = (x_k −
  root)·e along the arm, w_k = (x_k − root)·n normal to it (n the resting
  plane's normal; w_k is the out-of-plane displacement because the reference
  midline has w = 0). Segment tangent angles φ_{k+½} = atan2(Δw, Δa)
  (unwrapped along s) give the curvature at interior samples
  κ_k = (φ_{k+½} − φ_{k−½})/h (per unit reference length; exact for a
  circular arc whose ends lie on samples). With the threshold
  κ* = max(η max_k |κ_k|, κ_floor/L), η = ``ACTIVE_CURVATURE_FRACTION`` = 0.1,
  κ_floor = ``CURVATURE_FLOOR`` = 10⁻³ rad:

  - **active length** L_a = s_last − s_first, the arc length of the bent
    part. Consecutive samples with |κ_k| ≥ κ* and one sign of κ form a bent
    run; the runs that turn the tangent by at least η times the largest
    run's turn count (a bonded edge's slight kink does not), s_first is the
    first sample of the first (the root, s_0 = 0, when it is the first
    interior sample s_1) and s_last the last sample of the last; 0 when none
    bends. An arm bent from its root runs straight beyond s_last; a long
    arm lying on the ground that lifts its tip bends only around where it
    leaves the ground, and L_a is that bend, not the flat part before it.
    :class:`MidlineProbe` does not count the bonded patch: it reports
    s_last − max(s_first, s_b) (s_b the midline length over the clamp, see
    :func:`bonded_length`; 0 if s_last ≤ s_b). A circular arc over [a, b]
    with straight parts on either side gives b − a to within h; a
    small-deflection cantilever under a uniform distributed torque
    (κ ∝ L − s) gives (1 − η) L.
  - **folds**: the number of bent runs that turn the tangent by at least
    ``FOLD_ANGLE`` = 45° (|Σ κ_k h| ≥ 45°). An arm bent at its root is one
    fold; an S or a second crease is two; a straight arm in any rigid
    rotation is zero. Collapse when > 1.
  - **normal tip displacement** |w_tip|/L along the resting-plane normal n,
    and **spread of the out-of-plane displacement** std_k(w_k)/L (partial
    bending when > 0.1; the standard deviation over the equally spaced
    samples), both over the body (arm) length L. In 3D also the **sideways
    tip displacement** |(x_tip − X_tip)·(n × e)|/L, across the arm in the
    resting plane (collapse when > 0.2: the tip displacement normal to the
    arm; an arm that lifts in its own bending plane has none).

Points are evaluated in parallel and every rank holds the same values
(:class:`~magfem.mechanics.observers.base.PointEvaluator`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from dolfinx import fem

from magfem.geometry.robot_mesh import Arm
from magfem.mechanics.observers.base import Observer, PointEvaluator

__all__ = [
    "ACTIVE_CURVATURE_FRACTION",
    "CURVATURE_FLOOR",
    "FOLD_ANGLE",
    "MIDLINE_SAMPLES",
    "TIP_OFFSET",
    "AngleUnwrapper",
    "ArmAngles",
    "Midline",
    "MidlineProbe",
    "MidlineShape",
    "arm_angle_points",
    "bending_angle",
    "bonded_length",
    "midline_points",
    "midline_samples",
    "midline_shape",
]

TIP_OFFSET = 1e-3
"""δ/L of the tip-tangent difference (see the module docstring)."""

MIDLINE_SAMPLES = 81
"""Samples N of an arm's midline (spacing L/80: 4–20 per element on the scenes' meshes)."""
ACTIVE_CURVATURE_FRACTION = 0.1
"""η: a sample bends when |κ| ≥ η max|κ| (module docstring)."""
CURVATURE_FLOOR = 1e-3
"""κ_floor (rad): curvatures below κ_floor/L never count as bending."""
FOLD_ANGLE = math.pi / 4
"""Smallest turn (rad) of a bent run of the midline that counts as a fold."""


def arm_angle_points(arm: Arm, gdim: int) -> npt.NDArray[np.float64]:
    """The two midline points (2, 3) near the tip of ``arm`` whose chord gives the tangent."""
    root, e = np.asarray(arm.root, dtype=float), np.asarray(arm.direction, dtype=float)
    s1 = arm.length * (1.0 - 1e-9)  # just inside the tip face
    s0 = s1 - TIP_OFFSET * arm.length
    return np.array([root + s0 * e, root + s1 * e])


def bending_angle(
    x0: npt.NDArray[np.float64], x1: npt.NDArray[np.float64], arm: Arm, gdim: int
) -> float:
    """Angle (rad, in (−π, π]) of the chord x0 → x1 (deformed positions) against the rest plane.

    Args:
        x0, x1: deformed positions of the two points of :func:`arm_angle_points`,
            length gdim (m).
        arm: the arm (its in-plane direction e).
    """
    d = np.asarray(x1, dtype=float) - np.asarray(x0, dtype=float)
    e = np.asarray(arm.direction, dtype=float)[:gdim]
    if gdim == 3:
        along, normal = float(d @ e), float(d[2])
    else:
        along, normal = float(d[0] * e[0]), float(d[1])
    return math.atan2(normal, along)


class AngleUnwrapper:
    """Makes a sequence of angles in (−π, π] continuous (adds multiples of 2π)."""

    def __init__(self) -> None:
        self.last: float | None = None
        self.offset = 0.0

    def __call__(self, raw: float) -> float:
        if self.last is not None:
            jump = raw - self.last
            if jump > math.pi:
                self.offset -= 2 * math.pi
            elif jump < -math.pi:
                self.offset += 2 * math.pi
        self.last = raw
        return raw + self.offset


def midline_points(arm: Arm, samples: int = MIDLINE_SAMPLES) -> npt.NDArray[np.float64]:
    """Reference points (samples, 3) X_k = root + s_k e of the arm's midline, root to tip (m).

    The last point sits just inside the tip face (as :func:`arm_angle_points`).
    """
    root, e = np.asarray(arm.root, dtype=float), np.asarray(arm.direction, dtype=float)
    s = np.linspace(0.0, arm.length * (1.0 - 1e-9), samples)
    return root[None, :] + s[:, None] * e[None, :]


def midline_samples(arms: Sequence[Arm], spacing: float = 0.0) -> int:
    """Samples per arm so that no arm's midline samples are farther apart than ``spacing`` (m).

    At least ``MIDLINE_SAMPLES``; ``spacing`` 0 gives exactly that.
    """
    if spacing < 0.0 or not math.isfinite(spacing):
        raise ValueError(f"midline sample spacing must be >= 0 and finite, got {spacing!r} m")
    if spacing == 0.0 or not arms:
        return MIDLINE_SAMPLES
    longest = max(float(a.length) for a in arms)
    return max(MIDLINE_SAMPLES, math.ceil(longest / spacing - 1e-9) + 1)


def bonded_length(arm: Arm, in_clamp: Any, offset: Sequence[float], gdim: int) -> float:
    """Length (m) of the arm's midline, from its root, that lies over the bonded patch.

    Args:
        arm: the arm (mesh coordinates).
        in_clamp: vectorised ``(x, y) -> bool`` of the robot outline (robot frame,
            :meth:`magfem.geometry.robots.Outline.in_clamp`).
        offset: the robot's ``position`` (m): mesh = robot frame + offset
            ((px, pz) on a strip's (x, z) axes).
        gdim: 3 (solid) or 2 (strip: the outline's y is 0 on the midline).

    The midline is walked from the root; the end of the first run of bonded
    points is located by bisection to 1e-9 of the arm length. 0 when the
    root is not bonded.
    """
    root = np.asarray(arm.root, dtype=float)
    e = np.asarray(arm.direction, dtype=float)

    def bonded(s: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
        pts = root[None, :] + np.atleast_1d(s)[:, None] * e[None, :]
        x = pts[:, 0] - offset[0]
        y = pts[:, 1] - offset[1] if gdim == 3 else 0.0 * x
        return np.asarray(in_clamp(x, y), dtype=bool)

    s = np.linspace(0.0, arm.length, MIDLINE_SAMPLES)
    inside = bonded(s)
    if not inside[0]:
        return 0.0
    if inside.all():
        return float(arm.length)
    k = int(np.argmin(inside))  # first sample off the patch
    lo, hi = float(s[k - 1]), float(s[k])
    while hi - lo > 1e-9 * arm.length:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if bonded(np.array([mid]))[0] else (lo, mid)
    return 0.5 * (lo + hi)


class MidlineShape(NamedTuple):
    """Shape observables of one deformed arm midline (module docstring).

    Attributes:
        active_length: L_a (m).
        folds: number of folds.
        tip_normal: |w_tip|/L (dimensionless).
        spread: std(w)/L (dimensionless).
        max_curvature: max_k |κ_k| (1/m), the sharpest bend of the midline.
        active_start: s_first (m), where the bent part begins.
    """

    active_length: float
    folds: int
    tip_normal: float
    spread: float
    max_curvature: float = 0.0
    active_start: float = 0.0


def _bent_runs(
    kappa: npt.NDArray[np.float64], bent: npt.NDArray[np.bool_], h: float
) -> list[tuple[int, int, float]]:
    """Maximal runs of bent interior samples of one curvature sign: (first, last, turn (rad))."""
    runs: list[tuple[int, int, float]] = []
    start, turn, sign = 0, 0.0, 0.0
    for k in range(kappa.size + 1):  # k == size closes the last run
        inside = k < kappa.size and bool(bent[k])
        ksign = float(np.sign(kappa[k])) if inside else 0.0
        if sign != 0.0 and ksign != sign:  # the current run ends at k - 1
            runs.append((start, k - 1, turn))
            turn, sign = 0.0, 0.0
        if inside:
            if sign == 0.0:
                start = k
            sign = ksign
            turn += float(kappa[k]) * h
    return runs


def midline_shape(
    s: npt.NDArray[np.float64],
    a: npt.NDArray[np.float64],
    w: npt.NDArray[np.float64],
    length: float,
) -> MidlineShape:
    """Active length, folds, normal tip displacement and spread of a deformed midline.

    Args:
        s: (N,) equally spaced reference arc lengths from the root, s_0 = 0 (m).
        a: (N,) deformed positions along the arm's direction e, relative to the
            reference root (m).
        w: (N,) deformed positions along the resting-plane normal n, relative
            to the reference root (m) (= the out-of-plane displacement).
        length: body (arm) length L (m).

    Returns:
        the :class:`MidlineShape` (definitions in the module docstring).
    """
    s = np.asarray(s, dtype=float)
    a = np.asarray(a, dtype=float)
    w = np.asarray(w, dtype=float)
    h = float(s[1] - s[0])
    phi = np.unwrap(np.arctan2(np.diff(w), np.diff(a)))
    kappa = np.diff(phi) / h  # at the interior samples s[1:-1]
    kmax = float(np.max(np.abs(kappa))) if kappa.size else 0.0
    threshold = max(ACTIVE_CURVATURE_FRACTION * kmax, CURVATURE_FLOOR / length)
    bent = np.abs(kappa) >= threshold
    runs = _bent_runs(kappa, bent, h)
    folds = sum(abs(turn) >= FOLD_ANGLE for _, _, turn in runs)
    largest = max((abs(turn) for _, _, turn in runs), default=0.0)
    spans = [(i, j) for i, j, turn in runs if abs(turn) >= ACTIVE_CURVATURE_FRACTION * largest]
    first = last = 0.0
    if spans:  # interior sample k is s[k + 1]; a bend from s_1 starts at the root
        first = 0.0 if spans[0][0] == 0 else float(s[1 + spans[0][0]])
        last = float(s[1 + spans[-1][1]])
    active = last - first
    return MidlineShape(
        active_length=active,
        active_start=first,
        folds=folds,
        tip_normal=abs(float(w[-1])) / length,
        spread=float(np.std(w)) / length,
        max_curvature=kmax,
    )


class MidlineProbe:
    """Midline shape of every arm at the current displacement (collective).

    Args:
        function_space: space of the displacement.
        arms: the robot's arms.
        samples: midline samples per arm.

    Calling it with the displacement returns the CSV columns of
    :meth:`columns` (``active_length_<arm>`` in m, ``folds_<arm>``,
    ``tip_normal_<arm>``, ``spread_<arm>``, ``curvature_<arm>`` and, in 3D,
    ``tip_lateral_<arm>``: the tip's sideways displacement, across the arm in
    the resting plane, over L), identical on every rank.
    """

    def __init__(
        self,
        function_space: fem.FunctionSpace,
        arms: Sequence[Arm],
        samples: int = MIDLINE_SAMPLES,
        bonded: dict[str, float] | None = None,
    ):
        self.arms = list(arms)
        self.bonded = dict(bonded or {})
        self.gdim = function_space.mesh.geometry.dim
        self.samples = samples
        self.points = np.vstack([midline_points(a, samples) for a in self.arms])
        self.evaluator = PointEvaluator(function_space, self.points)

    def columns(self) -> list[str]:
        """CSV column names (``tip_lateral_<arm>`` in 3D only: a strip has no side)."""
        keys: tuple[str, ...] = ("active_length", "folds", "tip_normal", "spread", "curvature")
        keys += ("tip_lateral",) if self.gdim == 3 else ()
        return [f"{k}_{a.name}" for a in self.arms for k in keys]

    def __call__(self, u: fem.Function) -> dict[str, float]:
        disp = self.evaluator(u)[:, : self.gdim]
        x = self.points[:, : self.gdim] + disp
        row: dict[str, float] = {}
        n = self.samples
        for i, arm in enumerate(self.arms):
            xi = x[i * n : (i + 1) * n] - np.asarray(arm.root, dtype=float)[: self.gdim]
            e = np.asarray(arm.direction, dtype=float)[: self.gdim]
            along = xi @ e if self.gdim == 3 else xi[:, 0] * e[0]
            normal = xi[:, 2] if self.gdim == 3 else xi[:, 1]
            s = np.linspace(0.0, arm.length * (1.0 - 1e-9), n)
            shape = midline_shape(s, along, normal, arm.length)
            end = shape.active_start + shape.active_length
            start = max(shape.active_start, self.bonded.get(arm.name, 0.0))
            row[f"active_length_{arm.name}"] = max(end - start, 0.0)
            row[f"folds_{arm.name}"] = float(shape.folds)
            row[f"tip_normal_{arm.name}"] = shape.tip_normal
            row[f"spread_{arm.name}"] = shape.spread
            row[f"curvature_{arm.name}"] = shape.max_curvature
            if self.gdim == 3:  # sideways: n x e, across the arm in the resting plane
                side = np.array([-e[1], e[0], 0.0])
                row[f"tip_lateral_{arm.name}"] = abs(float(xi[-1] @ side)) / arm.length
        return row


class ArmAngles(Observer):
    """``angle_<arm>``: the unwrapped bending angle of every arm (rad), collective.

    Args:
        u: the displacement (m).
        arms: the robot's arms.
    """

    def __init__(self, u: fem.Function, arms: Sequence[Arm]):
        self.u = u
        self.arms = list(arms)
        self.gdim = u.function_space.mesh.geometry.dim
        self.points = np.vstack([arm_angle_points(a, self.gdim) for a in self.arms])
        self.evaluate = PointEvaluator(u.function_space, self.points)
        self.unwrap = {a.name: AngleUnwrapper() for a in self.arms}

    def columns(self) -> list[str]:
        return [f"angle_{a.name}" for a in self.arms]

    def state(self) -> dict[str, Any]:
        """The unwrapping of every arm's angle (its last raw value and turns so far)."""
        return {n: {"last": w.last, "offset": w.offset} for n, w in self.unwrap.items()}

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Continue the unwrapping from :meth:`state`."""
        for name, saved in state.items():
            self.unwrap[name].last = saved["last"]
            self.unwrap[name].offset = float(saved["offset"])

    def observe(self, t: float) -> dict[str, float]:
        gdim = self.gdim
        x = self.points[:, :gdim] + self.evaluate(self.u)[:, :gdim]
        row = {}
        for i, arm in enumerate(self.arms):
            raw = bending_angle(x[2 * i], x[2 * i + 1], arm, gdim)
            row[f"angle_{arm.name}"] = self.unwrap[arm.name](raw)
        return row


class Midline(Observer):
    """The midline columns of :class:`MidlineProbe` and ``bending_strain``, collective.

    ``bending_strain`` is κ h/2 of the sharpest midline bend of any arm: the
    surface strain of bending alone (unlike the pointwise largest strain,
    which 3D corners and free edges raise).

    Args:
        u: the displacement (m).
        arms: the robot's arms.
        thickness: membrane thickness h (m).
        bonded: arm name -> midline length over the bonded patch (m).
        spacing: largest reference spacing of the midline samples (m); 0 keeps
            ``MIDLINE_SAMPLES`` per arm (L/80).
    """

    def __init__(
        self,
        u: fem.Function,
        arms: Sequence[Arm],
        thickness: float,
        bonded: dict[str, float] | None = None,
        spacing: float = 0.0,
    ):
        self.u = u
        self.thickness = thickness
        samples = midline_samples(arms, spacing)
        self.probe = MidlineProbe(u.function_space, arms, samples=samples, bonded=bonded)

    def columns(self) -> list[str]:
        return [*self.probe.columns(), "bending_strain"]

    def observe(self, t: float) -> dict[str, float]:
        shape = self.probe(self.u)
        kappa = max(shape[f"curvature_{a.name}"] for a in self.probe.arms)
        return shape | {"bending_strain": kappa * self.thickness / 2}
