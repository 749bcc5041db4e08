"""``magfem field CASE``: outputs exist and hold the field; cases without ``[robot]`` work."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
import tomli_w

from magfem.case import Case, FieldCase, parse_field_case
from magfem.cli import main
from magfem.config import CaseError, from_table
from magfem.field import analytic as an
from magfem.field.run import run_field
from magfem.field.spec import FieldSpec
from magfem.plot import source_grids
from verification.field_references import thick_coil_by_loops

FIELD = {
    "workspace_size": "10 mm",
    "sources": [
        {"kind": "uniform", "flux_density": "1 mT", "direction": [1, 0, 0]},
        {
            "kind": "coil",
            "current": "2 A",
            "inner_radius": "10 mm",
            "outer_radius": "20 mm",
            "length": "10 mm",
            "turns": 100,
            "center": [0, 0, -0.01],
            "waveform": {"kind": "square", "frequency": "20 Hz"},
        },
    ],
}


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_run_field_writes_consistent_outputs(comm, shared_tmp):
    case = parse_field_case({"name": "field-output", "field": FIELD})
    written = run_field(case, shared_tmp / "out", comm)
    comm.barrier()
    for key in ("axis_csv", "workspace_csv", "models_csv", "png", "grid"):
        assert written[key].exists(), key
    assert written["png"].stat().st_size > 10_000
    data = np.loadtxt(written["workspace_csv"], delimiter=",", skiprows=1)
    assert data.shape == (9**3, 3 + 3 + 1 + 9)
    # uniform + coil at nominal strength against a 2D loop sum over the winding (independent)
    p = data[:, :3] - [0, 0, -0.01]
    rho = np.hypot(p[:, 0], p[:, 1])
    br, bz = thick_coil_by_loops(0.01, 0.02, 0.01, 100, 2.0, rho, p[:, 2], n=64)
    safe = np.where(rho > 0, rho, 1.0)
    B = np.column_stack([br * p[:, 0] / safe + 1e-3, br * p[:, 1] / safe, bz])
    # exact closed form, written with 10 significant digits: measured 1.1e-10 of max |B|
    assert np.abs(data[:, 3:6] - B).max() < 1e-9 * np.abs(B).max()
    np.testing.assert_allclose(data[:, 6], np.linalg.norm(data[:, 3:6], axis=1), rtol=1e-8)
    models = written["models_csv"].read_text().splitlines()
    assert models[0] == "model,B_error,gradB_error,chosen"
    assert sum(int(line.split(",")[-1]) for line in models[1:]) == 1  # exactly one chosen


SPHERE_CASE = {
    "name": "iron-sphere",
    "field": {
        "workspace_size": "6 mm",
        "expansion_point": [0, 0, "10 mm"],
        "sources": [{"kind": "uniform", "flux_density": "1 mT", "direction": [0, 0, 1]}],
        "iron": [{"kind": "sphere", "radius": "5 mm", "permeability": 1000}],
        "motions": [],
    },
}


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_field_command_without_robot_table(comm, shared_tmp, capsys):
    path = shared_tmp / "sphere.toml"
    if comm.rank == 0:
        path.write_text(tomli_w.dumps(SPHERE_CASE))
    comm.barrier()
    out = shared_tmp / "out"
    assert main(["field", str(path), "--out", str(out)]) == 0
    comm.barrier()
    text = capsys.readouterr().out
    if comm.rank == 0:
        assert "iron reaction to source0: (r, z)" in text
        assert (out / "case.resolved.toml").exists() and (out / "iron_reaction0.bp").exists()
    data = np.loadtxt(out / "field_axis.csv", delimiter=",", skiprows=1)
    above = data[data[:, 2] > 0.0055]  # on the axis above the sphere: B0 + the dipole
    m = 4 * math.pi * 0.005**3 / an.MU0 * 999 / 1002 * 1e-3
    ref = 1e-3 + an.MU0 * m / (2 * math.pi * above[:, 2] ** 3)
    assert np.abs(above[:, 5] - ref).max() < 2e-4 * 3e-3  # measured 4e-5 of the pole's 3 mT


def test_field_command_reports_bad_iron_input(comm, shared_tmp, capsys):
    path = shared_tmp / "bad.toml"
    bad = {"name": "bad", "field": {"iron": [{"kind": "sphere", "permeability": 0.5}]}}
    if comm.rank == 0:
        path.write_text(tomli_w.dumps(bad))
    comm.barrier()
    assert main(["field", str(path)]) == 2
    err = capsys.readouterr().err
    if comm.rank == 0:
        assert "field.iron[0].permeability = 0.5: must be >= 1" in err
        assert err.count("\n") == 1


def test_source_grids_draw_iron_parts():
    spec = from_table(
        FieldSpec,
        {
            "iron": [
                {"kind": "tweezers", "tip": [0, 0, 0.004]},
                {"kind": "rod", "center": [0.02, 0, 0]},
            ]
        },
        "field",
    )
    items = source_grids(spec.sources, spec.iron)
    assert [i.label for i in items] == ["iron 0 (tweezers)", "iron 1 (rod)"]
    for item, part in zip(items, spec.iron, strict=True):
        pts = part.sample_points()
        b = np.array(item.grid.bounds).reshape(3, 2)
        np.testing.assert_allclose(b[:, 0], pts.min(axis=0), atol=1e-4)  # rod ring: 8 samples
        np.testing.assert_allclose(b[:, 1], pts.max(axis=0), atol=1e-4)


@pytest.mark.serial
def test_field_case_with_and_without_robot(repo):
    full = parse_field_case(tomllib.loads((repo / "cases" / "one_arm_trapezoid.toml").read_text()))
    assert isinstance(full, Case)  # with [robot]: the whole case, validated as by magfem run
    only = parse_field_case({"name": "f", "field": FIELD, "mesh": {"size": "1 mm"}})
    assert isinstance(only, FieldCase) and len(only.field.sources) == 2
    with pytest.raises(CaseError, match=r"mesh\.size"):  # tables present are still validated
        parse_field_case({"name": "f", "field": FIELD, "mesh": {"size": "-1 mm"}})
