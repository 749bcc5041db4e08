"""Contact between surfaces of one body (arm–arm, petal–petal): the self-contact part.

Law: :mod:`.law`; search and pairing: :mod:`.search`; coupled Newton terms:
:mod:`.assembly`. History columns: ``self_contact_force`` (N; N/m × depth
for strips) in total and per pair of groups, the largest penetration and
the pressure-weighted centroid of the touching points, and with
``self_contact_inelastic`` the kinetic energy its impacts lost,
``self_contact_absorbed`` (:mod:`.absorber`); touch/release events go to
the log.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, la
from mpi4py import MPI

from magfem.config import CaseError
from magfem.mechanics.contacts.base import Contact
from magfem.mechanics.contacts.self_contact.absorber import PairAbsorber
from magfem.mechanics.contacts.self_contact.assembly import CoupledTerms
from magfem.mechanics.contacts.self_contact.law import TOUCH, create_self_contact_law
from magfem.mechanics.contacts.self_contact.search import SurfacePairing
from magfem.mechanics.contacts.self_contact.shell import ShellPairing
from magfem.mechanics.models.base import Model
from magfem.mechanics.solver import NewtonSolver
from magfem.mechanics.spec import ContactSpec
from magfem.parallel import JIT_WAIT

__all__ = ["SelfContact"]

_PAIRINGS: dict[str, type[SurfacePairing]] = {"shell": ShellPairing}
"""The pairing of a model's kinematics when not the continuum's (faces of the cells)."""


class SelfContact(Contact):
    """Two-pass penalty contact between the surfaces of cell groups of one body (collective).

    Args:
        spec: ``[contact]`` (penalty, onset, exclusion, groups, within; default
            groups: the robot's arms).
        model: the body: a continuum model (solid, strip: the groups' boundary
            faces touch) or the shell (the groups' mid-surfaces, a thickness
            apart when they touch, :mod:`.shell`).
        shear_modulus: μ (Pa), which scales the penalty stiffness.

    Raises:
        CaseError: another model (the rod), no group (fewer than two without
            ``self_contact_within``), an unknown or non-cell group.
    """

    name = "self_contact"
    newton_hooks = True

    def __init__(self, spec: ContactSpec, model: Model, *, shear_modulus: float):
        pairing = _PAIRINGS.get(model.kinematics, SurfacePairing)
        if len(model.unknowns) != 1 and pairing is SurfacePairing:
            raise CaseError(
                "contact.self_contact",
                True,
                "arm-arm contact needs the solid, strip or surface (shell) model",
            )
        self.model = model
        robot = model.robot
        law = create_self_contact_law(spec, shear_modulus=shear_modulus, thickness=robot.thickness)
        groups = spec.self_contact_groups or tuple(arm.name for arm in robot.arms)
        V = model.u.function_space
        self.pairing = p = pairing(robot, V, groups, law, quadrature_degree=model.quadrature_degree)
        integ = model.integrator
        self.integrator = integ
        self.terms = CoupledTerms(p, integ)
        X = ufl.SpatialCoordinate(V.mesh)
        phi = ufl.TestFunction(p.Vc)
        # nodal forces at the observed state (u_geom = u_n during observation)
        self._force_form = fem.form(
            ufl.inner(p.pressure(X + p.u_geom) * p.nbar, phi) * p.measure, jit_options=JIT_WAIT
        )
        self.absorber: PairAbsorber | None = None
        if spec.self_contact_inelastic and integ.dynamic:
            rates = model.accepted()[1]
            self.absorber = PairAbsorber(
                p,
                model.kinetic_energy(rates),
                rates[0],
                model.displacement_bcs,
                depth=model.depth,
            )
        self._searched = False  # the pairing is at the accepted state (after the absorber)
        self._active: dict[tuple[int, int], bool] = {}
        self.first_touch: dict[tuple[int, int], float] = {}
        self.max_force = 0.0
        self.max_penetration = 0.0
        self._events: list[str] = []

    @property
    def engaged(self) -> bool:
        """Some slave point of the body has a master (all ranks agree)."""
        return self.pairing.engaged

    def energy(self, model: Model) -> ufl.Form:
        X = ufl.SpatialCoordinate(model.robot.mesh)
        return self.pairing.energy(X + model.u)

    def attach(self, solver: NewtonSolver) -> None:
        self.terms.attach(solver, self.model.displacement_bcs)

    def add_residual(self, x: Any, b: Any) -> None:
        """The coupled residual terms at the iterate ``x`` (see :class:`CoupledTerms`)."""
        self.terms.add_residual(x, b)

    def add_jacobian(self, x: Any, A: Any) -> None:
        """The coupled Jacobian terms at the iterate ``x`` (see :class:`CoupledTerms`)."""
        self.terms.add_jacobian(x, A)

    def after_step(self) -> None:
        """With ``self_contact_inelastic``: absorb the new impacts (:mod:`.absorber`)."""
        if self.absorber is not None:
            integ = self.integrator
            self.absorber.apply(integ.u0, integ.v0, integ.a0)
            self._searched = True

    def before_solve(self) -> None:
        """Pair the surfaces at the stage displacement (1 − αf) u + αf u_n (collective)."""
        self._searched = False
        integ = self.integrator
        u = integ.u.x.array
        if integ.dynamic and integ.params is not None:
            af = integ.params.alpha_f
            self.pairing.search((1.0 - af) * u + af * integ.u0.x.array)
        else:
            self.pairing.search(u.copy())

    def step_limit(self) -> float | None:
        """The longest next step (s) at which the search keeps up with the surfaces' motion.

        Unpaired surfaces. The search pairs surfaces less than a cell a apart
        (the smallest of the groups' cells) at the start of a step; within it
        the penalty acts implicitly on those pairs only. Two surfaces s apart
        (nearest vertices of two groups, less the offset) whose points move at
        most at v close by at most 2 v Δt, so Δt ≤ max(s − a/2, a/2)/(2 v)
        keeps surfaces farther than a cell from meeting unpaired within the
        step. Pairs of a group with itself are not bounded by this.

        Paired points (of any two groups, or of one group with itself) that
        approach at the relative normal speed −w > 0 (w = (v_s − v_m)·n̄) with
        gap g close by about −w Δt: Δt ≤ (max(g, 0) + b/2)/(−w) lets no
        step carry a pair more than half the band b inside
        (:meth:`approach_limit`), where the search would drop it. None when
        nothing moves (quasi-static runs too).
        """
        integ = self.integrator
        if not integ.dynamic:
            return None
        p = self.pairing
        v = integ.v0.x.array.reshape(-1, p.gdim)
        speed = p.comm.allreduce(
            float(np.linalg.norm(v[p.vnodes], axis=1).max(initial=0.0)), op=MPI.MAX
        )
        if speed == 0.0:
            return None
        limit = self.approach_limit(integ.u0.x.array, v)
        if len(p.groups) >= 2:
            a = p.cell_size
            unpaired = max(p.clearance(integ.u0.x.array) - 0.5 * a, 0.5 * a) / (2.0 * speed)
            limit = unpaired if limit is None else min(limit, unpaired)
        return limit

    def approach_limit(self, u: npt.NDArray[Any], v: npt.NDArray[Any]) -> float | None:
        """The longest step (s) in which no paired node closes on its master by more than its
        gap plus half the band, at displacement ``u`` and velocity ``v`` (local arrays of V;
        None: no pair approaches; collective)."""
        p, gdim = self.pairing, self.pairing.gdim
        u, v = u.reshape(-1, gdim), v.reshape(-1, gdim)
        own = p._vown
        k = p.vpartner[own]
        nbar = p._nbar_v.x.array.reshape(-1, gdim)[own]
        length = np.linalg.norm(nbar, axis=1)
        paired = (k >= 0) & (length > 0)
        k, slave = k[paired], own[paired]
        n = nbar[paired] / length[paired, None]
        position = p._gvref + p.gather_nodes(u)
        velocity = p.gather_nodes(v)
        x = p.vreference[slave] + u[slave]
        gap = np.einsum("ij,ij->i", x - position[k] - p._lift[slave], n)
        w = np.einsum("ij,ij->i", v[slave] - velocity[k], n)
        closing = w < 0.0
        room = np.maximum(gap[closing], 0.0) + 0.5 * p.law.band
        local = float(np.min(room / -w[closing], initial=np.inf))
        limit = p.comm.allreduce(local, op=MPI.MIN)
        return None if limit == np.inf else limit

    # --- observation ------------------------------------------------------------------------

    @property
    def pairs(self) -> list[tuple[int, int]]:
        """Unordered pairs (i < j) of group indices, then (i, i) per group touching itself."""
        n = len(self.pairing.groups)
        within = [(i, i) for i in range(n)] if self.pairing.law.within else []
        return list(itertools.combinations(range(n), 2)) + within

    def pair_name(self, pair: tuple[int, int]) -> str:
        """``<group_i>__<group_j>``."""
        return f"{self.pairing.groups[pair[0]]}__{self.pairing.groups[pair[1]]}"

    def columns(self) -> list[str]:
        """CSV columns written by :meth:`observe`."""
        cols = [
            "self_contact_force",
            "self_contact_penetration",
            "self_contact_x",
            "self_contact_y",
            "self_contact_z",
        ]
        cols += [f"self_contact_force_{self.pair_name(p)}" for p in self.pairs]
        return cols + (["self_contact_absorbed"] if self.absorber is not None else [])

    def observe(self, t: float) -> dict[str, float]:
        """Contact observables at the accepted state u_n (collective).

        Refreshes the pairing at that state. Returns the :meth:`columns`:
        force (N; strips: N/m × depth) summed over pairs and per pair
        (mean of the two passes' resultant magnitudes; a group on itself: half
        the sum of its nodal force magnitudes, both faces being slaves), the largest
        penetration −g (m, >= 0) and the pressure-weighted centroid of the
        touching vertices (m; strips: (x, 0, z); NaN when nothing touches).
        Records touch/release events.
        """
        p = self.pairing
        if not self._searched:
            p.search(self.model.integrator.u0.x.array)
        width, gdim = self.model.depth, p.gdim
        f = fem.assemble_vector(self._force_form)
        f.scatter_reverse(la.InsertMode.add)
        nodes = p.nodes[p.nodes < p.size_local]
        force = f.array.reshape(-1, gdim)[nodes]
        label, partner = p.node_label[nodes], p.partner[nodes]
        x = p.reference[nodes] + p.vertex_displacement.x.array.reshape(-1, gdim)[nodes]
        pen = np.where(partner >= 0, -p.gap[nodes], 0.0)
        ng = len(p.groups)
        resultant = np.zeros((ng, ng, gdim))  # force on slave group i from master j
        weight = np.zeros((ng, ng))
        moment = np.zeros((ng, ng, gdim))
        deepest = np.zeros((ng, ng))
        touching = partner >= 0
        mag = np.linalg.norm(force, axis=1)
        li, pj = label[touching], partner[touching]
        np.add.at(resultant, (li, pj), force[touching])
        np.add.at(weight, (li, pj), mag[touching])
        np.add.at(moment, (li, pj), mag[touching, None] * x[touching])
        np.maximum.at(deepest, (li, pj), pen[touching])
        resultant, weight, moment = (_sum(a, p.comm) for a in (resultant, weight, moment))
        p.comm.Allreduce(MPI.IN_PLACE, deepest, op=MPI.MAX)
        row: dict[str, float] = {}
        total, total_w, total_m = 0.0, 0.0, np.zeros(gdim)
        for pair in self.pairs:
            i, j = pair
            if i == j:  # both faces are slaves, their forces cancel: half the magnitudes' sum
                fp = 0.5 * width * weight[i, i]
            else:
                fp = (
                    0.5
                    * width
                    * (np.linalg.norm(resultant[i, j]) + np.linalg.norm(resultant[j, i]))
                )
            row[f"self_contact_force_{self.pair_name(pair)}"] = float(fp)
            w = weight[i, j] + (weight[j, i] if i != j else 0.0)
            m = moment[i, j] + (moment[j, i] if i != j else 0.0)
            total += fp
            total_w += w
            total_m += m
            active = bool(max(deepest[i, j], deepest[j, i]) > TOUCH * self.pairing.law.onset)
            was = self._active.get(pair, False)
            if active and not was:
                self.first_touch.setdefault(pair, t)
                other = "itself" if i == j else self.pairing.groups[j]
                # a vertex inside whose node carries no force (unpaired deeper than the band)
                where = f" at {_mm(m / w)} mm" if w > 0 else ""
                self._events.append(
                    f"t = {t:.6g} s: {self.pairing.groups[i]} touches {other}{where}, "
                    f"force {fp:.3g} N"
                )
            elif was and not active:
                other = "itself" if i == j else self.pairing.groups[j]
                self._events.append(f"t = {t:.6g} s: {self.pairing.groups[i]} leaves {other}")
            self._active[pair] = active
        centroid = total_m / total_w if total_w > 0 else np.full(gdim, np.nan)
        c3 = centroid if gdim == 3 else np.array([centroid[0], 0.0, centroid[1]])
        penetration = float(np.max(deepest)) if deepest.size else 0.0
        row["self_contact_force"] = total
        row["self_contact_penetration"] = penetration
        row["self_contact_x"], row["self_contact_y"], row["self_contact_z"] = map(float, c3)
        if self.absorber is not None:
            row["self_contact_absorbed"] = self.absorber.absorbed
        self.max_force = max(self.max_force, total)
        self.max_penetration = max(self.max_penetration, penetration)
        return row

    def events(self) -> list[str]:
        out, self._events = self._events, []
        return out

    def state(self) -> dict[str, Any]:
        """Touching pairs, first touches, largest force and penetration, pending events."""
        return {
            "active": [[i, j, a] for (i, j), a in self._active.items()],
            "first_touch": [[i, j, t] for (i, j), t in self.first_touch.items()],
            "max_force": self.max_force,
            "max_penetration": self.max_penetration,
            "events": list(self._events),
            "absorber": self.absorber.state() if self.absorber is not None else None,
        }

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`state`."""
        self._active = {(int(i), int(j)): bool(a) for i, j, a in state["active"]}
        self.first_touch = {(int(i), int(j)): float(t) for i, j, t in state["first_touch"]}
        self.max_force = float(state["max_force"])
        self.max_penetration = float(state["max_penetration"])
        self._events = list(state["events"])
        if self.absorber is not None and state.get("absorber") is not None:
            self.absorber.load_state(state["absorber"])

    def summary(self) -> dict[str, float]:
        """First touch time per pair (s, NaN if never), largest force (N) and penetration (m)
        and, with the absorber, the number of impacts it absorbed."""
        out = {
            f"first_touch_{self.pair_name(p)}": self.first_touch.get(p, float("nan"))
            for p in self.pairs
        }
        out["max_self_contact_force"] = self.max_force
        out["max_self_contact_penetration"] = self.max_penetration
        if self.absorber is not None:  # its energy is the history's (history_summary)
            out["self_contact_impacts"] = float(self.absorber.impacts)
        return out


def _sum(a: npt.NDArray[np.float64], comm: MPI.Comm) -> npt.NDArray[np.float64]:
    out = np.zeros_like(a)
    comm.Allreduce(np.ascontiguousarray(a), out, op=MPI.SUM)
    return out


def _mm(x: npt.NDArray[np.float64]) -> str:
    return "(" + ", ".join(f"{1e3 * v:.3g}" for v in x) + ")"
