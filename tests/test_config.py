"""The case-table validation engine on a small schema of its own."""

from dataclasses import dataclass, field

import pytest

from magfem.config import (
    CaseError,
    from_table,
    integer,
    option,
    quantity,
    to_table,
    vector,
)


@dataclass(frozen=True)
class Inner:
    gap: float = quantity("1 mm", "m", gt=0)


@dataclass(frozen=True)
class Outer:
    thickness: float = quantity(unit="m", gt=0, le=5e-3)
    layers: int = integer(1, ge=1, le=8)
    kind: str = option("hex", ("hex", "wedge"))
    direction: tuple[float, ...] = vector((0.0, 0.0, 1.0), "", nonzero=True)
    inner: Inner = field(default_factory=Inner)
    items: tuple[Inner, ...] = ()
    options: dict[str, object] = field(default_factory=dict)
    limit: float | None = quantity(None, "s", gt=0)
    flag: bool = False

    def __post_init__(self):
        if self.layers > 4 and self.kind == "wedge":
            raise CaseError("layers", self.layers, "at most 4 layers with wedges")


def test_defaults_units_and_nesting():
    out = from_table(
        Outer,
        {"thickness": "80 um", "items": [{"gap": "2 mm"}], "options": {"ksp_type": "preonly"}},
        "robot",
    )
    assert out.thickness == pytest.approx(80e-6)
    assert out.inner.gap == pytest.approx(1e-3)  # default string converted too
    assert out.items[0].gap == pytest.approx(2e-3)
    assert out.limit is None
    assert to_table(out)["items"] == [{"gap": pytest.approx(2e-3)}]


@pytest.mark.parametrize(
    ("table", "key", "problem"),
    [
        ({}, "robot.thickness", "missing required key"),
        ({"thickness": 1e-4, "colour": "red"}, "robot.colour", "unknown key"),
        ({"thickness": -1e-4}, "robot.thickness", "must be > 0"),
        ({"thickness": "1 cm"}, "robot.thickness", "must be <= 0.005"),
        ({"thickness": "80 T"}, "robot.thickness", "not a unit of m"),
        ({"thickness": 1e-4, "layers": 2.5}, "robot.layers", "must be an integer"),
        ({"thickness": 1e-4, "layers": 0}, "robot.layers", "must be >= 1"),
        ({"thickness": 1e-4, "kind": "tet"}, "robot.kind", "must be one of hex, wedge"),
        ({"thickness": 1e-4, "direction": [0, 0, 0]}, "robot.direction", "zero vector"),
        ({"thickness": 1e-4, "direction": [1, 0]}, "robot.direction", "3 components"),
        ({"thickness": 1e-4, "inner": 3}, "robot.inner", "must be a table"),
        ({"thickness": 1e-4, "items": [{"gap": 0}]}, "robot.items[0].gap", "must be > 0"),
        ({"thickness": 1e-4, "flag": "yes"}, "robot.flag", "true or false"),
        ({"thickness": 1e-4, "options": {"a": [1]}}, "robot.options.a", "string, number"),
        ({"thickness": 1e-4, "layers": 5, "kind": "wedge"}, "robot.layers", "at most 4"),
    ],
)
def test_errors_name_key_value_and_rule(table, key, problem):
    with pytest.raises(CaseError) as info:
        from_table(Outer, table, "robot")
    assert info.value.key == key
    assert problem in str(info.value)
    assert "\n" not in str(info.value)
