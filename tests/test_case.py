"""Case files: loading, overrides, the resolved case, and bad input.

Every bad input must give exactly one line on stderr that names the file and
the offending key (or the file itself), and exit status 2, with no traceback.
"""

from __future__ import annotations

import copy
import subprocess
import sys
import tomllib
from pathlib import Path

import dolfinx
import pytest
import tomli_w

import magfem
from magfem.case import (
    Case,
    apply_overrides,
    load_case,
    load_field_case,
    parse_case,
    write_resolved_case,
)
from magfem.cli import main
from magfem.config import CaseError
from magfem.provenance import provenance

BASE: dict = {
    "name": "probe",
    "robot": {"shape": "trapezoid", "thickness": "80 um", "length": "7.5 mm"},
    "mesh": {"size": "0.5 mm"},
    "material": {"shear_modulus": "115 kPa", "density": "2130 kg/m^3", "remanence": "123 kA/m"},
    "field": {
        "sources": [
            {
                "kind": "uniform",
                "flux_density": "2 mT",
                "direction": [1, 0, 0],
                "waveform": {"kind": "square", "frequency": "20 Hz"},
            }
        ]
    },
    "time": {"end": "100 ms", "step": "0.25 ms"},
}


def _write(directory: Path, data: dict | str, name: str = "case.toml") -> Path:
    path = directory / name
    path.write_text(data if isinstance(data, str) else tomli_w.dumps(data), encoding="utf-8")
    return path


def _mutate(edit) -> dict:
    data = copy.deepcopy(BASE)
    edit(data)
    return data


def _set(path: str, value):
    def edit(data):
        node = data
        parts = path.split(".")
        for p in parts[:-1]:
            node = node[int(p)] if isinstance(node, list) else node.setdefault(p, {})
        node[parts[-1]] = value

    return edit


def _drop(path: str):
    def edit(data):
        node = data
        parts = path.split(".")
        for p in parts[:-1]:
            node = node[int(p)] if isinstance(node, list) else node[p]
        del node[parts[-1]]

    return edit


