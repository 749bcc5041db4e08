"""Applied magnetic field: sources, iron parts, waveforms, motions, field models.

Layers (each a module):

* :mod:`~magfem.field.spec` (with :mod:`~magfem.field.source_spec`,
  :mod:`~magfem.field.iron_spec`): the ``[field]`` case table.
* :mod:`~magfem.field.waveforms`, :mod:`~magfem.field.placement`: time
  functions and rigid keyframed motions.
* :mod:`~magfem.field.analytic`: closed-form fields of coils and magnets and
  their gradients; :mod:`~magfem.field.source`: those fields placed in 3D.
* :mod:`~magfem.field.iron` (with :mod:`~magfem.field.iron_mesh`, :mod:`~magfem.field.reaction`,
  :mod:`~magfem.field.recovery`, :mod:`~magfem.field.points`): the FE
  reaction field of soft-iron parts.
* :mod:`~magfem.field.build`: the case table → terms (field × waveform × motion).
* :mod:`~magfem.field.models`, :mod:`~magfem.field.choice`,
  :mod:`~magfem.field.model`: the field models the mechanics uses and
  ``create_field_model``.
* :mod:`~magfem.field.output`, :mod:`~magfem.field.run`: ``magfem field CASE``.

Measured accuracy and cost: docs/field.md.
"""

from __future__ import annotations

from magfem.field.model import FieldModel, create_field_model
from magfem.field.spec import FieldSpec
from magfem.field.waveforms import Waveform, build_waveform

__all__ = ["FieldModel", "FieldSpec", "Waveform", "build_waveform", "create_field_model"]
