"""Fuzzing the case files of cases/: every mutation (a value of the wrong type, sign, unit,
size, a non-finite value, a missing or unknown key) is either a valid case or one line of
CaseError naming the key; never another exception (a traceback for the user).

In-process parses are cheap (~1 ms): a seeded sample of mutations of every case file; a few
go through the console script to check the exit status and the single line on stderr.
"""

from __future__ import annotations

import copy
import math
import random
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import tomli_w

from magfem.case import parse_case
from magfem.config import CaseError
from magfem.sanity import implausible

REPO = Path(__file__).resolve().parents[1]
CASES = sorted((REPO / "cases").glob("*.toml"))
PER_CASE = 100  # mutations per case file (13 files: 1300 parses, ~4 s)


def _leaves(tree: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(tree, list) and tree and all(isinstance(v, dict) for v in tree):
        for i, v in enumerate(tree):
            yield from _leaves(v, (*path, i))
    else:
        yield path


def _mutations(value: Any) -> list[Any]:
    """Wrong type, sign, unit, size and non-finite versions of ``value``."""
    out: list[Any] = [[1, 2], {"a": 1}, True, "", "text", math.nan, math.inf, -1]
    if isinstance(value, str) and value[:1].isdigit():
        number, _, unit = value.partition(" ")
        out += [f"-{value}", f"{number} kg", f"{number} furlong", f"1e999 {unit}"]
        out += [f"1e-999 {unit}", f"nan {unit}", f"inf {unit}", f"1 {unit}^400", number]
    elif isinstance(value, int | float) and not isinstance(value, bool):
        out += [-value, 1e308 * 10, -1e300, 0, 0.5]
    return out


def _set(data: dict[str, Any], path: tuple[Any, ...], value: Any) -> None:
    node: Any = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value


def _delete(data: dict[str, Any], path: tuple[Any, ...]) -> None:
    node: Any = data
    for key in path[:-1]:
        node = node[key]
    del node[path[-1]]


def _sample(case: Path) -> Iterator[tuple[str, dict[str, Any]]]:
    original = tomllib.loads(case.read_text(encoding="utf-8"))
    rng = random.Random(case.name)  # the same sample on every run and every rank
    leaves = list(_leaves(original))
    for _ in range(PER_CASE):
        path = rng.choice(leaves)
        data = copy.deepcopy(original)
        kind = rng.random()
        if kind < 0.1:
            _delete(data, path)
            yield f"del {path}", data
        elif kind < 0.15:
            _set(data, (*path[:-1], "nonsense_key"), 1)
            yield f"{path[:-1]}.nonsense_key", data
        else:
            node: Any = original
            for key in path:
                node = node[key]
            value = rng.choice(_mutations(node))
            _set(data, path, value)
            yield f"{path} = {value!r}", data


@pytest.mark.parametrize("case", CASES, ids=[c.stem for c in CASES])
def test_mutated_case_files_are_valid_or_one_line_errors(case):
    errors = 0
    for what, data in _sample(case):
        try:
            parsed = parse_case(data, require_units=True)
        except CaseError as err:
            errors += 1
            text = str(err)
            assert "\n" not in text and 0 < len(text) < 500, (what, text)
            continue
        except Exception as err:  # the bug this test is for: a traceback for the user
            pytest.fail(f"{case.name}: {what}: {type(err).__name__}: {err}")
        for line in implausible(parsed):  # warnings of a valid case do not fail either
            assert "\n" not in line
    assert errors > PER_CASE // 3  # most mutations are errors: the sample mutates something


@pytest.mark.slow
@pytest.mark.serial
def test_mutated_case_files_fail_through_the_console_script_with_one_line(tmp_path):
    """Two mutations through ``magfem check`` (a process each, ~6 s): status 2, one line."""
    original = tomllib.loads((REPO / "cases" / "two_arm_20hz.toml").read_text(encoding="utf-8"))
    mutations = [("robot", "thickness", "nan um"), ("mesh", "size", [1, 2])]
    magfem = str(Path(sys.executable).parent / "magfem")
    for table, key, value in mutations:
        data = copy.deepcopy(original)
        data[table][key] = value
        path = tmp_path / f"{table}_{key}.toml"
        path.write_text(tomli_w.dumps(data), encoding="utf-8")
        done = subprocess.run([magfem, "check", str(path)], capture_output=True, text=True)
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 2, (key, done.stderr)
        assert len(lines) == 1 and lines[0].startswith(f"magfem: error: {path}: {table}.{key}")
        assert "Traceback" not in done.stderr
