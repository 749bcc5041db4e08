"""The interface every structural model implements (solid, strip, shell, rod).

A :class:`Model` is a discretised body: its unknowns and their time
integrator, its elastic energy and inertia, and the kinematic handles that
loads and contacts use — the hard-magnetic energy density at a state, the
displacement of its mass points, the surfaces that can touch obstacles
(:class:`Face`). The problem (:mod:`magfem.mechanics.problem`) writes the
step residual from a model, a list of loads and a list of contacts without
knowing which they are.

A *state* is the list of UFL expressions of the model's unknowns (``[u]``
or the shell's ``[u, θ]``); *rates* and *accelerations* are their time
derivatives, as lists of the same shapes.
"""

from __future__ import annotations

import functools
import operator
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import basix.ufl
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem

from magfem.config import CaseError
from magfem.geometry.robot_mesh import Arm, RobotMesh
from magfem.mechanics.block_integrator import BlockIntegrator
from magfem.mechanics.integrator import TimeIntegrator
from magfem.mechanics.models.pressure import MixedPressure
from magfem.mechanics.pose import RigidMotion
from magfem.mechanics.spec import EnvironmentSpec, MaterialSpec, SolverSpec, TimeSpec
from magfem.plugins import Registry

__all__ = [
    "MODELS",
    "BodySetup",
    "Face",
    "FluxDensity",
    "Model",
    "ModelInputs",
    "director_faces",
    "midsurface_sides",
    "nodal_metadata",
    "rate_of",
    "sum_work",
]

State = Sequence[Any]
"""One UFL expression per unknown: a state, its rates or its accelerations."""
Names = Sequence[str]
"""Names of faces, groups or sides (``[contact] surfaces``)."""
Faces = list["Face"]
"""A model's contact faces (:meth:`Model.faces`)."""

FluxDensity = Callable[[Any], Any]
"""B_a(x) (T) as a UFL 3-vector of a current position x (UFL 3-vector, m)."""


@dataclass(frozen=True)
class BodySetup:
    """What a model needs to know about the robot beyond its mesh.

    Attributes:
        depth: out-of-plane depth (m) of a 2D strip, whose integrals are per
            unit depth (1 for 3D models): multiplies per-depth totals.
        center: the robot's centre in mesh coordinates (m): the shell's
            bending frame of radial robots turns about it.
        rotation: the rotation (3×3, rows) of the body's initial placement
            (``[initial]``), or None: the shell measures its directors from it.
        turn_axis: the in-plane axis the shell's director turns about without limit
            (``[mesh] turn_axis``), or None: the shell's own choice.
    """

    depth: float = 1.0
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[tuple[float, ...], ...] | None = None
    turn_axis: tuple[float, ...] | None = None


@dataclass(frozen=True)
class ModelInputs:
    """What a model is built from: the robot's mesh and the case tables it reads.

    Attributes:
        robot: the robot mesh of the model's kind.
        material: ``[material]``.
        solver: ``[solver]`` (element degree, quadrature degrees).
        time: ``[time]`` (scheme, ρ∞, first step).
        environment: ``[environment]`` (supports).
        body: what the model needs to know about the robot beyond its mesh.
    """

    robot: RobotMesh
    material: MaterialSpec
    solver: SolverSpec
    time: TimeSpec
    environment: EnvironmentSpec
    body: BodySetup = BodySetup()


@dataclass(frozen=True)
class Face:
    """A surface of the body that may touch an obstacle, at one state (UFL).

    Attributes:
        position: current position x of its points (UFL gdim-vector, m).
        velocity: their velocity (UFL gdim-vector, m/s).
        work: maps a traction t (UFL gdim-vector, Pa per reference area) to
            its virtual work on each unknown's test function (list of forms,
            one per unknown), integrated over the face.
        measure: the measure the face is integrated over (``ds`` of facets or
            ``dx`` of a mid-surface), explicit quadrature degree.
        facets: local indices of the face's facets, or None when every node of
            the mesh is on it (a mid-surface).
        normal: n da/dA, the current outward unit normal times the current
            area per reference area (UFL gdim-vector; Nanson's formula), for
            loads that depend on the face's orientation (pressure, fluid).
        count: how many of the body's faces it stands for (2: a thin model's
            two faces taken at its mid-surface, :meth:`Model.fluid_faces`);
            a load multiplies its traction by it.
    """

    position: Any
    velocity: Any
    work: Callable[[Any], list[Any]]
    measure: Any
    facets: npt.NDArray[np.int32] | None
    normal: Any = None
    count: int = 1


