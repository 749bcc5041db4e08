"""The rod's adequacy (``magfem check``) and ``[mesh] model = "auto"`` (magfem.accuracy)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from magfem.accuracy import SLENDERNESS, WIDTH_PER_BEND_LENGTH, resolve_model, rod_adequacy
from magfem.case import load_case
from magfem.cli import main
from magfem.material import magnetoelastic_length
from verification import setups as vc

DEFAULT_CASE = Path(__file__).parents[1] / "cases" / "one_arm_trapezoid.toml"


def narrow_case(width: float, model: str = "auto"):
    """The elastica's cantilever (6.5 mm free, 7.5 mm in all) in the default drive (2 mT)."""
    return vc.cantilever_case(model, 0.25e-3, width, "strain", field=vc.DRIVE)


def test_narrow_arm_takes_the_rod():
    """0.25 mm × 7.5 mm at 2 mT: L/b = 30, b/ℓ = 0.29 (ℓ = 0.86 mm): the rod (§6 of the docs)."""
    case = narrow_case(0.25e-3)
    assert rod_adequacy(case).adequate
    resolved, why = resolve_model(case)
    assert resolved.mesh.model == "rod"
    assert why is not None and "auto: rod" in why


def test_width_against_bend_length_decides():
    """Just below and above WIDTH_PER_BEND_LENGTH ℓ (slender either way)."""
    mat = narrow_case(1e-3).material
    ell = magnetoelastic_length(mat.shear_modulus, mat.bulk, vc.THICKNESS, mat.remanence, 2e-3)
    limit = WIDTH_PER_BEND_LENGTH * ell
    assert vc.LENGTH / (1.05 * limit) > SLENDERNESS
    assert rod_adequacy(narrow_case(0.95 * limit)).adequate
    verdict = rod_adequacy(narrow_case(1.05 * limit))
    assert not verdict.adequate and "magnetoelastic length" in verdict.reason


def test_default_trapezoid_takes_the_shell():
    """4 → 2 mm × 7.5 mm: length/width 1.9, not slender; auto gives the shell."""
    case = load_case(DEFAULT_CASE)
    verdict = rod_adequacy(case)
    assert not verdict.adequate and "not slender" in verdict.reason
    assert resolve_model(case) == (case, None)  # the file says solid: nothing is chosen
    auto = dataclasses.replace(case, mesh=dataclasses.replace(case.mesh, model="auto"))
    assert resolve_model(auto)[0].mesh.model == "surface"


@pytest.mark.serial  # only rank 0 prints
def test_rod_line_in_check(capsys):
    """``magfem check`` says whether the rod is adequate, and why."""
    assert main(["check", str(DEFAULT_CASE)]) == 0
    out = capsys.readouterr().out
    assert "rod       not adequate: arm: length/width 1.88" in out
