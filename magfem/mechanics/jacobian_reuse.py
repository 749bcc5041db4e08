"""When Newton may keep its factorised Jacobian (modified Newton), and why it did not."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from dolfinx import fem
from petsc4py import PETSc

__all__ = ["REBUILD_REASONS", "JacobianReuse"]

REBUILD_REASONS = ("contraction", "krylov", "time_step", "start")
"""Why a Jacobian was assembled instead of kept (:attr:`JacobianReuse.rebuilds`)."""


SAME_VALUE = 1e-9
"""Relative change of a watched constant below which the kept Jacobian still holds it: the
steps that land on a switch or the end differ from the nominal step by round-off."""


class JacobianReuse:
    """When :class:`NewtonSolver` may keep the factorised Jacobian (modified Newton).

    The Jacobian of the previous assembly, and its factorisation, serve the next
    iterations, of this step and of the following ones, as long as

    * each iteration made with it leaves ‖R‖ at or below ``contraction`` times the
      previous iterate's (``SolverSpec.reuse_contraction``; Newton with an exact
      Jacobian, converging, reduces it by far more),
    * the values of the constants in ``watch`` (e.g. the time step, which scales
      the inertia term) are those it was assembled with (to :data:`SAME_VALUE`),
    * the last solve converged,
    * with ``krylov_iterations`` (Jacobian-free Newton–Krylov, where the kept
      Jacobian only preconditions GMRES), the last linear solve took at most that
      many GMRES iterations.

    Its test reads SNES's residual norm and GMRES's iteration count, which are the same on
    every rank: the decision is collective without communication. Newton's tests on
    ‖R‖ stay the same, so the step is converged to the same tolerances.

    ``rebuilds`` counts why a Jacobian was assembled, over the run: ``contraction``
    (the last iteration reduced ‖R‖ too little, or raised it), ``krylov`` (GMRES
    needed more than ``krylov_iterations``), ``time_step`` (a
    watched constant changed), ``start`` (nothing valid to keep: the first
    iteration of the run, or after a failed solve).
    """

    def __init__(
        self,
        contraction: float,
        watch: Sequence[fem.Constant] = (),
        krylov_iterations: int | None = None,
    ):
        self.contraction = contraction
        self.krylov_iterations = krylov_iterations
        self.watch = list(watch)
        self.valid = False
        self._values: tuple[float, ...] = ()
        self._same: bool | None = None  # the watched values unchanged, once per solve
        self._previous = math.inf
        self.kept_this_solve = 0
        self.assembled_this_solve = 0
        self.rebuilds = dict.fromkeys(REBUILD_REASONS, 0)

    def _current(self) -> tuple[float, ...]:
        return tuple(float(np.sum(c.value)) for c in self.watch)

    def _unchanged(self) -> bool:
        """The watched values are those of the kept Jacobian (read once per solve: they
        change between solves only)."""
        if self._same is None:
            pairs = zip(self._current(), self._values, strict=True)
            self._same = all(math.isclose(a, b, rel_tol=SAME_VALUE) for a, b in pairs)
        return self._same

    def start(self) -> None:
        """A new solve begins (its first iteration has no contraction yet)."""
        self._same = None
        self._previous = math.inf
        self.kept_this_solve = 0
        self.assembled_this_solve = 0

    def keep(self, snes: PETSc.SNES) -> bool:
        """Whether this iteration may use the kept Jacobian (called before assembling it)."""
        norm = float(snes.getFunctionNorm())
        previous, self._previous = self._previous, norm
        if not self.valid:
            reason = "start"
        elif not self._unchanged():
            reason = "time_step"
        elif norm > self.contraction * previous:
            reason = "contraction"
        elif (
            self.krylov_iterations is not None
            and snes.getKSP().getIterationNumber() > self.krylov_iterations
        ):
            reason = "krylov"
        else:
            self.kept_this_solve += 1
            return True
        self.rebuilds[reason] += 1
        return False

    def assembled(self) -> None:
        """A Jacobian was assembled: it is the one kept from now on."""
        self.valid = True
        self._values = self._current()
        self._same = True
        self.assembled_this_solve += 1
