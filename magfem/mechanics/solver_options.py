"""Checking ``[solver] petsc_options`` before a run: PETSc says what it does not use.

The Newton solver hands its options (:func:`magfem.mechanics.solver.newton_options`:
magfem's defaults, then ``petsc_options``) to PETSc when it is set up. An
option PETSc does not read (a typo, an option of another solver type) is
ignored without a word, and a malformed value (``snes_rtol = "abc"``)
fails only in the run. :func:`check_petsc_options` sets the same options up
on a throw-away SNES (``PETSC_COMM_SELF``) whose linear solver it sets up
on a 4 × 4 diagonal matrix (the factorization reads the direct solvers'
options such as ``mat_mumps_icntl_14``), and asks PETSc which of the user's
options it did not use.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Mapping
from typing import Any

from petsc4py import PETSc

from magfem.config import CaseError
from magfem.mechanics.solver import newton_options
from magfem.mechanics.spec import SolverSpec

__all__ = ["check_petsc_options"]

_COUNTER = itertools.count()
_KEY = "solver.petsc_options"


def _set_up(options: Mapping[str, Any]) -> tuple[PETSc.Error | None, list[str]]:
    """(PETSc's error or None, the options it did not use) of a SNES set up with ``options``."""
    prefix = f"magfem_check_{next(_COUNTER)}_"
    db = PETSc.Options()
    n = 4
    A = PETSc.Mat().createAIJ((n, n), nnz=1, comm=PETSc.COMM_SELF)
    for i in range(n):
        A.setValue(i, i, 2.0)
    A.assemble()
    snes = PETSc.SNES().create(PETSc.COMM_SELF)
    snes.setOptionsPrefix(prefix)
    for key, value in options.items():
        db.setValue(prefix + key, value)
    error: PETSc.Error | None = None
    try:
        snes.setFromOptions()
        ksp = snes.getKSP()
        ksp.setOperators(A, A)
        ksp.setUp()
    except PETSc.Error as err:
        error = err
    finally:
        unused = [key for key in options if not db.used(prefix + key)]
        for key in options:
            db.delValue(prefix + key)
        snes.destroy()
        A.destroy()
    return error, unused


def check_petsc_options(spec: SolverSpec) -> None:
    """Raise CaseError for the first option of ``spec.petsc_options`` PETSc cannot use.

    Not collective (every rank may call it; ``PETSC_COMM_SELF``).

    Raises:
        CaseError: ``solver.petsc_options.<key>``: a value PETSc cannot read
            (a malformed number, an unknown type name) or an option it does
            not use with these settings.
    """
    user = dict(spec.petsc_options)
    if not user:
        return
    error, unused = _set_up(newton_options(spec))
    if error is not None:
        # the options one at a time (with magfem's defaults) to name the culprit
        defaults = newton_options(dataclasses.replace(spec, petsc_options={}))
        for key, value in user.items():
            if _set_up(defaults | {key: value})[0] is not None:
                raise CaseError(
                    f"{_KEY}.{key}", value, f"PETSc cannot read this value (error {_code(error)})"
                )
        raise CaseError(_KEY, user, f"PETSc refuses these options (error {_code(error)})")
    for key in user:
        if key in unused:
            raise CaseError(
                f"{_KEY}.{key}",
                user[key],
                "PETSc does not use this option in the Newton solver "
                "(unknown, or an option of another solver type)",
            )


def _code(err: PETSc.Error) -> object:
    """PETSc's error number of ``err``."""
    return getattr(err, "ierr", "?")
