"""The largest nominal strain of the body and the energy density it stores.

* **Largest nominal strain** ε_a = max over the arm of (λ_max − 1), λ_max
  the largest principal stretch (√ of the largest eigenvalue of C = FᵀF),
  sampled at the vertices of every cell (where bending strains peak) except
  those within one thickness of the clamped facets: the edge where a bonded
  patch ends is a stress singularity, whose FE strain (16.6 % on the default
  case, against a bending strain t/(2R) of ~1 %) measures the mesh, not the
  arm (:class:`StrainProbe`).

Energy density ρE = 3 μ ε_a²/2 (:func:`magfem.material.energy_density`).
"""

from __future__ import annotations

from typing import Any

import basix
import numpy as np
import numpy.typing as npt
import ufl
from dolfinx import fem
from mpi4py import MPI
from scipy.spatial import cKDTree

from magfem import material
from magfem.mechanics.observers.base import Observer
from magfem.parallel import JIT_WAIT

__all__ = ["Strain", "StrainProbe"]


class StrainProbe:
    """Largest nominal strain max(λ_max − 1) at cell vertices away from the supports (collective).

    Args:
        u: displacement (m).
        exclude: (N, 3) reference points (m) of the supports (the vertices of
            the clamped facets), or None.
        radius: vertices within this distance (m) of an excluded point are not
            sampled.
        metrics: UFL right Cauchy–Green tensors (all of one shape) to sample
            instead of FᵀF of ``u``: the shell's two faces, whose strain adds
            the bending strain to the membrane's.

    The bonded patch ends in a re-entrant edge where the strain of the
    continuum is singular (its FE value grows as the mesh is refined and says
    nothing about the arm): on the default case it read 16.6 % while the
    bending strain t/(2R) of the arm is ~1 %. The simulation excludes the
    vertices within one thickness of the clamped facets, so ε_a measures the
    arm (bending plus stretching).
    """

    def __init__(
        self,
        u: fem.Function,
        exclude: npt.NDArray[np.float64] | None = None,
        radius: float = 0.0,
        metrics: list[Any] | None = None,
    ):
        domain = u.function_space.mesh
        self.comm = domain.comm
        self.domain = domain
        gdim = domain.geometry.dim
        cell = domain.topology.cell_type
        points = basix.geometry(getattr(basix.CellType, cell.name))
        if metrics is None:
            F = ufl.Identity(gdim) + ufl.grad(u)
            metrics = [F.T * F]
        self.dim = ufl.shape(metrics[0])[0]
        self.expr = fem.Expression(ufl.as_tensor(list(metrics)), points, jit_options=JIT_WAIT)
        n_local = domain.topology.index_map(domain.topology.dim).size_local
        self.cells = np.arange(n_local, dtype=np.int32)
        nv = len(points)
        # reference coordinates (cells, vertices, 3) of the sampled vertices (P1/P2 geometry:
        # the first nv geometry nodes of a cell are its vertices, in basix order)
        xyz = domain.geometry.x[domain.geometry.dofmaps[0][:n_local, :nv]]
        self.mask = np.ones((n_local, nv), dtype=bool)
        if exclude is not None and len(exclude) and radius > 0 and n_local:
            tree = cKDTree(np.asarray(exclude, dtype=float).reshape(-1, 3))
            dist, _ = tree.query(xyz.reshape(-1, 3))
            self.mask = (dist >= radius).reshape(n_local, nv)

    def __call__(self) -> float:
        """ε_a (dimensionless), identical on every rank (0 if every vertex is excluded)."""
        local = 0.0
        if self.cells.size and self.mask.any():
            C = np.asarray(self.expr.eval(self.domain, self.cells))
            n = len(self.mask.ravel())
            C = C.reshape(n, -1, self.dim, self.dim)[self.mask.ravel()].reshape(
                -1, self.dim, self.dim
            )
            lam_max = np.sqrt(np.max(np.linalg.eigvalsh(C), axis=1))
            local = float(np.max(lam_max)) - 1.0
        return float(self.comm.allreduce(local, op=MPI.MAX))


class Strain(Observer):
    """``strain`` (ε_a, dimensionless) and ``energy_density`` (J/m³) of :class:`StrainProbe`.

    Args:
        probe: the strain probe of the body.
        shear_modulus: μ (Pa).
    """

    def __init__(self, probe: StrainProbe, shear_modulus: float):
        self.probe = probe
        self.shear_modulus = shear_modulus

    def columns(self) -> list[str]:
        return ["strain", "energy_density"]

    def observe(self, t: float) -> dict[str, float]:
        strain = self.probe()
        return {
            "strain": strain,
            "energy_density": material.energy_density(self.shear_modulus, strain),
        }