def sum_work(faces: Sequence[Face], tractions: Sequence[Any]) -> list[Any]:
    """Σ over faces of the virtual work of one traction per face, per unknown."""
    total: list[Any] | None = None
    for face, t in zip(faces, tractions, strict=True):
        work = face.work(t)
        total = work if total is None else [a + b for a, b in zip(total, work, strict=True)]
    if total is None:
        raise ValueError("sum_work needs at least one face")
    return total


class Model(ABC):
    """A discretised robot body (see the module docstring).

    Subclasses set these attributes in their constructor:

    Attributes:
        robot: the robot mesh and its groups.
        gdim: geometric dimension of the mesh (2: strip side view (x, z); 3).
        unknowns: the unknowns, displacement first (m; angles in rad).
        tests: a test function per unknown.
        integrator: the time integrator of the unknowns.
        dx: cell measure with the model's quadrature degree.
        quadrature_degree: the degree of every measure of the model.
        mass_density: mass per unit of the mesh's measure (kg/m³ solid; kg/m²
            shell; kg/m² per unit depth strip) as a UFL scalar.
        face_offset: height of the mesh above the robot's bottom face (m).
        depth: out-of-plane depth of a strip (m), 1 for 3D models.
        magnetization: remanent magnetization M̃ (DG0, A/m).
        bcs: Dirichlet conditions (homogeneous) of every unknown.
        displacement_bcs: the conditions on the displacement.
        free_body: nothing holds the body.
        X: the reference coordinates (UFL ``SpatialCoordinate``, m).
        strain_metrics: UFL right Cauchy–Green tensors whose largest stretch is
            the largest strain, or None for FᵀF of the displacement.
    """

    kinematics: str = "model"
    robot: RobotMesh
    gdim: int
    unknowns: list[fem.Function]
    tests: list[Any]
    integrator: TimeIntegrator | BlockIntegrator
    dx: ufl.Measure
    X: Any
    quadrature_degree: int
    mass_density: Any
    face_offset: float
    depth: float
    magnetization: fem.Function
    bcs: list[fem.DirichletBC]
    displacement_bcs: list[fem.DirichletBC]
    free_body: bool
    strain_metrics: list[Any] | None = None

    @abstractmethod
    def __init__(self, inputs: ModelInputs) -> None:
        """Build the model's spaces, unknowns, integrator and supports on ``inputs.robot``."""

    def _displacement_and_angles(
        self, inputs: ModelInputs, angles: int, angle_name: str
    ) -> tuple[fem.FunctionSpace, fem.FunctionSpace]:
        """Lagrange displacement (3) and ``angles`` rotation unknowns of the solver's degree.

        For the models of a mid-surface or midline in 3D: sets ``unknowns``,
        ``tests``, the block ``integrator`` and ``quadrature_degree`` (the
        solver's, or twice the degree); returns the two spaces.
        """
        domain, degree = inputs.robot.mesh, inputs.solver.degree
        self.quadrature_degree = inputs.solver.quadrature_degree or 2 * degree
        cell = domain.basix_cell()
        spaces = [
            fem.functionspace(domain, basix.ufl.element("Lagrange", cell, degree, shape=(n,)))
            for n in (3, angles)
        ]
        self.unknowns = [
            fem.Function(spaces[0], name="displacement"),
            fem.Function(spaces[1], name=angle_name),
        ]
        self.tests = [ufl.TestFunction(V) for V in spaces]
        self.integrator = BlockIntegrator([time_integrator(f, inputs.time) for f in self.unknowns])
        return spaces[0], spaces[1]

    @property
    def u(self) -> fem.Function:
        """The displacement unknown u_{n+1} (m)."""
        return self.unknowns[0]

    @property
    def arms(self) -> tuple[Arm, ...]:
        """The robot's arms."""
        return self.robot.arms

    @property
    def thickness(self) -> float:
        """Membrane thickness (m)."""
        return self.robot.thickness

    @abstractmethod
    def elastic_energy(self, state: Sequence[Any]) -> ufl.Form:
        """Strain energy at ``state`` (J; J/m for strips), a UFL form."""

    @abstractmethod
    def strain_rate_energy(self, state: Sequence[Any], rates: Sequence[Any]) -> ufl.Form:
        """½ ∫ ṡ : ℂ₀ : ṡ (J/s²; J/(s² m) for strips), a UFL form.

        ṡ = Ds(q)[q̇] are the rates of the model's objective strain measures s
        (zero for a rigid motion at any state) and ℂ₀ its small-strain
        stiffness: the dissipation potential of material damping
        (:mod:`magfem.mechanics.loads.damping`).
        """

    @abstractmethod
    def magnetic_energy_density(self, state: Sequence[Any], flux: FluxDensity) -> Any:
        """Hard-magnetic energy −(F M̃)·B_a(x) per unit of the mesh's measure (UFL)."""

    @abstractmethod
    def inertia(self, accelerations: Sequence[Any]) -> list[ufl.Form]:
        """Virtual work of the inertia forces, one form per unknown."""

    def inertia_at(
        self, states: Sequence[Any], rates: Sequence[Any], accelerations: Sequence[Any]
    ) -> list[ufl.Form]:
        """Virtual work of the inertia forces at a state and its rates, one form per unknown.

        The default is :meth:`inertia` (linear in the accelerations); a model
        whose inertia depends on its state (the rod's rotary inertia, with its
        gyroscopic term) overrides it.
        """
        return self.inertia(accelerations)

    @abstractmethod
    def kinetic_energy(self, rates: Sequence[Any]) -> ufl.Form:
        """Kinetic energy (J; J/m for strips) at the given rates."""

    @abstractmethod
    def faces(self, state: State, rates: State, surfaces: Names, *, nodal: bool = False) -> Faces:
        """The contact faces named by ``surfaces`` (``"all"``, groups or sides) at a state.

        ``nodal``: integrate with the Gauss–Lobatto points of the displacement's
        degree (:func:`nodal_metadata`), which are its nodes, corners and edges
        included, on quadrilateral and hexahedral cells (the default rule
        elsewhere): a contact then acts wherever a node meets the obstacle, and
        a corner cannot pass an obstacle's slanted wall between two interior
        quadrature points.

        Raises:
            CaseError: a name the model does not have (key ``contact.surfaces``).
        """

    def fluid_faces(self, state: State, rates: State, surfaces: Names) -> Faces:
        """The faces a surrounding fluid acts on: :meth:`faces` (a thin model may stand its
        two faces by one at its mid-surface, with ``count`` 2)."""
        return self.faces(state, rates, surfaces)

    def place(self, motion: RigidMotion) -> None:
        """Start from a rigid placement and velocity: u_n, the iterate and v_n (collective).

        The displacement's nodes get x₀ − X and the rigid velocity at x₀
        (:class:`~magfem.mechanics.pose.RigidMotion`); a strip's nodes are
        (x, z) and keep those components.
        """
        integ = self.integrator.parts[0]
        V = self.u.function_space
        gdim = self.gdim
        X = V.tabulate_dof_coordinates()
        X3 = X.copy() if gdim == 3 else np.column_stack([X[:, 0], np.zeros(len(X)), X[:, 1]])
        keep = [0, 1, 2] if gdim == 3 else [0, 2]
        disp = (motion.position(X3) - X3)[:, keep]
        integ.u0.x.array[:] = disp.ravel()
        integ.u.x.array[:] = disp.ravel()
        integ.v0.x.array[:] = motion.speed(X3)[:, keep].ravel()
        integ.a0.x.array[:] = 0.0

    def displacement(self, state: Sequence[Any]) -> Any:
        """Displacement of the mass points (UFL gdim-vector, m): what gravity works on."""
        return state[0]

    def stage(self) -> tuple[list[Any], list[Any], list[Any]]:
        """(state, rates, accelerations) at the integrator's stage point."""
        parts = self.integrator.parts
        triples = [p.stage() for p in parts]
        return [s[0] for s in triples], [s[1] for s in triples], [s[2] for s in triples]

    def end_of_step(self) -> tuple[list[Any], list[Any]]:
        """(state, rates) at t_{n+1} as UFL expressions of the unknowns."""
        if not self.integrator.dynamic:
            return list(self.unknowns), [ufl.zero(*ufl.shape(u)) for u in self.unknowns]
        return list(self.unknowns), [p.velocity() for p in self.integrator.parts]

    def accepted(self) -> tuple[list[Any], list[Any]]:
        """(state, rates) of the last accepted step t_n as Functions (after ``advance``)."""
        return list(self.unknowns), [p.v0 for p in self.integrator.parts]

    def mixed_pressure(self, points: int) -> MixedPressure | None:
        """The pressure Newton solves for with the displacement, or None (the default).

        ``points``: the states per step at which the potential's forces act
        (:meth:`~magfem.mechanics.integrator.TimeIntegrator.potential_points`).
        """
        return None

    def residual_form(self, forms: list[Any]) -> Any:
        """The residual as NewtonSolver takes it: one form, or the list of block forms."""
        return forms if len(forms) > 1 else forms[0]


