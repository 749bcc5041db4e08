"""``run_field`` (magfem field CASE): outputs exist and hold the solved field."""

from __future__ import annotations

import numpy as np

from magfem.case import parse_case
from magfem.field import analytic as an
from magfem.field.run import run_field

CASE = {
    "name": "field-output",
    "robot": {"shape": "rectangle", "length": "10 mm", "width": "2 mm", "thickness": "80 um"},
    "mesh": {"size": "1 mm"},
    "material": {"shear_modulus": "115 kPa", "density": "2130 kg/m^3", "remanence": "123 kA/m"},
    "field": {
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
        "solve": {"degree": 2, "mesh_size": "2 mm"},
    },
}


def test_run_field_writes_consistent_outputs(comm, shared_tmp):
    case = parse_case(CASE)
    written = run_field(case, shared_tmp / "out", comm)
    comm.barrier()
    for key in ("axis_csv", "workspace_csv", "models_csv", "png", "grid", "vtx_source1"):
        assert written[key].exists(), key
    assert written["png"].stat().st_size > 10_000
    data = np.loadtxt(written["workspace_csv"], delimiter=",", skiprows=1)
    assert data.shape == (9**3, 3 + 3 + 1 + 9)
    # the CSV holds uniform + coil at nominal strength; compare with the closed form
    ref = an.coil_field(np.array([0, 0, -0.01]), np.array([0, 0, 1.0]), 0.01, 0.02, 0.01, 100, 2.0)
    B = ref(data[:, :3]) + np.array([1e-3, 0, 0])
    # P2 on a 2 mm mesh: measured 2.3e-3 of max |B|; bound 5e-3
    assert np.abs(data[:, 3:6] - B).max() < 5e-3 * np.abs(B).max()
    np.testing.assert_allclose(data[:, 6], np.linalg.norm(data[:, 3:6], axis=1), rtol=1e-8)
    models = written["models_csv"].read_text().splitlines()
    assert models[0] == "model,B_error,gradB_error,chosen"
    assert sum(int(line.split(",")[-1]) for line in models[1:]) == 1  # exactly one chosen