# (id, case content, key the message must name, words the message must contain)
BAD_INPUTS = [
    ("unknown-top-key", _mutate(_set("colour", "red")), "colour", "unknown key"),
    ("unknown-robot-key", _mutate(_set("robot.colour", "red")), "robot.colour", "unknown key"),
    ("other-shapes-key", _mutate(_set("robot.petals", 5)), "robot.petals", "unknown key"),
    ("missing-name", _mutate(_drop("name")), "name", "missing"),
    ("missing-robot", _mutate(_drop("robot")), "robot", "missing"),
    ("missing-thickness", _mutate(_drop("robot.thickness")), "robot.thickness", "missing"),
    (
        "missing-shear-modulus",
        _mutate(_drop("material.shear_modulus")),
        "material.shear_modulus",
        "missing",
    ),
    ("wrong-type-thickness", _mutate(_set("robot.thickness", [1, 2])), "robot.thickness", "number"),
    ("wrong-type-table", _mutate(_set("mesh", 3)), "mesh", "must be a table"),
    ("negative-thickness", _mutate(_set("robot.thickness", "-80 um")), "robot.thickness", ">"),
    (
        "unknown-unit",
        _mutate(_set("robot.thickness", "80 furlong")),
        "robot.thickness",
        "unknown unit",
    ),
    (
        "incompatible-unit",
        _mutate(_set("robot.thickness", "80 mT")),
        "robot.thickness",
        "not a unit of m",
    ),
    ("unknown-shape", _mutate(_set("robot.shape", "octopus")), "robot.shape", "trapezoid"),
    (
        "square-frequency-zero",
        _mutate(_set("field.sources.0.waveform.frequency", "0 Hz")),
        "field.sources[0].waveform.frequency",
        "> 0",
    ),
    (
        "square-frequency-missing",
        _mutate(_drop("field.sources.0.waveform.frequency")),
        "field.sources[0].waveform.frequency",
        "required",
    ),
    (
        "mesh-larger-than-robot",
        _mutate(_set("mesh.size", "5 mm")),
        "mesh.size",
        "smallest in-plane",
    ),
    (
        "strip-for-star",
        _mutate(
            lambda d: d.update(
                robot={"shape": "star", "thickness": "80 um"},
                mesh={"size": "0.5 mm", "model": "strip"},
            )
        ),
        "mesh.model",
        "uniform-width",
    ),
    (
        "unknown-waveform",
        _mutate(_set("field.sources.0.waveform.kind", "sawtooth")),
        "waveform.kind",
        "square",
    ),
    (
        "unknown-source",
        _mutate(_set("field.sources.0.kind", "dipole")),
        "field.sources[0].kind",
        "coil",
    ),
    (
        "zero-direction",
        _mutate(_set("field.sources.0.direction", [0, 0, 0])),
        "direction",
        "zero vector",
    ),
    ("layers-not-int", _mutate(_set("mesh.layers", 1.5)), "mesh.layers", "integer"),
    ("layers-zero", _mutate(_set("mesh.layers", 0)), "mesh.layers", ">= 1"),
    ("bad-mesh-model", _mutate(_set("mesh.model", "shell")), "mesh.model", "solid"),
    ("negative-density", _mutate(_set("material.density", "-1 kg/m^3")), "material.density", "> 0"),
    (
        "bare-flux-density",
        _mutate(_set("field.sources.0.flux_density", 2)),
        "field.sources[0].flux_density",
        "needs a unit",
    ),
    ("bare-string-number", _mutate(_set("robot.thickness", "8e-5")), "robot.thickness", "unit"),
    ("unit-overflow", _mutate(_set("robot.thickness", "1 km^400")), "robot.thickness", "overflow"),
    ("unit-underflow", _mutate(_set("robot.length", "1 mm^-999")), "robot.length", "overflow"),
    ("value-overflow", _mutate(_set("field.sources.0.flux_density", "1e999 mT")), "flux", "finite"),
    ("value-underflow", _mutate(_set("robot.thickness", "1e-999 m")), "thickness", "underflow"),
    ("toml-infinity", _mutate(_set("time.end", float("inf"))), "time.end", "finite"),
    ("name-escapes", _mutate(_set("name", "../x")), "name", "plain file name"),
    ("name-absolute", _mutate(_set("name", "/tmp/x")), "name", "plain file name"),
    ("units-not-si", _mutate(_set("units", "mm")), "units", '"SI"'),
    ("rho-inf-above-one", _mutate(_set("time.rho_inf", 1.5)), "time.rho_inf", "<= 1"),
    ("end-time-zero", _mutate(_set("time.end", "0 s")), "time.end", "> 0"),
    (
        "clamp-longer-than-arm",
        _mutate(_set("robot.clamp_length", "9 mm")),
        "robot.clamp_length",
        "< length",
    ),
    ("bool-as-string", _mutate(_set("contact.ground", "yes")), "contact.ground", "true or false"),
    ("empty-name", _mutate(_set("name", " ")), "name", "non-empty"),
    ("empty-file", "", "(file)", "empty"),
    ("toml-syntax", "name = 'x'\n[robot\nshape = 1\n", "(file)", "TOML syntax error"),
]


@pytest.mark.parametrize(
    ("content", "key", "words"), [b[1:] for b in BAD_INPUTS], ids=[b[0] for b in BAD_INPUTS]
)
def test_bad_input_gives_one_line_and_exit_2(shared_tmp, comm, capsys, content, key, words):
    path = _write(shared_tmp, content)
    status = main(["check", str(path)])
    err = capsys.readouterr().err
    assert status == 2
    if comm.rank == 0:
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        assert lines[0].startswith(f"magfem: error: {path}: ")
        assert key in lines[0]
        assert words in lines[0]
        assert "Traceback" not in err
    else:
        assert err == ""  # only rank 0 prints


