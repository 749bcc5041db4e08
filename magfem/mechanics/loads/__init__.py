"""Loads on the body, one module each: the magnetic field, gravity and the ``[[loads]]`` kinds.

:mod:`.base` defines the :class:`~magfem.mechanics.loads.base.Load`
interface and the registry of ``[[loads]]`` kinds; a new load is a new
module here whose spec class registers itself in
:data:`~magfem.mechanics.loads.base.LOADS`.
"""

from magfem.mechanics.loads.base import LOADS, Load, LoadSpec
from magfem.mechanics.loads.gravity import GravityLoad
from magfem.mechanics.loads.magnetic import MagneticLoad
from magfem.plugins import import_modules

__all__ = ["LOADS", "GravityLoad", "Load", "LoadSpec", "MagneticLoad"]

import_modules(__name__, __path__)
