"""Scene studies as data: one TOML file per study, read by ``magfem report``.

A study is the prediction ``magfem report`` makes for one scene: a sweep of
a case file over one or more parameters (:func:`magfem.sweep.run_sweep`, so
an interrupted report resumes), the summary scalars to tabulate and the
notes that frame the result. The studies live in ``cases/studies/``, one file
each; the file name without ``.toml`` is the scene id (``magfem report
--only ID``, the run directory ``output/report/ID``, the section of
docs/scenes.md). Example, ``cases/studies/two-arm-20hz.toml``::

    order = 50                            # position in the report (cheapest first)
    title = "Two-arm strip, 2 mT, 20 Hz"
    case = "cases/two_arm_20hz.toml"      # relative to where magfem report runs
    observe = "arm angle history; speed 0° → 90°"
    params = ["time.end=50ms"]            # magfem sweep --param texts
    columns = ["max_angle_arm_right", "bending_speed_arm_right"]

The keys, their defaults and what they accept are listed in
docs/case_reference.md. Text keys (``title``, ``observe``, ``notes``,
``pending``, ``unresolved``, ``uncertainty``) are single paragraphs: line breaks and runs of
spaces become one space, so long texts can be TOML multi-line strings.
Validation is that of case files: any problem raises
:class:`magfem.config.CaseError` naming the file, the key and the value.
"""

from __future__ import annotations

import dataclasses
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from magfem.config import MISSING, CaseError, build_fields, flag, integer, option, quantity
from magfem.sweep import build_points, parse_param
from magfem.units import UnitError, parse_quantity

__all__ = ["STUDIES_DIR", "Study", "load_studies", "load_study"]

STUDIES_DIR = Path("cases/studies")
"""Where ``magfem report`` looks for study files (relative to the directory it runs in)."""

_IDENT = re.compile(r"^[a-z0-9]+(-[a-z0-9]+)*$")
_SET = re.compile(r"^[A-Za-z_]\w*(\.\w+)*=")
_WINDOW_LABEL = re.compile(r"^[A-Za-z0-9_.]+$")
_TEXT_KEYS = ("title", "observe", "notes", "pending", "unresolved", "uncertainty")


