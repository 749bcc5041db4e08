"""Weighted L² projection of scalar UFL expressions onto a continuous Lagrange space.

Used to recover B and ∇B from a potential: ``P(f)`` solves
∫ P(f) w ρ dx = ∫ f w ρ dx for all w, with ρ a weight (r in axisymmetry,
1 in 3D). Vector and tensor quantities are projected component by
component with one scalar mass matrix (assembled once; CG + Jacobi: a mass
matrix has a condition number independent of h after diagonal scaling),
which is an order of magnitude cheaper than assembling the blocked
(3 × 3)-valued mass matrix. The weight also switches the sources off
(:func:`air_indicator`), so the projections recover the field of the air,
where it is smooth. Components may be constrained to zero on a set
of dofs (e.g. B_r = 0 on the symmetry axis).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc
from petsc4py import PETSc

from magfem.parallel import JIT_WAIT

__all__ = ["Projector", "air_indicator", "pack"]


def pack(functions: list[Any], name: str = "packed") -> Any:
    """One blocked Function holding scalar ``functions`` (same space) as components.

    Point evaluation then locates each point once and evaluates all components
    in one call (the recovered B, ∇B are evaluated at every robot node per step).
    """
    V = functions[0].function_space
    W = fem.functionspace(
        V.mesh, ("Lagrange", V.ufl_element().embedded_superdegree, (len(functions),))
    )
    out = fem.Function(W, name=name)
    bs = len(functions)
    for i, f in enumerate(functions):
        out.x.array[i::bs] = f.x.array  # same mesh and element: identical scalar dof layout
    return out


def air_indicator(mesh: Any, cell_tags: Any, source_tags: list[int], eps: float = 1e-8) -> Any:
    """DG0 weight: 1 in air, ``eps`` in the sources (windings, magnets).

    B (magnets: tangential jump μ0 M × n) and ∇B (coils: curl B = μ0 J) are
    discontinuous across a source's surface; a continuous projection over
    the whole domain would smear that jump into the air. With this weight
    the projection is, up to ``eps``, the projection over the air alone
    (the dofs inside a source are decoupled, not constrained).
    """
    Q = fem.functionspace(mesh, ("DG", 0))
    chi = fem.Function(Q, name="air_indicator")
    chi.x.array[:] = 1.0
    for tag in source_tags:
        cells = cell_tags.find(tag)
        chi.x.array[Q.dofmap.list[cells].ravel()] = eps
    chi.x.scatter_forward()
    return chi


class Projector:
    """Weighted L² projector onto the scalar space ``V`` (collective).

    Args:
        V: scalar Lagrange space.
        dx: integration measure (with its quadrature degree).
        weight: UFL weight ρ (e.g. r), or 1.
        zero_dofs: dofs (local indices) where constrained projections vanish.
        prefix: PETSc options prefix.
    """

    def __init__(
        self,
        V: Any,
        dx: Any,
        weight: Any = 1.0,
        *,
        zero_dofs: np.ndarray | None = None,
        prefix: str,
    ):
        self.V, self.dx, self.weight = V, dx, weight
        u, self._w = ufl.TrialFunction(V), ufl.TestFunction(V)
        a = fem.form(u * self._w * weight * dx, jit_options=JIT_WAIT)
        self._ksp: dict[bool, Any] = {}
        self._bc = None
        variants = [False]
        if zero_dofs is not None:
            self._bc = fem.dirichletbc(0.0, np.asarray(zero_dofs, dtype=np.int32), V)
            variants.append(True)
        self._mats = []
        for constrained in variants:
            A = petsc.assemble_matrix(
                a, bcs=[self._bc] if constrained and self._bc is not None else []
            )
            A.assemble()
            ksp = PETSc.KSP().create(V.mesh.comm)
            ksp.setOptionsPrefix(f"{prefix}{'c' if constrained else 'f'}_")
            ksp.setOperators(A)
            ksp.setType("cg")
            ksp.getPC().setType("jacobi")
            ksp.setTolerances(rtol=1e-12, atol=0.0, max_it=2000)
            ksp.setFromOptions()
            self._ksp[constrained] = ksp
            self._mats.append(A)
        self.prefix = prefix

    def __call__(self, expr: Any, *, constrained: bool = False, name: str = "") -> Any:
        """The projection of the scalar UFL ``expr`` (a new Function on V)."""
        L = fem.form(expr * self._w * self.weight * self.dx, jit_options=JIT_WAIT)
        b = petsc.assemble_vector(L)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)  # type: ignore[arg-type]
        if constrained:
            if self._bc is None:
                raise ValueError("Projector: no zero_dofs given for a constrained projection")
            petsc.set_bc(b, [self._bc])
        out = fem.Function(self.V, name=name)
        ksp = self._ksp[constrained]
        ksp.solve(b, out.x.petsc_vec)
        reason = int(ksp.getConvergedReason())
        b.destroy()
        if reason <= 0:
            raise RuntimeError(f"{self.prefix}: projection of {name} failed (KSP reason {reason})")
        out.x.scatter_forward()
        return out

    def destroy(self) -> None:
        """Free the PETSc objects."""
        for ksp in self._ksp.values():
            ksp.destroy()
        for A in self._mats:
            A.destroy()
