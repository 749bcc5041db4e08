"""Registries of interchangeable parts (models, loads, contacts), filled by their own modules.

A part registers itself where it is defined::

    LOADS = Registry("load")          # in the parts package's base module

    @LOADS.register("drag")
    class DragSpec: ...

and its package imports every one of its modules once (:func:`import_modules`,
at the end of the package's ``__init__``), so adding a part is adding one file.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any

from magfem.config import MISSING, CaseError, build_fields

__all__ = ["Registry", "build_registered", "import_modules"]


class Registry[T]:
    """Name -> registered object, with errors that list the names.

    Args:
        what: the kind of part, for messages (``"load"``).
    """

    def __init__(self, what: str) -> None:
        self.what = what
        self._items: dict[str, T] = {}

    def register(self, name: str) -> Callable[[T], T]:
        """Decorator registering its argument under ``name`` (a programming error if taken).

        A registered class gets the class attribute ``KIND = name`` (the case
        reference lists the kinds of a table through it).
        """

        def add(item: T) -> T:
            if name in self._items:
                raise ValueError(f"{self.what} '{name}' is registered twice")
            self._items[name] = item
            if isinstance(item, type):
                setattr(item, "KIND", name)  # noqa: B010  (a class attribute of a part)
            return item

        return add

    def get(self, name: Any, key: str) -> T:
        """The item named ``name``.

        Raises:
            CaseError: naming ``key`` and the registered names when ``name`` is unknown.
        """
        if name is MISSING:
            raise CaseError(key, MISSING, f"missing required key; {self._choices()}")
        if not isinstance(name, str) or name not in self._items:
            raise CaseError(key, name, f"unknown {self.what}; {self._choices()}")
        return self._items[name]

    def names(self) -> list[str]:
        """Registered names, sorted."""
        return sorted(self._items)

    def items(self) -> Iterator[tuple[str, T]]:
        """(name, item) pairs, sorted by name."""
        return iter(sorted(self._items.items()))

    def __contains__(self, name: object) -> bool:
        return name in self._items

    def _choices(self) -> str:
        return f"{self.what}s are " + ", ".join(self.names())


def import_modules(package: str, path: Iterable[str]) -> None:
    """Import every public module of a package (``package`` name, its ``__path__``)."""
    for info in sorted(pkgutil.iter_modules(list(path)), key=lambda m: m.name):
        if not info.name.startswith("_"):
            importlib.import_module(f"{package}.{info.name}")


def build_registered(
    registry: Registry[type[Any]], table: Mapping[str, Any], where: str, key: str = "kind"
) -> Any:
    """Validate a table whose ``key`` names a registered spec class, into that class.

    The registered class has a ``key`` field itself (so that the resolved case
    writes it back).

    Raises:
        CaseError: unknown or missing ``key``, or any problem of the class's own keys.
    """
    cls = registry.get(table.get(key, MISSING), f"{where}.{key}" if where else key)
    return build_fields(cls, table, where)
