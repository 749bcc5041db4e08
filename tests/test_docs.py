"""The documentation names only files, tests and benchmarks that exist."""

from __future__ import annotations

import re

import pytest

PATH = re.compile(r"\b((?:benchmarks|cases|docs|magfem|tests|verification)/[\w./*-]*[\w*])(::\w+)?")
MODULE = re.compile(r"python -m (benchmarks\.\w+|magfem\.\w+(?:\.\w+)*)")
# Paths that the docs name as outputs or as examples of files a user adds.
NOT_IN_REPOSITORY = {"cases/studies/self-clean-10hz.toml"}


def _pages(repo):
    return [repo / "README.md", *sorted((repo / "docs").glob("*.md"))]


@pytest.mark.parametrize("name", ["README.md", "docs"])
def test_named_files_and_tests_exist(repo, name):
    pages = [p for p in _pages(repo) if p.name == name or p.parent.name == name]
    missing = []
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for match in PATH.finditer(text):
            path, test = match.group(1), match.group(2)
            if path in NOT_IN_REPOSITORY:
                continue
            target = repo / path
            if "*" in path:
                if not list(repo.glob(path)):
                    missing.append(f"{page.name}: {path}")
            elif not target.exists():
                missing.append(f"{page.name}: {path}")
            elif test and f"def {test[2:]}(" not in target.read_text(encoding="utf-8"):
                missing.append(f"{page.name}: {path}{test}")
        for module in MODULE.findall(text):
            if not (repo / (module.replace(".", "/") + ".py")).is_file():
                missing.append(f"{page.name}: python -m {module}")
    assert missing == []
