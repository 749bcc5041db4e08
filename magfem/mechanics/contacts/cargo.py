r"""A cargo (``[[contacts]] kind = "cargo"``): a rigid body with six degrees of freedom that the
robot can push, grip, lift and drop.

Why rigid. The gripper's cargo is a polyurethane foam cube: its stiffness
(tens of kPa) is below the robot's, but it deforms only where the arms press
on it. A second hyperelastic body would need a second mesh and model in the
same Newton system (both are one body in magfem); a rigid body with a
compliant surface carries what the scene asks — whether the arms hold the
cube's weight — with six unknowns. The foam's compliance is in the contact
law: a Winkler layer, a pressure p indents the surface by p·``depth``/E
(``modulus`` E; ``depth`` defaults to half the smallest edge: the cube
squeezed between opposite faces), i.e. the penalty law of
:mod:`magfem.mechanics.contacts.penalty` with k_n = E/``depth``, its onset
``penalty_onset`` robot thicknesses, a dashpot of ``damping`` × the
critical damping of the robot's membrane on that spring, and friction
``friction`` (regularised as the obstacles'). Not modelled: the foam's
global deformation (bending, shear of the cube) and its inner dissipation.

Coupling. Within a robot step the cargo is an obstacle on a prescribed
rigid motion (:class:`~magfem.mechanics.contacts.obstacle.Obstacle`, its
placement extrapolated from the cargo's velocity and spin); after the step
the force and moment the robot's faces received are applied, reversed, to
the cargo, whose equations

.. math::

    m\,\dot{\mathbf V} = \mathbf F_{robot} + m\,\mathbf g + \mathbf F_{floor},\qquad
    \frac{d}{dt}(I\boldsymbol\omega) = \boldsymbol\tau_{robot} + \boldsymbol\tau_{floor},\qquad
    \dot{\mathbf c} = \mathbf V,\ \dot R = [\boldsymbol\omega]_\times R,

are integrated over the step by symplectic Euler sub-steps of at most
0.2/ω_floor (ω_floor² = k_n A/m, A its largest face): a staggered,
explicit coupling. The robot's impulse on the cargo over a step is then
exactly −Δt times the contact force of the step, so with the midpoint rule
(ρ∞ = 1) the total momentum of robot and cargo is conserved; it is stable
while the contact stiffness the robot meets, k_n times the area in contact,
stays below ~m/Δt² (the foams here: k_n = 10⁷ Pa/m, arm tips ~10⁻⁶ m²,
m ~ 10⁻⁵ kg: (ωΔt)² ~ 0.1 at Δt = 0.1 ms); the run's log says when it does
not. The floor (``floor``, a
horizontal plane at that height, optionally on the keyframes
``floor_motion``) holds the cargo with the same law and friction
``floor_friction``, sampled at 5 × 5 Gauss–Lobatto points on every face (a
sphere: 400 points), each carrying its area projected on the floor,
max(0, −n_z) × area: the floor presses on the cargo's horizontal shadow, so
a level box's side faces (whose bottom edges the Lobatto points also sample)
carry nothing and a tilting box's load passes over continuously.

Held. The cargo is *held* when the floor carries less than 1 % of its
weight and the robot at least half of it (with no gravity: when the robot
touches it and the floor does not).

History: ``cargo_<name>_x``, ``_y``, ``_z`` (centre, m), ``_vx``, ``_vy``,
``_vz`` (m/s), ``_fx``, ``_fy``, ``_fz`` (the robot's force on the cargo, N),
``_floor`` (the floor's upward force, N), ``_held`` (1 or 0) and ``_gap``
(the robot's smallest distance to it, m). Summary (from the ``_held`` column,
:func:`magfem.mechanics.observers.summary.summarize_cargo`): ``cargo_<name>_held_time``
(s held in all), ``_first_held`` and ``_released`` (the first instant held;
the instant after the last held one, if the run ends with the cargo not held;
nan if none).

    [[contacts]]
    kind = "cargo"
    name = "foam"
    shape = "box"
    center = [0, 0, "2 mm"]
    size = ["4 mm", "4 mm", "4 mm"]
    density = "30 kg/m^3"
    modulus = "50 kPa"
    floor = 0
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl

from magfem.config import MISSING, CaseError, option, quantity, vector
from magfem.field.placement import frame, rotation
from magfem.field.spec import FieldSpec
from magfem.mechanics.contacts.base import CONTACTS, Contact, ContactKindSpec
from magfem.mechanics.contacts.obstacle import Obstacle
from magfem.mechanics.contacts.penalty import PenaltyLaw, critical_contact_damping, penalty_ramp
from magfem.mechanics.contacts.rigid import MotionSpec, describe_motion, describe_shape
from magfem.mechanics.forms import ScalarForms
from magfem.mechanics.models.base import Model
from magfem.mechanics.spec import EnvironmentSpec, MaterialSpec

__all__ = ["Cargo", "CargoSpec", "RigidBody"]


@CONTACTS.register("cargo")
@dataclass(frozen=True, kw_only=True)
class CargoSpec(ContactKindSpec):
    """``[[contacts]] kind = "cargo"``: a rigid box or sphere with a compliant surface."""

    kind: str = option("cargo", ("cargo",), doc="contact kind")
    name: str = option(doc="a word for the history columns (letters, digits, _)")
    shape: str = option("box", ("box", "sphere"), doc="box or sphere")
    center: tuple[float, ...] = vector(unit="m", doc="its centre at the start")
    size: tuple[float, ...] | None = vector(None, "m", doc="box edges along its x, y, z")
    radius: float | None = quantity(None, "m", gt=0.0, doc="sphere radius")
    axis: tuple[float, ...] | None = vector(None, "", nonzero=True, doc="the box's z edge")
    roll: float | None = quantity(None, "rad", doc="the box's x edge turned about axis")
    density: float = quantity(unit="kg/m^3", gt=0.0, doc="mean density (foam: tens of kg/m³)")
    modulus: float = quantity(unit="Pa", gt=0.0, doc="Young's modulus of its surface layer")
    depth: float | None = quantity(
        None, "m", gt=0.0, doc="Winkler depth (default: half the smallest edge, or the radius)"
    )
    velocity: tuple[float, ...] = vector((0.0, 0.0, 0.0), "m/s", doc="velocity at the start")
    friction: float = quantity(0.5, "", ge=0.0, doc="robot–cargo Coulomb coefficient")
    penalty_onset: float = quantity(0.05, "", gt=0.0, doc="onset of the ramp, robot thicknesses")
    damping: float = quantity(1.0, "", ge=0.0, doc="contact dashpot, fraction of critical")
    regularization_velocity: float = quantity(1e-3, "m/s", gt=0.0, doc="friction's v_ε")
    slip_length: float = quantity(0.01, "", ge=0.0, doc="friction's ℓ, robot thicknesses")
    floor: float | None = quantity(None, "m", doc="height of a horizontal floor under it")
    floor_motion: MotionSpec | None = None
    floor_friction: float = quantity(0.5, "", ge=0.0, doc="cargo–floor Coulomb coefficient")

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise CaseError("name", self.name, "must be letters, digits and _ (a column name)")
        need = ("size",) if self.shape == "box" else ("radius",)
        other = ("radius",) if self.shape == "box" else ("size", "axis", "roll")
        for key in need:
            if getattr(self, key) is None:
                raise CaseError(key, MISSING, f"is required for shape '{self.shape}'")
        for key in other:
            if getattr(self, key) is not None:
                raise CaseError(key, getattr(self, key), f"is not a key of shape '{self.shape}'")
        if self.size is not None and not all(v > 0.0 for v in self.size):
            raise CaseError("size", self.size, "all three edges must be > 0 m")
        if self.floor_motion is not None and self.floor is None:
            raise CaseError("floor_motion", "(a motion)", "needs a floor")
        if self.floor_motion is not None and self.floor_motion.turns:
            raise CaseError("floor_motion.angles", self.floor_motion.angles, "the floor only moves")

    @property
    def side(self) -> str:
        """The robot stays outside the cargo."""
        return "outside"

    @property
    def motion(self) -> None:
        """The cargo moves by its own dynamics, not on keyframes."""
        return None

    @property
    def winkler_depth(self) -> float:
        """Depth (m) of the surface layer: a pressure p indents it by p depth / modulus."""
        if self.depth is not None:
            return self.depth
        return 0.5 * min(self.size) if self.size is not None else float(self.radius or 0.0)

    def describe(self) -> str:
        mass = _inertia(self)[0]
        floor = "no floor" if self.floor is None else f"floor at z = {1e3 * self.floor:.3g} mm"
        return (
            f"cargo '{self.name}': {describe_shape(self)}, {1e6 * mass:.3g} mg, "
            f"surface {self.modulus:.3g} Pa, {floor}{describe_motion(self.floor_motion)}"
        )

    def build(
        self,
        model: Model,
        material: MaterialSpec,
        *,
        environment: EnvironmentSpec | None = None,
        field: FieldSpec | None = None,
    ) -> Contact:
        gravity = environment.gravity if environment is not None else (0.0, 0.0, 0.0)
        return Cargo(self, model, material, gravity)


class RigidBody:
    """A rigid body's state and its sub-stepped equations of motion (numpy, every rank alike).

    Args:
        mass: m (kg). inertia: body-frame inertia tensor (3, 3) (kg·m²).
        center: c (3,) (m). velocity: V (3,) (m/s).

    Attributes:
        c, V, R, w: centre, velocity, rotation from the start, spin (world, rad/s).
    """

    def __init__(self, mass: float, inertia: npt.NDArray[np.float64], center: Any, velocity: Any):
        self.mass = float(mass)
        self.inertia = np.asarray(inertia, dtype=float)
        self.c = np.asarray(center, dtype=float).copy()
        self.V = np.asarray(velocity, dtype=float).copy()
        self.R = np.eye(3)
        self.w = np.zeros(3)

    def predict(self, tau: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(centre, rotation) extrapolated ``tau`` seconds ahead at constant V and ω."""
        spin = float(np.linalg.norm(self.w))
        turn = rotation(self.w / spin, spin * tau) if spin > 0.0 else np.eye(3)
        return self.c + tau * self.V, turn @ self.R

    def step(self, h: float, force: Any, torque: Any) -> None:
        """One symplectic Euler step of length h (s) under ``force`` (N) and ``torque`` (N·m)."""
        self.V = self.V + h * np.asarray(force) / self.mass
        self.c = self.c + h * self.V
        inertia = self.R @ self.inertia @ self.R.T  # world frame
        gyro = np.cross(self.w, inertia @ self.w)
        self.w = self.w + h * np.linalg.solve(inertia, np.asarray(torque) - gyro)
        spin = float(np.linalg.norm(self.w))
        if spin > 0.0:
            self.R = rotation(self.w / spin, spin * h) @ self.R


