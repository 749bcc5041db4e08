"""The package's shape: no import cycles, imports at module level, modules and functions small.

The layering itself (no stage imports one above it) is import-linter's
contract in pyproject.toml, checked by ``lint-imports`` in ``./dev test``.
"""

from __future__ import annotations

import ast

import grimp
import pytest

OPTIONAL = {
    "magfem/__init__.py": {"dolfinx_solver"},
    "magfem/sweep/engines.py": {"submitit"},
}
"""Imports allowed inside a function or a try block: optional dependencies, per file."""

MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 80
SIZE_REASON = "# size:"
"""A function longer than the limit must say why in a comment starting with this."""


def _cycles(graph: grimp.ImportGraph) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for root in sorted(graph.modules):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.find_modules_directly_imported_by(root))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append(
                        (child, iter(sorted(graph.find_modules_directly_imported_by(child))))
                    )
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    component.append(top)
                    if top == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_import_cycles():
    graph = grimp.build_graph("magfem")
    assert len(graph.modules) > 50
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_a_cycle():
    graph = grimp.ImportGraph()
    for name in ("p", "p.a", "p.b", "p.c"):
        graph.add_module(name)
    graph.add_import(importer="p.a", imported="p.b")
    graph.add_import(importer="p.b", imported="p.c")
    graph.add_import(importer="p.c", imported="p.a")
    assert _cycles(graph) == [["p.a", "p.b", "p.c"]]


def _nested_imports(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, module) of every import that is not at a module's top level."""
    top = set()
    for node in getattr(tree, "body", []):
        if isinstance(node, ast.Import | ast.ImportFrom):
            top.add(id(node))
        elif isinstance(node, ast.If):  # `if TYPE_CHECKING:` blocks
            top |= {id(n) for n in node.body if isinstance(n, ast.Import | ast.ImportFrom)}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import | ast.ImportFrom) and id(node) not in top:
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module]
            out += [(node.lineno, str(n).split(".")[0]) for n in names]
    return out


def test_imports_are_at_module_level(repo):
    found = []
    for path in sorted((repo / "magfem").rglob("*.py")):
        rel = path.relative_to(repo).as_posix()
        for line, module in _nested_imports(ast.parse(path.read_text(encoding="utf-8"))):
            if module not in OPTIONAL.get(rel, set()):
                found.append(f"{rel}:{line} imports {module}")
    assert found == []


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("import os\ndef f():\n    import sys\n", [(3, "sys")]),
        ("try:\n    import x\nexcept ImportError:\n    pass\n", [(2, "x")]),
        ("if TYPE_CHECKING:\n    from a import b\n", []),
    ],
)
def test_nested_import_finder(source, expected):
    assert _nested_imports(ast.parse(source)) == expected


def _long_functions(source: str, limit: int) -> list[tuple[int, str, int]]:
    """(line, name, length) of the functions over ``limit`` lines that give no size reason."""
    lines = source.splitlines()
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            length = (node.end_lineno or node.lineno) - node.lineno + 1
            body = lines[node.lineno - 1 : node.end_lineno]
            if length > limit and not any(SIZE_REASON in line for line in body):
                out.append((node.lineno, node.name, length))
    return out


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_modules_and_functions_are_small(repo):
    found = []
    for path in sorted((repo / "magfem").rglob("*.py")):
        rel = path.relative_to(repo).as_posix()
        source = path.read_text(encoding="utf-8")
        if len(source.splitlines()) > MAX_MODULE_LINES:
            found.append(f"{rel}: {len(source.splitlines())} lines")
        for line, name, length in _long_functions(source, MAX_FUNCTION_LINES):
            found.append(f"{rel}:{line} {name}: {length} lines")
    assert found == []


def test_the_size_check_finds_a_long_function():
    body = "".join(f"    x{i} = {i}\n" for i in range(10))
    assert _long_functions(f"def f():\n{body}", 8) == [(1, "f", 11)]
    assert _long_functions(f"def f():\n    {SIZE_REASON} a table\n{body}", 8) == []
    assert _long_functions(f"def f():\n{body}", 11) == []
