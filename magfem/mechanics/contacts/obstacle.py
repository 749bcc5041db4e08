r"""Rigid obstacles: analytic bodies the robot cannot enter (``[[contacts]] kind = "obstacle"``).

An obstacle is a signed distance g(x) from its surface, positive where the
robot may be, with the unit normal n(x) = ∇g pointing there (UFL functions
of the current position). ``side = "outside"`` keeps the robot out of the
solid (a stick, a sphere), ``side = "inside"`` keeps it within the surface (a
tube, a pipette tip, a bowl):

==============  =====================================  ===========================
shape           keys                                   g (outside; inside: −g)
==============  =====================================  ===========================
``half_space``  ``point``, ``normal`` (into the free    (x − p)·n̂
                region; ``side`` unused)
``sphere``      ``center``, ``radius``                  |x − c| − R
``cylinder``    ``point`` on the axis, ``axis``,        |r| − R,  r = (x − p) − ((x − p)·â) â
                ``radius`` (infinite)
``cone``        ``apex``, ``axis`` (into the cone),     |r| cos α − ((x − p)·â) sin α
                ``half_angle`` (infinite)
==============  =====================================  ===========================

The cone's g is the distance to its surface line in the plane through the
axis (exact where the nearest point is on the mantle, i.e. away from the
apex). Every point may move rigidly with ``motion``: piecewise-linear
offsets ``positions`` (m) at ``times`` (s), held outside them; the offset and
its velocity are Constants set at the end of each step, and the keyframes
are switching instants the steps land on.

The contact law is the ground's penalty with friction
(:mod:`magfem.mechanics.contacts.penalty`) on the penetration δ = −g, with
the velocity relative to the moving obstacle, acting at the end of the step
in dynamic runs. Not modelled: the impact absorption of the ground (a
landing on an obstacle rebounds as the generalized-α update makes it), and
obstacle rotation. On a strip (side view) the obstacle is its section in the
x–z plane (vectors keep their x and z). History: ``obstacle_<name>_x``,
``_y`` (3D only), ``_z``: the force of the obstacle on the robot (N; N/m ×
depth for strips).

    [[contacts]]
    kind = "obstacle"
    name = "pipette"
    shape = "cone"
    side = "inside"
    apex = [0, 0, "30 mm"]
    axis = [0, 0, -1]
    half_angle = "4 deg"
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem

from magfem.config import MISSING, CaseError, option, quantity, vector
from magfem.mechanics.contacts.base import CONTACTS, Contact, ContactKindSpec
from magfem.mechanics.contacts.penalty import create_penalty_law, penalty_ramp
from magfem.mechanics.forms import assemble_scalars, compile_form
from magfem.mechanics.models.base import Face, Model, sum_work
from magfem.mechanics.spec import MaterialSpec

__all__ = ["OBSTACLE_SHAPES", "Obstacle", "ObstacleSpec", "signed_distance"]

OBSTACLE_SHAPES = ("half_space", "sphere", "cylinder", "cone")
_KEYS = {
    "half_space": ("point", "normal"),
    "sphere": ("center", "radius"),
    "cylinder": ("point", "axis", "radius"),
    "cone": ("apex", "axis", "half_angle"),
}


@dataclass(frozen=True)
class MotionSpec:
    """Rigid translation of an obstacle: offsets ``positions`` (m) at ``times`` (s)."""

    times: tuple[float, ...] = vector(unit="s", length=None, doc="keyframe times, increasing")
    positions: tuple[tuple[float, ...], ...] = vector(
        (), "m", length=None, doc="offset [x, y, z] of the obstacle at each time"
    )

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        if t.size < 1 or np.any(np.diff(t) <= 0):
            raise CaseError("times", list(self.times), "must be one or more increasing times")
        if len(self.positions) != t.size:
            raise CaseError(
                "positions", list(self.positions), f"must have one entry per time ({t.size})"
            )
        for i, p in enumerate(self.positions):
            if len(p) != 3 or not all(math.isfinite(float(v)) for v in p):
                raise CaseError(f"positions[{i}]", p, "must be 3 finite numbers (m)")

    def offset(self, t: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(offset m, velocity m/s) at time t; the velocity of the segment t lies in."""
        times = np.asarray(self.times, dtype=float)
        pos = np.asarray(self.positions, dtype=float)
        offset = np.array([np.interp(t, times, pos[:, k]) for k in range(3)])
        k = int(np.searchsorted(times, t, side="left"))
        if 0 < k < times.size:
            velocity = (pos[k] - pos[k - 1]) / (times[k] - times[k - 1])
        else:
            velocity = np.zeros(3)
        return offset, velocity


