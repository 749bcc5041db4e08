"""Observables of a membrane run: bending angles, strain, energies, contact force.

Definitions (DESIGN.md, after Wang, Mao et al., Commun. Mater. 1, 67 (2020)):

* **Bending angle** of an arm: angle between the tangent of the deformed
  midline at the tip and the resting plane, seen from the side. With e the
  arm's in-plane direction and n the resting plane's normal (+z; the second
  axis of a strip), and x(s) = X(s) + u(X(s)) the deformed mid-thickness
  midline at arc length s from the root,
  θ = atan2((x(L) − x(L − δ))·n, (x(L) − x(L − δ))·e), δ = 10⁻³ L (a
  one-sided difference inside the last element, exact to O(δ) for the
  tangent of a P2 field). θ is unwrapped in time (:class:`AngleUnwrapper`),
  so it passes 90°, 180° and 270° continuously.
* **Largest nominal strain** ε_a = max over the arm of (λ_max − 1), λ_max
  the largest principal stretch (√ of the largest eigenvalue of C = FᵀF),
  sampled at the vertices of every cell (where bending strains peak) except
  those within one thickness of the clamped facets: the edge where a bonded
  patch ends is a stress singularity, whose FE strain (16.6 % on the default
  case, against a bending strain t/(2R) of ~1 %) measures the mesh, not the
  arm (:class:`StrainProbe`).
* **Midline shape** of an arm (:class:`MidlineProbe`, :func:`midline_shape`):
  the deformed midline is sampled at ``MIDLINE_SAMPLES`` equally spaced
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

  - **active length** L_a = s of the last sample with |κ_k| ≥ κ* (0 when
    none): the arc length from the root to where the arm stops bending and
    runs straight. :class:`MidlineProbe` reports it from the end of the
    bonded patch, L_a − s_b (s_b the midline length over the clamp, see
    :func:`bonded_length`; 0 if L_a ≤ s_b): the deformed part of the arm,
    not counting the glued strip it starts on. A circular arc over [0, ℓ]
    followed by a straight part gives ℓ to within h; a small-deflection cantilever under a uniform
    distributed torque (κ ∝ L − s) gives (1 − η) L.
  - **folds**: the number of maximal runs of consecutive samples with
    |κ_k| ≥ κ* and one sign of κ that turn the tangent by at least
    ``FOLD_ANGLE`` = 45° (|Σ κ_k h| ≥ 45°). An arm bent at its root is one
    fold; an S or a second crease is two; a straight arm in any rigid
    rotation is zero. Collapse when > 1 (DESIGN.md).
  - **normal tip displacement** |w_tip|/L (collapse when > 0.2, DESIGN.md)
    and **spread of the out-of-plane displacement** std_k(w_k)/L (partial
    bending when > 0.1, DESIGN.md), both over the body (arm) length L.
    These two follow DESIGN.md's wording literally ("normal to the arm" =
    along the resting-plane normal n; "spread" = standard deviation over
    equally spaced samples along x); the paper's own definitions were not
    available to check them against.
* **Bending speed** 0° → 90° (:func:`bending_speed`): 90° over the time from
  the last instant the angle was ≤ 0° to the first instant it reaches 90°
  after it (both linearly interpolated between samples), in rad/s
  (reported in °/ms).
* Energy density ρE = 3 μ ε_a²/2 and power density ρW = f ρE
  (:func:`magfem.material.energy_density`), kinetic/elastic/magnetic/gravity
  energy (J; J per m of width for strips) and the resultant ground force (N).

Point evaluation works in parallel: every rank evaluates the points found in
its local cells, rank 0 combines them and broadcasts, so every rank holds
the same values.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import basix
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, geometry
from mpi4py import MPI

from magfem.geometry.robot_mesh import Arm

__all__ = [
    "AngleUnwrapper",
    "MidlineProbe",
    "MidlineShape",
    "PointEvaluator",
    "StrainProbe",
    "arm_angle_points",
    "bending_angle",
    "bending_speed",
    "history_summary",
    "max_over_window",
    "midline_points",
    "midline_shape",
    "summarize_midline",
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
COLLAPSE_TIP_NORMAL = 0.2
"""|w_tip|/L above which an arm has collapsed (DESIGN.md)."""
COLLAPSE_FOLDS = 1
"""More folds than this: collapse (DESIGN.md)."""
PARTIAL_SPREAD = 0.1
"""std(w)/L above which an arm bends partially (DESIGN.md)."""


class PointEvaluator:
    """Evaluate a Function at fixed reference points on every rank (collective).

    Args:
        function_space: space of the functions to evaluate.
        points: (N, 3) reference points (m; strips: (x, z, 0)).

    Raises:
        ValueError: a point lies outside the mesh.
    """

    def __init__(self, function_space: fem.FunctionSpace, points: npt.NDArray[np.float64]):
        domain = function_space.mesh
        self.comm = domain.comm
        self.points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        tree = geometry.bb_tree(domain, domain.topology.dim)
        candidates = geometry.compute_collisions_points(tree, self.points)
        colliding = geometry.compute_colliding_cells(domain, candidates, self.points)
        self.local_index: list[int] = []
        self.cells: list[int] = []
        for i in range(len(self.points)):
            links = colliding.links(i)
            if len(links) > 0:
                self.local_index.append(i)
                self.cells.append(int(links[0]))
        found = np.zeros(len(self.points), dtype=np.int32)
        found[self.local_index] = 1
        total = np.zeros_like(found)
        self.comm.Allreduce(found, total, op=MPI.SUM)
        if np.any(total == 0):
            missing = self.points[total == 0]
            raise ValueError(f"points outside the mesh: {missing.tolist()}")

    def __call__(self, f: fem.Function) -> npt.NDArray[np.float64]:
        """Values (N, value_size) of ``f`` at the points, identical on every rank."""
        size = int(np.prod(f.ufl_shape)) if f.ufl_shape else 1
        local = np.zeros((len(self.points), size))
        have = np.zeros(len(self.points))
        if self.cells:
            vals = f.eval(self.points[self.local_index], np.array(self.cells, dtype=np.int32))
            local[self.local_index] = np.asarray(vals).reshape(len(self.cells), size)
            have[self.local_index] = 1.0
        total = np.zeros_like(local)
        count = np.zeros_like(have)
        self.comm.Allreduce(local, total, op=MPI.SUM)
        self.comm.Allreduce(have, count, op=MPI.SUM)
        return total / count[:, None]  # points on shared cells: identical values, averaged


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


def midline_points(arm: Arm, samples: int = MIDLINE_SAMPLES) -> npt.NDArray[np.float64]:
    """Reference points (samples, 3) X_k = root + s_k e of the arm's midline, root to tip (m).

    The last point sits just inside the tip face (as :func:`arm_angle_points`).
    """
    root, e = np.asarray(arm.root, dtype=float), np.asarray(arm.direction, dtype=float)
    s = np.linspace(0.0, arm.length * (1.0 - 1e-9), samples)
    return root[None, :] + s[:, None] * e[None, :]


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
    """

    active_length: float
    folds: int
    tip_normal: float
    spread: float
    max_curvature: float = 0.0


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
    active = float(s[1:-1][bent][-1]) if np.any(bent) else 0.0
    folds = 0
    turn = 0.0
    sign = 0.0
    for k in range(kappa.size + 1):  # one pass over runs; k == size closes the last run
        inside = k < kappa.size and bool(bent[k])
        ksign = float(np.sign(kappa[k])) if inside else 0.0
        if sign != 0.0 and ksign != sign:  # the current run ends here
            folds += int(abs(turn) >= FOLD_ANGLE)
            turn, sign = 0.0, 0.0
        if inside:
            sign = ksign
            turn += float(kappa[k]) * h
    return MidlineShape(
        active_length=active,
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
    ``tip_normal_<arm>``, ``spread_<arm>``), identical on every rank.
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
        """CSV column names."""
        keys = ("active_length", "folds", "tip_normal", "spread", "curvature")
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
            start = self.bonded.get(arm.name, 0.0)
            row[f"active_length_{arm.name}"] = max(shape.active_length - start, 0.0)
            row[f"folds_{arm.name}"] = float(shape.folds)
            row[f"tip_normal_{arm.name}"] = shape.tip_normal
            row[f"spread_{arm.name}"] = shape.spread
            row[f"curvature_{arm.name}"] = shape.max_curvature
        return row


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


