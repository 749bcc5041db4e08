"""Structural models, one module each, registered by their ``[mesh] model`` name.

:mod:`.base` defines the :class:`~magfem.mechanics.models.base.Model`
interface; a new model is a new module here that registers its class in
:data:`~magfem.mechanics.models.base.MODELS`.
"""

from magfem.mechanics.models.base import MODELS, BodySetup, Face, Model, ModelInputs
from magfem.plugins import import_modules

__all__ = ["MODELS", "BodySetup", "Face", "Model", "ModelInputs"]

import_modules(__name__, __path__)
