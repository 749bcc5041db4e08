"""The rigid cargo (``[[contacts]] kind = "cargo"``): its dynamics and its coupling to the robot.

* A free plate thrown at a free cube (no gravity) passes it momentum: the
  staggered coupling applies to the cube exactly the impulse the plate's
  step received, so with the midpoint rule the total momentum of plate and
  cube is conserved to round-off.
* A cube resting on its floor carries its weight there at the Winkler
  law's closed-form indentation; a cube resting on a held plate is *held*:
  the plate carries its weight.
* Bad cargo tables give one-line errors naming the key.
"""

from __future__ import annotations

import numpy as np
import pytest

from magfem.case import parse_case
from magfem.config import CaseError
from magfem.mechanics.contacts.penalty import penalty_penetration
from magfem.pipeline import build_simulation

NO_OUTPUT = {"csv": False, "vtx_every": 0, "plot": False, "animation": False}
PLATE = {"shape": "membrane", "thickness": 1e-4, "length": "2 mm", "width": "2 mm"}


def _case(cargo: dict, environment: dict, time: dict, **tables):
    return parse_case(
        {
            "name": "cargo",
            "robot": tables.pop("robot", PLATE),
            "mesh": {"size": "0.5 mm", "model": "surface"},
            "material": {"shear_modulus": "115 kPa", "density": 2130},
            "environment": environment,
            "contacts": [{"kind": "cargo", "name": "foam", **cargo}],
            "time": time,
            "output": NO_OUTPUT,
            **tables,
        }
    )


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_plate_and_cargo_exchange_momentum(comm):
    cube = {
        "shape": "box",
        "center": [0.3e-3, 0, 1.2e-3],
        "size": [2e-3, 2e-3, 2e-3],
        "density": 300,
        "modulus": "5 kPa",
    }
    case = _case(
        cube,
        {"gravity": [0, 0, 0], "clamped": []},
        {"end": 0.005, "step": 1e-4, "adaptive": False, "rho_inf": 1.0},
        initial={"velocity": [0, 0, 0.05]},
        solver={"rtol": 1e-12, "atol": 1e-20},
    )
    sim = build_simulation(case, comm)
    h = sim.run(progress=False).history
    cargo = sim.problem.contacts[0]
    mass = cargo.body.mass
    total = np.vstack([h[f"momentum_{a}"] + mass * h[f"cargo_foam_v{a}"] for a in "xyz"])
    # the cube (2.4e-6 kg) takes most of the plate's momentum (8.5e-7 kg at 5 cm/s); the
    # coupling is stable here: k_n × area × Δt²/m = 0.08
    assert h["cargo_foam_vz"][-1] > 0.01
    assert h["cargo_foam_held"].max() == 1.0  # touched (no gravity: held = in contact)
    assert np.max(np.abs(total - total[:, :1])) < 1e-12 * abs(total[2, 0])
    assert not sim.log or all("staggered" not in line for line in sim.log)


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_cargo_rests_on_its_floor_at_the_winkler_indentation(comm):
    size, rho, modulus = 2e-3, 300.0, 5e3
    cube = {
        "shape": "box",
        "center": [0, 0, 5e-3],  # well above the plate (clamped at z = 0)
        "size": [size] * 3,
        "density": rho,
        "modulus": modulus,
        "floor": 4e-3,
    }
    case = _case(
        cube,
        {"gravity": [0, 0, -9.8], "clamped": ["robot"]},
        {"end": 0.03, "step": 1e-3, "adaptive": False},
    )
    sim = build_simulation(case, comm)
    h = sim.run(progress=False).history
    cargo = sim.problem.contacts[0]
    weight = cargo.body.mass * 9.8
    # the floor carries the weight once the drop of the penalty's onset has been damped
    assert h["cargo_foam_floor"][-1] == pytest.approx(weight, rel=1e-6)
    assert h["cargo_foam_held"][-1] == 0.0
    # indentation: the penalty law with k_n = E/depth (depth = size/2) under p = ρ g size
    expected = penalty_penetration(rho * 9.8 * size, modulus / (size / 2), cargo.law.onset)
    sink = 4e-3 - (h["cargo_foam_z"][-1] - size / 2)
    assert sink == pytest.approx(expected, rel=1e-6)


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_cargo_on_a_held_plate_is_held(comm):
    cube = {
        "shape": "box",
        "center": [0, 0, 1e-4 + 1e-3],  # just above the plate's top face
        "size": [2e-3, 2e-3, 2e-3],
        "density": 300,
        "modulus": "1 kPa",
        "floor": -5e-3,
    }
    robot = PLATE | {"length": "4 mm", "width": "4 mm"}
    # the staggered coupling is stable for k_n × area × Δt²/m = 5e5 × 4e-6 × 2.5e-7 / 2.4e-6
    # = 0.2 < 1; the cube bobs at 2π/√(k_n A/m) = 5 ms, damped at ~0.6 of critical
    case = _case(
        cube,
        {"gravity": [0, 0, -9.8], "clamped": ["robot"]},
        {"end": 0.025, "step": 5e-4, "adaptive": False},
        robot=robot,
    )
    sim = build_simulation(case, comm)
    h = sim.run(progress=False).history
    weight = sim.problem.contacts[0].body.mass * 9.8
    assert h["cargo_foam_fz"][-1] == pytest.approx(weight, rel=1e-4)  # the plate pushes up
    assert h["cargo_foam_held"][-1] == 1.0 and h["cargo_foam_floor"][-1] == 0.0
    summary = sim.summary(h)
    assert summary["cargo_foam_held_time"] > 0.0


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"shape": "box", "center": [0, 0, 0], "density": 30, "modulus": 1e4}, r"size: is req"),
        (
            {
                "shape": "sphere",
                "center": [0, 0, 0],
                "density": 30,
                "modulus": 1e4,
                "size": [1, 1, 1],
            },
            r"radius: is required",
        ),
        (
            {"shape": "sphere", "center": [0, 0, 0], "radius": 1e-3, "density": -1, "modulus": 1e4},
            r"density .*> 0",
        ),
        (
            {
                "shape": "sphere",
                "center": [0, 0, 0],
                "radius": 1e-3,
                "density": 30,
                "modulus": 1e4,
                "floor_motion": {"times": [0, 1], "positions": [[0, 0, 0], [0, 0, 1]]},
            },
            r"floor_motion .*needs a floor",
        ),
        ({"shape": "cube", "center": [0, 0, 0]}, r"shape = 'cube'"),
    ],
)
def test_bad_cargo_tables_name_the_key(table, message):
    with pytest.raises(CaseError, match=message):
        _case(table, {"clamped": []}, {"end": 0.01})