def summarize_midline(history: Mapping[str, npt.NDArray[np.float64]]) -> dict[str, float]:
    """Summary entries of the midline and speed observables from a run's history columns.

    Per arm (when its columns exist): ``final_active_length_<arm>`` (m),
    ``max_folds_<arm>``, ``max_tip_normal_<arm>``, ``max_spread_<arm>``,
    ``bending_speed_<arm>`` (rad/s, 0° → 90°, nan if not reached); and, when
    any arm has midline columns, ``collapse`` (1.0 if an arm's max tip normal
    displacement exceeds 0.2 or its folds exceed 1, else 0.0) and
    ``partial_bending`` (1.0 if an arm's max spread exceeds 0.1).
    """
    out: dict[str, float] = {}
    t = np.asarray(history["time"], dtype=float)
    collapse = partial = False
    have = False
    for key in history:
        if key.startswith("angle_"):
            arm = key[len("angle_") :]
            out[f"bending_speed_{arm}"] = bending_speed(t, history[key])
        if not key.startswith("active_length_"):
            continue
        have = True
        arm = key[len("active_length_") :]
        out[f"final_active_length_{arm}"] = float(history[key][-1])
        folds = float(np.nanmax(history[f"folds_{arm}"]))
        tip = float(np.nanmax(history[f"tip_normal_{arm}"]))
        spread = float(np.nanmax(history[f"spread_{arm}"]))
        out[f"max_folds_{arm}"], out[f"max_tip_normal_{arm}"] = folds, tip
        out[f"max_spread_{arm}"] = spread
        collapse |= tip > COLLAPSE_TIP_NORMAL or folds > COLLAPSE_FOLDS
        partial |= spread > PARTIAL_SPREAD
    if have:
        out["collapse"] = float(collapse)
        out["partial_bending"] = float(partial)
    return out


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


