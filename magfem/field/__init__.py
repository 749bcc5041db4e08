"""Applied magnetic field: sources, waveforms, magnetostatic FE solves, field models.

Layers (each a module):

* :mod:`~magfem.field.spec`: the ``[field]`` case table (sources, waveforms, FE settings).
* :mod:`~magfem.field.waveforms`: dimensionless time functions with their switching instants.
* :mod:`~magfem.field.analytic`: closed-form reference fields (current loop, thick coil,
  cylinder and block magnets), independent of the FE code.
* :mod:`~magfem.field.axisymmetric`: A_φ solve in (r, z) for coils and cylinder magnets.
* :mod:`~magfem.field.solid`: 3D reduced-scalar-potential solve for block magnets.
* :mod:`~magfem.field.recovery`, :mod:`~magfem.field.points`: air-only L² recovery of B and
  ∇B; collective evaluation at arbitrary points.
* :mod:`~magfem.field.solvers`: source table → geometry, default mesh sizes, FE solve.
* :mod:`~magfem.field.model`: :class:`FieldModel` (uniform, Taylor, FE) for the mechanics.
* :mod:`~magfem.field.output`: VTX/.vti/CSV/PNG writers.
* :mod:`~magfem.field.run`: ``run_field(case, outdir, comm)`` behind ``magfem field CASE``.

Measured accuracy and cost: docs/field.md.
"""

from __future__ import annotations

from magfem.field.model import FieldModel, create_field_model
from magfem.field.spec import FieldSpec
from magfem.field.waveforms import Waveform, build_waveform

__all__ = ["FieldModel", "FieldSpec", "Waveform", "build_waveform", "create_field_model"]
