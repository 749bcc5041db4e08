"""Physical quantities written as strings in case files, converted once to SI.

A case file may say ``thickness = "80 um"``, ``B = "2 mT"`` or
``frequency = "60 Hz"``; inside magfem every number is SI (m, kg, s, A and
the derived T, Pa, Hz, A/m, ...). This module parses such strings and checks
that the unit has the dimension the key expects. It never guesses: a unit of
the wrong dimension is an error, and a bare number (``2``, or the string
``"2"``) for a quantity that has a dimension is either SI or an error, as
the caller says (:func:`bare_numbers`): case files must give units unless
they declare ``units = "SI"``; code that builds cases from SI numbers may
leave them bare. Zero needs no unit. Numbers and units whose value
overflows (``"1 km^400"``, ``"1e999 mT"``) or underflows to zero
(``"1e-999 m"``) are errors, as are non-finite numbers.

Grammar: ``<number> [<unit expression>]`` where a unit expression is a
product/quotient of units with optional SI prefix and integer power, e.g.
``kg/m^3``, ``m/s^2``, ``kA/m``, ``N*m``, ``1/s``. ``um`` and ``µm`` both
mean micrometre.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import re
from collections.abc import Iterator

__all__ = [
    "PREFIXES",
    "UNIT_SYMBOLS",
    "UNPREFIXED",
    "UnitError",
    "bare_numbers",
    "dimension_of",
    "parse_angle",
    "parse_quantity",
    "parse_unit",
]

# Dimension vector: exponents of (m, kg, s, A).
Dim = tuple[int, int, int, int]

_BASE: dict[str, tuple[float, Dim]] = {
    "m": (1.0, (1, 0, 0, 0)),
    "g": (1e-3, (0, 1, 0, 0)),
    "s": (1.0, (0, 0, 1, 0)),
    "A": (1.0, (0, 0, 0, 1)),
    "Hz": (1.0, (0, 0, -1, 0)),
    "N": (1.0, (1, 1, -2, 0)),
    "Pa": (1.0, (-1, 1, -2, 0)),
    "J": (1.0, (2, 1, -2, 0)),
    "W": (1.0, (2, 1, -3, 0)),
    "V": (1.0, (2, 1, -3, -1)),
    "Ohm": (1.0, (2, 1, -3, -2)),
    "ohm": (1.0, (2, 1, -3, -2)),
    "Ω": (1.0, (2, 1, -3, -2)),
    "H": (1.0, (2, 1, -2, -2)),
    "T": (1.0, (0, 1, -2, -1)),
    "G": (1e-4, (0, 1, -2, -1)),  # gauss
    "rad": (1.0, (0, 0, 0, 0)),
    "deg": (math.pi / 180.0, (0, 0, 0, 0)),
    "1": (1.0, (0, 0, 0, 0)),
    "%": (1e-2, (0, 0, 0, 0)),
    "min": (60.0, (0, 0, 1, 0)),
}
# Units that must not take a prefix (avoids "min" = milli-"in", "Gs" etc.).
_NO_PREFIX = {"deg", "1", "%", "min", "rad", "G"}

_PREFIX = {
    "G": 1e9,
    "M": 1e6,
    "k": 1e3,
    "c": 1e-2,
    "m": 1e-3,
    "u": 1e-6,
    "µ": 1e-6,
    "μ": 1e-6,
    "n": 1e-9,
    "p": 1e-12,
}

UNIT_SYMBOLS: tuple[str, ...] = tuple(_BASE)
"""The unit symbols a quantity string may use (``1`` is a plain number)."""
PREFIXES: tuple[str, ...] = tuple(_PREFIX)
"""SI prefixes, on every symbol but those of :data:`UNPREFIXED`."""
UNPREFIXED: tuple[str, ...] = tuple(sorted(_NO_PREFIX))

_ANGLE_UNIT = re.compile(r"[0-9.]\s*m?(deg|rad)\s*$")
_NUMBER = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*?)\s*$")
_FACTOR = re.compile(r"^([^\^]+?)(?:\^([+-]?\d+))?$")


class UnitError(ValueError):
    """A quantity string could not be parsed or has the wrong dimension."""


_BARE_IS_SI = contextvars.ContextVar("magfem_bare_numbers_are_si", default=True)


@contextlib.contextmanager
def bare_numbers(si: bool) -> Iterator[None]:
    """Within the block, bare numbers for dimensional quantities are SI (``si``) or errors."""
    token = _BARE_IS_SI.set(si)
    try:
        yield
    finally:
        _BARE_IS_SI.reset(token)


def _check_bare(number: float, unit: str) -> None:
    """A bare ``number`` for a quantity in ``unit``: accepted or an error (:func:`bare_numbers`)."""
    if _BARE_IS_SI.get() or number == 0.0 or not unit or parse_unit(unit)[1] == (0, 0, 0, 0):
        return
    raise UnitError(
        f'a quantity in {unit} needs a unit: write "{number:g} {unit}" if SI is meant '
        '(bare numbers are SI only in a case file that says units = "SI")'
    )


def _finite(value: float, number: float, text: object) -> float:
    if not math.isfinite(value):
        raise UnitError(f"{text!r} overflows (not a finite number)")
    if value == 0.0 and number != 0.0:
        raise UnitError(f"{text!r} underflows to 0")
    return value


def _lookup(symbol: str) -> tuple[float, Dim]:
    if symbol in _BASE:
        return _BASE[symbol]
    if len(symbol) > 1 and symbol[0] in _PREFIX:
        rest = symbol[1:]
        if rest in _BASE and rest not in _NO_PREFIX:
            scale, dim = _BASE[rest]
            return _PREFIX[symbol[0]] * scale, dim
    raise UnitError(f"unknown unit '{symbol}'")


def parse_unit(expr: str) -> tuple[float, Dim]:
    """Return (scale to SI, dimension) of a unit expression such as ``kg/m^3``."""
    expr = expr.replace("·", "*").replace(" ", "*").strip()
    if not expr:
        return 1.0, (0, 0, 0, 0)
    scale = 1.0
    dim = [0, 0, 0, 0]
    # split into factors keeping track of the operator before each one
    tokens = re.split(r"([*/])", expr)
    sign = 1
    for tok in tokens:
        if tok == "*":
            sign = 1
            continue
        if tok == "/":
            sign = -1
            continue
        if not tok:
            continue
        m = _FACTOR.match(tok)
        if m is None:
            raise UnitError(f"cannot read unit '{tok}'")
        s, d = _lookup(m.group(1))
        power = int(m.group(2) or 1) * sign
        try:
            scale *= s**power
        except OverflowError:
            raise UnitError(f"unit '{expr}' overflows") from None
        if not math.isfinite(scale) or scale == 0.0:
            raise UnitError(f"unit '{expr}' overflows or underflows")
        for i in range(4):
            dim[i] += d[i] * power
    return scale, (dim[0], dim[1], dim[2], dim[3])


def dimension_of(unit: str) -> Dim:
    """Dimension vector (m, kg, s, A) of a unit expression."""
    return parse_unit(unit)[1]


def parse_angle(value: object, *, largest: float = math.inf) -> float:
    """A positive angle written with its unit (``"1 deg"``, ``"0.02 rad"``, ``"5 mrad"``) in rad.

    Raises:
        UnitError: not a string, no angle unit, not > 0, or above ``largest`` (rad).
    """
    if not isinstance(value, str) or _ANGLE_UNIT.search(value) is None:
        raise UnitError('must be an angle with its unit, e.g. "1 deg"')
    angle = parse_quantity(value, "rad")
    if not 0.0 < angle <= largest:
        raise UnitError(f"must be > 0 deg and <= {math.degrees(largest):g} deg")
    return angle


def parse_quantity(value: object, unit: str) -> float:
    """Convert ``value`` (number or "<number> <unit>" string) to SI.

    Args:
        value: a float/int (SI) or a string like ``"80 um"``.
        unit: the SI unit the caller expects, e.g. ``"m"``, ``"T"``, ``"A/m"``;
            it fixes the dimension that ``value``'s unit must have.

    Returns:
        The value in SI units (finite).

    Raises:
        UnitError: unreadable number or unit, a unit of another dimension, a
            value that is not finite or overflows or underflows, or a bare
            number where units are required (:func:`bare_numbers`).
    """
    if isinstance(value, bool):
        raise UnitError(f"expected a number or a quantity in {unit}, got a boolean")
    if isinstance(value, int | float):
        try:
            number = float(value)
        except OverflowError:
            raise UnitError(f"{value!r} overflows (not a finite number)") from None
        if not math.isfinite(number):
            raise UnitError(f"expected a finite number, got {value}")
        _check_bare(number, unit)
        return number
    if not isinstance(value, str):
        raise UnitError(f"expected a number or a quantity string in {unit}")
    m = _NUMBER.match(value)
    if m is None:
        raise UnitError(f"cannot read a number in '{value}'")
    number = float(m.group(1))
    if number == 0.0 and re.search(r"[1-9]", m.group(1).split("e")[0].split("E")[0]):
        raise UnitError(f"{value!r} underflows to 0")
    given = m.group(2)
    if not given:  # a number written as a string is a bare number
        _check_bare(_finite(number, number, value), unit)
        return number
    scale, dim = parse_unit(given)
    want_scale, want_dim = parse_unit(unit)
    if dim != want_dim:
        raise UnitError(f"unit '{given or '(none)'}' is not a unit of {unit}")
    return _finite(number * scale / want_scale, number, value)