class StrainProbe:
    """Largest nominal strain max(λ_max − 1) at cell vertices away from the supports (collective).

    Args:
        u: displacement (m).
        exclude: (N, 3) reference points (m) of the supports (the vertices of
            the clamped facets), or None.
        radius: vertices within this distance (m) of an excluded point are not
            sampled.
        metrics: UFL right Cauchy–Green tensors (all of one shape) to sample
            instead of FᵀF of ``u``: the shell's two faces, whose strain adds
            the bending strain to the membrane's.

    The bonded patch ends in a re-entrant edge where the strain of the
    continuum is singular (its FE value grows as the mesh is refined and says
    nothing about the arm): on the default case it read 16.6 % while the
    bending strain t/(2R) of the arm is ~1 %. The simulation excludes the
    vertices within one thickness of the clamped facets, so ε_a measures the
    arm (bending plus stretching).
    """

    def __init__(
        self,
        u: fem.Function,
        exclude: npt.NDArray[np.float64] | None = None,
        radius: float = 0.0,
        metrics: list[Any] | None = None,
    ):
        domain = u.function_space.mesh
        self.comm = domain.comm
        self.domain = domain
        gdim = domain.geometry.dim
        cell = domain.topology.cell_type
        points = basix.geometry(getattr(basix.CellType, cell.name))
        if metrics is None:
            F = ufl.Identity(gdim) + ufl.grad(u)
            metrics = [F.T * F]
        self.dim = ufl.shape(metrics[0])[0]
        self.expr = fem.Expression(ufl.as_tensor(list(metrics)), points)
        n_local = domain.topology.index_map(domain.topology.dim).size_local
        self.cells = np.arange(n_local, dtype=np.int32)
        nv = len(points)
        # reference coordinates (cells, vertices, 3) of the sampled vertices (P1/P2 geometry:
        # the first nv geometry nodes of a cell are its vertices, in basix order)
        xyz = domain.geometry.x[domain.geometry.dofmaps[0][:n_local, :nv]]
        self.mask = np.ones((n_local, nv), dtype=bool)
        if exclude is not None and len(exclude) and radius > 0 and n_local:
            from scipy.spatial import cKDTree

            tree = cKDTree(np.asarray(exclude, dtype=float).reshape(-1, 3))
            dist, _ = tree.query(xyz.reshape(-1, 3))
            self.mask = (dist >= radius).reshape(n_local, nv)

    def __call__(self) -> float:
        """ε_a (dimensionless), identical on every rank (0 if every vertex is excluded)."""
        local = 0.0
        if self.cells.size and self.mask.any():
            C = np.asarray(self.expr.eval(self.domain, self.cells))
            n = len(self.mask.ravel())
            C = C.reshape(n, -1, self.dim, self.dim)[self.mask.ravel()].reshape(
                -1, self.dim, self.dim
            )
            lam_max = np.sqrt(np.max(np.linalg.eigvalsh(C), axis=1))
            local = float(np.max(lam_max)) - 1.0
        return float(self.comm.allreduce(local, op=MPI.MAX))