def test_at_least_twenty_kinds_of_bad_input():
    assert len(BAD_INPUTS) >= 20


def test_missing_case_file(shared_tmp, comm, capsys):
    status = main(["check", str(shared_tmp / "nope.toml")])
    err = capsys.readouterr().err
    assert status == 2
    if comm.rank == 0:
        assert "no such case file" in err and err.count("\n") == 1


@pytest.mark.serial
@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_console_script_prints_no_traceback(tmp_path):
    """The installed entry point, in a fresh interpreter, as a user runs it."""
    path = _write(tmp_path, _mutate(_set("robot.thickness", "-1 mm")))
    proc = subprocess.run(
        [sys.executable, "-m", "magfem", "check", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "robot.thickness" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_valid_case_units_are_si():
    case = parse_case(BASE)
    assert isinstance(case, Case)
    assert case.robot.thickness == pytest.approx(80e-6, rel=1e-12)
    assert case.material.shear_modulus == pytest.approx(115e3)
    assert case.field.sources[0].waveform.frequency == pytest.approx(20.0)
    assert case.time.step == pytest.approx(2.5e-4)


def test_overrides_apply_before_validation():
    data = apply_overrides(BASE, ["field.sources.0.waveform.frequency=50Hz", "mesh.layers=2"])
    case = parse_case(data)
    assert case.field.sources[0].waveform.frequency == pytest.approx(50.0)
    assert case.mesh.layers == 2
    assert BASE["mesh"].get("layers") is None  # the input is not modified
    with pytest.raises(CaseError, match="expected KEY=VALUE"):
        apply_overrides(BASE, ["mesh.layers"])


def test_resolved_case_round_trips(shared_tmp, comm):
    """The resolved case says units = "SI" (its bare numbers are SI) and carries the versions
    in [provenance], which reading it back ignores."""
    case = parse_case(BASE)
    path = shared_tmp / "resolved.toml"
    if comm.rank == 0:
        write_resolved_case(case, path, provenance=provenance())
    comm.barrier()
    assert load_case(path) == case
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    assert data["units"] == "SI"
    assert data["robot"]["thickness"] == case.robot.thickness  # a bare SI number
    info = data["provenance"]
    assert info["magfem"] == magfem.__version__
    assert info["dolfinx"] == dolfinx.__version__ and info["petsc"].count(".") == 2
    assert "git_commit" in info


def test_bare_numbers_need_units_in_files_but_not_in_code(shared_tmp, comm):
    """A case file with a bare number for a dimensional key is refused unless it says
    units = "SI"; a table built in code is SI."""
    data = copy.deepcopy(BASE)
    data["robot"]["thickness"] = 8e-5
    assert parse_case(data).robot.thickness == 8e-5
    path = _write(shared_tmp, data, "bare.toml") if comm.rank == 0 else shared_tmp / "bare.toml"
    comm.barrier()
    with pytest.raises(CaseError, match=r"robot\.thickness = 8e-05: a quantity in m needs a unit"):
        load_case(path)
    assert load_case(path, ["units=SI"]).robot.thickness == 8e-5
    clean = _write(shared_tmp, BASE, "clean.toml") if comm.rank == 0 else shared_tmp / "clean.toml"
    comm.barrier()
    with pytest.raises(CaseError, match=r"time\.end = 0\.05: .*needs a unit"):
        load_case(clean, ["time.end=0.05"])  # --set takes units too
    assert load_case(clean, ["time.end=50ms"]).time.end == pytest.approx(0.05)


def test_every_shipped_case_is_valid_and_round_trips(repo, shared_tmp, comm):
    cases = sorted((repo / "cases").glob("*.toml"))
    assert cases, "the case library is empty"
    for i, path in enumerate(cases):
        case = load_field_case(path)  # a Case, or a field-only FieldCase (no [robot])
        out = shared_tmp / f"{i}.toml"
        if comm.rank == 0:
            write_resolved_case(case, out)
        comm.barrier()
        assert load_field_case(out) == case, path.name
