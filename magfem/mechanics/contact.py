r"""Ground contact: penalty on penetration with regularised Coulomb friction.

A rigid, flat ground occupies ``x[vertical] < ground_height``. Every point
of the body's boundary on which the contact measure is integrated carries a
traction per *reference* area

.. math::

    \mathbf t = p_n\,\mathbf e_v
        - \mu_f\,p_n\,\frac{\mathbf v_t}{\sqrt{\mathbf v_t\cdot\mathbf v_t + v_\varepsilon^2}},
    \qquad
    p_n = \big\langle k_n\,r(\delta) + c_n\,s(\delta)\,\dot\delta \big\rangle_+ ,

with the penetration :math:`\delta = h_g - x_v` (m), its rate
:math:`\dot\delta = -v_v` (m/s), the tangential velocity
:math:`\mathbf v_t = \mathbf v - v_v\mathbf e_v` and
:math:`\langle a\rangle_+ = \max(a, 0)`.

Normal law (penalty).
    :math:`r` is a C¹ ramp that is *exactly zero for a positive gap* (a
    sqrt-smoothed penalty pulls on the body from afar, see
    FENICSX.md):

    .. math::

        r(\delta) = 0 \ (\delta \le 0),\quad
        \frac{\delta^2}{2\delta_0}\ (0 < \delta < \delta_0),\quad
        \delta - \frac{\delta_0}{2}\ (\delta \ge \delta_0).

    The onset width :math:`\delta_0` removes the kink of the plain ramp
    (Newton then sees a continuous tangent when a quadrature point crosses
    the ground). The stiffness is scaled with the membrane,
    :math:`k_n = \kappa\,\mu/h` (Pa/m), so that a pressure ``p`` penetrates
    by ``p h / (κ μ)``: 1/κ of the shear strain the same pressure would
    cause in the layer. This keeps the contact stiffness below the
    through-thickness stiffness of one element (≈ 100 μ/h for K = 100 μ)
    for κ ≲ 100, which is what keeps a thin P2 plate from inverting its
    bottom layer on impact; results converge as κ grows (see
    ``docs/verification.md``). The static penetration under a pressure
    ``p`` is the inverse of ``r``: :func:`penalty_penetration`.

Impact damping.
    :math:`c_n\,s(\delta)\,\dot\delta` is a contact dashpot that switches on
    continuously with the penetration (:math:`s = \min(\delta/\delta_0, 1)`
    for :math:`\delta > 0`, else 0; the Hunt–Crossley idea of a damping force
    that vanishes at first touch). :math:`c_n = 2\zeta\sqrt{k_n\rho h}` is
    ζ times the critical damping of the membrane (mass ρh per area) on the
    penalty spring. It dissipates the impact energy of a falling plate in the
    contact layer instead of letting it ring through the stiff thickness
    mode. The bracket keeps the pressure compressive (no adhesion while
    the body lifts off).

Friction (regularised Coulomb).
    The tangential traction is :math:`\mu_f p_n` opposite to the sliding
    velocity when :math:`|\mathbf v_t| \gg v_\varepsilon`, and viscous
    (:math:`\mu_f p_n \mathbf v_t / v_\varepsilon`) near sticking. A block
    sliding at speed ``v`` then decelerates at
    :math:`\mu_f g\,v/\sqrt{v^2 + v_\varepsilon^2}`, within
    :math:`(v_\varepsilon/v)^2/2` of :math:`\mu_f g` (Wriggers,
    *Computational Contact Mechanics*, 2nd ed., Springer 2006, §5.2 for the
    penalty and regularised-friction laws).

    Stick on tiny steps. With the velocity of the time integrator,
    :math:`\partial\mathbf v/\partial\mathbf u = \gamma/(\beta\Delta t)`, so the
    tangent of the viscous branch grows like :math:`\mu_f p_n/(v_\varepsilon\Delta t)`
    and Newton stalls when an impact forces Δt down to ~1e-6 s (the default
    case's arm landing on its top face at t ≈ 30 ms). The solver therefore
    passes Δt, and the regularisation is
    :math:`\sqrt{v_\varepsilon^2 + (\ell/\Delta t)^2}`: a slip of ℓ per step
    is "sticking". At the nominal step this is a few mm/s (ℓ = 0.01 h,
    Δt = 0.5 ms: 1.6 mm/s for 80 µm) and changes sliding by
    :math:`(\ell/(v\Delta t))^2/2`; on the tiny steps of an impact the
    friction tangent stays bounded by :math:`\mu_f p_n/\ell`, an elastic
    stick of stiffness μ_f p_n/ℓ.

Both laws are written with the *current* position and velocity as UFL
expressions of the unknown displacement, so ``ufl.derivative`` gives their
exact linearisation (including the dependence of the velocity on the
displacement through the time integrator). Tractions are per reference
area: for the membranes here (stretch ≈ 1 at the contact) the difference
from the current area is the in-plane strain, ≲ 1e-2.

Contract with the solver (``problem.py`` calls this when
``case.contact.ground`` is true)::

    law = create_ground_contact_law(case.contact, shear_modulus=μ,
                                    density=ρ, thickness=h)
    contact = GroundContact(law, mesh, vertical=gdim - 1,
                            ground_height=case.contact.ground_height)
    R = ... - contact.work(x, v, w, ds_contact)   # x = X + u, v = velocity

    # or, in one call:
    ground_contact_work(x, v, w, law, ds_contact, vertical=..., ground_height=...)

``x`` (m) and ``v`` (m/s) are UFL vectors of length gdim, ``w`` is the test
function, ``ds_contact`` a boundary measure *with an explicit quadrature
degree* (4 for P2; the whole boundary may be given, since the traction is
exactly zero off the ground). Impacts (see :class:`ImpactAbsorber` and
``benchmarks/contact_impact.py``): evaluate the contact at the *end* of the
step, ``x = X + u_{n+1}``, ``v = v_{n+1}`` (``integrator.u`` and
``integrator.velocity()``), not at the generalized-α stage point, and after
every accepted step call::

    absorber = ImpactAbsorber(V, contact_facets, vertical=gdim - 1,
                              ground_height=case.contact.ground_height)
    ...
    integrator.advance()
    absorber.apply(integrator.u0, integrator.v0, integrator.a0)

:meth:`GroundContact.force_forms` gives scalar forms for the normal and
tangential contact force (N, or N/m in a 2D strip) for the observers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

__all__ = [
    "ContactParameters",
    "GroundContact",
    "GroundContactLaw",
    "ImpactAbsorber",
    "contact_stiffness",
    "create_ground_contact_law",
    "critical_contact_damping",
    "ground_contact_work",
    "penalty_penetration",
    "penalty_ramp",
]


class ContactParameters(Protocol):
    """What :func:`create_ground_contact_law` reads from the ``[contact]`` table.

    ``magfem.mechanics.spec.ContactSpec`` provides these attributes.
    """

    @property
    def friction(self) -> float:
        """Coulomb coefficient μ_f (-)."""
        ...

    @property
    def penalty(self) -> float:
        """κ (-): k_n = κ μ / h."""
        ...

    @property
    def penalty_onset(self) -> float:
        """δ0 / h (-): width of the C¹ onset of the ramp."""
        ...

    @property
    def damping(self) -> float:
        """ζ (-): contact dashpot as a fraction of critical."""
        ...

    @property
    def regularization_velocity(self) -> float:
        """v_ε (m/s)."""
        ...


@dataclass(frozen=True)
class GroundContactLaw:
    """Constants of the ground contact law, SI units.

    Attributes:
        stiffness: penalty stiffness k_n (Pa/m = N/m³; N/m² per m in 2D).
        onset: width δ0 > 0 of the C¹ onset of the penalty ramp (m).
        damping: contact dashpot c_n (Pa·s/m) >= 0.
        friction: Coulomb coefficient μ_f >= 0.
        regularization_velocity: v_ε > 0 (m/s).
        slip_length: ℓ >= 0 (m); with a time step Δt the friction is
            regularised by sqrt(v_ε² + (ℓ/Δt)²) instead of v_ε.
    """

    stiffness: float
    onset: float
    damping: float = 0.0
    friction: float = 0.5
    regularization_velocity: float = 1e-3
    slip_length: float = 0.0

    def __post_init__(self) -> None:
        # programming errors only: user input is validated by ContactSpec
        for name in ("stiffness", "onset", "regularization_velocity"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"GroundContactLaw.{name} must be finite and > 0, got {value!r}")
        for name in ("damping", "friction", "slip_length"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"GroundContactLaw.{name} must be finite and >= 0, got {value!r}")


def contact_stiffness(penalty: float, shear_modulus: float, thickness: float) -> float:
    """Penalty stiffness k_n = κ μ / h (Pa/m).

    Args:
        penalty: κ (-), the ratio of contact stiffness to the layer's shear stiffness.
        shear_modulus: μ (Pa).
        thickness: membrane thickness h (m).
    """
    return penalty * shear_modulus / thickness


def critical_contact_damping(stiffness: float, density: float, thickness: float) -> float:
    """Critical damping 2 sqrt(k_n ρ h) (Pa·s/m) of a membrane of mass ρh per area on k_n."""
    return 2.0 * math.sqrt(stiffness * density * thickness)


def create_ground_contact_law(
    spec: ContactParameters, *, shear_modulus: float, density: float, thickness: float
) -> GroundContactLaw:
    """The SI contact law of a ``[contact]`` table for a membrane of the given material.

    Args:
        spec: the validated ``[contact]`` table (``ContactSpec``).
        shear_modulus: μ (Pa).
        density: ρ (kg/m³).
        thickness: membrane thickness h (m); the length that scales k_n and δ0.
    """
    k_n = contact_stiffness(spec.penalty, shear_modulus, thickness)
    return GroundContactLaw(
        stiffness=k_n,
        onset=spec.penalty_onset * thickness,
        damping=spec.damping * critical_contact_damping(k_n, density, thickness),
        friction=spec.friction,
        regularization_velocity=spec.regularization_velocity,
        slip_length=getattr(spec, "slip_length", 0.0) * thickness,
    )


def penalty_ramp(delta: Any, onset: Any) -> tuple[Any, Any]:
    """C¹ ramp r(δ) and its switch s(δ) = r'(δ) (UFL).

    Args:
        delta: penetration δ (m), UFL scalar.
        onset: δ0 > 0 (m), UFL scalar.

    Returns:
        ``(r, s)``: r in m, exactly 0 for δ <= 0; s in [0, 1].
    """
    inside = ufl.lt(delta, onset)
    r = ufl.conditional(
        ufl.le(delta, 0.0),
        0.0,
        ufl.conditional(inside, delta**2 / (2.0 * onset), delta - onset / 2.0),
    )
    s = ufl.conditional(ufl.le(delta, 0.0), 0.0, ufl.conditional(inside, delta / onset, 1.0))
    return r, s


def penalty_penetration(pressure: float, stiffness: float, onset: float) -> float:
    """Static penetration δ (m) of the C¹ penalty ramp carrying ``pressure`` (Pa).

    Inverse of p = k_n r(δ): sqrt(2 δ0 p/k_n) below p/k_n = δ0/2, p/k_n + δ0/2 above.
    """
    q = pressure / stiffness
    if q <= 0.0:
        return 0.0
    if q < onset / 2.0:
        return math.sqrt(2.0 * onset * q)
    return q + onset / 2.0


class GroundContact:
    """The ground contact law on one mesh, with its constants as ``fem.Constant``.

    The constants can be changed in place with :meth:`update` (tightening the
    penalty in a convergence study) without recompiling forms.

    Args:
        law: the contact constants.
        mesh: the body's dolfinx mesh (gdim 2 or 3).
        vertical: index of the vertical axis (1 for a 2D strip, 2 in 3D).
        ground_height: position of the ground plane along ``vertical`` (m).
    """

    def __init__(
        self,
        law: GroundContactLaw,
        mesh: Any,
        *,
        vertical: int,
        ground_height: float = 0.0,
        time_step: Any = None,
    ) -> None:
        gdim = mesh.geometry.dim
        if not 0 <= vertical < gdim:
            raise ValueError(f"vertical axis {vertical} outside 0..{gdim - 1}")
        self.gdim = gdim
        self.vertical = vertical
        self.law = law
        self.stiffness = fem.Constant(mesh, np.float64(law.stiffness))
        self.onset = fem.Constant(mesh, np.float64(law.onset))
        self.damping = fem.Constant(mesh, np.float64(law.damping))
        self.friction = fem.Constant(mesh, np.float64(law.friction))
        self.regularization_velocity = fem.Constant(mesh, np.float64(law.regularization_velocity))
        self.ground_height = fem.Constant(mesh, np.float64(ground_height))
        self.slip_length = fem.Constant(mesh, np.float64(law.slip_length))
        self.time_step = time_step  # a fem.Constant Δt (s), or None: no ℓ/Δt term

    def update(self, law: GroundContactLaw) -> None:
        """Set new constants in place (compiled forms stay valid)."""
        self.law = law
        for name in (
            "stiffness",
            "onset",
            "damping",
            "friction",
            "regularization_velocity",
            "slip_length",
        ):
            constant: Any = getattr(self, name)
            constant.value = getattr(law, name)

    def pressure(self, x: Any, v: Any) -> Any:
        """Normal contact pressure p_n >= 0 (Pa per reference area), UFL scalar.

        Args:
            x: current position, UFL vector (gdim,) (m).
            v: current velocity, UFL vector (gdim,) (m/s).
        """
        delta = self.ground_height - x[self.vertical]
        r, s = penalty_ramp(delta, self.onset)
        p = self.stiffness * r - self.damping * s * v[self.vertical]
        return ufl.conditional(ufl.gt(p, 0.0), p, 0.0)

    def traction(self, x: Any, v: Any) -> Any:
        """Traction of the ground on the body (Pa per reference area), UFL vector (gdim,)."""
        e_v = ufl.as_vector([1.0 if i == self.vertical else 0.0 for i in range(self.gdim)])
        p_n = self.pressure(x, v)
        v_t = v - v[self.vertical] * e_v
        eps2 = self.regularization_velocity**2
        if self.time_step is not None:
            eps2 = eps2 + (self.slip_length / self.time_step) ** 2
        speed = ufl.sqrt(ufl.dot(v_t, v_t) + eps2)
        return p_n * e_v - self.friction * p_n * v_t / speed

    def work(self, x: Any, v: Any, w: Any, ds: Any) -> Any:
        """Virtual work ∫ t·w dA of the ground traction (J per unit test field), UFL form.

        Subtract it from a residual written as internal minus external work.
        ``ds`` must carry an explicit quadrature degree.
        """
        return ufl.inner(self.traction(x, v), w) * ds

    def force_forms(self, x: Any, v: Any, ds: Any) -> list[Any]:
        """Scalar forms of the resultant ground force components (N; N/m in 2D), length gdim."""
        t = self.traction(x, v)
        return [t[i] * ds for i in range(self.gdim)]


def ground_contact_work(
    x: Any,
    v: Any,
    w: Any,
    law: GroundContactLaw,
    ds: Any,
    *,
    vertical: int,
    ground_height: float = 0.0,
) -> Any:
    """Virtual work of the ground traction on test function ``w`` (UFL form).

    One-call form of :class:`GroundContact` (constants not updatable).

    Args:
        x: current position X + u, UFL vector (gdim,) (m).
        v: current velocity, UFL vector (gdim,) (m/s).
        w: test function (vector, gdim).
        law: contact constants.
        ds: boundary measure with explicit quadrature degree.
        vertical: index of the vertical axis.
        ground_height: ground plane position along ``vertical`` (m).
    """
    mesh = w.ufl_function_space().mesh
    return GroundContact(law, mesh, vertical=vertical, ground_height=ground_height).work(
        x, v, w, ds
    )


class ImpactAbsorber:
    """Perfectly inelastic normal impact of the membrane's through-thickness columns.

    Why. A thin plate meeting the ground stops within the contact time
    2π sqrt(ρh/k_n) (≈ 2e-5 s for 100 µm, κ = 10), far below any useful time
    step. Within one step the Newmark/generalized-α velocity update
    v_{n+1} = v_n + Δt((1 − γ)a_n + γ a_{n+1}) then *reverses* the velocity of
    a plate that was stopped (u_{n+1} ≈ u_n gives v_{n+1} ≈ −v_n for the
    trapezoidal rule), whatever the contact law: measured rebound 0.87 v for a
    plate dropped flat at 0.2 m/s with Δt = 0.1 ms and a critical contact
    dashpot (0.03 v when Δt = 1 µs resolves the contact), and the rebound
    re-enters the ground at the next swing. ``benchmarks/contact_impact.py``
    measures this.

    What. After each accepted step, every through-thickness column of nodes
    (nodes sharing the reference coordinates other than ``vertical``) whose
    contact node has gone below the ground loses its upward normal velocity
    and normal acceleration (at the step it arrives, and later only if it
    rebounds faster than ``rest_velocity``): the
    impact is perfectly inelastic in the normal direction, the limit the
    resolved contact dashpot approaches (ζ >= 1), and the column comes to
    rest as a unit, which is what it does physically (the through-thickness
    wave crosses 100 µm in ~1 µs). Columns resting on the ground, and nodes
    above it, are untouched; tangential motion is
    left to friction. Together with the contact evaluated at the end of the
    step (x_{n+1}, v_{n+1}; the stage point x_{n+1−αf} lets the plate end the
    step below the ground by αf/(1 − αf) of the gap it closed), a dropped
    plate comes to rest in one step at Δt = 0.1 ms; in the spirit of the
    contact-stabilised Newmark scheme (Deuflhard, Krause, Ertel, IJNME 73
    (2008) 1274–1290), which also removes the normal velocity of contacting
    nodes.

    Args:
        V: the displacement space (blocked vector Lagrange, gdim components).
        facets: local indices of the facets that may touch the ground; None:
            every node (the shell, whose nodes are on its mid-surface).
        vertical: index of the vertical axis.
        ground_height: ground plane position (m).
        offset: a node touches when its height minus ``offset`` is below the
            ground (m): 0 for nodes on the faces, t/2 for the shell's
            mid-surface nodes.
        rest_velocity: columns that were already below the ground at the
            previous step are reset only when they move up faster than this
            (m/s; the stored penetration of an impact released over the next
            steps), like the bounce threshold of rigid-body engines. Resting
            contact (vertical velocity ~1e-7 m/s in the sliding benchmark) is
            then left alone: resetting it every step removes upward momentum
            each time, which the ground repays with a mean normal force above
            the weight, and friction with it (a sliding strip decelerated at
            1.04 μ_f g).

    The reference membrane must be flat with its thickness along ``vertical``
    (as every magfem robot is); columns are found by rounding the other
    reference coordinates to 1e-9 of the mesh extent. :meth:`apply` is
    collective.
    """

    def __init__(
        self,
        V: Any,
        facets: Any,
        *,
        vertical: int,
        ground_height: float = 0.0,
        rest_velocity: float = 1e-3,
        offset: float = 0.0,
    ) -> None:
        mesh = V.mesh
        self.comm = mesh.comm
        self.bs = V.dofmap.index_map_bs
        self.vertical = vertical
        self.touch_height = float(ground_height) + float(offset)
        self.rest_velocity = float(rest_velocity)
        X = V.tabulate_dof_coordinates()[:, : mesh.geometry.dim]  # (nodes, gdim), owned + ghost
        others = [i for i in range(X.shape[1]) if i != vertical]
        gdim = X.shape[1]
        lo, hi = np.empty(gdim), np.empty(gdim)
        self.comm.Allreduce(X.min(axis=0) if X.size else np.full(gdim, np.inf), lo, op=MPI.MIN)
        self.comm.Allreduce(X.max(axis=0) if X.size else np.full(gdim, -np.inf), hi, op=MPI.MAX)
        tol = 1e-9 * float(np.max(hi - lo))
        keys = np.round((X[:, others] - lo[others]) / tol).astype(np.int64)
        # one int64 per column: the coordinates fit in 31 bits each (extent / tol = 1e9)
        self.column = keys[:, 0] if keys.shape[1] == 1 else keys[:, 0] * (1 << 31) + keys[:, 1]
        self.reference_height = X[:, vertical]
        if facets is None:
            self.contact_nodes = np.arange(X.shape[0])
        else:
            tdim = mesh.topology.dim
            mesh.topology.create_connectivity(tdim - 1, tdim)
            dofs = fem.locate_dofs_topological(V.sub(vertical), tdim - 1, np.asarray(facets))
            self.contact_nodes = np.unique(np.asarray(dofs) // self.bs)
        self.touching = np.empty(0, dtype=np.int64)  # columns below ground at the last call

    def apply(self, u: Any, v: Any, a: Any) -> int:
        """Remove the upward vertical velocity/acceleration of columns that just hit the ground.

        Columns below the ground now and not at the previous call lose any
        upward velocity; columns already below it, only an upward velocity
        above ``rest_velocity``.

        Args:
            u, v, a: Functions of ``V`` holding the accepted state at t_{n+1}
                (the integrator's u_n, v_n, a_n after ``advance``); v and a are
                changed in place (owned and ghost entries alike).

        Returns:
            the number of columns reset (global).
        """
        k = self.vertical
        nodes = self.contact_nodes
        height = self.reference_height[nodes] + u.x.array[nodes * self.bs + k]
        hit_local = np.unique(self.column[nodes[height < self.touch_height]])
        hit = np.unique(np.concatenate(self.comm.allgather(hit_local)))
        new = np.setdiff1d(hit, self.touching, assume_unique=True)
        self.touching = hit
        if hit.size == 0:
            return 0
        idx = np.flatnonzero(np.isin(self.column, hit)) * self.bs + k
        fresh = np.isin(self.column[idx // self.bs], new)
        vz = v.x.array[idx]
        # new contacts lose any upward velocity; resting ones only a rebound above v_rest
        reset = (vz > 0.0) & (fresh | (vz > self.rest_velocity))
        v.x.array[idx[reset]] = 0.0
        a.x.array[idx[reset]] = 0.0
        done = np.unique(self.column[idx[reset] // self.bs])
        return int(np.unique(np.concatenate(self.comm.allgather(done))).size)