def nodal_metadata(mesh: Any, degree: int, quadrature_degree: int) -> dict[str, Any]:
    """Measure metadata of the nodal (Gauss–Lobatto) contact quadrature, or the default one.

    GLL with degree + 1 points per direction (exact to degree 2 degree − 1): the
    nodes of a Lagrange element of ``degree`` on quadrilaterals and hexahedra;
    simplices keep ``quadrature_degree`` (basix has no GLL rule for them).
    """
    if mesh.topology.cell_name() in ("quadrilateral", "hexahedron"):
        return {"quadrature_degree": 2 * degree - 1, "quadrature_rule": "GLL"}
    return {"quadrature_degree": quadrature_degree}


MODELS: Registry[type[Model]] = Registry("model")
"""``[mesh] model`` name -> Model class (filled by the model modules)."""


def time_integrator(unknown: fem.Function, time: TimeSpec) -> TimeIntegrator:
    """The ``[time]`` scheme's integrator of one unknown (its ρ∞ and first step)."""
    return TimeIntegrator(
        unknown,
        time.scheme,
        rho_inf=time.rho_inf,
        dt=time.step,
        average_forces=time.average_forces,
    )


_SIDES = {"bottom": -1.0, "clamp": -1.0, "top": 1.0}


def midsurface_sides(names: Sequence[str], model: str) -> list[float]:
    """Faces (−1 bottom, +1 top) of ``[contact] surfaces`` for a model of the mid-surface.

    Raises:
        CaseError: a name other than ``all``, ``bottom``, ``clamp`` and ``top``.
    """
    unknown = set(names) - {"all", *_SIDES}
    if unknown:
        raise CaseError(
            "contact.surfaces",
            list(names),
            f'the {model} model has the faces "all", "bottom" (with "clamp") and "top"',
        )
    if "all" in names:
        return [-1.0, 1.0]
    return [s for s in (-1.0, 1.0) if any(_SIDES.get(n) == s for n in names)]


