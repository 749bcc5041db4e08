r"""Perfectly inelastic impacts between surfaces of one body (``self_contact_inelastic``).

Two membranes that strike each other (the bow tie's arms clapping, a fin
folding onto the body) meet within the contact time 2π sqrt(m/k_c) of the
penalty, far below any useful step: within one step a surface may go most of
the way into the band of the other, the penalty force jumps by an order of
magnitude and Newton fails at any step length. The ground and the obstacles
make such impacts perfectly inelastic in the normal direction
(:class:`~magfem.mechanics.contacts.ground.ImpactAbsorber`); this is the same
for two points of the body.

Which pairs.
    After each accepted step the pairing is searched at the accepted state
    u_{n+1}, and every slave node inside its master (normal gap g < 0,
    :mod:`.search`) forms a pair with its master node and the master's unit
    normal n̂ at the slave (two nodes paired with each other count once). With
    the relative normal velocity w = (v_s − v_m)·n̂ (negative: approaching), a
    pair that was not inside at the previous step (an impact) is reset
    whatever the sign of w, so the penetration stops growing and the penalty
    then pushes the points apart gently; a pair inside already (resting,
    squeezed or sliding contact) only when it separates faster than
    ``rest_velocity`` (a rebound, as on the ground).

The reset.
    The reset pairs' relative normal velocities G v (one row n̂ᵀ(·_s − ·_m)
    per pair) are removed by the impulses of least kinetic energy: with M the
    lumped mass matrix of the displacement,

    .. math::

        \mathbf v^+ = \mathbf v + M^{-1} G^\top \boldsymbol\lambda,\qquad
        (G M^{-1} G^\top)\,\boldsymbol\lambda = -G\mathbf v ,

    the M-orthogonal projection of v onto G v = 0 (the contact-stabilised
    Newmark scheme's projection: Deuflhard, Krause & Ertel, IJNME 73 (2008)
    1274–1290). M is the diagonal of the kinetic energy's mass matrix scaled
    to the body's mass (Hinton, Rock & Zienkiewicz, Earthq. Eng. Struct. Dyn.
    4, 245 (1976)), so only the paired nodes change: with the consistent
    matrix M⁻¹Gᵀ reaches over the whole mesh with alternating signs, and the
    bow tie's clap failed at 25.3 ms where the lumped projection runs through.
    Each impulse acts equally and oppositely on the two points, so momentum is
    conserved (supported nodes, of infinite mass, take none), and the kinetic
    energy of the lumped masses falls by exactly
    ½ (G v)ᵀ (G M⁻¹ Gᵀ)⁻¹ (G v) ≥ 0, summed in :attr:`PairAbsorber.absorbed`
    (J; J/m × depth for strips): the energy the impacts lose. The relative
    normal acceleration is removed the same way. Tangential motion is left
    alone.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from scipy import sparse
from scipy.spatial import cKDTree

from magfem.mechanics.contacts.self_contact.search import SurfacePairing
from magfem.parallel import JIT_WAIT

__all__ = ["PairAbsorber"]


class PairAbsorber:
    """Inelastic normal impacts between paired nodes of a :class:`SurfacePairing` (collective).

    Args:
        pairing: the paired surfaces; :meth:`apply` searches it at the accepted state.
        kinetic_energy: the body's kinetic energy (UFL form) at the rates ``rate``.
        rate: the displacement's velocity Function in it (of the pairing's space V).
        bcs: the displacement's Dirichlet conditions (supported nodes do not move).
        depth: the strip's depth (m; 1 for 3D bodies): the history's J/m × depth.
        rest_velocity: pairs already inside are reset only when they separate
            faster than this (m/s).
    """

    def __init__(
        self,
        pairing: SurfacePairing,
        kinetic_energy: ufl.Form,
        rate: fem.Function,
        bcs: Sequence[fem.DirichletBC],
        *,
        depth: float = 1.0,
        rest_velocity: float = 1e-3,
    ) -> None:
        p = pairing
        self.pairing = p
        self.depth = float(depth)
        self.rest_velocity = float(rest_velocity)
        V = p.V
        mass = ufl.derivative(
            ufl.derivative(kinetic_energy, rate, ufl.TestFunction(V)), rate, ufl.TrialFunction(V)
        )
        M = fem_petsc.assemble_matrix(fem.form(mass, jit_options=JIT_WAIT))
        M.assemble()
        ones, diagonal = M.createVecRight(), M.createVecRight()
        ones.set(1.0)
        M.mult(ones, diagonal)
        gdim = p.gdim
        rows = diagonal.getArray(readonly=True).reshape(-1, gdim)  # owned nodes × components
        total = p.comm.allreduce(rows.sum(axis=0))  # the body's mass per component
        M.getDiagonal(diagonal)
        diag = diagonal.getArray(readonly=True).reshape(-1, gdim).copy()
        lumped = diag * (total / p.comm.allreduce(diag.sum(axis=0)))
        for m in (M, ones, diagonal):
            m.destroy()
        inverse = 1.0 / lumped
        for bc in bcs:
            dofs, owned = bc.dof_indices()
            inverse.reshape(-1)[dofs[:owned]] = 0.0  # supported: infinite mass
        self._inverse_mass = p.gather_nodes(inverse).reshape(-1, gdim)
        """Per gathered contact node and component: 1/m (1/kg; 0 where supported)."""
        sizes = p.comm.allgather(int(p._vown.size))
        self._first = int(sum(sizes[: p.comm.rank]))  # this rank's first gathered node
        self._count = int(sum(sizes))
        self.touching = np.zeros(self._count, dtype=bool)
        """Per gathered contact node: a slave inside its master at the last call."""
        self.absorbed = 0.0
        """Kinetic energy removed so far (J; J/m × depth for strips)."""
        self.impacts = 0
        """Pairs reset so far whose relative normal speed exceeded ``rest_velocity`` (the
        others, touching and parting by round-off, change nothing that matters)."""

    def apply(self, u: Any, v: Any, a: Any) -> int:
        """Make the new impacts of the accepted state inelastic; returns the impacts (pairs).

        Args:
            u, v, a: displacement, velocity and acceleration Functions at
                t_{n+1} (the integrator's u_n, v_n, a_n after ``advance``); v
                and a are changed in place (owned and ghost entries).
        """
        p, gdim = self.pairing, self.pairing.gdim
        p.search(u.x.array)
        own = p._vown
        i, k, normal = self._pairs(u.x.array.reshape(-1, gdim)[own])
        inside = np.zeros(self._count, dtype=bool)
        inside[i] = True
        fresh = ~self.touching[i]
        self.touching = inside
        vel = self._gathered(v)
        w = np.einsum("ij,ij->i", vel[i] - vel[k], normal)
        reset = fresh | (w > self.rest_velocity)
        if not reset.any():
            return 0
        impacts = int(np.count_nonzero(reset & (np.abs(w) > self.rest_velocity)))
        i, k, normal, w = i[reset], k[reset], normal[reset], w[reset]
        G = self._constraints(i, k, normal)
        Minv = sparse.diags(self._inverse_mass.ravel())
        S = (G @ Minv @ G.T).toarray()
        acc = self._gathered(a)
        lam = np.linalg.lstsq(S, -w, rcond=1e-12)[0]
        self._set(v, vel + (Minv @ (G.T @ lam)).reshape(vel.shape))
        lam_a = np.linalg.lstsq(S, -(G @ acc.ravel()), rcond=1e-12)[0]
        self._set(a, acc + (Minv @ (G.T @ lam_a)).reshape(acc.shape))
        self.absorbed += self.depth * 0.5 * float(-w @ lam)
        self.impacts += impacts
        return impacts

    def _set(self, f: fem.Function, gathered: npt.NDArray[np.float64]) -> None:
        """Write this rank's part of gathered contact-node values into ``f`` (collective)."""
        own = self.pairing._vown
        f.x.array.reshape(-1, self.pairing.gdim)[own] = gathered[
            self._first : self._first + own.size
        ]
        f.x.scatter_forward()

    def _gathered(self, f: fem.Function) -> npt.NDArray[np.float64]:
        """The values of ``f`` at every contact node, in the gathered order (collective)."""
        p = self.pairing
        return p.gather_nodes(f.x.array.reshape(-1, p.gdim)).reshape(-1, p.gdim)

    def _pairs(
        self, owned_displacement: npt.NDArray[np.float64]
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """The slave nodes inside their masters (gathered indices), their masters and the unit
        normals n̂, the same on every rank; of two nodes paired with each other, once."""
        p, gdim = self.pairing, self.pairing.gdim
        own = p._vown
        partner = p.vpartner[own]
        nbar = p._nbar_v.x.array.reshape(-1, gdim)[own]
        length = np.linalg.norm(nbar, axis=1)
        x = p.vreference[own] + owned_displacement
        xbar = p.xbar.x.array.reshape(-1, gdim)[own]
        gap = np.einsum("ij,ij->i", x - xbar, nbar)
        hit = (partner >= 0) & (length > 0) & (gap < 0.0)
        slave = self._first + np.flatnonzero(hit)
        unit = nbar[hit] / length[hit, None]
        parts = p.comm.allgather((slave, partner[hit], unit))
        i = np.concatenate([q[0] for q in parts]).astype(np.int64)
        k = np.concatenate([q[1] for q in parts]).astype(np.int64)
        normal = np.concatenate([q[2] for q in parts]).reshape(-1, gdim)
        key, back = i * self._count + k, k * self._count + i
        once = ~(np.isin(back, key) & (i > k))
        return i[once], k[once], normal[once]

    def _constraints(
        self, i: npt.NDArray[np.int64], k: npt.NDArray[np.int64], normal: npt.NDArray[np.float64]
    ) -> sparse.csr_matrix:
        """G: per pair the row n̂ᵀ(·_i − ·_k) over the gathered nodes' components."""
        gdim = self.pairing.gdim
        n = len(i)
        rows = np.repeat(np.arange(n), 2 * gdim)
        cols = np.concatenate([i[:, None] * gdim, k[:, None] * gdim], axis=1)
        cols = (cols[:, :, None] + np.arange(gdim)).reshape(n, 2 * gdim)
        values = np.concatenate([normal, -normal], axis=1)
        return sparse.csr_matrix(
            (values.ravel(), (rows, cols.ravel())), shape=(n, self._count * gdim)
        )

    def state(self) -> dict[str, Any]:
        """The slave nodes inside at the last call (reference positions, m), the energy and
        impacts so far (independent of the number of ranks)."""
        return {
            "touching": self.pairing._gvref[self.touching].tolist(),
            "absorbed": self.absorbed,
            "impacts": self.impacts,
        }

    def load_state(self, state: dict[str, Any]) -> None:
        """Continue from :meth:`state`."""
        self.absorbed = float(state["absorbed"])
        self.impacts = int(state["impacts"])
        self.touching = np.zeros(self._count, dtype=bool)
        points = np.asarray(state["touching"], dtype=np.float64).reshape(-1, self.pairing.gdim)
        if points.size:
            _, index = cKDTree(self.pairing._gvref).query(points)
            self.touching[index] = True
