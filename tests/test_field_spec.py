"""The ``[field]`` table: bad input raises one CaseError naming key, value and what is allowed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.config import CaseError, from_table
from magfem.field.spec import FieldSpec
from magfem.field.waveforms import build_waveform

pytestmark = pytest.mark.serial  # pure validation, no MPI

MAGNET = {"kind": "cylinder_magnet", "center": [0, 0, -0.02]}
NEEDLE = {"kind": "needle", "tip": [0, 0, 0.0], "axis": [0, 0, 1]}


@pytest.mark.parametrize(
    ("table", "match"),
    [
        ({"model": "dipole"}, r"field.model = 'dipole': must be one of"),
        ({"sources": [{"kind": "halbach"}]}, r"sources\[0\].kind = 'halbach': unknown source"),
        ({"sources": [{"kind": "coil", "turns": 0, "current": 1}]}, r"sources\[0\].turns"),
        (
            {"sources": [{"kind": "coil", "inner_radius": "6 cm", "current": 1}]},
            r"sources\[0\].inner_radius",
        ),
        ({"sources": [{"kind": "coil"}]}, r"sources\[0\].current"),
        (
            {
                "sources": [
                    {"kind": "coil_pair", "current": 1},
                    {"kind": "cylinder_magnet", "center": [0.04, 0, 0.035]},
                ]
            },
            "winding",
        ),
        (
            {"sources": [{"kind": "uniform", "flux_density": 1e-3, "direction": [0, 0, 0]}]},
            r"sources\[0\].direction",
        ),
        ({"sources": [{"kind": "uniform", "flux_density": 1e-3, "radius": 1}]}, "allowed keys"),
        (
            {"sources": [{"kind": "uniform", "flux_density": 1e-3, "waveform": {"kind": "x"}}]},
            r"sources\[0\].waveform.kind",
        ),
        ({"iron": [{"kind": "cube"}]}, r"iron\[0\].kind = 'cube': unknown iron kind"),
        ({"iron": [{"kind": "sphere", "permeability": 0.5}]}, r"iron\[0\].permeability = 0.5"),
        ({"iron": [{"kind": "sphere", "saturation": "-1 T"}]}, r"iron\[0\].saturation"),
        ({"iron": [{"kind": "sphere", "tip": [0, 0, 0]}]}, r"iron\[0\].tip = .*allowed keys"),
        ({"iron": [{"kind": "needle", "tip_radius": "2 mm"}]}, r"iron\[0\].tip_radius"),
        ({"iron": [{"kind": "tweezers", "spread": "1 mm"}]}, r"iron\[0\].spread"),
        (
            {"sources": [MAGNET], "iron": [{"kind": "sphere", "center": [0, 0, -0.02]}]},
            r"iron\[0\] = 'sphere': overlaps the source sources\[0\]",
        ),
        ({"sources": [MAGNET | {"motion": "go"}]}, r"sources\[0\].motion = 'go': unknown motion"),
        (
            {"motions": [{"name": "a", "times": [0, 0], "offsets": [[0, 0, 0], [0, 0, 1]]}]},
            r"motions\[0\].times",
        ),
        (
            {"motions": [{"name": "a", "times": [0, 1], "offsets": [[0, 0, 0]]}]},
            r"motions\[0\].offsets.*one entry per time",
        ),
        (
            {"motions": [{"name": "a", "times": [0, 1], "offsets": [[0, 0], [0, 0]]}]},
            r"motions\[0\].offsets.*list of \[x, y, z\]",
        ),
        ({"motions": [{"name": "a", "times": [0, 1]}]}, r"motions\[0\].offsets: give offsets"),
        (
            {"motions": [{"name": "a", "times": [0], "angles": [0]}] * 2},
            r"motions\[1\].name = 'a': motion names must be unique",
        ),
        (
            {
                "sources": [MAGNET | {"motion": "a"}],
                "iron": [NEEDLE],
                "motions": [{"name": "a", "times": [0], "angles": [0]}],
            },
            r"sources\[0\].motion = 'a': the iron moves with motion ''",
        ),
        (
            {
                "sources": [{"kind": "uniform", "flux_density": 1e-3}],
                "iron": [NEEDLE | {"motion": "a"}],
                "motions": [{"name": "a", "times": [0], "angles": [0]}],
            },
            r"sources\[0\].kind = 'uniform': a uniform source acting on moving iron",
        ),
        (
            {
                "sources": [MAGNET | {"waveform": {"kind": "sine", "frequency": 5}}],
                "iron": [NEEDLE | {"saturation": "2 T"}],
            },
            r"sources\[0\].waveform = 'sine': nonlinear iron",
        ),
        ({"solve": {"geometry": "2d"}}, r"field.solve.geometry = '2d': must be one of"),
    ],
)
def test_bad_field_input(table, match):
    with pytest.raises(CaseError, match=match):
        from_table(FieldSpec, table, "field")


def test_good_field_input():
    # a magnet in the bore of a coil, moving iron with its magnet, nonlinear iron on a square wave
    from_table(FieldSpec, {"sources": [{"kind": "coil", "current": 1}, MAGNET]}, "field")
    spec = from_table(
        FieldSpec,
        {
            "sources": [MAGNET | {"motion": "a", "waveform": {"kind": "square", "frequency": 5}}],
            "iron": [NEEDLE | {"motion": "a", "saturation": "2 T"}],
            "motions": [
                {"name": "a", "times": ["0 s", "1 s"], "offsets": [[0, 0, 0], [0, 0, "1 mm"]]}
            ],
        },
        "field",
    )
    assert spec.motions[0].offsets[1] == (0.0, 0.0, 1e-3)
    assert spec.motion("a") is spec.motions[0] and spec.motion("") is None


def _uniform(flux: str, direction: list[float], waveform: dict) -> dict:
    return {"kind": "uniform", "flux_density": flux, "direction": direction, "waveform": waveform}


SQUARE = {"kind": "square", "frequency": "2 Hz"}


@pytest.mark.parametrize(
    ("sources", "scale"),
    [
        # two square waves in quadrature (the propeller): |B| is 2 mT at every instant
        (
            [
                _uniform("1.414 mT", [0, 1, 0], SQUARE),
                _uniform("1.414 mT", [0, 0, 1], SQUARE | {"phase": "90 deg"}),
            ],
            1.0,
        ),
        # a DC bias along a unipolar square wave: the two add when the square is on
        (
            [
                _uniform("3 mT", [0, 0, 1], {}),
                _uniform("4 mT", [0, 0, 1], SQUARE | {"bipolar": False}),
            ],
            1.0,
        ),
        # a bias of 3 mT along z and a bipolar 4 mT along x: 5 mT
        (
            [
                _uniform("3 mT", [0, 0, 1], {}),
                _uniform("4 mT", [1, 0, 0], SQUARE | {"amplitude": -1}),
            ],
            1.0,
        ),
        # the flower's trigger, then its drive: never on together, so they do not add (3 mT;
        # added they would give 4.46 mT); a DC from 0.3 s overlaps the drive and adds
        (
            [
                _uniform("2 mT", [1, 1, 1], {"kind": "trigger", "duration": "0.1 s"}),
                _uniform("3 mT", [0, 0, 1], SQUARE | {"start": "0.1 s"}),
            ],
            1.0,
        ),
        (
            [
                _uniform("2 mT", [1, 1, 1], {"kind": "trigger", "duration": "0.1 s"}),
                _uniform("3 mT", [0, 0, 1], SQUARE | {"start": "0.1 s"}),
                _uniform("1 mT", [1, 0, 0], {"start": "0.3 s"}),
            ],
            1.0,
        ),
        # a rotating field of sines in quadrature: |B| = 1 mT, the bound sqrt(2) too large
        (
            [
                _uniform("1 mT", [1, 0, 0], {"kind": "sine", "frequency": "5 Hz"}),
                _uniform(
                    "1 mT", [0, 1, 0], {"kind": "sine", "frequency": "5 Hz", "phase": "90 deg"}
                ),
            ],
            math.sqrt(2.0),
        ),
    ],
)
def test_nominal_flux_bound_is_the_largest_field_the_sources_give(sources, scale):
    """The bound against |B(t)| of the waveforms sampled over a period (and its switches)."""
    spec = from_table(FieldSpec, {"sources": sources}, "field")
    t = np.linspace(0.0, 0.5, 20001)
    total = sum(
        np.outer(build_waveform(s.waveform).value(t), s.flux_density * s.unit_direction)
        for s in spec.sources
    )
    largest = float(np.max(np.linalg.norm(total, axis=1)))
    # the square waves' plateaus and the rotating field's constant |B| are sampled exactly:
    # the tolerance is round-off's
    assert spec.nominal_flux_bound() == pytest.approx(scale * largest, rel=1e-6)
