"""The base class of robot shapes and their registry.

A shape is a frozen dataclass of its ``[robot]`` keys (declared with
:func:`magfem.config.quantity`, ``option``, ``integer``, each with a
default and a ``doc``), registered under its ``shape`` name with
:func:`register`. It validates its keys in ``__post_init__`` (raising
:class:`magfem.config.CaseError` with the key), and gives its smallest
feature, its strip depth and its planar :class:`~magfem.geometry.outline.Outline`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import ClassVar, TypeVar

from magfem.config import CaseError
from magfem.geometry.outline import Outline

__all__ = ["SHAPES", "Shape", "UniformWidthShape", "check_clamp_length", "need", "register"]


class Shape(ABC):
    """Base of the per-shape key dataclasses (``RectangleShape``, ``StarShape``, ...)."""

    name: ClassVar[str]
    """The ``shape`` value that selects this class (set by :func:`register`)."""

    @property
    @abstractmethod
    def min_feature(self) -> float:
        """Smallest in-plane dimension (m) an element must resolve (e.g. the arm width)."""

    @property
    def uniform_width(self) -> float | None:
        """Depth (m) of the 2D side-view ``strip`` model, or None: no strip model."""
        return None

    @abstractmethod
    def outline(self) -> Outline:
        """The planar outline in the robot's frame (bottom face on z = 0)."""


class UniformWidthShape(Shape):
    """A shape of uniform ``width`` (m) along y: it has the 2D side-view ``strip`` model."""

    width: float

    @property
    def uniform_width(self) -> float:
        return self.width


SHAPES: dict[str, type[Shape]] = {}
"""Shape name -> the dataclass validating its keys (filled by :func:`register`)."""

S = TypeVar("S", bound=type[Shape])


def register(name: str) -> Callable[[S], S]:
    """Class decorator: make ``cls`` the shape selected by ``shape = name``."""

    def decorate(cls: S) -> S:
        if name in SHAPES:
            raise ValueError(f"shape {name!r} is registered twice")
        cls.name = name
        SHAPES[name] = cls
        return cls

    return decorate


def need(cond: bool, key: str, value: object, problem: str) -> None:
    """Raise ``CaseError(key, value, problem)`` unless ``cond``."""
    if not cond:
        raise CaseError(key, value, problem)


def check_clamp_length(clamp_length: float, length: float) -> None:
    """The bonded root strip must leave part of the arm free."""
    need(clamp_length < length, "clamp_length", clamp_length, f"must be < length ({length:g} m)")
