r"""Self-contact's coupled step terms: Newton hooks for a contact that couples distant dofs.

When the data are refreshed: implicit coupling.
    The pairing (which master node, n̄) is searched at the start of every
    step (at the integrator's stage displacement, where the residual is
    enforced) and before every observation, and is frozen within the step.
    x̄ is not: inside every Newton iteration it is the *current* stage
    position of the paired master node, x̄ = X_m + u_{n+1−αf}(X_m), so the
    gap is evaluated with the master's current displacement. The step terms
    are non-local (slave rows depend on master dofs), so they are not part
    of the UFL residual: :meth:`CoupledTerms.attach` registers hooks on the
    Newton solver that add ∂E/∂u to the residual (slave traction assembled
    as a dolfinx form, master reaction scattered to the master nodes' global
    rows) and its consistent linearisation to the Jacobian: the four blocks
    slave/master rows × slave/master columns, assembled as dolfinx forms in
    (u, x̄) and mapped to global dofs, scaled by ∂u_stage/∂u_{n+1} = 1 − αf,
    off the Dirichlet rows and columns, as new nonzeros of the PETSc matrix.
    Within a step the contact is the gradient of E (symmetric Jacobian,
    forces summing to zero); the forms are compiled once.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem, la
from petsc4py import PETSc

from magfem.mechanics.block_integrator import BlockIntegrator
from magfem.mechanics.contacts.self_contact.search import SurfacePairing
from magfem.mechanics.forms import JIT_OPTIONS
from magfem.mechanics.integrator import TimeIntegrator
from magfem.mechanics.solver import NewtonSolver

__all__ = ["CoupledTerms"]


class CoupledTerms:
    """The self-contact terms of the step residual and Jacobian (collective).

    Args:
        pairing: the paired contact surfaces (its x̄, n̄ and u_geom).
        integrator: the time integrator (the stage weights place the terms), of the
            displacement alone or of all the model's unknowns.
    """

    def __init__(self, pairing: SurfacePairing, integrator: TimeIntegrator | BlockIntegrator):
        self.pairing = pairing
        self.integrator = integrator
        self._bc_global = np.zeros(0, dtype=np.int64)
        # the half-pass traction on the slave (test w) and its reaction on the master point x̄
        # (test ψ, nodal values of x̄ in V), with their derivatives in u_geom (slave columns)
        # and in x̄ (master columns)
        V = pairing.V
        X = ufl.SpatialCoordinate(V.mesh)
        w, psi = ufl.TestFunction(V), ufl.TestFunction(V)
        du, dxbar = ufl.TrialFunction(V), ufl.TrialFunction(V)
        half = 0.5 * pairing.pressure(X + pairing.u_geom)
        slave = -half * ufl.inner(pairing.nbar, w) * pairing.measure  # ∂E/∂u_s
        master = half * ufl.inner(pairing.nbar, psi) * pairing.measure  # ∂E/∂x̄
        jit = JIT_OPTIONS
        self._slave_form = fem.form(slave, jit_options=jit)
        self._master_form = fem.form(master, jit_options=jit)
        self._blocks = []
        for form, var, trial in (
            (slave, pairing.u_geom, du),
            (slave, pairing.xbar, dxbar),
            (master, pairing.u_geom, du),
            (master, pairing.xbar, dxbar),
        ):
            a = fem.form(ufl.derivative(form, var, trial), jit_options=jit)
            self._blocks.append((a, fem.create_matrix(a, la.BlockMode.expanded)))

    def attach(self, solver: NewtonSolver, bcs: Sequence[fem.DirichletBC]) -> None:
        """Add the coupled contact terms to ``solver``'s residual and Jacobian (collective).

        ``bcs`` are the (homogeneous) Dirichlet conditions of the displacement:
        entries in their rows or columns are left out of the Jacobian. The
        displacement is ``solver``'s only unknown or its first block (the
        shell's u before its angles): its dofs are numbered as the solver's
        vectors number them (:meth:`SurfacePairing.number_rows`).
        """
        self.pairing.number_rows(int(solver.problem.x.getOwnershipRange()[0]))
        row = self.pairing.row
        bs = self.pairing.V.dofmap.index_map_bs
        owned = [np.zeros(0, dtype=np.int64)]
        for bc in bcs:
            dofs, num_owned = bc.dof_indices()
            local = np.asarray(dofs[:num_owned], dtype=np.int64)
            owned.append(row[local // bs] + local % bs)
        self._bc_global = np.unique(
            np.concatenate(self.pairing.comm.allgather(np.concatenate(owned)))
        )
        solver.residual_hooks.append(self.add_residual)
        solver.jacobian_hooks.append(self.add_jacobian)

    @property
    def stage_weight(self) -> float:
        """∂u_stage/∂u_{n+1}: 1 − αf for the dynamic schemes, 1 quasi-static."""
        integ = self.integrator
        if integ.dynamic and integ.params is not None:
            return 1.0 - integ.params.alpha_f
        return 1.0

    def _state(self, x: Any) -> npt.NDArray[np.int64]:
        """Set u_geom to the stage displacement of the iterate ``x`` and x̄ to the current
        master nodes (collective); returns the master's row (first component) per local V node.

        The displacement's owned entries are the first ones of ``x`` on every rank.
        """
        u_geom = self.pairing.u_geom
        owned = self.pairing.V.dofmap.index_map.size_local * self.pairing.V.dofmap.index_map_bs
        u_geom.x.array[:owned] = x.array_r[:owned]
        u_geom.x.scatter_forward()
        integ = self.integrator
        if integ.dynamic and integ.params is not None:
            af = integ.params.alpha_f
            self.pairing.u_geom.x.array[:] = (
                1.0 - af
            ) * self.pairing.u_geom.x.array + af * integ.u0.x.array
        return self.pairing.place(self.pairing.u_geom.x.array)

    def add_residual(self, x: Any, b: Any) -> None:
        """Residual hook: add ∂E/∂u at the stage point of ``x`` to ``b`` (collective).

        E = ½ Σ_passes ∫ k_c R(−g) dA with g = (x_s − x̄)·n̄ and x̄ following the
        master nodes: the slave gets −½ ∫ k_c r n̄·w dA, the master nodes the
        opposite, weighted by the shape functions of x̄ (action = reaction).
        """
        if not self.pairing.engaged:
            return
        gdim = self.pairing.gdim
        target = self._state(x)
        slave = fem.assemble_vector(self._slave_form)
        slave.scatter_reverse(la.InsertMode.add)
        n = self.pairing.V.dofmap.index_map.size_local * self.pairing.V.dofmap.index_map_bs
        with b.localForm() as local:  # the displacement's owned entries come first
            local.array[:n] += slave.array[:n]
        master = fem.assemble_vector(self._master_form).array  # local + ghost nodes, unsummed
        rows = (target[:, None] + np.arange(gdim)).ravel()
        keep = master != 0.0
        rows, values = rows[keep], master[keep]
        b.setValues(rows.astype(PETSc.IntType), values, addv=PETSc.InsertMode.ADD)
        b.assemblyBegin()
        b.assemblyEnd()

    def add_jacobian(self, x: Any, A: Any) -> None:
        """Jacobian hook: add the consistent linearisation of :meth:`add_residual` (collective).

        The four blocks (slave/master rows × slave/master columns) are
        assembled as dolfinx forms in (u_geom, x̄), mapped to global
        displacement dofs (x̄ of a node → its master node), scaled by
        ∂u_stage/∂u and added to ``A`` off the Dirichlet rows and columns
        (new nonzeros allowed: master–slave couplings are not in the form's
        sparsity).
        """
        if not self.pairing.engaged:
            return
        gdim = self.pairing.gdim
        target = self._state(x)
        bs = self.pairing.V.dofmap.index_map_bs
        v_rows = (self.pairing.row[:, None] + np.arange(bs)).ravel()
        x_rows = (target[:, None] + np.arange(gdim)).ravel()
        rows, cols, vals = [], [], []
        for (form, mat), (r_map, c_map) in zip(
            self._blocks,
            ((v_rows, v_rows), (v_rows, x_rows), (x_rows, v_rows), (x_rows, x_rows)),
            strict=True,
        ):
            mat.data[:] = 0.0
            fem.assemble_matrix(mat, form)
            coo = mat.to_scipy(ghosted=True).tocoo()
            keep = coo.data != 0.0
            rows.append(r_map[coo.row[keep]])
            cols.append(c_map[coo.col[keep]])
            vals.append(coo.data[keep])
        row, col, val = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
        keep = ~(np.isin(row, self._bc_global) | np.isin(col, self._bc_global))
        row, col, val = row[keep], col[keep], self.stage_weight * val[keep]
        order = np.lexsort((col, row))
        row, col, val = row[order], col[order], val[order]
        uniq, start = np.unique(row, return_index=True)
        indptr = np.append(start, row.size).astype(PETSc.IntType)
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        if uniq.size:
            A.setValuesIJV(
                indptr,
                col.astype(PETSc.IntType),
                val,
                addv=PETSc.InsertMode.ADD,
                rowmap=uniq.astype(PETSc.IntType),
            )
        A.assemble()
