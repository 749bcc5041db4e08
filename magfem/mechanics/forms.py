"""Compiled forms of the mechanics: the compiler flags, and assembly of scalar forms.

Every mechanics form is compiled with :data:`JIT_OPTIONS` (through
:func:`compile_form` or the solver), once, outside the time loop.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from dolfinx import fem
from mpi4py import MPI

__all__ = ["FORM_COMPILER_OPTIONS", "JIT_OPTIONS", "assemble_scalars", "compile_form"]

FORM_COMPILER_OPTIONS: dict[str, Any] = {"scalar_type": np.float64}
"""Form compiler options of every mechanics form (real PETSc)."""
JIT_OPTIONS: dict[str, Any] = {
    "cffi_extra_compile_args": ["-O3", "-g0", "-ffast-math", "-fno-finite-math-only"]
}
"""C compiler flags of every mechanics form.

``-ffast-math`` lets the compiler vectorise the long sums of the element
tangent (the default case's Jacobian assembles ~2.5× faster);
``-fno-finite-math-only`` keeps NaN meaningful, so an inverted element still
fails its step; no ``-march=native``, so a shared form cache holds code every
CPU of a cluster runs; ``-g0`` drops the debug information Python's flags ask
for (faster cold compiles). Measured in docs/mechanics.md ("Compile flags").
"""


def compile_form(form: Any) -> fem.Form:
    """``fem.form`` with the mechanics' compiler options."""
    return fem.form(form, form_compiler_options=FORM_COMPILER_OPTIONS, jit_options=JIT_OPTIONS)


def assemble_scalars(forms: list[Any], comm: MPI.Comm) -> list[float]:
    """Assemble compiled scalar forms and sum them over ranks (collective)."""
    local = np.array([fem.assemble_scalar(f) for f in forms], dtype=float)
    total = np.zeros_like(local)
    comm.Allreduce(local, total, op=MPI.SUM)
    return total.tolist()
