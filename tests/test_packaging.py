"""Every third-party module the code imports is declared in pyproject.toml."""

from __future__ import annotations

import ast
import importlib.metadata
import re
import sys
import tomllib

import pytest

# Part of every dolfinx 0.11 install (the PyPI wheel dolfinx-solver-real bundles them, a
# conda-forge install brings them as its own packages): not declared on their own.
WITH_DOLFINX = {"dolfinx", "dolfinx_solver", "petsc4py"}
LOCAL = {"magfem", "verification", "benchmarks", "conftest", "test_mechanics_simulation"}


def _imports(paths):
    """Top-level names imported (absolutely) by the Python files under ``paths``."""
    names = set()
    for root in paths:
        for path in root.rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Import):
                    names |= {a.name.split(".")[0] for a in node.names}
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names.add(node.module.split(".")[0])
    return names - set(sys.stdlib_module_names) - LOCAL - WITH_DOLFINX


def _normalise(name):
    return re.sub(r"[-_.]+", "-", name).lower()


def _declared(requirements):
    return {_normalise(re.match(r"[A-Za-z0-9_.-]+", r).group(0)) for r in requirements}


OPTIONAL_PROVIDERS = {"elastica": ["pyelastica"]}
"""Modules of optional extras whose distribution has another name (they may not be installed)."""


def _undeclared(modules, declared):
    providers = OPTIONAL_PROVIDERS | importlib.metadata.packages_distributions()
    return sorted(
        m for m in modules if not {_normalise(d) for d in providers.get(m, [m])} & declared
    )


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_package_imports_are_runtime_dependencies(repo):
    """Or an optional extra's (imported where needed: tests/test_architecture.py's OPTIONAL)."""
    project = tomllib.loads((repo / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    runtime = _declared(project["dependencies"]) | _declared(
        project["optional-dependencies"]["cluster"]
    )
    package = _imports([repo / "magfem"])
    assert _undeclared(package, runtime) == []


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_test_and_benchmark_imports_are_declared(repo):
    project = tomllib.loads((repo / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    extras = project["optional-dependencies"]
    declared = _declared(project["dependencies"]) | _declared(extras["test"])
    declared |= _declared(extras["benchmarks"])  # optional benchmark dependencies
    dirs = [repo / d for d in ("tests", "benchmarks", "verification")]
    assert _undeclared(_imports(dirs), declared) == []