def history_summary(
    history: Mapping[str, npt.NDArray[np.float64]], *, start: float, frequency: float | None
) -> dict[str, float]:
    """Summary scalars of a run's history columns (the run's own and the sweep's summary).

    Per arm with an ``angle_<arm>`` column: ``max_angle_<arm>`` (max |θ|, rad),
    ``final_angle_<arm>`` and, for a periodic drive of ``frequency`` (Hz),
    ``max_angle_{halfperiod,1period,2periods}_<arm>`` over [start, start + n/f]
    (nan when the run ends before the window does); ``max_strain``,
    ``max_bending_strain``, ``max_energy_density`` (J/m³) and ``power_density``
    (f ρE, W/m³); ``first_self_touch`` (s, first sample with a self-contact
    force; nan if none) and ``max_self_contact_force`` (N); and
    :func:`summarize_midline`. Columns that are absent give no entry; blank
    samples (nan) are skipped.
    """
    t = np.asarray(history["time"], dtype=float)
    out: dict[str, float] = {}
    for key, values in history.items():
        if not key.startswith("angle_"):
            continue
        arm = key[len("angle_") :]
        out[f"max_angle_{arm}"] = float(np.nanmax(np.abs(values)))
        out[f"final_angle_{arm}"] = float(values[-1])
        if frequency:
            for n, label in ((0.5, "halfperiod"), (1, "1period"), (2, "2periods")):
                end = start + n / frequency
                covered = t[-1] >= end - 1e-9
                out[f"max_angle_{label}_{arm}"] = (
                    max_over_window(t, values, start, end) if covered else math.nan
                )
    out |= summarize_midline(history)
    for column, key in (("strain", "max_strain"), ("bending_strain", "max_bending_strain")):
        if column in history:
            out[key] = float(np.nanmax(history[column]))
    if "self_contact_force" in history:
        force = np.asarray(history["self_contact_force"], dtype=float)
        touching = np.flatnonzero(force > 0.0)
        out["first_self_touch"] = float(t[touching[0]]) if touching.size else math.nan
        out["max_self_contact_force"] = float(np.nanmax(force))
    if "energy_density" in history:
        out["max_energy_density"] = float(np.nanmax(history["energy_density"]))
        if frequency:
            out["power_density"] = frequency * out["max_energy_density"]
    return out


def max_over_window(
    times: npt.NDArray[np.float64], values: npt.NDArray[np.float64], t0: float, t1: float
) -> float:
    """max |value| over t0 <= t <= t1 (nan when no sample lies there)."""
    mask = (times >= t0 - 1e-12) & (times <= t1 + 1e-12)
    return float(np.nanmax(np.abs(values[mask]))) if np.any(mask) else float("nan")


def assemble_scalars(forms: list[Any], comm: MPI.Comm) -> list[float]:
    """Assemble compiled scalar forms and sum them over ranks."""
    local = np.array([fem.assemble_scalar(f) for f in forms], dtype=float)
    total = np.zeros_like(local)
    comm.Allreduce(local, total, op=MPI.SUM)
    return total.tolist()
