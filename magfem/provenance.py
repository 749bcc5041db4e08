"""What produced a run: the versions of magfem and its stack, and the git commit.

:func:`provenance` is written into ``case.resolved.toml`` (table
``[provenance]``, ignored when the file is read back as a case) so that a
run's outputs say which code made them.
"""

from __future__ import annotations

import platform
import subprocess
from importlib import metadata
from pathlib import Path

import dolfinx
from petsc4py import PETSc

from magfem import __version__

__all__ = ["git_commit", "provenance"]


def git_commit(directory: Path | None = None) -> str:
    """The commit of the git work tree holding ``directory`` (default: magfem's source).

    Returns the full hash, with ``+modified`` when tracked files differ from
    it, or "" when the source is not in a git work tree (an installed wheel)
    or git is not available.
    """
    where = Path(directory) if directory is not None else Path(__file__).resolve().parent
    try:
        head = subprocess.run(
            ["git", "-C", str(where), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(where), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    return head + ("+modified" if dirty else "")


def _distribution_version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return ""


def provenance() -> dict[str, str]:
    """Versions of magfem, dolfinx, PETSc, Python and the git commit of magfem (strings)."""
    major, minor, patch = PETSc.Sys.getVersion()
    out = {
        "magfem": __version__,
        "dolfinx": dolfinx.__version__,
        "petsc": f"{major}.{minor}.{patch}",
        "python": platform.python_version(),
        "git_commit": git_commit(),
    }
    wheel = _distribution_version("dolfinx-solver-real")
    if wheel:
        out["dolfinx_solver_real"] = wheel
    return out
