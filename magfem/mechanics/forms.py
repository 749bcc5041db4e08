"""Compiled forms of the mechanics: the compiler flags, and scalar integrals in bundles.

Every mechanics form is compiled with :data:`JIT_OPTIONS` (through
:func:`compile_form`, :class:`ScalarForms` or the solver), once, outside the time loop.
"""

from __future__ import annotations

import hashlib
import platform
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from magfem.parallel import JIT_WAIT

__all__ = ["FORM_COMPILER_OPTIONS", "JIT_OPTIONS", "ScalarForms", "compile_form", "native_flags"]

FORM_COMPILER_OPTIONS: dict[str, Any] = {"scalar_type": np.float64}
"""Form compiler options of every mechanics form (real PETSc)."""


def native_flags(cpuinfo: str | None = None, machine: str | None = None) -> list[str]:
    """``-march=native`` and a define naming this CPU, on x86-64; [] elsewhere.

    ffcx keys its form cache by the compile flags, so the define
    (``-DMAGFEM_CPU=<hash>`` of the CPU's model name and instruction-set flags in
    ``/proc/cpuinfo``, else of the platform's processor and host name) gives each
    CPU its own build: machines of different CPUs that share a cache never load
    code for instructions they lack.

    Args:
        cpuinfo: the text of ``/proc/cpuinfo`` (None: read it, where it exists).
        machine: ``platform.machine()`` (None: this machine's).
    """
    machine = platform.machine() if machine is None else machine
    if machine not in ("x86_64", "AMD64"):
        return []
    if cpuinfo is None:
        path = Path("/proc/cpuinfo")
        cpuinfo = path.read_text(encoding="utf-8", errors="replace") if path.is_file() else ""
    keys = ("model name", "flags")
    lines = [ln for ln in cpuinfo.splitlines() if ln.split(":")[0].strip() in keys]
    identity = "\n".join(lines[: len(keys)]) or f"{platform.processor()} {platform.node()}"
    digest = hashlib.sha256(identity.encode()).hexdigest()[:16]
    return ["-march=native", f"-DMAGFEM_CPU={digest}"]


JIT_OPTIONS: dict[str, Any] = {
    **JIT_WAIT,
    "cffi_extra_compile_args": [
        "-O3",
        "-g0",
        "-ffast-math",
        "-fno-finite-math-only",
        *native_flags(),
    ],
}
"""JIT options of every mechanics form: the C compiler flags, and how long to wait for a
form that another process compiles (:data:`magfem.parallel.JIT_WAIT`).

``-ffast-math`` lets the compiler vectorise the long sums of the element
tangent (the default case's Jacobian assembles ~2.5× faster);
``-fno-finite-math-only`` keeps NaN meaningful, so an inverted element still
fails its step; ``-march=native`` (x86-64, :func:`native_flags`) lets it use
the machine's vector instructions (the P3 shell's residual 1.45× cheaper), with
a per-CPU cache key; ``-g0`` drops the debug information Python's flags ask
for (faster cold compiles). Measured in docs/verification.md (section 4b, and
"Compile flags for this CPU").
"""


def compile_form(form: Any) -> fem.Form:
    """``fem.form`` with the mechanics' compiler options."""
    return fem.form(form, form_compiler_options=FORM_COMPILER_OPTIONS, jit_options=JIT_OPTIONS)


class ScalarForms:
    """Scalar integrals (forces, moments, energies, mass moments) compiled and assembled together.

    The k-th integral is tested with the k-th component of a piecewise-constant (DG0) vector
    function, so one compiled form, assembled in one pass over the mesh, holds every cell's share
    of every integral; the sum of a rank's entries (ghost cells included: each cell and facet is
    integrated by one rank) is that rank's part of each integral. One module instead of one per
    integral: the observers of a run compile a few forms instead of tens (the JIT of a fresh
    machine is most of a first run and of the test suite). dolfinx takes one subdomain datum per
    integral type in a form, so integrals over differently tagged measures go into separate forms.

    Args:
        mesh: the mesh of every form.
        forms: scalar UFL forms (an empty form is the value 0).
    """

    def __init__(self, mesh: dmesh.Mesh, forms: Sequence[ufl.Form]):
        self.size, self.comm = len(forms), mesh.comm
        groups: list[tuple[list[int], dict[str, Any]]] = []
        for k, form in enumerate(forms):
            if form.empty():
                continue
            data = _subdomain_data(form)
            for members, seen in groups:
                if all(seen.get(kind, datum) is datum for kind, datum in data.items()):
                    members.append(k)
                    seen.update(data)
                    break
            else:
                groups.append(([k], dict(data)))
        self.parts = [_Bundle(mesh, [forms[k] for k in members], members) for members, _ in groups]
        """The compiled forms: one per set of compatible measures."""

    def assemble(self) -> list[float]:
        """The integrals at the current coefficients, summed over ranks (collective)."""
        local = np.zeros(self.size)
        for part in self.parts:
            local[part.members] = part.assemble()
        total = np.zeros_like(local)
        self.comm.Allreduce(local, total, op=MPI.SUM)
        return total.tolist()


class _Bundle:
    """Scalar forms with compatible measures as one DG0-tested vector form."""

    def __init__(self, mesh: dmesh.Mesh, forms: list[ufl.Form], members: list[int]):
        self.members = members
        self.space = fem.functionspace(mesh, ("DG", 0, (len(forms),)))
        v = ufl.TestFunction(self.space)
        integrals = [
            itg.reconstruct(integrand=itg.integrand() * _tested(v, k, itg.integral_type()))
            for k, form in enumerate(forms)
            for itg in form.integrals()
        ]
        self.form = compile_form(ufl.Form(integrals))
        cells = self.space.dofmap.index_map
        self.cells = np.zeros((cells.size_local + cells.num_ghosts) * len(forms))

    def assemble(self) -> np.ndarray:
        self.cells[:] = 0.0
        fem.assemble_vector(self.cells, self.form)  # type: ignore[arg-type]  # array overload
        return self.cells.reshape(-1, len(self.members)).sum(axis=0)


def _tested(v: Any, k: int, integral_type: str) -> Any:
    """The k-th test component, on the '+' side of an interior facet."""
    return v("+")[k] if integral_type == "interior_facet" else v[k]


def _subdomain_data(form: ufl.Form) -> dict[str, Any]:
    """Integral type -> the (one) subdomain datum of that type in ``form``."""
    data: dict[str, Any] = {}
    for kinds in form.subdomain_data().values():
        for kind, values in kinds.items():
            for datum in values:
                if datum is not None:
                    data[kind] = datum
    return data
