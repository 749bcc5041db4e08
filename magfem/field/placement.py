"""Rigid placements of field sources: local frames, and trajectories in time.

A source's field is computed once in its *reference* placement (the one the
case file gives). A :class:`Placement` (R, d) moves it rigidly, x = R x_ref +
d, so its field there is B(x) = R B_ref(Rᵀ(x − d)) and its gradient
∇B(x) = R ∇B_ref Rᵀ. A :class:`Trajectory` gives the placement at time t by
piecewise-linear interpolation of keyframes (translation offsets and angles
about a fixed axis through a pivot), held constant outside the keyframes;
its keyframe times, where the velocity jumps, are breakpoints for a time
stepper.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

__all__ = ["Placement", "Trajectory", "frame", "rotation"]


def frame(axis: np.ndarray, roll: float = 0.0) -> np.ndarray:
    """Rotation matrix whose columns are the local x, y, z axes; local z = ``axis``.

    Args:
        axis: unit vector, shape (3,).
        roll: rotation of the local x axis about ``axis``, rad.

    Returns:
        R, shape (3, 3), with x_global = R @ x_local.
    """
    z = np.asarray(axis, dtype=float)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = helper - z * (helper @ z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    c, s = math.cos(roll), math.sin(roll)
    x, y = c * x + s * y, -s * x + c * y
    return np.column_stack([x, y, z])


def rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) by ``angle`` (rad) about the unit vector ``axis`` (Rodrigues)."""
    n = np.asarray(axis, dtype=float)
    K = np.array([[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


class Placement(NamedTuple):
    """Rigid motion x = R x_ref + d (R (3, 3) orthogonal, d (3,) in m)."""

    R: np.ndarray
    d: np.ndarray

    @classmethod
    def identity(cls) -> Placement:
        """No motion."""
        return cls(np.eye(3), np.zeros(3))

    def to_reference(self, points: np.ndarray) -> np.ndarray:
        """Reference positions (N, 3) of world ``points`` (N, 3): Rᵀ(x − d)."""
        return (np.atleast_2d(points) - self.d) @ self.R

    def apply(self, points: np.ndarray) -> np.ndarray:
        """World positions (N, 3) of reference ``points`` (N, 3)."""
        return np.atleast_2d(points) @ self.R.T + self.d

    def vectors(self, B: np.ndarray) -> np.ndarray:
        """Reference vectors (N, 3) turned into the world frame."""
        return B @ self.R.T

    def tensors(self, G: np.ndarray) -> np.ndarray:
        """Reference tensors (N, 3, 3) turned into the world frame: R G Rᵀ."""
        return np.einsum("ia,nab,jb->nij", self.R, G, self.R)

    def tensors3(self, H: np.ndarray) -> np.ndarray:
        """Reference third-order tensors (N, 3, 3, 3) in the world frame."""
        return np.einsum("ia,jb,kc,nabc->nijk", self.R, self.R, self.R, H)


class Trajectory:
    """Piecewise-linear keyframed rigid motion (module docstring).

    Args:
        times: keyframe times (K,), strictly increasing, s.
        offsets: translations (K, 3), m, added to the reference placement.
        angles: rotation angles (K,), rad, about ``axis`` through ``pivot``.
        axis: unit rotation axis (3,).
        pivot: point (3,), m, of the reference placement the rotation turns about.
        name: label.
    """

    def __init__(
        self,
        times: Sequence[float],
        offsets: np.ndarray,
        angles: Sequence[float],
        axis: np.ndarray,
        pivot: np.ndarray,
        name: str = "motion",
    ):
        self.times = np.asarray(times, dtype=float)
        self.offsets = np.asarray(offsets, dtype=float).reshape(-1, 3)
        self.angles = np.asarray(angles, dtype=float)
        self.axis = np.asarray(axis, dtype=float)
        self.pivot = np.asarray(pivot, dtype=float)
        self.name = name

    def placement(self, t: float) -> Placement:
        """Placement at time ``t`` (s) (continuous in t, so no one-sided limits)."""
        tk = self.times
        off = np.array([np.interp(t, tk, self.offsets[:, k]) for k in range(3)])
        R = rotation(self.axis, float(np.interp(t, tk, self.angles)))
        return Placement(R, self.pivot + off - R @ self.pivot)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """Keyframe times in (t0, t1], s."""
        return self.times[(self.times > t0) & (self.times <= t1)]

    def sample_times(self) -> np.ndarray:
        """Keyframe times and the midpoints between them (where to check a model's error)."""
        mids = 0.5 * (self.times[1:] + self.times[:-1])
        return np.unique(np.concatenate([self.times, mids]))