def _surface_points(
    spec: CargoSpec,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Reference points (N, 3) on the cargo's surface relative to its centre, their areas (N,)
    and outward unit normals (N, 3)."""
    if spec.shape == "sphere":
        n, r = 400, float(spec.radius or 0.0)
        idx = np.arange(n) + 0.5  # a Fibonacci lattice: equal areas
        z = 1.0 - 2.0 * idx / n
        phi = math.pi * (1.0 + 5.0**0.5) * idx
        rho = np.sqrt(1.0 - z * z)
        sphere = r * np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
        return sphere, np.full(n, 4.0 * math.pi * r * r / n), sphere / r
    half = 0.5 * np.asarray(spec.size, dtype=float)
    xg = np.array([-1.0, -math.sqrt(3.0 / 7.0), 0.0, math.sqrt(3.0 / 7.0), 1.0])
    wg = np.array([0.1, 49.0 / 90.0, 32.0 / 45.0, 49.0 / 90.0, 0.1])  # 5-point GLL on [-1, 1]
    pts: list[npt.NDArray[np.float64]] = []
    areas: list[float] = []
    normals: list[npt.NDArray[np.float64]] = []
    for k in range(3):
        i, j = [a for a in range(3) if a != k]
        for side in (-1.0, 1.0):
            for a, wa in zip(xg, wg, strict=True):
                for b, wb in zip(xg, wg, strict=True):
                    p = np.zeros(3)
                    p[k], p[i], p[j] = side * half[k], a * half[i], b * half[j]
                    pts.append(p)
                    areas.append(float(wa * wb * half[i] * half[j]))
                    normals.append(np.eye(3)[k] * side)
    axis = np.asarray(spec.axis if spec.axis is not None else (0.0, 0.0, 1.0), dtype=float)
    Rb = frame(axis / np.linalg.norm(axis), spec.roll or 0.0)
    return np.asarray(pts) @ Rb.T, np.asarray(areas), np.asarray(normals) @ Rb.T


def _inertia(spec: CargoSpec) -> tuple[float, npt.NDArray[np.float64]]:
    """Mass (kg) and body-frame inertia (3, 3) (kg·m²) of the uniform box or sphere."""
    if spec.shape == "sphere":
        r = float(spec.radius or 0.0)
        mass = spec.density * 4.0 / 3.0 * math.pi * r**3
        return mass, 0.4 * mass * r * r * np.eye(3)
    a, b, c = spec.size or (0.0, 0.0, 0.0)
    mass = spec.density * a * b * c
    local = mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    axis = np.asarray(spec.axis if spec.axis is not None else (0.0, 0.0, 1.0), dtype=float)
    Rb = frame(axis / np.linalg.norm(axis), spec.roll or 0.0)
    return mass, Rb @ local @ Rb.T


class Cargo(Obstacle):
    """The cargo of a :class:`CargoSpec` in contact with ``model`` (module docstring).

    Args:
        spec: the cargo's table.
        model: the robot.
        material: the robot's material (its density sets the contact dashpot).
        gravity: the acceleration of gravity (3,) (m/s²).
    """

    absorbs_impacts = False  # the cargo takes the robot's momentum through the contact

    def __init__(
        self, spec: CargoSpec, model: Model, material: MaterialSpec, gravity: Sequence[float]
    ):
        if model.gdim != 3:
            raise CaseError(f"cargo '{spec.name}'", "(a 2D strip)", "a cargo needs a 3D model")
        t = model.thickness
        stiffness = spec.modulus / spec.winkler_depth
        law = PenaltyLaw(
            stiffness=stiffness,
            onset=spec.penalty_onset * t,
            damping=spec.damping * critical_contact_damping(stiffness, material.density, t),
            friction=spec.friction,
            regularization_velocity=spec.regularization_velocity,
            slip_length=spec.slip_length * t,
        )
        mass, inertia = _inertia(spec)
        self.body = RigidBody(mass, inertia, spec.center, spec.velocity)
        self.gravity = np.asarray(gravity, dtype=float)
        self.t_state = model.integrator.time
        self.points, self.areas, self.normals = _surface_points(spec)
        self.floor_stiffness = stiffness
        if spec.shape == "box":
            a, b, c = spec.size or (0.0, 0.0, 0.0)
            height, area = max(a, b, c), max(a * b, b * c, a * c)
        else:
            height, area = 2.0 * float(spec.radius or 0.0), math.pi * float(spec.radius or 0.0) ** 2
        self.floor_damping = spec.damping * 2.0 * math.sqrt(stiffness * spec.density * height)
        self.floor_omega = math.sqrt(stiffness * area / mass)  # the cargo on its floor (rad/s)
        self.floor_force = 0.0
        super().__init__(
            spec, model, shear_modulus=material.shear_modulus, density=material.density, law=law
        )
        self.name = f"cargo_{spec.name}"
        faces = model.faces(*model.accepted(), self.surfaces, nodal=True)
        arm = [f.position - self.offset for f in faces]
        moment = functools.reduce(
            operator.add, [ufl.cross(r, self.traction(f)) for r, f in zip(arm, faces, strict=True)]
        )
        switch = [penalty_ramp(-self.surface(f.position)[0], self.onset)[1] for f in faces]
        # the moment about the cargo's centre (3) and the contact stiffness summed over faces
        self._moment_stiffness = ScalarForms(
            model.robot.mesh,
            [moment[i] * faces[0].measure for i in range(3)]
            + [self.stiffness * sum(switch) * faces[0].measure],
        )
        self._events: list[str] = []
        self._warned = False

    @property
    def turning(self) -> bool:  # type: ignore[override]
        """The cargo always turns (its own rotation)."""
        return True

    @turning.setter
    def turning(self, value: bool) -> None:
        pass

    def _place(self, t: float) -> None:
        c, R = self.body.predict(t - self.t_state)
        self.offset.value = c  # type: ignore[assignment]
        self.pivot.value = np.asarray(self.spec.center, dtype=float)  # type: ignore[assignment]
        self.rotation.value = R  # type: ignore[assignment]
        self.velocity.value = self.body.V  # type: ignore[assignment]
        self.spin.value = self.body.w  # type: ignore[assignment]

    def breakpoints(self, t0: float, t1: float) -> npt.NDArray[np.float64]:
        motion = self.spec.floor_motion
        if motion is None:
            return np.zeros(0)
        times = np.asarray(motion.times, dtype=float)
        return times[(times > t0) & (times <= t1)]

    # --- the cargo's own dynamics ---------------------------------------------------------------

    def floor_height(self, t: float) -> float:
        """Height of the floor at time t (m)."""
        spec = self.spec
        motion = spec.floor_motion
        shift = motion.placement(t).offset[2] if motion is not None else 0.0
        return float(spec.floor) + float(shift)

    def floor_contact(self, t: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(force (3,), torque (3,)) of the floor on the cargo at time t (N, N·m)."""
        if self.spec.floor is None:
            return np.zeros(3), np.zeros(3)
        b = self.body
        arm = self.points @ b.R.T
        x = b.c + arm
        v = b.V + np.cross(b.w, arm)
        depth = self.floor_height(t) - x[:, 2]
        onset = self.law.onset
        ramp = np.where(depth < onset, depth**2 / (2 * onset), depth - onset / 2)
        r = np.where(depth <= 0.0, 0.0, ramp)
        s = np.clip(depth / onset, 0.0, 1.0)
        p = self.floor_stiffness * r - self.floor_damping * s * v[:, 2]
        shadow = self.areas * np.maximum(0.0, -(self.normals @ b.R.T)[:, 2])
        p = np.maximum(p, 0.0) * shadow
        vt = v.copy()
        vt[:, 2] = 0.0
        eps = self.spec.regularization_velocity
        slip = np.sqrt(np.sum(vt * vt, axis=1) + eps * eps)
        f = -self.spec.floor_friction * (p / slip)[:, None] * vt
        f[:, 2] += p
        return f.sum(axis=0), np.cross(arm, f).sum(axis=0)

    def after_step(self) -> None:
        on_robot = np.array(self._forces.assemble())
        *moment_list, stiffness = self._moment_stiffness.assemble()
        moment = np.array(moment_list)
        t_end = self.model.integrator.time
        span = t_end - self.t_state
        b = self.body
        coupling = stiffness * span**2 / b.mass
        if coupling > 1.0 and not self._warned:
            self._warned = True
            self._events.append(
                f"t = {t_end:.6g} s: {self.name}: the robot's contact stiffness times Δt²/m is "
                f"{coupling:.3g} > 1, where the staggered coupling can gain energy: shorten "
                "time.max_step, or soften the cargo (modulus, depth)"
            )
        n = max(1, math.ceil(span * self.floor_omega / 0.2))
        h = span / n
        for k in range(n):
            t = self.t_state + (k + 1) * h
            floor_f, floor_tau = self.floor_contact(t)
            self.floor_force = float(floor_f[2])
            b.step(h, -on_robot + b.mass * self.gravity + floor_f, -moment + floor_tau)
        self.t_state = t_end

    def events(self) -> list[str]:
        out, self._events = self._events, []
        return out

    def state(self) -> dict[str, Any]:
        """The rigid body's state and the time it was advanced to (checkpoints)."""
        b = self.body
        return {
            "center": b.c.copy(),
            "velocity": b.V.copy(),
            "rotation": b.R.copy(),
            "spin": b.w.copy(),
            "t_state": float(self.t_state),
            "floor_force": float(self.floor_force),
            "warned": bool(self._warned),
        }

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`state`."""
        b = self.body
        b.c = np.asarray(state["center"], dtype=float).copy()
        b.V = np.asarray(state["velocity"], dtype=float).copy()
        b.R = np.asarray(state["rotation"], dtype=float).copy()
        b.w = np.asarray(state["spin"], dtype=float).copy()
        self.t_state = float(state["t_state"])
        self.floor_force = float(state["floor_force"])
        self._warned = bool(state["warned"])
        self._place(self.t_state)

    # --- observation ----------------------------------------------------------------------------

    def columns(self) -> list[str]:
        n = self.name
        cols = [f"{n}_{a}" for a in "xyz"] + [f"{n}_v{a}" for a in "xyz"]
        cols += [f"{n}_f{a}" for a in "xyz"]
        return [*cols, f"{n}_floor", f"{n}_held", f"{n}_gap"]

    def observe(self, t: float) -> dict[str, float]:
        self._place(t)
        n, b = self.name, self.body
        on_cargo = -np.array(self._forces.assemble())
        row = {f"{n}_{a}": float(v) for a, v in zip("xyz", b.c, strict=True)}
        row |= {f"{n}_v{a}": float(v) for a, v in zip("xyz", b.V, strict=True)}
        row |= {f"{n}_f{a}": float(v) for a, v in zip("xyz", on_cargo, strict=True)}
        row[f"{n}_floor"] = self.floor_force
        held = self._is_held(on_cargo)
        row[f"{n}_held"] = float(held)
        row[f"{n}_gap"] = self.gap()
        return row

    def _is_held(self, on_cargo: npt.NDArray[np.float64]) -> bool:
        g = float(np.linalg.norm(self.gravity))
        weight = self.body.mass * g
        if weight == 0.0:
            return bool(np.linalg.norm(on_cargo) > 0.0 and self.floor_force == 0.0)
        up = -self.gravity / g
        return bool(self.floor_force < 0.01 * weight and on_cargo @ up >= 0.5 * weight)
