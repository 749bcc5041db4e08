"""The block residual of several unknowns assembled by one kernel on their mixed space.

A model with several unknowns (the shell's and the rod's displacement u and
rotation angles θ) gives Newton one residual form per unknown, each tested by
that unknown's test function. Assembled as blocks, each form is its own
generated kernel, and each kernel evaluates the whole kinematics again at
every quadrature point (the shell's strains, director and stress resultants
appear in both). :class:`FusedResidual` writes the blocks as one form on the
mixed space W = V_u × V_θ, F(w; (δu, δθ)) = F_u(u, θ; δu) + F_θ(u, θ; δθ), so one
kernel computes the kinematics once and both blocks' entries from them
(1.5 × less CPU per residual on the default case's P3 shell,
``python -m benchmarks.dynamics_speed fused``).

The unknowns keep their own spaces (checkpoints, outputs and the Jacobian's
blocks are unchanged): each of their degrees of freedom is matched to W's by
its coordinates, once, and the residual's vector is permuted into Newton's
block layout (owned entries of each block, then the ghosts of each block).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import basix.ufl
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from magfem.mechanics.forms import compile_form

__all__ = ["FusedResidual", "fusable"]

_LAGRANGE = ("P",)


def fusable(forms: Any, unknowns: Any) -> bool:
    """Whether ``forms`` are the block residuals of several Lagrange ``unknowns`` on one mesh."""
    if not (isinstance(forms, Sequence) and isinstance(unknowns, Sequence)):
        return False
    if len(forms) < 2 or len(forms) != len(unknowns):
        return False
    mesh = unknowns[0].function_space.mesh
    return all(
        f.function_space.mesh is mesh and f.function_space.ufl_element().family_name in _LAGRANGE
        for f in unknowns
    )


def _node_match(V: fem.FunctionSpace, Wi: fem.FunctionSpace) -> npt.NDArray[np.int64] | None:
    """For each local node of V, the local node of Wi at the same point; None when the nodes
    are not one-to-one by their coordinates or an owned node would map to a ghost."""
    cv, cw = V.tabulate_dof_coordinates(), Wi.tabulate_dof_coordinates()
    mv, mw = V.dofmap.index_map, Wi.dofmap.index_map
    if cv.shape != cw.shape or mv.size_local != mw.size_local:
        return None
    ov, ow = np.lexsort(cv.T[::-1]), np.lexsort(cw.T[::-1])
    scale = max(float(np.max(np.abs(cv), initial=0.0)), 1e-300)
    if not np.allclose(cv[ov], cw[ow], rtol=0.0, atol=1e-10 * scale):
        return None
    if len(ov) > 1 and np.min(np.max(np.abs(np.diff(cv[ov], axis=0)), axis=1)) <= 1e-10 * scale:
        return None  # two nodes at one point: coordinates do not tell them apart
    match = np.empty(len(ov), dtype=np.int64)
    match[ov] = ow
    owned = mv.size_local
    if np.any(match[:owned] >= owned):
        return None
    return match


class FusedResidual:
    """The block residuals ``forms`` of ``unknowns`` as one form on their mixed space.

    Args:
        forms: UFL residual of each unknown, linear in that unknown's test function.
        unknowns: the Functions the forms are nonlinear in (Newton's unknowns).

    Raises:
        ValueError: on every rank, when on some rank the unknowns' degrees of freedom
            cannot be matched to the mixed space's (:meth:`build` returns None instead).
    """

    def __init__(self, forms: Sequence[ufl.Form], unknowns: Sequence[fem.Function]):
        spaces = [u.function_space for u in unknowns]
        mesh = spaces[0].mesh
        W = fem.functionspace(mesh, basix.ufl.mixed_element([V.ufl_element() for V in spaces]))
        self.w = fem.Function(W, name="fused_unknowns")
        parts, tests = ufl.split(self.w), ufl.TestFunctions(W)
        fused: Any = 0
        for i, form in enumerate(forms):
            (test,) = form.arguments()
            mapping = {u: p for u, p in zip(unknowns, parts, strict=True)} | {test: tests[i]}
            fused = fused + ufl.replace(form, mapping)
        owned, ghosts = [], []
        matched = True
        for i, V in enumerate(spaces):
            Wi, to_parent = W.sub(i).collapse()
            match = _node_match(V, Wi)
            if match is None:
                matched = False
                continue
            bs = V.dofmap.index_map_bs
            index = np.asarray(to_parent, dtype=np.int64).reshape(-1, bs)[match].reshape(-1)
            n = bs * V.dofmap.index_map.size_local
            owned.append(index[:n])
            ghosts.append(index[n:])
        self.perm = np.concatenate(owned + ghosts)
        """W's local dof of each entry of Newton's local block vector."""
        bs_w = W.dofmap.index_map_bs
        size = (W.dofmap.index_map.size_local + W.dofmap.index_map.num_ghosts) * bs_w
        n_owned = sum(len(o) for o in owned)
        matched = matched and not (
            len(self.perm) != size
            or len(np.unique(self.perm)) != size
            or n_owned != W.dofmap.index_map.size_local * bs_w
            or np.any(self.perm[:n_owned] >= n_owned)
        )
        if mesh.comm.allreduce(not matched, op=MPI.LOR):  # every rank raises, or none
            raise ValueError("the unknowns' degrees of freedom do not match the mixed space's")
        self.form = compile_form(fused)
        self.vector: Any = fem_petsc.create_vector(W)

    @classmethod
    def build(cls, forms: Any, unknowns: Any) -> FusedResidual | None:
        """The fused residual of ``forms``, or None where they are not fusable block residuals
        or the unknowns' nodes cannot be matched to the mixed space's (collective)."""
        if not fusable(forms, unknowns):
            return None
        try:
            return cls(forms, unknowns)
        except ValueError:  # raised on every rank
            return None

    def assemble(self, x: Any, b: Any) -> None:
        """b = the block residual at x (ghost-updated x, Newton's block layout); b's owned
        entries are complete (ghost-accumulated), its ghost entries partial sums that the
        caller's forward scatter replaces."""
        with x.localForm() as x_local:
            self.w.x.array[self.perm] = x_local.array_r
        vector = self.vector
        with vector.localForm() as v_local:
            v_local.set(0.0)
        fem_petsc.assemble_vector(vector, self.form)  # type: ignore[arg-type]
        vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        with vector.localForm() as v_local, b.localForm() as b_local:
            b_local.array[:] = v_local.array_r[self.perm]
