"""docs/case_reference.md is generated from the case tables and kept current."""

from __future__ import annotations

import dataclasses
import typing

import pytest

from magfem.case import Case
from magfem.casedoc import _quantity, build_reference, main
from magfem.field.source_spec import SourceSpec
from magfem.geometry.spec import SHAPES
from magfem.study import Study
from magfem.units import parse_quantity


def test_committed_reference_is_current(repo):
    committed = (repo / "docs" / "case_reference.md").read_text(encoding="utf-8")
    assert committed == build_reference(), (
        "docs/case_reference.md is out of date: run python -m magfem.casedoc"
    )


def _tables(cls):
    """Every dataclass reachable from ``cls`` through its fields."""
    yield cls
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        for tp in (hints[f.name], *typing.get_args(hints[f.name])):
            if dataclasses.is_dataclass(tp):
                yield from _tables(tp)


def _subclasses(cls):
    for sub in cls.__subclasses__():
        yield sub
        yield from _subclasses(sub)


def test_every_key_of_every_table_is_listed():
    text = build_reference()
    classes = {*_tables(Case), *SHAPES.values(), *_subclasses(SourceSpec), Study}
    missing = [
        f"{cls.__name__}.{f.name}"
        for cls in classes
        for f in dataclasses.fields(cls)
        if f.init and f.metadata.get("table", True) and f.metadata and f"| `{f.name}` |" not in text
    ]
    assert not missing
    for shape in SHAPES:
        assert f'### `[robot]` shape = `"{shape}"`' in text


@pytest.mark.parametrize(
    ("value", "unit", "text"),
    [
        (1e-3, "m", "1 mm"),
        (80e-6, "m", "80 um"),
        (2.5e-4, "s", "250 us"),
        (115e3, "Pa", "115 kPa"),
        (4.5e-3, "H", "4.5 mH"),
        (2130.0, "kg/m^3", "2130 kg/m^3"),
        (0.0, "m", "0 m"),
        (0.5, "", "0.5"),
        (1e-12, "N", "1e-12 N"),
    ],
)
def test_defaults_are_case_file_strings_of_the_same_value(value, unit, text):
    assert _quantity(value, unit) == text
    assert parse_quantity(text, unit) == pytest.approx(value, rel=1e-12)


def test_check_fails_on_a_stale_page_and_passes_once_written(tmp_path):
    page = tmp_path / "case_reference.md"
    page.write_text("stale\n", encoding="utf-8")
    assert main(["--check", "--out", str(page)]) == 1
    assert main(["--out", str(page)]) == 0
    assert main(["--check", "--out", str(page)]) == 0
