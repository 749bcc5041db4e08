"""Sweep points: the ``--param`` grammar, the points' product or pairing, their stable ids."""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
import tomllib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from magfem.config import CaseError

__all__ = [
    "MAX_POINTS",
    "SYNTAX",
    "Point",
    "build_points",
    "fingerprint",
    "format_number",
    "parse_param",
]

_RANGE = re.compile(
    r"^\s*([+-]?[\d.]+(?:[eE][+-]?\d+)?)\s*:\s*([+-]?[\d.]+(?:[eE][+-]?\d+)?)\s*:"
    r"\s*([+-]?[\d.]+(?:[eE][+-]?\d+)?)\s*([A-Za-zµμ%][\w/^*µμ]*)?\s*$"
)
_NAME = re.compile(r"^[A-Za-z_]\w*(\.\w+)*$")
SYNTAX = "expected NAME=V1,V2,... or NAME=START:STOP:STEP[unit], e.g. robot.thickness=100:400:100um"
MAX_POINTS = 10_000


def format_number(x: float) -> str:
    """A number as written in point parameters and summaries (12 significant digits)."""
    return f"{x:.12g}"


def parse_param(text: str) -> tuple[str, list[str]]:
    """Parse one ``--param NAME=VALUES`` argument into (NAME, [value strings]).

    Raises:
        CaseError: key ``--param``, naming the text and the accepted syntax.
    """
    if "=" not in text:
        raise CaseError("--param", text, SYNTAX)
    name, values = (s.strip() for s in text.split("=", 1))
    if not _NAME.match(name):
        raise CaseError("--param", text, "NAME must be a dotted case key; " + SYNTAX)
    if not values:
        raise CaseError("--param", text, "no values; " + SYNTAX)
    if ":" in values and not values.startswith(("[", '"')):
        m = _RANGE.match(values)
        if m is None:
            raise CaseError("--param", text, "bad range; " + SYNTAX)
        start, stop, step = (float(m.group(i)) for i in (1, 2, 3))
        unit = m.group(4) or ""
        if step <= 0 or stop < start:
            raise CaseError("--param", text, "a range needs STEP > 0 and STOP >= START")
        n = math.floor((stop - start) / step + 1e-9) + 1
        if n > MAX_POINTS:
            raise CaseError("--param", text, f"more than {MAX_POINTS} values")
        return name, [format_number(start + i * step) + unit for i in range(n)]
    items = [v.strip() for v in values.split(",")]
    if any(not v for v in items):
        raise CaseError("--param", text, "empty list item; " + SYNTAX)
    return name, items


@dataclass(frozen=True)
class Point:
    """One sweep point: its parameters (name -> value as given) and its directory id."""

    index: int
    params: dict[str, str]
    ident: str

    def overrides(self) -> list[str]:
        """``--set`` arguments of this point."""
        return [f"{k}={v}" for k, v in self.params.items()]


def fingerprint(case_path: Path, base_overrides: Sequence[str]) -> str:
    """SHA-256 (hex) of the case file's content and the ``--set`` overrides: a point's base case.

    The content is the parsed TOML (keys sorted), so comments and layout do not count: a
    case file whose comments change keeps its finished points.
    """
    content = tomllib.loads(case_path.read_text(encoding="utf-8"))
    h = hashlib.sha256(json.dumps(content, sort_keys=True, default=str).encode())
    for item in base_overrides:
        h.update(b"\0" + item.encode())
    return h.hexdigest()


def build_points(
    params: Sequence[tuple[str, list[str]]], fingerprint: str, *, paired: bool = False
) -> list[Point]:
    """Points with stable ids: the Cartesian product of the parameter lists (last varies
    fastest), or with ``paired=True`` their element-wise pairing (lists of equal length).

    Raises:
        CaseError: a NAME given twice, or paired lists of different lengths.
    """
    names = [n for n, _ in params]
    if len(set(names)) != len(names):
        raise CaseError("--param", ", ".join(names), "each NAME may be given once")
    lengths = {len(v) for _, v in params}
    if paired and len(lengths) > 1:
        raise CaseError(
            "--param",
            ", ".join(f"{n}: {len(v)} values" for n, v in params),
            "paired parameters need lists of the same length",
        )
    combos: Iterable[tuple[str, ...]] = (
        zip(*(v for _, v in params), strict=True)
        if paired
        else itertools.product(*(v for _, v in params))
    )
    points = []
    for i, combo in enumerate(combos):
        p = dict(zip(names, combo, strict=True))
        digest = hashlib.sha256((fingerprint + json.dumps(p, sort_keys=True)).encode())
        points.append(Point(i, p, f"p{i:04d}_{digest.hexdigest()[:10]}"))
    if len(points) > MAX_POINTS:
        raise CaseError("--param", len(points), f"at most {MAX_POINTS} points")
    return points
