"""The linear drag load (``[[loads]] kind = "drag"``) against the closed-form decay of a free plate.

A free plate (no field, no gravity, no support) moving normal to itself at
v₀, both faces in the fluid, obeys ρt v̇ = −2c v: v(t) = v₀ exp(−t/τ) with
τ = ρt/(2c), so its kinetic energy is E₀ exp(−2t/τ). The shell carries the
drag on its two faces, the solid on its ``top`` and ``bottom`` facet groups
(the edges left out, so that the drag area is exactly twice the outline's
on both models). The plate translates rigidly, so the only error is the
time integrator's, second order in Δt (generalized-α, ρ∞ = 1).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.case import parse_case
from magfem.config import CaseError
from magfem.pipeline import build_simulation

RHO, T, C = 2130.0, 1e-4, 0.1065  # kg/m³, m, Pa·s/m
TAU = RHO * T / (2 * C)  # 1 ms
V0 = 0.01  # m/s


def _case(model: str, dt: float, surfaces: list[str], **extra):
    return parse_case(
        {
            "name": "drag",
            "robot": {"shape": "membrane", "thickness": T, "length": "4 mm", "width": "2 mm"},
            "mesh": {"size": "1 mm", "model": model},
            "material": {"shear_modulus": "115 kPa", "density": RHO},
            "environment": {"gravity": [0, 0, 0], "clamped": []},
            "time": {"end": 2 * TAU, "step": dt, "adaptive": False, "rho_inf": 1.0},
            "loads": [{"kind": "drag", "coefficient": C, "surfaces": surfaces, **extra}],
            "output": {"csv": False, "vtx_every": 0, "plot": False, "animation": False},
        }
    )


def _energy_error(comm, model: str, surfaces: list[str], dt: float) -> float:
    sim = build_simulation(_case(model, dt, surfaces), comm)
    v0 = sim.integrator.parts[0].v0
    v0.x.array.reshape(-1, sim.gdim)[:, -1] = V0  # rigid translation along z
    history = sim.run(progress=False).history
    e0 = 0.5 * RHO * T * 8e-6 * V0**2  # J, plate 4 x 2 mm
    exact = e0 * np.exp(-2 * history["time"] / TAU)
    assert history["energy_kinetic"][0] == pytest.approx(e0, rel=1e-10)
    return float(np.max(np.abs(history["energy_kinetic"] - exact)) / e0)


@pytest.mark.parametrize(
    ("model", "surfaces"), [("surface", ["all"]), ("solid", ["top", "bottom"])]
)
@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_free_plate_slows_down_exponentially_at_second_order(comm, model, surfaces):
    coarse = _energy_error(comm, model, surfaces, TAU / 10)
    fine = _energy_error(comm, model, surfaces, TAU / 20)
    # the trapezoidal rule on v' = -v/τ loses (Δt/τ)³/12 of v per step, so v is off by
    # (t/τ)(Δt/τ)²/12 relative and E = E0 exp(-2t/τ) by twice that: largest at t = τ/2,
    # (Δt/τ)²/12 e⁻¹ = 3.07e-4 at Δt = τ/10 (measured 3.069e-4 on both models, 7.67e-5 at τ/20)
    expected = (0.1**2 / 12) * math.exp(-1)
    assert coarse == pytest.approx(expected, rel=0.02)
    assert coarse / fine == pytest.approx(4.0, rel=0.02)


@pytest.mark.parametrize(
    ("load", "key"),
    [
        ({"kind": "drag", "coefficient": "-1 Pa*s/m"}, r"loads\[0\]\.coefficient"),
        ({"kind": "drag", "coefficient": "1 mT"}, r"loads\[0\]\.coefficient"),
        ({"kind": "drag"}, r"loads\[0\]\.coefficient: missing"),
        ({"kind": "wind"}, r"loads\[0\]\.kind = 'wind': unknown load; loads are drag"),
        ({"coefficient": 1.0}, r"loads\[0\]\.kind: missing"),
    ],
)
def test_drag_keys_are_validated(load, key):
    data = {
        "name": "x",
        "robot": {"shape": "membrane", "thickness": T},
        "mesh": {"size": "1 mm"},
        "material": {"shear_modulus": 1e5, "density": RHO},
        "loads": [load],
    }
    with pytest.raises(CaseError, match=key):
        parse_case(data)


def test_unknown_face_names_the_key(comm):
    with pytest.raises(CaseError, match=r"contact\.surfaces"):
        build_simulation(_case("surface", 1e-4, ["side"]), comm)
