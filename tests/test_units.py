"""Quantity strings -> SI, and the dimension check."""

import math

import pytest

from magfem.units import UnitError, bare_numbers, parse_quantity


@pytest.mark.parametrize(
    ("text", "unit", "expected"),
    [
        ("80 um", "m", 80e-6),
        ("80 µm", "m", 80e-6),
        ("7.5mm", "m", 7.5e-3),
        ("2 mT", "T", 2e-3),
        ("20 G", "T", 2e-3),
        ("123 kA/m", "A/m", 123e3),
        ("115 kPa", "Pa", 115e3),
        ("4.9 MPa", "Pa", 4.9e6),
        ("2130 kg/m^3", "kg/m^3", 2130.0),
        ("2.13 g/cm^3", "kg/m^3", 2130.0),
        ("9.8 m/s^2", "m/s^2", 9.8),
        ("60 Hz", "Hz", 60.0),
        ("5 ms", "s", 5e-3),
        ("4.5 mH", "H", 4.5e-3),
        ("1 Ohm", "Ohm", 1.0),
        ("20 V", "V", 20.0),
        ("10 A", "A", 10.0),
        ("90 deg", "rad", math.pi / 2),
        ("1.3 T", "T", 1.3),
        ("1e-3", "T", 1e-3),
        (0.5, "", 0.5),
        (3, "m", 3.0),
    ],
)
def test_parse_quantity_converts_to_si(text, unit, expected):
    assert parse_quantity(text, unit) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(
    ("text", "unit", "message"),
    [
        ("2 mT", "m", "not a unit of m"),
        ("3 furlong", "m", "unknown unit"),
        ("abc", "m", "cannot read a number"),
        (True, "m", "boolean"),
        ([1, 2], "m", "expected a number"),
        (float("nan"), "m", "finite"),
    ],
)
def test_parse_quantity_rejects(text, unit, message):
    with pytest.raises(UnitError, match=message):
        parse_quantity(text, unit)


@pytest.mark.parametrize(
    ("text", "unit", "message"),
    [
        ("1 km^400", "m", "overflows"),
        ("1 mm^-999", "m", "overflows"),
        ("1 um^400", "m", "overflows or underflows"),
        ("1e999 mT", "T", "overflows"),
        ("1e-999 m", "m", "underflows"),
        ("1e-320 km", "m", None),  # subnormal but nonzero: a value, not an error
        (10**400, "m", "overflows"),
        (float("inf"), "m", "finite"),
    ],
)
def test_parse_quantity_rejects_overflow_and_underflow(text, unit, message):
    """Python raises OverflowError for 1000.0**400; every such case is a UnitError instead."""
    if message is None:
        assert parse_quantity(text, unit) > 0.0
        return
    with pytest.raises(UnitError, match=message):
        parse_quantity(text, unit)


def test_bare_numbers_are_si_or_errors_as_the_caller_says():
    assert parse_quantity(2, "T") == 2.0  # the default: code passes SI numbers
    with bare_numbers(False):
        for value in (2, 0.5, "2", "8e-5"):
            with pytest.raises(UnitError, match=r'needs a unit: write ".*T" if SI is meant'):
                parse_quantity(value, "T")
        assert parse_quantity(0, "T") == 0.0  # zero is zero in every unit
        assert parse_quantity("0", "m/s^2") == 0.0
        assert parse_quantity(0.5, "") == 0.5  # dimensionless
        assert parse_quantity(3, "rad") == 3.0  # radians are dimensionless
        assert parse_quantity("2 mT", "T") == pytest.approx(2e-3)
    assert parse_quantity(2, "T") == 2.0  # the block restored the default