@CONTACTS.register("obstacle")
@dataclass(frozen=True, kw_only=True)
class ObstacleSpec(ContactKindSpec):
    """``[[contacts]] kind = "obstacle"``: a rigid half-space, sphere, cylinder or cone."""

    kind: str = option("obstacle", ("obstacle",), doc="contact kind")
    name: str = option(doc="a word for the history columns (letters, digits, _)")
    shape: str = option(choices=OBSTACLE_SHAPES, doc="half_space, sphere, cylinder or cone")
    side: str = option("outside", ("outside", "inside"), doc="where the robot stays")
    point: tuple[float, ...] | None = vector(None, "m", doc="a point of the plane or the axis")
    normal: tuple[float, ...] | None = vector(None, "", nonzero=True, doc="half_space normal")
    center: tuple[float, ...] | None = vector(None, "m", doc="sphere centre")
    radius: float | None = quantity(None, "m", gt=0.0, doc="sphere or cylinder radius")
    apex: tuple[float, ...] | None = vector(None, "m", doc="cone apex")
    axis: tuple[float, ...] | None = vector(None, "", nonzero=True, doc="cylinder or cone axis")
    half_angle: float | None = quantity(None, "rad", gt=0.0, lt=math.pi / 2, doc="cone")
    motion: MotionSpec | None = None
    friction: float = quantity(0.5, "", ge=0.0, doc="Coulomb friction coefficient")
    penalty: float = quantity(10.0, "", gt=0.0, doc="κ: stiffness k_n = κ μ / thickness")
    penalty_onset: float = quantity(0.05, "", gt=0.0, doc="onset of the ramp, in thicknesses")
    damping: float = quantity(1.0, "", ge=0.0, doc="contact dashpot, fraction of critical")
    regularization_velocity: float = quantity(1e-3, "m/s", gt=0.0, doc="friction's v_ε")
    slip_length: float = quantity(0.01, "", ge=0.0, doc="friction's ℓ, in thicknesses")

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise CaseError("name", self.name, "must be letters, digits and _ (a column name)")
        for key in _KEYS[self.shape]:
            if getattr(self, key) is None:
                raise CaseError(key, MISSING, f"is required for shape '{self.shape}'")
        for key in {k for keys in _KEYS.values() for k in keys} - set(_KEYS[self.shape]):
            if getattr(self, key) is not None:
                raise CaseError(key, getattr(self, key), f"is not a key of shape '{self.shape}'")

    def build(self, model: Model, material: MaterialSpec) -> Contact:
        return Obstacle(self, model, shear_modulus=material.shear_modulus, density=material.density)


def _unit(v: Any) -> Any:
    return v / ufl.sqrt(ufl.dot(v, v))


def signed_distance(spec: ObstacleSpec, x: Any, offset: Any, gdim: int) -> tuple[Any, Any]:
    """(g, n): signed distance (m, positive where the robot may be) and unit normal (UFL).

    Args:
        x: current position, UFL gdim-vector (m).
        offset: the obstacle's translation, UFL gdim-vector (m).
    """

    def vec(v: Sequence[float]) -> Any:
        arr = np.asarray(v, dtype=float)
        return ufl.as_vector((arr if gdim == 3 else arr[::2]).tolist())

    sign = -1.0 if spec.side == "inside" else 1.0
    if spec.shape == "half_space":
        assert spec.point is not None and spec.normal is not None
        n = _unit(vec(spec.normal))
        return ufl.dot(x - vec(spec.point) - offset, n), n
    if spec.shape == "sphere":
        assert spec.center is not None and spec.radius is not None
        d = x - vec(spec.center) - offset
        dist = ufl.sqrt(ufl.dot(d, d) + (1e-9 * spec.radius) ** 2)
        return sign * (dist - spec.radius), sign * d / dist
    assert spec.axis is not None
    a = _unit(vec(spec.axis))
    origin = spec.point if spec.shape == "cylinder" else spec.apex
    assert origin is not None
    d = x - vec(origin) - offset
    along = ufl.dot(d, a)
    radial = d - along * a
    scale = spec.radius if spec.radius is not None else 1e-3
    rho = ufl.sqrt(ufl.dot(radial, radial) + (1e-9 * scale) ** 2)
    e_rho = radial / rho
    if spec.shape == "cylinder":
        assert spec.radius is not None
        return sign * (rho - spec.radius), sign * e_rho
    assert spec.half_angle is not None
    c, s = math.cos(spec.half_angle), math.sin(spec.half_angle)
    return sign * (rho * c - along * s), sign * (c * e_rho - s * a)


