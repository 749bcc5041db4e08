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

__all__ = [
    "SHAPES",
    "ClampedArmShape",
    "Shape",
    "UniformWidthShape",
    "register",
]


class Shape(ABC):
    """Base of the per-shape key dataclasses (``RectangleShape``, ``StarShape``, ...)."""

    name: ClassVar[str]
    """The ``shape`` value that selects this class (set by :func:`register`)."""

    feature_keys: ClassVar[tuple[str, ...]] = ()
    """Keys whose smallest value is :attr:`min_feature` (shapes may override the property)."""

    @property
    def min_feature(self) -> float:
        """Smallest in-plane dimension (m) an element must resolve (e.g. the arm width)."""
        return min(float(getattr(self, key)) for key in self.feature_keys)

    @property
    def uniform_width(self) -> float | None:
        """Depth (m) of the 2D side-view ``strip`` model, or None: no strip model."""
        return None

    @abstractmethod
    def outline(self) -> Outline:
        """The planar outline in the robot's frame (bottom face on z = 0)."""

    def at_most(self, key: str, limit: float, what: str, *, strict: bool = False) -> None:
        """Raise a CaseError naming ``key`` unless its value is <= ``limit`` (< if ``strict``).

        ``what`` names the limit in the message (e.g. ``"length"``).
        """
        value = getattr(self, key)
        if value > limit or (strict and value == limit):
            raise CaseError(key, value, f"must be {'<' if strict else '<='} {what} ({limit:g} m)")

    def at_least(self, key: str, limit: float, what: str, *, strict: bool = False) -> None:
        """Raise a CaseError naming ``key`` unless its value is >= ``limit`` (> if ``strict``)."""
        value = getattr(self, key)
        if value < limit or (strict and value == limit):
            raise CaseError(key, value, f"must be {'>' if strict else '>='} {what} ({limit:g} m)")


class ClampedArmShape(Shape):
    """A shape whose bonded strip ``clamp_length`` (m) must be shorter than its ``length``."""

    length: float
    clamp_length: float

    def __post_init__(self) -> None:
        self.at_most("clamp_length", self.length, "length", strict=True)


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
        if not cls.feature_keys and cls.min_feature is Shape.min_feature:
            raise TypeError(f"shape {name!r} declares neither feature_keys nor min_feature")
        cls.name = name
        SHAPES[name] = cls
        return cls

    return decorate