def director_faces(
    model: Model,
    disp: Any,
    rates: State,
    director: Any,
    jacobian: Any,
    sides: Sequence[float],
    measure: Any,
    area_normal: Any = None,
) -> Faces:
    """The faces at ±t/2 along a director of a mid-surface or midline model (shell, rod).

    Face points x = X + u + h d (h = ±t/2) move as u̇ + h (∂d/∂θ) θ̇; a traction t
    works on δu and, through the lever h ∂d/∂θ, on δθ. ``area_normal``: the
    mid-surface's n da/dA (signed per side), or None.
    """
    w_u, w_t = model.tests
    out = []
    for side in sides:
        h = side * 0.5 * model.thickness
        lever = h * jacobian

        def work(t: Any, lever: Any = lever) -> list[Any]:
            return [ufl.dot(t, w_u) * measure, ufl.dot(lever.T * t, w_t) * measure]

        out.append(
            Face(
                position=model.X + disp + h * director,
                velocity=rates[0] + lever * rates[1],
                work=work,
                measure=measure,
                facets=None,
                normal=None if area_normal is None else side * area_normal,
            )
        )
    return out


def rate_of(expr: Any, state: Sequence[Any], rates: Sequence[Any]) -> Any:
    """D expr(q)[q̇]: the rate of a UFL expression of the state Functions ``state`` (UFL)."""
    terms = [ufl.derivative(expr, q, r) for q, r in zip(state, rates, strict=True)]
    return ufl.algorithms.expand_derivatives(functools.reduce(operator.add, terms))