class Obstacle(Contact):
    """The contact of a :class:`ObstacleSpec` with ``model``'s faces (module docstring).

    Args:
        spec: the obstacle.
        model: the body.
        shear_modulus, density: of the membrane (Pa, kg/m³), which scale the law.
    """

    def __init__(self, spec: ObstacleSpec, model: Model, *, shear_modulus: float, density: float):
        self.spec = spec
        self.model = model
        self.name = f"obstacle_{spec.name}"
        self.surfaces = ("all",)
        self.law = create_penalty_law(
            spec, shear_modulus=shear_modulus, density=density, thickness=model.thickness
        )
        mesh = model.robot.mesh
        self.gdim = model.gdim
        zeros = np.zeros(self.gdim)
        self.offset = fem.Constant(mesh, zeros.copy())
        self.velocity = fem.Constant(mesh, zeros.copy())
        self.stiffness = fem.Constant(mesh, self.law.stiffness)
        self.onset = fem.Constant(mesh, self.law.onset)
        self.damping = fem.Constant(mesh, self.law.damping)
        self.friction = fem.Constant(mesh, self.law.friction)
        eps2 = self.law.regularization_velocity**2
        dt = model.integrator.dt
        self.eps2 = eps2 + (self.law.slip_length / dt) ** 2 if model.integrator.dynamic else eps2
        self._place(model.integrator.time)
        faces = model.faces(*model.accepted(), self.surfaces)
        total = functools.reduce(operator.add, [self.traction(f) for f in faces])
        self._forces = [compile_form(total[i] * faces[0].measure) for i in range(self.gdim)]

    def traction(self, face: Face) -> Any:
        """Traction (Pa per reference area) of the obstacle on a face's points (UFL)."""
        g, n = signed_distance(self.spec, face.position, self.offset, self.gdim)
        v = face.velocity - self.velocity
        vn = ufl.dot(v, n)
        r, s = penalty_ramp(-g, self.onset)
        p = self.stiffness * r - self.damping * s * vn
        p = ufl.conditional(ufl.gt(p, 0.0), p, 0.0)
        v_t = v - vn * n
        return p * n - self.friction * p * v_t / ufl.sqrt(ufl.dot(v_t, v_t) + self.eps2)

    def work(self, faces: Sequence[Face]) -> list[ufl.Form]:
        return sum_work(faces, [self.traction(f) for f in faces])

    def _place(self, t: float) -> None:
        if self.spec.motion is None:
            return
        offset, velocity = self.spec.motion.offset(t)
        keep = slice(None) if self.gdim == 3 else slice(None, None, 2)
        self.offset.value = offset[keep]  # type: ignore[assignment]
        self.velocity.value = velocity[keep]  # type: ignore[assignment]

    def before_solve(self) -> None:
        integ = self.model.integrator
        self._place(integ.time + float(integ.dt.value))  # it acts at the end of the step

    def breakpoints(self, t0: float, t1: float) -> npt.NDArray[np.float64]:
        if self.spec.motion is None:
            return np.zeros(0)
        times = np.asarray(self.spec.motion.times, dtype=float)
        return times[(times > t0) & (times <= t1)]

    def columns(self) -> list[str]:
        axes = "xyz" if self.gdim == 3 else "xz"
        return [f"{self.name}_{a}" for a in axes]

    def observe(self, t: float) -> dict[str, float]:
        self._place(t)
        forces = assemble_scalars(self._forces, self.model.robot.mesh.comm)
        return {c: f * self.model.depth for c, f in zip(self.columns(), forces, strict=True)}
