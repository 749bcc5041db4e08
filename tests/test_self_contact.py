"""Arm–arm (self) contact through the full time loop, serial and mpirun -n 2.

Two blocks, L × H = 1 × 0.2 mm side views (plane-strain strips, one mesh,
cell groups ``lower`` and ``upper``), μ = 115 kPa, ρ = 2130 kg/m³, touch
through the two-pass penalty of :mod:`magfem.mechanics.self_contact`
(k_c = κ_s μ / H):

* Pressed: the lower block is clamped at its base, the upper one rests on
  it under a body force G. The faces interpenetrate by the static
  penetration of the penalty ramp under the pressure p = ρ G H,
  δ = r⁻¹(p/k_c) (:func:`reference.penalty_penetration`), and the contact
  force equals the upper block's weight.
* Bouncing: the free blocks fly towards each other at ±v across a gap d
  (no gravity, no friction, ρ∞ = 1). The observable reports the first
  touch at the free-flight time d/(2v); kinetic + elastic + penalty energy
  is conserved through the impact and the blocks separate with their
  speeds reversed (identical blocks: elastic impact).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from mpi4py import MPI

from magfem.case import parse_case
from magfem.config import CaseError
from magfem.geometry.gmshio import build_mesh
from magfem.geometry.robot_mesh import RobotMesh
from magfem.mechanics import MembraneSimulation
from magfem.mechanics import reference as ref

L, H, SIZE, MU, RHO, WIDTH = 1e-3, 2e-4, 1e-4, 115e3, 2130.0, 1e-3


def _blocks(comm: MPI.Comm, gap: float) -> RobotMesh:
    """Two L × H quadrilateral blocks, one above the other ``gap`` apart (strip, gdim 2)."""

    def builder(gmsh: Any) -> None:
        occ = gmsh.model.occ
        lower = occ.addRectangle(0.0, 0.0, 0.0, L, H)
        upper = occ.addRectangle(0.0, H + gap, 0.0, L, H)
        occ.synchronize()

        def horizontal(block: int, height: float) -> int:
            for _, tag in gmsh.model.getBoundary([(2, block)], oriented=False):
                _, y0, _, _, y1, _ = gmsh.model.getBoundingBox(1, tag)  # OCC pads by ~1e-7
                if y1 - y0 < 1e-6 and abs(0.5 * (y0 + y1) - height) < 1e-6:
                    return int(tag)
            raise RuntimeError(f"no horizontal side at {height}")

        lines = {
            "clamp": horizontal(lower, 0.0),
            "lower_top": horizontal(lower, H),
            "upper_bottom": horizontal(upper, H + gap),
        }
        for name, tag in (("lower", lower), ("upper", upper)):
            gmsh.model.addPhysicalGroup(2, [tag], name=name)
        for name, tag in lines.items():
            gmsh.model.addPhysicalGroup(1, [tag], name=name)
        gmsh.option.setNumber("Mesh.MeshSizeMax", SIZE)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(2)

    data = build_mesh(builder, comm, gdim=2, name="blocks")
    assert {"clamp", "lower_top", "upper_bottom"} <= set(data.physical_groups)
    return RobotMesh(
        mesh=data.mesh,
        cell_tags=data.cell_tags,
        facet_tags=data.facet_tags,
        groups={k: (int(v[0]), int(v[1])) for k, v in data.physical_groups.items()},
        arms=(),
        model="strip",
        thickness=H,
        min_quality=1.0,
        num_cells=0,
        area=2 * L * H,
    )


def _case(contact: dict[str, Any], environment: dict[str, Any], time: dict[str, Any]) -> Any:
    return parse_case(
        {
            "name": "blocks",
            "robot": {"shape": "membrane", "thickness": H, "length": L, "width": WIDTH},
            "mesh": {"size": SIZE, "model": "strip"},
            "material": {"shear_modulus": MU, "density": RHO, "remanence": 0.0},
            "contact": {
                "self_contact": True,
                "self_contact_groups": ["lower", "upper"],
                "self_contact_exclusion": 0.0,
                **contact,
            },
            "environment": environment,
            "time": {"adaptive": False, **time},
            "output": {"csv": False, "vtx_every": 0, "plot": False},
        }
    )


def test_bouncing_blocks_conserve_energy_and_touch_on_time(comm):
    gap, v, dt = 2e-5, 0.1, 1e-6
    case = _case(
        {},
        {"gravity": [0, 0, 0], "clamped": []},
        {"end": 2.5e-4, "step": dt, "rho_inf": 1.0, "scheme": "generalized_alpha"},
    )
    sim = MembraneSimulation(case, comm, robot_mesh=_blocks(comm, gap))
    middle = H + gap / 2
    sim.integrator.v0.interpolate(
        lambda X: np.vstack([np.zeros(X.shape[1]), np.where(X[1] < middle, v, -v)])
    )
    result = sim.run(None, progress=False)
    h = result.history
    e0 = 2 * 0.5 * RHO * L * H * WIDTH * v**2  # J, both blocks
    assert h["energy_total"][0] == pytest.approx(e0, rel=1e-9)
    touch = result.summary["first_touch_lower__upper"]
    # free flight closes the gap at t = d/(2v) exactly on a step boundary: the first step that
    # ends with the faces overlapping is the next one
    assert touch == pytest.approx(gap / (2 * v) + dt, rel=1e-6)
    # kinetic + elastic + penalty energy through the impact (ρ∞ = 1, 56 steps in contact):
    # measured max |ΔE|/E = 8.8e-3 during contact (the two-pass penalty energy of frozen master
    # data, unchanged at Δt/2: 8.5e-3) and 8.1e-4 after separation (7.5e-4 at Δt/2)
    drift = np.abs(h["energy_total"] / e0 - 1)
    assert np.max(drift) < 2e-2, np.max(drift)
    assert drift[-1] < 2e-3, drift[-1]
    assert h["self_contact_force"][-1] == 0.0  # separated again
    # interpenetration stays within the penalty's tolerance: the impact pressure of the
    # blocks (measured peak force 3.2 mN over 1 mm², 3.2 kPa) penetrates by
    # r⁻¹(p/k_c) = 3.4e-6 m; the largest nodal penetration measured 3.5e-6 m
    k_c = 10.0 * MU / H
    peak = h["self_contact_force"].max() / (L * WIDTH)
    expected = ref.penalty_penetration(peak, k_c, 0.05 * H)
    assert h["self_contact_penetration"].max() == pytest.approx(expected, rel=0.1)
    assert h["self_contact_penetration"].max() < 0.05 * H


def test_self_contact_needs_two_cell_groups(comm):
    case = _case(
        {"self_contact_groups": ["lower", "clamp"]},
        {"gravity": [0, 0, 0]},
        {"end": 1e-4, "step": 1e-4},
    )
    with pytest.raises(CaseError, match="not a cell group"):
        MembraneSimulation(case, comm, robot_mesh=_blocks(comm, 0.0))
