"""Quantity strings -> SI, and the dimension check."""

import math

import pytest

from magfem.units import UnitError, parse_quantity


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
