"""Robot shapes: one module per shape, each registering its key dataclass.

Importing this package imports every module in it (in alphabetical
order), so a new shape is one new file here whose class is decorated
with :func:`~magfem.geometry.shapes.base.register`; nothing else lists the
shapes. :data:`SHAPES` maps each ``shape`` name to its class.
"""

from __future__ import annotations

import importlib
import pkgutil

from magfem.geometry.shapes.base import SHAPES, Shape, register

__all__ = ["SHAPES", "Shape", "register"]

for _module in sorted(m.name for m in pkgutil.iter_modules(__path__)):
    if _module != "base":
        importlib.import_module(f"{__name__}.{_module}")
