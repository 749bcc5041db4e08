"""The command line: check and mesh on a small case (serial and mpirun -n 2)."""

from __future__ import annotations

import meshio
import tomli_w

from magfem.cli import main

CASE = {
    "name": "cli_probe",
    "robot": {"shape": "rectangle", "thickness": "100 um", "length": "4 mm", "width": "1 mm"},
    "mesh": {"size": "0.5 mm"},
    "material": {"shear_modulus": "115 kPa", "density": "2130 kg/m^3"},
}


def _case_file(directory):
    path = directory / "cli_probe.toml"
    if not path.exists():
        path.write_text(tomli_w.dumps(CASE))
    return path


def test_check_reports_ok(shared_tmp, comm, capsys):
    path = _case_file(shared_tmp)
    comm.barrier()
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    if comm.rank == 0:
        assert out.strip().endswith(f"{path}: OK")
        assert "rectangle, thickness 100 um" in out
        assert "magnetoelastic length" not in out  # no field, no magnetisation: no length


def test_check_accepts_a_field_only_case_and_still_rejects_bad_keys(repo, shared_tmp, comm, capsys):
    """A case without [robot] is what magfem field needs: check says so; its keys are checked."""
    assert main(["check", str(repo / "cases" / "tweezers_field.toml")]) == 0
    out = capsys.readouterr().out
    if comm.rank == 0:
        assert "2 source(s) and iron part(s); no [robot]: field only" in out
    bad = shared_tmp / "field_only_bad.toml"
    if comm.rank == 0:
        bad.write_text(tomli_w.dumps({"name": "f", "field": {"model": "spline"}}))
    comm.barrier()
    assert main(["check", str(bad)]) == 2


def test_check_reports_the_magnetoelastic_length(shared_tmp, comm, capsys):
    """ℓ = t √(E/(12 M B)) and the elements per ℓ, here 100 µm at 2 mT: 1.08 mm, 0.5 mm mesh."""
    case = CASE | {
        "material": CASE["material"] | {"remanence": "123 kA/m"},
        "field": {"sources": [{"kind": "uniform", "flux_density": "2 mT", "direction": [1, 0, 0]}]},
    }
    path = shared_tmp / "cli_probe_field.toml"
    if comm.rank == 0:
        path.write_text(tomli_w.dumps(case))
    comm.barrier()
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    if comm.rank == 0:
        assert "magnetoelastic length 1.08 mm at 2 mT: 2.2 element(s) per length" in out
    else:
        assert out == ""


def test_mesh_writes_msh_with_named_groups(shared_tmp, comm, capsys):
    path = _case_file(shared_tmp)
    comm.barrier()
    assert main(["mesh", str(path), "--out", str(shared_tmp)]) == 0
    out = capsys.readouterr().out
    msh = shared_tmp / "cli_probe.msh"
    if comm.rank == 0:
        assert f"wrote     {msh}" in out
        m = meshio.read(msh)
        # 4 mm x 1 mm at 0.5 mm, one layer of hexahedra: 8 x 2 cells
        assert sum(len(b.data) for b in m.cells if b.type == "hexahedron") == 16
        for name in ("arm", "bottom", "clamp", "tip", "top"):
            assert name in m.field_data, name
            assert f"{name}" in out


def test_sweep_paired_lists_must_have_equal_lengths(shared_tmp, comm, capsys):
    """--paired reaches the sweep: unequal lists are refused before any run."""
    path = _case_file(shared_tmp)
    comm.barrier()
    argv = ["sweep", str(path), "--paired", "--out", str(shared_tmp / "sw")]
    argv += ["--param", "mesh.size=0.5mm,0.25mm", "--param", "time.end=1ms"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    if comm.rank == 0:
        assert err.count("\n") == 1 and err.startswith("magfem: error:")
