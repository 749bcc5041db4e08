"""Is a run reproducible bit for bit? The same case twice, and stopped and resumed, compared.

    mpirun -n 2 python -m benchmarks.reproducibility [--model surface] [--solver mumps]

The case is the strip cantilever of the checkpoint test (verification.setups.STRIP_CANTILEVER,
ground contact, 3 ms in 0.25 ms steps) on the chosen model (1 mm along, 2 mm across for the
shell and the solid). It is run twice, then a third time stopped after step 7 and resumed;
rank 0 prints, per history column that differs, the largest difference from the first run.
"""

from __future__ import annotations

import argparse
import copy
import itertools
import shutil
import signal

import numpy as np
from mpi4py import MPI

from magfem.case import parse_case
from magfem.errors import RunInterrupted
from magfem.parallel import rank0_print, shared_directory
from magfem.pipeline import simulate
from verification.setups import STRIP_CANTILEVER


def _case(model: str, solver: str):
    data = copy.deepcopy(STRIP_CANTILEVER)
    data["contact"] = {"ground": True}
    data["time"] = {"end": "3 ms", "step": "0.25 ms"}
    if model != "strip":
        data["mesh"] = {"model": model, "size": "1 mm", "size_across": "2 mm"}
    data["solver"] = {"linear_solver": solver}
    data["output"] = {"csv": True, "vtx_every": 0, "vtu_every": 0, "plot": False}
    data["output"] |= {"animation": False}
    return parse_case(data)


def _differences(label: str, first: dict, other: dict) -> None:
    worst = {
        k: float(np.max(np.abs(np.asarray(other[k]) - np.asarray(v)))) for k, v in first.items()
    }
    differ = {k: d for k, d in worst.items() if d != 0.0}
    rank0_print(f"{label}: {'identical' if not differ else f'{len(differ)} columns differ'}")
    for key, d in sorted(differ.items(), key=lambda kv: -kv[1])[:8]:
        rank0_print(f"    {key:24s} {d:.3e}   (largest |value| {np.max(np.abs(first[key])):.3e})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="surface", choices=("strip", "surface", "solid"))
    parser.add_argument("--solver", default="mumps", choices=("mumps", "superlu_dist", "petsc"))
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    case = _case(args.model, args.solver)
    root = shared_directory(comm, prefix="magfem-repro-")
    rank0_print(f"{args.model}, {args.solver}, {comm.size} rank(s)")
    first = simulate(case, root / "first", comm, progress=False).history
    again = simulate(case, root / "again", comm, progress=False).history
    _differences("run twice", first, again)
    calls = itertools.count(1)
    try:
        stop = lambda c: int(signal.SIGINT) * (next(calls) == 7)  # noqa: E731
        simulate(case, root / "cut", comm, progress=False, stop=stop)
    except RunInterrupted:
        pass
    comm.barrier()
    resumed = simulate(case, root / "cut", comm, progress=False, resume=True).history
    _differences("stopped after step 7 and resumed", first, resumed)
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
