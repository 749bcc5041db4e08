"""Validation engine that maps TOML tables one-to-one onto frozen dataclasses.

Each stage declares its own case table as a frozen dataclass whose fields
carry metadata built with :func:`quantity`, :func:`vector`, :func:`option`,
:func:`integer` or :func:`flag` (unit, bounds, choices and a one-line
``doc``; a docstring written under a field serves as its ``doc`` too).
The same metadata generates the case-file reference, docs/case_reference.md
(:mod:`magfem.casedoc`). :func:`from_table` converts a parsed TOML table into that
dataclass: units are converted to SI once, ranges and choices checked, and
any problem raises :class:`CaseError` naming the key, the value and what is
allowed. :func:`to_table` is the inverse (SI numbers), used to write the
resolved case next to the outputs.

Supported field types: ``float`` (quantity with unit), ``int``, ``bool``,
``str`` (optionally with choices), ``tuple[float, ...]`` (vectors of
quantities), ``tuple[str, ...]``, a nested dataclass (sub-table), a tuple of
dataclasses (array of tables), ``dict[str, ...]`` (free mapping such as PETSc
options) and ``X | None`` for optional values. A dataclass may define a
classmethod ``__from_table__(table, where)`` to take over its own parsing
(used for tables whose keys depend on a discriminator such as ``shape``),
and a method ``__to_table__()`` for the inverse. A table that lists the
keys that apply to one value of a ``kind`` option does so through a
``table_keys()`` method that reads ``kind`` only, or has one subclass per
kind with a ``KIND`` class variable.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from typing import Any, TypeVar

from magfem.units import UnitError, parse_quantity

__all__ = [
    "MISSING",
    "CaseError",
    "build_fields",
    "check_keys",
    "flag",
    "from_table",
    "integer",
    "not_in_table",
    "option",
    "quantity",
    "to_table",
    "vector",
]

T = TypeVar("T")

MISSING: Any = dataclasses.MISSING
_MISSING = MISSING


class CaseError(ValueError):
    """Invalid case input. ``str(err)`` is the one-line message for the user."""

    def __init__(self, key: str, value: object, problem: str, source: str | None = None):
        self.key = key
        self.value = value
        self.problem = problem
        self.source = source
        super().__init__(self._format())

    def _format(self) -> str:
        where = f"{self.source}: " if self.source else ""
        if self.value is _MISSING:
            return f"{where}{self.key}: {self.problem}"
        return f"{where}{self.key} = {_show(self.value)}: {self.problem}"

    def with_source(self, source: str) -> CaseError:
        return CaseError(self.key, self.value, self.problem, source)

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        # picklable (MPI broadcasts it), the MISSING sentinel included
        missing = self.value is _MISSING
        value = None if missing else self.value
        return (_rebuild_case_error, (self.key, value, missing, self.problem, self.source))


def _rebuild_case_error(
    key: str, value: object, missing: bool, problem: str, source: str | None
) -> CaseError:
    return CaseError(key, _MISSING if missing else value, problem, source)


def _show(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def quantity(
    default: Any = _MISSING,
    unit: str = "",
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    doc: str = "",
) -> Any:
    """A float field given in ``unit`` (SI), with optional bounds.

    The default may be written with its unit (``quantity("1 mm", "m")``); it
    is converted to SI here, once.
    """
    if isinstance(default, str):
        default = parse_quantity(default, unit)
    meta = {"unit": unit, "gt": gt, "ge": ge, "lt": lt, "le": le, "doc": doc}
    return dataclasses.field(default=default, metadata=meta)


def vector(
    default: Any = _MISSING,
    unit: str = "",
    *,
    length: int | None = 3,
    doc: str = "",
    nonzero: bool = False,
) -> Any:
    """A tuple-of-floats field (e.g. a position or direction)."""
    meta = {"unit": unit, "length": length, "doc": doc, "nonzero": nonzero}
    return dataclasses.field(default=default, metadata=meta)


def integer(
    default: Any = _MISSING,
    *,
    ge: int | None = None,
    le: int | None = None,
    doc: str = "",
) -> Any:
    """An integer field with optional inclusive bounds."""
    return dataclasses.field(default=default, metadata={"ge": ge, "le": le, "doc": doc})


def option(
    default: Any = _MISSING, choices: tuple[str, ...] | None = None, *, doc: str = ""
) -> Any:
    """A string field restricted to ``choices`` (or free when None)."""
    return dataclasses.field(default=default, metadata={"choices": choices, "doc": doc})


def flag(default: Any = _MISSING, *, doc: str = "") -> Any:
    """A boolean field (``true``/``false`` in TOML)."""
    return dataclasses.field(default=default, metadata={"doc": doc})


def check_keys(table: Mapping[str, Any], allowed: typing.Iterable[str], where: str) -> None:
    """Raise CaseError for the first key of ``table`` not in ``allowed``."""
    allowed = list(allowed)
    for key in table:
        if key not in allowed:
            raise CaseError(
                _join(where, key),
                table[key],
                "unknown key; allowed keys are " + ", ".join(sorted(allowed)),
            )


def _join(where: str, key: str) -> str:
    return f"{where}.{key}" if where else key


def _check_bounds(key: str, raw: object, value: float, meta: Mapping[str, Any], unit: str) -> None:
    u = f" {unit}" if unit else ""
    if meta.get("gt") is not None and not value > meta["gt"]:
        raise CaseError(key, raw, f"must be > {meta['gt']:g}{u}")
    if meta.get("ge") is not None and not value >= meta["ge"]:
        raise CaseError(key, raw, f"must be >= {meta['ge']:g}{u}")
    if meta.get("lt") is not None and not value < meta["lt"]:
        raise CaseError(key, raw, f"must be < {meta['lt']:g}{u}")
    if meta.get("le") is not None and not value <= meta["le"]:
        raise CaseError(key, raw, f"must be <= {meta['le']:g}{u}")


def _convert(tp: Any, raw: Any, key: str, meta: Mapping[str, Any]) -> Any:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    # X | None
    if origin in (typing.Union, types.UnionType):
        non_none = [a for a in args if a is not type(None)]
        if raw is None:
            return None
        if len(non_none) == 1:
            return _convert(non_none[0], raw, key, meta)
        # float | str style unions: try each
        errors = []
        for a in non_none:
            try:
                return _convert(a, raw, key, meta)
            except CaseError as err:
                errors.append(err.problem)
        raise CaseError(key, raw, " or ".join(errors))
    if dataclasses.is_dataclass(tp):
        if not isinstance(raw, Mapping):
            raise CaseError(key, raw, "must be a table")
        return from_table(tp, raw, key)  # type: ignore[arg-type]
    if tp is float:
        unit = meta.get("unit", "")
        try:
            value = parse_quantity(raw, unit)
        except UnitError as err:
            raise CaseError(key, raw, str(err)) from None
        _check_bounds(key, raw, value, meta, unit)
        return value
    if tp is bool:
        if not isinstance(raw, bool):
            raise CaseError(key, raw, "must be true or false")
        return raw
    if tp is int:
        if isinstance(raw, bool) or not isinstance(raw, int):
            raise CaseError(key, raw, "must be an integer")
        if meta.get("ge") is not None and raw < meta["ge"]:
            raise CaseError(key, raw, f"must be >= {meta['ge']}")
        if meta.get("le") is not None and raw > meta["le"]:
            raise CaseError(key, raw, f"must be <= {meta['le']}")
        return raw
    if tp is str:
        if not isinstance(raw, str):
            raise CaseError(key, raw, "must be a string")
        choices = meta.get("choices")
        if choices is not None and raw not in choices:
            raise CaseError(key, raw, "must be one of " + ", ".join(choices))
        return raw
    if origin is tuple:
        if not isinstance(raw, list | tuple):
            raise CaseError(key, raw, "must be an array")
        item_tp = args[0]
        if dataclasses.is_dataclass(item_tp):
            items = []
            for i, item in enumerate(raw):
                if not isinstance(item, Mapping):
                    raise CaseError(f"{key}[{i}]", item, "must be a table")
                items.append(from_table(item_tp, item, f"{key}[{i}]"))  # type: ignore[arg-type]
            return tuple(items)
        length = meta.get("length")
        if length is not None and len(raw) != length:
            raise CaseError(key, raw, f"must have {length} components")
        out = tuple(_convert(item_tp, r, f"{key}[{i}]", meta) for i, r in enumerate(raw))
        if meta.get("nonzero") and all(v == 0 for v in out):
            raise CaseError(key, raw, "must not be the zero vector")
        return out
    if origin is dict:
        if not isinstance(raw, Mapping):
            raise CaseError(key, raw, "must be a table")
        for k, v in raw.items():
            if isinstance(v, Mapping | list):
                raise CaseError(_join(key, k), v, "must be a string, number or boolean")
        return dict(raw)
    raise TypeError(f"config: unsupported field type {tp!r} for {key}")  # programming error


def from_table[T](cls: type[T], table: Mapping[str, Any], where: str = "") -> T:
    """Build dataclass ``cls`` from a TOML table, validating every key.

    Args:
        cls: a frozen dataclass whose fields use this module's metadata.
        table: the parsed TOML table.
        where: dotted key path of the table, for messages (``"robot"``).

    Raises:
        CaseError: unknown key, missing key, wrong type, unit or range.
    """
    hook = getattr(cls, "__from_table__", None)
    if hook is not None:
        return typing.cast(T, hook(table, where))
    return build_fields(cls, table, where)


def build_fields[T](cls: type[T], table: Mapping[str, Any], where: str, **fixed: Any) -> T:
    """The generic part of :func:`from_table` (callable from hooks).

    ``fixed`` holds values the caller already parsed (they bypass ``table``).
    """
    hints = typing.get_type_hints(cls)
    fields = [f for f in dataclasses.fields(cls) if f.init and _in_table(f)]  # type: ignore[arg-type]
    check_keys(table, [f.name for f in fields if f.name not in fixed], where)
    kwargs: dict[str, Any] = dict(fixed)
    for f in fields:
        if f.name in fixed:
            continue
        key = _join(where, f.name)
        if f.name in table:
            kwargs[f.name] = _convert(hints[f.name], table[f.name], key, f.metadata)
        elif f.default is _MISSING and f.default_factory is _MISSING:
            raise CaseError(key, _MISSING, "missing required key")
    try:
        return cls(**kwargs)
    except CaseError as err:
        # __post_init__ checks raise with keys relative to their own table
        key = err.key if not where or err.key.startswith(where + ".") else _join(where, err.key)
        raise CaseError(key, err.value, err.problem) from None


def not_in_table(default: Any = None, *, doc: str = "") -> Any:
    """A field that is no key of the table: set by code, never read from or written to TOML."""
    return dataclasses.field(default=default, compare=False, metadata={"table": False, "doc": doc})


def _in_table(f: dataclasses.Field[Any]) -> bool:
    return f.metadata.get("table", True) is not False


def to_table(obj: Any) -> Any:
    """Inverse of :func:`from_table`: plain TOML-serialisable data (SI numbers).

    A dataclass whose table is not its fields (e.g. ``[robot]``, flat keys of
    a nested shape object) writes it with a ``__to_table__()`` method.
    """
    hook = getattr(obj, "__to_table__", None)
    if hook is not None and not isinstance(obj, type):
        return hook()
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        # a table whose allowed keys depend on a discriminator (e.g. a waveform's
        # kind) lists the keys that apply via ``table_keys()``
        names = getattr(obj, "table_keys", None)
        keep = set(names()) if names is not None else None
        out = {}
        for f in dataclasses.fields(obj):
            if (keep is not None and f.name not in keep) or not _in_table(f):
                continue
            value = getattr(obj, f.name)
            if value is None:
                continue
            out[f.name] = to_table(value)
        return out
    if isinstance(obj, tuple | list):
        return [to_table(v) for v in obj]
    if isinstance(obj, dict):
        return {k: to_table(v) for k, v in obj.items()}
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    return obj