@dataclass(frozen=True, kw_only=True)
class Study:
    """One scene's study (a study file, validated); ``ident`` is the file name's stem."""

    ident: str
    title: str = option(doc="heading of the scene's section in docs/scenes.md")
    case: str = option(
        doc="case file swept, relative to the directory magfem report runs in (the repository root)"
    )
    observe: str = option(doc="what the scene asks to observe, one phrase")
    params: tuple[str, ...] = option(
        doc="swept parameters as magfem sweep's --param texts: NAME=V1,V2,... or "
        "NAME=START:STOP:STEP[unit]"
    )
    paired: bool = flag(
        False, doc="pair the params lists element by element (equal lengths) instead of crossing"
    )
    sets: tuple[str, ...] = option((), doc="KEY=VALUE overrides applied to every run (--set)")
    columns: tuple[str, ...] = option(
        (), doc="summary scalars tabulated first (the per-arm max_angle_<arm> and end_time follow)"
    )
    compare: tuple[str, ...] = option(
        (),
        doc="summary scalars whose difference between the last and the first run is stated "
        "under the table, in the table's units",
    )
    compare_by: str = option(
        "",
        doc="with compare: the parameter (e.g. mesh.size) whose last run is compared with its "
        "first for each value of the other parameters, one line each, and the sweep plot "
        "draws a line per its value; empty: the last run of the study against the first",
    )
    compare_also: tuple[str, ...] = option(
        (),
        doc="with compare_by: parameters that change with it (e.g. time.step halved with "
        "mesh.size), left out of the grouping and named in the difference line",
    )
    figure: tuple[str, ...] = option(
        (),
        doc="history columns plotted against time, one panel each and a line per run (default: "
        "the sweep plot, or the single run's angle history)",
    )
    animation: bool = flag(
        False,
        doc="show the motion.gif of the study's last finished run below its figure (copied "
        "next to the figures as scenes_<id>.gif)",
    )
    windows: tuple[str, ...] = option(
        (),
        doc="LABEL=TIME texts (e.g. 40Hz=12.5ms): each adds every summary scalar over the "
        "history up to TIME as <scalar>@LABEL (max_folds_arm@40Hz), for columns, compare and "
        "the sweep summary; nan where a run ended before TIME",
    )
    hold: float = quantity(
        0.0,
        "s",
        ge=0,
        doc="adds held_angle_* for every max_angle_* summary scalar: the largest angle held "
        "for at least this long (e.g. 0.1ms: an impact's flick of the tip over a step or two "
        "is not counted); 0: none",
    )
    notes: str = option("", doc="what the reader needs to read the table")
    pending: str = option(
        "", doc="why the study may not have run yet (its cost), shown while it has not"
    )
    unresolved: str = option(
        "",
        doc="why finished runs are still not a prediction (e.g. a mesh coarser than the "
        "physics' length scale): the scene is then under-resolved",
    )
    uncertainty: str = option(
        "",
        doc="the numbers' numerical uncertainty where the study does not measure it by two "
        "resolutions (compare), e.g. a convergence study of the same model elsewhere; with "
        "neither, finished runs are not called predicted",
    )
    order: int = integer(0, ge=0, doc="position in the report: studies sorted by order, then by id")

    def __post_init__(self) -> None:
        if not _IDENT.match(self.ident):
            raise CaseError(
                "(file name)",
                self.ident,
                "a study id is lowercase letters and digits joined by single hyphens",
            )
        for key in _TEXT_KEYS:
            object.__setattr__(self, key, " ".join(getattr(self, key).split()))
        for key in ("title", "case", "observe"):
            if not getattr(self, key):
                raise CaseError(key, getattr(self, key), "must be a non-empty string")
        if not self.params:
            raise CaseError("params", [], "give at least one NAME=VALUES text")
        parsed = []
        for i, text in enumerate(self.params):
            try:
                parsed.append(parse_param(text))
            except CaseError as err:
                raise CaseError(f"params[{i}]", text, err.problem) from None
        try:
            build_points(parsed, "", paired=self.paired)
        except CaseError as err:
            raise CaseError("params", err.value, err.problem) from None
        names = [name for name, _ in parsed]
        if self.compare_by and self.compare_by not in names:
            raise CaseError(
                "compare_by", self.compare_by, "must name one of params: " + ", ".join(names)
            )
        for i, name in enumerate(self.compare_also):
            if not self.compare_by:
                raise CaseError(f"compare_also[{i}]", name, "needs compare_by")
            if name not in names or name == self.compare_by:
                raise CaseError(
                    f"compare_also[{i}]",
                    name,
                    "must name another of params: " + ", ".join(names),
                )
        for i, text in enumerate(self.sets):
            if not _SET.match(text):
                raise CaseError(f"sets[{i}]", text, "expected KEY=VALUE, e.g. time.end=20ms")
        self.window_ends()  # raises for a bad window

    def window_ends(self) -> dict[str, float]:
        """``windows`` as label -> end time (s).

        Raises:
            CaseError: ``windows[i]``: not LABEL=TIME, a label of other characters than
                letters, digits, ``.`` and ``_``, a label given twice, or a time that is
                not a positive duration.
        """
        ends: dict[str, float] = {}
        for i, text in enumerate(self.windows):
            label, sep, value = text.partition("=")
            if not sep or not _WINDOW_LABEL.match(label):
                raise CaseError(
                    f"windows[{i}]",
                    text,
                    "expected LABEL=TIME, e.g. 40Hz=12.5ms (LABEL: letters, digits, '.' and '_')",
                )
            if label in ends:
                raise CaseError(f"windows[{i}]", text, f"the label {label!r} is given twice")
            try:
                end = parse_quantity(value, "s")
            except UnitError as err:
                raise CaseError(f"windows[{i}]", text, str(err)) from None
            if not end > 0.0:
                raise CaseError(f"windows[{i}]", text, "the time must be > 0")
            ends[label] = end
        return ends

    @classmethod
    def table_keys(cls) -> tuple[str, ...]:
        """The study file's keys (what :func:`magfem.config.to_table` writes): all but the id."""
        return tuple(f.name for f in dataclasses.fields(cls) if f.name != "ident")


def parse_study(data: dict[str, Any], ident: str) -> Study:
    """Validate a parsed study file (no file involved; ``ident`` is the scene id)."""
    return build_fields(Study, data, "", ident=ident)


def load_study(path: str | Path) -> Study:
    """Read and validate one study file; its case file must exist.

    Raises:
        CaseError: with the file name in the message, for every bad input.
    """
    path = Path(path)
    source = str(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise CaseError("(file)", MISSING, f"cannot read: {err.strerror}", source) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise CaseError("(file)", MISSING, f"TOML syntax error: {err}", source) from None
    try:
        study = parse_study(data, path.stem)
    except CaseError as err:
        raise err.with_source(source) from None
    if not Path(study.case).is_file():
        raise CaseError(
            "case",
            study.case,
            "no such case file (relative to the directory magfem report runs in)",
            source,
        )
    return study


def load_studies(folder: str | Path = STUDIES_DIR) -> tuple[Study, ...]:
    """Every ``*.toml`` study of ``folder``, sorted by ``order`` then id.

    Raises:
        CaseError: a missing folder, or the first bad study file.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise CaseError("(folder)", MISSING, "no such studies folder", str(folder))
    studies = [load_study(path) for path in sorted(folder.glob("*.toml"))]
    return tuple(sorted(studies, key=lambda s: (s.order, s.ident)))
