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
``box``         ``center``, ``size`` (edges along the   |⟨q⟩₊| + min(max_i q_i, 0),
                box's x, y, z), optional ``axis`` (its  q = |Rᵦᵀ(x − c)| − size/2
                z edge) and ``roll`` (its x edge about
                ``axis``)
==============  =====================================  ===========================

The cone's g is the distance to its surface line in the plane through the
axis (exact where the nearest point is on the mantle, i.e. away from the
apex); the box's is its exact signed distance (an enclosure: ``side =
"inside"``; a crate or a step: ``"outside"``), with the normal of the
nearest face inside it and the gradient of the distance outside.

Every obstacle may move rigidly with ``motion``: keyframe ``times`` (s),
offsets ``positions`` (m) and ``angles`` (rad) about ``rotation_axis``
through ``pivot`` (a point of the obstacle as the table places it), each
interpolated linearly and held outside the keyframes, as the field's
``[[field.motions]]`` do. With the placement x = R (y − p) + p + d of the
obstacle's reference points y, the distance at a point x is g(Rᵀ(x − p − d) + p),
the normal R n, and the obstacle's surface moves at d' + ω × (x − p − d)
(ω = θ' â). The placement and its rates are Constants set at the end of
each step; the keyframes are switching instants the steps land on.

The contact law is the ground's penalty with friction
(:mod:`magfem.mechanics.contacts.penalty`) on the penetration δ = −g, with
the velocity relative to the moving obstacle, acting at the end of the step
in dynamic runs. After each accepted dynamic step,
:class:`ObstacleAbsorber` makes impacts on it perfectly inelastic in the
normal direction, as the ground's absorber does for landings (a node that
has entered the obstacle loses the normal velocity with which it leaves it;
docs/untethered.md, "Impacts on obstacles"). On a
strip (side view) the obstacle is its section in the x–z plane (vectors
keep their x and z; it may only turn about y). History: ``obstacle_<name>_x``,
``_y`` (3D only), ``_z``: the force of the obstacle on the robot (N; N/m ×
depth for strips); ``obstacle_<name>_gap``: the smallest signed distance of
the robot's face nodes from it (m; negative: the deepest penetration).

The contact is integrated at the nodes of the robot's faces (Gauss–Lobatto
points: :meth:`~magfem.mechanics.models.base.Model.faces` with ``nodal``),
so corners and edges feel it: with the model's Gauss points, a plate's
corner entered a cone's slanted wall by 93 % of the thickness before a
quadrature point touched it (with nodes: 2 %).

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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from mpi4py import MPI

from magfem.config import MISSING, CaseError, option, quantity, vector
from magfem.field.spec import FieldSpec
from magfem.mechanics.contacts.base import CONTACTS, Contact, ContactKindSpec
from magfem.mechanics.contacts.penalty import PenaltyLaw, create_penalty_law, penalty_ramp
from magfem.mechanics.contacts.rigid import (
    MotionSpec,
    box_frame,
    describe_motion,
    describe_shape,
    signed_distance,
)
from magfem.mechanics.forms import ScalarForms
from magfem.mechanics.models.base import Face, Model, sum_work
from magfem.mechanics.spec import EnvironmentSpec, MaterialSpec
from magfem.parallel import JIT_WAIT

__all__ = [
    "OBSTACLE_SHAPES",
    "MotionSpec",
    "Obstacle",
    "ObstacleAbsorber",
    "ObstacleSpec",
    "signed_distance",
]

OBSTACLE_SHAPES = ("half_space", "sphere", "cylinder", "cone", "box")
_KEYS = {
    "half_space": ("point", "normal"),
    "sphere": ("center", "radius"),
    "cylinder": ("point", "axis", "radius"),
    "cone": ("apex", "axis", "half_angle"),
    "box": ("center", "size"),
}
_OPTIONAL = {"box": ("axis", "roll")}


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
    axis: tuple[float, ...] | None = vector(
        None, "", nonzero=True, doc="cylinder or cone axis; the box's z edge (default z)"
    )
    half_angle: float | None = quantity(None, "rad", gt=0.0, lt=math.pi / 2, doc="cone")
    size: tuple[float, ...] | None = vector(None, "m", doc="box edges along its x, y, z")
    roll: float | None = quantity(None, "rad", doc="box: its x edge turned about axis")
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
        allowed = {*_KEYS[self.shape], *_OPTIONAL.get(self.shape, ())}
        every = {k for keys in (*_KEYS.values(), *_OPTIONAL.values()) for k in keys}
        for key in every - allowed:
            if getattr(self, key) is not None:
                raise CaseError(key, getattr(self, key), f"is not a key of shape '{self.shape}'")
        if self.size is not None and not all(v > 0.0 for v in self.size):
            raise CaseError("size", self.size, "all three edges must be > 0 m")

    def describe(self) -> str:
        return (
            f"obstacle '{self.name}': {describe_shape(self)}, robot {self.side}"
            f"{describe_motion(self.motion)}"
        )

    def build(
        self,
        model: Model,
        material: MaterialSpec,
        *,
        environment: EnvironmentSpec | None = None,
        field: FieldSpec | None = None,
    ) -> Contact:
        return Obstacle(self, model, shear_modulus=material.shear_modulus, density=material.density)


