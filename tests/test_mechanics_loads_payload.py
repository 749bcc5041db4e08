"""The payload load (``[[loads]] kind = "payload"``): its weight and inertia on a cell group.

A free 4 × 2 mm², 50 µm plate in water carries a payload of mass m_p on its
whole body, displacing m_f of water. Released from rest, Newton's law of
the plate with the water's added mass m_a per area and its buoyancy gives
the uniform initial acceleration (closed form)

    a₀ = [(ρ_s − ρ) h A + (m_p − m_f)] g / (ρ_s h A + m_a A + m_p),

which the consistent initial acceleration must reproduce: the payload's
inertia enters it through :meth:`magfem.mechanics.loads.base.Load.inertia`.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.case import parse_case
from magfem.config import CaseError
from magfem.pipeline import build_simulation
from verification import fluid_references as fr

RHO_S, RHO_W, H, AREA = 2130.0, 998.2, 50e-6, 8e-6  # kg/m³, kg/m³, m, m²


def _case(model: str, payload: dict, time: dict | None = None):
    return parse_case(
        {
            "name": "payload",
            "robot": {"shape": "membrane", "thickness": H, "length": "4 mm", "width": "2 mm"},
            "mesh": {"size": "1 mm", "model": model},
            "material": {"shear_modulus": "115 kPa", "density": RHO_S},
            "environment": {"clamped": []},
            "time": time or {"end": 1e-3, "step": 1e-3},
            "fluid": {"medium": "water", "swim_direction": [0, 0, -1]},
            "loads": [{"kind": "payload", **payload}],
            "output": {"csv": False, "vtx_every": 0, "plot": False, "animation": False},
        }
    )


M_P, M_F = 2e-6, 0.5e-6  # kg: about twice the plate's 0.85 mg
M_A = math.pi / 4 * RHO_W * 2e-3  # kg/m², the chord is the width, 2 mm
LOAD = ((RHO_S - RHO_W) * H * AREA + (M_P - M_F)) * 9.8  # N
INERTIA = RHO_S * H * AREA + M_A * AREA + M_P  # kg


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_payload_weighs_and_resists_acceleration(comm):
    payload = {"mass": M_P, "group": "body", "displaced_mass": M_F}
    sim = build_simulation(_case("surface", payload), comm)
    sim.initialise()
    expected = -LOAD / INERTIA
    vertical = sim.integrator.a0.x.array.reshape(-1, 3)[:, 2]
    local = np.abs(vertical - expected).max() if vertical.size else 0.0
    # exact up to round-off; without the payload's inertia a0 would be 2.2 times larger
    assert comm.allreduce(local, op=max) < 1e-9 * abs(expected)


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_strip_with_payload_falls_with_the_reference(comm):
    """The 2D strip: weight and payload in its section, added mass on its faces (the first
    steps damp a thickness mode); after 2 ms it falls as the settling ODE of the whole."""
    payload = {"mass": M_P, "group": "body", "displaced_mass": M_F}
    time = {"end": 2e-3, "step": 1e-4, "adaptive": False}
    history = build_simulation(_case("strip", payload, time), comm).run(progress=False).history
    reference = fr.settling_velocity(
        history["time"],
        load=LOAD / AREA,
        inertia=INERTIA / AREA,
        density=RHO_W,
        viscosity=1.002e-3,
        chord=2e-3,
    )
    # measured -3e-5 (drag is 0.5 % of the load at 2 ms, in the reference as in the model)
    assert history["swim_speed"][-1] == pytest.approx(reference[-1], rel=2e-3)


def test_payload_on_an_unknown_group_names_the_key(comm):
    with pytest.raises(CaseError, match=r"loads\.group = 'deck': no such cell group"):
        build_simulation(_case("surface", {"mass": "1 mg", "group": "deck"}), comm)


def test_payload_mass_is_validated():
    with pytest.raises(CaseError, match=r"loads\[0\]\.mass = '-1 mg': must be > 0"):
        _case("surface", {"mass": "-1 mg", "group": "body"})