class Obstacle(Contact):
    """The contact of a :class:`ObstacleSpec` with ``model``'s faces (module docstring).

    Args:
        spec: the obstacle.
        model: the body.
        shear_modulus, density: of the membrane (Pa, kg/m³), which scale the law.
        law: the penalty law (default: the spec's, scaled by the membrane).
        motion: its keyframed motion (default: the spec's ``motion``).

    Attributes:
        absorbs_impacts: impacts are made inelastic by an :class:`ObstacleAbsorber`
            (dynamic runs); a body that takes momentum from the robot must not.
    """

    absorbs_impacts = True

    def __init__(
        self,
        spec: Any,
        model: Model,
        *,
        shear_modulus: float,
        density: float,
        law: PenaltyLaw | None = None,
        motion: MotionSpec | None = None,
    ):
        self.spec = spec
        self.motion = motion if motion is not None else spec.motion
        self.model = model
        self.name = f"obstacle_{spec.name}"
        self.surfaces = ("all",)
        self.nodal = True
        self.law = law or create_penalty_law(
            spec, shear_modulus=shear_modulus, density=density, thickness=model.thickness
        )
        mesh = model.robot.mesh
        self.gdim = gdim = model.gdim
        self.keep = [0, 1, 2] if gdim == 3 else [0, 2]
        if spec.shape == "box":
            box_frame(spec, gdim)  # a strip needs a box edge along y
        self.turning = self.motion is not None and self.motion.turns
        if self.turning and gdim == 2:
            axis = np.asarray(self.motion.rotation_axis, dtype=float)
            if not np.allclose(axis[[0, 2]], 0.0):
                raise CaseError(
                    f"obstacle '{spec.name}'.motion.rotation_axis",
                    self.motion.rotation_axis,
                    "the strip model (x-z side view) can only turn about y",
                )
        zeros = np.zeros(gdim)
        self.offset = fem.Constant(mesh, zeros.copy())  # p + d when turning, else d
        self.velocity = fem.Constant(mesh, zeros.copy())
        self.rotation = fem.Constant(mesh, np.eye(gdim))
        self.pivot = fem.Constant(mesh, zeros.copy())
        self.spin = fem.Constant(mesh, np.zeros(3) if gdim == 3 else 0.0)
        self.stiffness = fem.Constant(mesh, self.law.stiffness)
        self.onset = fem.Constant(mesh, self.law.onset)
        self.damping = fem.Constant(mesh, self.law.damping)
        self.friction = fem.Constant(mesh, self.law.friction)
        eps2 = self.law.regularization_velocity**2
        dt = model.integrator.dt
        self.eps2 = eps2 + (self.law.slip_length / dt) ** 2 if model.integrator.dynamic else eps2
        self._place(model.integrator.time)
        faces = model.faces(*model.accepted(), self.surfaces, nodal=self.nodal)
        total = functools.reduce(operator.add, [self.traction(f) for f in faces])
        self._forces = ScalarForms(mesh, [total[i] * faces[0].measure for i in range(gdim)])
        # (g, n, w) at the displacement's nodes of each face: the gap and the impact absorber
        nodes = model.u.function_space.element.interpolation_points
        self._at_nodes = [
            fem.Expression(ufl.as_vector([g, *n, *w]), nodes, jit_options=JIT_WAIT)
            for g, n, w in (self.surface(f.position) for f in faces)
        ]
        tdim = mesh.topology.dim
        self._cells = np.arange(mesh.topology.index_map(tdim).size_local, dtype=np.int32)
        self.absorber: ObstacleAbsorber | None = None
        if model.integrator.dynamic and self.absorbs_impacts:
            self.absorber = ObstacleAbsorber(model.u.function_space, self._at_nodes)

    def distance(self, x: Any, offset: Any) -> tuple[Any, Any]:
        """(g, n) of the shape in its table's placement translated by ``offset`` (UFL)."""
        return signed_distance(self.spec, x, offset, self.gdim)

    def surface(self, x: Any) -> tuple[Any, Any, Any]:
        """(g, n, v): distance (m), unit normal and the obstacle's velocity at x (UFL)."""
        if not self.turning:
            g, n = self.distance(x, self.offset)
            return g, n, self.velocity
        R = self.rotation
        arm = x - self.offset
        g, n = self.distance(R.T * arm + self.pivot, 0.0 * self.offset)
        if self.gdim == 3:
            return g, R * n, self.velocity + ufl.cross(self.spin, arm)
        w = self.spin  # about y: ω × (r_x, 0, r_z) = ω (r_z, 0, −r_x)
        return g, R * n, self.velocity + ufl.as_vector([w * arm[1], -w * arm[0]])

    def traction(self, face: Face) -> Any:
        """Traction (Pa per reference area) of the obstacle on a face's points (UFL)."""
        g, n, moving = self.surface(face.position)
        v = face.velocity - moving
        vn = ufl.dot(v, n)
        r, s = penalty_ramp(-g, self.onset)
        p = self.stiffness * r - self.damping * s * vn
        p = ufl.conditional(ufl.gt(p, 0.0), p, 0.0)
        v_t = v - vn * n
        return p * n - self.friction * p * v_t / ufl.sqrt(ufl.dot(v_t, v_t) + self.eps2)

    def work(self, faces: Sequence[Face]) -> list[ufl.Form]:
        return sum_work(faces, [self.traction(f) for f in faces])

    def _place(self, t: float) -> None:
        if self.motion is None:
            return
        placed = self.motion.placement(t)
        keep = self.keep
        self.velocity.value = placed.velocity[keep]  # type: ignore[assignment]
        if not self.turning:
            self.offset.value = placed.offset[keep]  # type: ignore[assignment]
            return
        self.offset.value = (placed.pivot + placed.offset)[keep]  # type: ignore[assignment]
        self.pivot.value = placed.pivot[keep]  # type: ignore[assignment]
        self.rotation.value = placed.R[np.ix_(keep, keep)]  # type: ignore[assignment]
        self.spin.value = placed.spin if self.gdim == 3 else placed.spin[1]  # type: ignore[assignment]

    def before_solve(self) -> None:
        integ = self.model.integrator
        self._place(integ.time + float(integ.dt.value))  # it acts at the end of the step

    def after_step(self) -> None:
        if self.absorber is not None:
            integ = self.model.integrator
            self.absorber.apply(integ.v0, integ.a0)

    def state(self) -> dict[str, Any]:
        """The nodes inside the obstacle at the last step (the impact absorber's memory)."""
        if self.absorber is None:
            return {"touching": np.zeros(0, dtype=np.int64)}
        return {"touching": self.absorber.touching_global()}

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`state`."""
        if self.absorber is not None:
            self.absorber.set_touching_global(np.asarray(state["touching"], dtype=np.int64))

    def breakpoints(self, t0: float, t1: float) -> npt.NDArray[np.float64]:
        if self.motion is None:
            return np.zeros(0)
        times = np.asarray(self.motion.times, dtype=float)
        return times[(times > t0) & (times <= t1)]

    def columns(self) -> list[str]:
        axes = "xyz" if self.gdim == 3 else "xz"
        return [*(f"{self.name}_{a}" for a in axes), f"{self.name}_gap"]

    def gap(self) -> float:
        """Smallest signed distance (m) of the faces' nodes from the obstacle (collective).

        Negative: the deepest penetration. Evaluated at the displacement's nodes of
        every cell on each face (a solid's interior nodes too, which are never deeper).
        """
        mesh = self.model.robot.mesh
        local = np.inf
        if self._cells.size:
            width = 1 + 2 * self.gdim  # g, n, w
            local = min(
                float(np.min(e.eval(mesh, self._cells).reshape(-1, width)[:, 0]))
                for e in self._at_nodes
            )
        return float(mesh.comm.allreduce(local, op=MPI.MIN))

    def observe(self, t: float) -> dict[str, float]:
        self._place(t)
        forces = self._forces.assemble()
        row = {c: f * self.model.depth for c, f in zip(self.columns()[:-1], forces, strict=True)}
        row[f"{self.name}_gap"] = self.gap()
        return row


class ObstacleAbsorber:
    """Perfectly inelastic normal impact of the body's nodes on a rigid obstacle.

    The counterpart of the ground's
    :class:`~magfem.mechanics.contacts.ground.ImpactAbsorber` for a surface of
    any shape and motion: a node stopped by the penalty within a step leaves
    it with the velocity the generalized-α update reverses, so an impact
    rebounds at a speed set by the step, not by the contact law (the ground's
    measurements: docs/verification.md, "Impact").

    After each accepted step, every node of the displacement whose face point
    is inside the obstacle (g < 0; of a shell's two faces, the deeper) loses
    its velocity *out of* the obstacle relative to the obstacle's surface,
    (v − w)·n > 0, and its normal acceleration: at the step it arrives, and
    later only when it leaves faster than ``rest_velocity`` (resting and
    sliding contact are left alone, as on the ground). Tangential motion is
    left to friction.

    Args:
        V: the displacement space (blocked vector Lagrange, gdim components).
        at_nodes: per face, the Expression of the vector (g, n, w) at V's nodes,
            for the face's points of the accepted state: signed distance (m), the
            obstacle's outward unit normal and its surface velocity (m/s).
        rest_velocity: the bounce threshold (m/s) of nodes already inside.

    :meth:`apply` is collective.
    """

    def __init__(self, V: Any, at_nodes: Sequence[Any], *, rest_velocity: float = 1e-3) -> None:
        mesh = V.mesh
        self.mesh = mesh
        self.bs = V.dofmap.index_map_bs
        self.rest_velocity = float(rest_velocity)
        self._contact = list(at_nodes)
        tdim = mesh.topology.dim
        self._cells = np.arange(mesh.topology.index_map(tdim).size_local, dtype=np.int32)
        self._dofs = np.asarray(V.dofmap.list)[self._cells]  # (cells, nodes per cell)
        imap = V.dofmap.index_map
        self._owned = imap.size_local
        self._global = imap.local_to_global(np.arange(imap.size_local + imap.num_ghosts))
        # the local nodes (owned and ghost) that were inside at the last call
        self.touching = np.zeros(self._global.size, dtype=bool)

    def apply(self, v: Any, a: Any) -> int:
        """Remove the outward normal velocity/acceleration of nodes that hit the obstacle.

        Args:
            v, a: velocity and acceleration Functions of ``V`` at t_{n+1} (the
                integrator's v_n, a_n after ``advance``), changed in place.

        Returns:
            the number of nodes reset (global).
        """
        bs = self.bs
        inside = np.zeros(0, dtype=np.int64)
        reset_count = 0
        if self._cells.size:
            ncell, nper = self._dofs.shape
            values = np.concatenate(
                [e.eval(self.mesh, self._cells).reshape(ncell * nper, -1) for e in self._contact]
            )
            node = np.tile(self._dofs.ravel(), len(self._contact))
            hit = values[:, 0] < 0.0
            values, node = values[hit], node[hit]
            deepest = np.argsort(values[:, 0], kind="stable")
            inside, first = np.unique(node[deepest], return_index=True)  # the deeper face per node
            values = values[deepest[first]]
            n, w = values[:, 1 : 1 + bs], values[:, 1 + bs : 1 + 2 * bs]
            vel = v.x.array.reshape(-1, bs)
            acc = a.x.array.reshape(-1, bs)
            vn = np.einsum("ij,ij->i", vel[inside] - w, n)
            fresh = ~self.touching[inside]
            reset = (vn > 0.0) & (fresh | (vn > self.rest_velocity))
            idx = inside[reset]
            vel[idx] -= vn[reset, None] * n[reset]
            acc[idx] -= np.einsum("ij,ij->i", acc[idx], n[reset])[:, None] * n[reset]
            reset_count = int(np.count_nonzero(idx < self._owned))
        self.touching[:] = False
        self.touching[inside] = True
        v.x.scatter_forward()
        a.x.scatter_forward()
        return int(self.mesh.comm.allreduce(reset_count))

    def touching_global(self) -> npt.NDArray[np.int64]:
        """Global indices of the nodes inside at the last call (every rank's; collective)."""
        mine = self._global[self.touching]
        return np.unique(np.concatenate(self.mesh.comm.allgather(mine)))

    def set_touching_global(self, nodes: npt.NDArray[np.int64]) -> None:
        """Restore :meth:`touching_global`."""
        self.touching = np.isin(self._global, nodes)
