"""A simulation case: a TOML file validated into one frozen :class:`Case`.

Each top-level table maps one-to-one onto the frozen dataclass of the stage
that owns it:

=============== ======================================= =====================
table           dataclass                               owner module
=============== ======================================= =====================
``[robot]``     :class:`magfem.geometry.spec.RobotSpec` geometry
``[mesh]``      :class:`magfem.geometry.spec.MeshSpec`  geometry
``[field]``     :class:`magfem.field.spec.FieldSpec`    field
``[material]``  ``magfem.mechanics.spec.MaterialSpec``  mechanics
``[time]``      ``magfem.mechanics.spec.TimeSpec``      mechanics
``[solver]``    ``magfem.mechanics.spec.SolverSpec``    mechanics
``[contact]``   ``magfem.mechanics.spec.ContactSpec``   mechanics
``[environment]`` ``magfem.mechanics.spec.EnvironmentSpec`` mechanics
``[initial]``   ``magfem.mechanics.pose.InitialSpec``   mechanics
``[fluid]``     ``magfem.mechanics.fluid_spec.FluidSpec`` mechanics
``[output]``    ``magfem.mechanics.spec.OutputSpec``    mechanics
``[[loads]]``   a spec class per ``kind``               ``magfem.mechanics.loads``
``[[contacts]]`` a spec class per ``kind``              ``magfem.mechanics.contacts``
=============== ======================================= =====================

Quantities are strings with units (``"80 um"``), converted once here to SI.
A case file (:func:`load_case`) must give the unit of every nonzero
quantity unless it says ``units = "SI"`` at the top; a table built in code
(:func:`parse_case`) may give SI numbers. Every problem raises
:class:`magfem.config.CaseError` whose message names the file, the key, the
value and what is allowed. Values can be overridden from the command line
with ``--set table.key=value``.
"""

from __future__ import annotations

import copy
import dataclasses
import re
import tomllib
import typing
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from dataclasses import field as _field
from pathlib import Path
from typing import Any

import tomli_w

from magfem import material
from magfem.config import (
    MISSING,
    CaseError,
    build_fields,
    check_keys,
    from_table,
    not_in_table,
    to_table,
)
from magfem.field.spec import FieldSpec
from magfem.geometry.spec import MeshSpec, RobotSpec, check_mesh_for_robot
from magfem.mechanics.contacts import ContactKindSpec
from magfem.mechanics.fluid_spec import FluidSpec
from magfem.mechanics.loads import LoadSpec
from magfem.mechanics.pose import InitialSpec
from magfem.mechanics.spec import (
    ContactSpec,
    EnvironmentSpec,
    MaterialSpec,
    OutputSpec,
    SolverSpec,
    TimeSpec,
)
from magfem.units import bare_numbers

__all__ = [
    "Case",
    "FieldCase",
    "apply_overrides",
    "load_case",
    "load_field_case",
    "parse_case",
    "parse_field_case",
    "write_resolved_case",
]


@dataclass(frozen=True)
class Case:
    """Everything a run needs, validated, in SI units."""

    name: str
    robot: RobotSpec
    mesh: MeshSpec
    material: MaterialSpec
    field: FieldSpec = _field(default_factory=FieldSpec)
    time: TimeSpec = _field(default_factory=TimeSpec)
    solver: SolverSpec = _field(default_factory=SolverSpec)
    contact: ContactSpec = _field(default_factory=ContactSpec)
    environment: EnvironmentSpec = _field(default_factory=EnvironmentSpec)
    initial: InitialSpec = _field(default_factory=InitialSpec)
    fluid: FluidSpec | None = None
    output: OutputSpec = _field(default_factory=OutputSpec)
    loads: tuple[LoadSpec, ...] = ()
    contacts: tuple[ContactKindSpec, ...] = ()
    description: str = ""
    given: frozenset[str] | None = not_in_table(
        doc="the dotted keys the case's tables set (``mesh.size``, ...); None: every key "
        "counts as set (a case built in code, or resolved by magfem.accuracy)"
    )

    def resolution(self) -> str | None:
        """One line on how well the mesh resolves a field-driven bend, or None.

        The magnetoelastic length ℓ (:func:`magfem.material.magnetoelastic_length`)
        at the field amplitude bound (:meth:`FieldSpec.nominal_flux_bound`: the
        sources' nominal flux densities as vectors) and the elements of
        ``mesh.size`` per ℓ; about 3 P2 or 1.7 P3 elements give ~1°
        (docs/verification.md §4a, §4c). None without a magnetisation or a
        nominal field.
        """
        flux = self.field.nominal_flux_bound()
        mat = self.material
        if flux <= 0.0 or mat.remanence <= 0.0:
            return None
        ell = material.magnetoelastic_length(
            mat.shear_modulus, mat.bulk, self.robot.thickness, mat.remanence, flux
        )
        return (
            f"magnetoelastic length {ell * 1e3:.3g} mm at {flux * 1e3:g} mT: "
            f"{ell / self.mesh.size:.2g} element(s) per length (about 3 P2 or 1.7 P3 elements "
            "resolve a bend to ~1 deg, docs/verification.md 4a, 4c)"
        )


def _check_consistency(case: Case) -> None:
    """Checks that involve several tables."""
    check_mesh_for_robot(case.robot, case.mesh)
    for i, spec in enumerate(case.contacts):
        try:
            spec.check_field(case.field)
        except CaseError as err:
            raise CaseError(f"contacts[{i}].{err.key}", err.value, err.problem) from None


_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]{0,99}")
UNITS_KEY = "units"
"""Top-level key: ``units = "SI"`` makes bare numbers SI in a case file."""
PROVENANCE_KEY = "provenance"
"""Top-level table written into resolved cases (versions, commit); ignored on input."""
_INFO_KEYS = (UNITS_KEY, PROVENANCE_KEY)


def _check_name(raw: object) -> None:
    """A case name is a plain file name: it names the output folder and the mesh file."""
    if not isinstance(raw, str) or not raw.strip():
        raise CaseError("name", raw if raw is not None else MISSING, "must be a non-empty string")
    if _NAME.fullmatch(raw) is None or ".." in raw:
        raise CaseError(
            "name",
            raw,
            "must be a plain file name: letters, digits and _ . + - starting with a letter "
            "or digit, no / or .., at most 100 characters",
        )


def _units_declared(data: Mapping[str, Any]) -> bool:
    """Whether the document says ``units = "SI"`` (bare numbers are SI)."""
    if UNITS_KEY not in data:
        return False
    if data[UNITS_KEY] != "SI":
        raise CaseError(UNITS_KEY, data[UNITS_KEY], 'must be "SI" (or left out: units required)')
    return True


def parse_case(data: Mapping[str, Any], *, require_units: bool = False) -> Case:
    """Validate a parsed TOML document into a :class:`Case` (no file involved).

    Args:
        require_units: nonzero quantities need units unless the document says
            ``units = "SI"`` (case files); False: bare numbers are SI (tables
            built in code).
    """
    if not data:
        raise CaseError(
            "(file)",
            MISSING,
            "the case is empty; it needs at least name, [robot], [mesh], [material]",
        )
    bare_si = _units_declared(data) or not require_units
    data = {k: v for k, v in data.items() if k not in _INFO_KEYS}
    if "name" in data:
        _check_name(data["name"])
    raw = data.get("description", "")
    if not isinstance(raw, str):
        raise CaseError("description", raw, "must be a string")
    given = frozenset(_dotted_keys(data))
    with bare_numbers(bare_si):
        data = _provisional_size(data)
        case = build_fields(Case, data, "", given=given)
        _check_consistency(case)
    return case


def _dotted_keys(data: Mapping[str, Any]) -> Iterable[str]:
    """``table.key`` for every key of the document's tables (and the top-level keys)."""
    for name, value in data.items():
        yield name
        if isinstance(value, Mapping):
            yield from (f"{name}.{key}" for key in value)


def _provisional_size(data: Mapping[str, Any]) -> Mapping[str, Any]:
    """``data`` with ``mesh.size`` = the robot's smallest feature where ``[solver] accuracy``
    will choose it (magfem.accuracy) and the file leaves it out; else ``data`` itself."""
    solver, mesh, robot = (data.get(k) for k in ("solver", "mesh", "robot"))
    if not (isinstance(solver, Mapping) and solver.get("accuracy") is not None):
        return data
    if not isinstance(mesh, Mapping) or "size" in mesh or not isinstance(robot, Mapping):
        return data
    feature = from_table(RobotSpec, robot, "robot").min_feature
    return {**data, "mesh": {**mesh, "size": f"{feature!r} m"}}


def _parse_override_value(text: str) -> Any:
    """TOML value if it parses as one (numbers, booleans, arrays), else the raw string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()


def apply_overrides(data: dict[str, Any], overrides: Iterable[str]) -> dict[str, Any]:
    """Apply ``table.key=value`` overrides to a parsed TOML document (copy).

    ``value`` is read as a TOML value when it is one (``3``, ``true``,
    ``[1, 0, 0]``, ``"2 mT"``) and as a plain string otherwise (``2mT``).
    Arrays of tables are addressed by index: ``field.sources.0.frequency=50Hz``.
    """
    out = copy.deepcopy(data)
    for item in overrides:
        if "=" not in item:
            raise CaseError("--set", item, "expected KEY=VALUE, e.g. time.end=100ms")
        key, value = item.split("=", 1)
        parts = key.strip().split(".")
        node: Any = out
        for i, part in enumerate(parts[:-1]):
            if isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise CaseError(
                        "--set " + key, value, f"'{part}' is not an index of {'.'.join(parts[:i])}"
                    )
                node = node[int(part)]
            else:
                node = node.setdefault(part, {})
            if not isinstance(node, dict | list):
                raise CaseError(
                    "--set " + key, value, f"'{'.'.join(parts[: i + 1])}' is not a table"
                )
        if isinstance(node, list):
            raise CaseError("--set " + key, value, "cannot set a whole array element")
        node[parts[-1]] = _parse_override_value(value)
    return out


@dataclass(frozen=True)
class FieldCase:
    """What ``magfem field`` needs from a case without ``[robot]``: its name and ``[field]``."""

    name: str
    field: FieldSpec = _field(default_factory=FieldSpec)
    description: str = ""


def parse_field_case(data: Mapping[str, Any], *, require_units: bool = False) -> Case | FieldCase:
    """A :class:`Case` if the document has ``[robot]``, else a :class:`FieldCase`.

    Without ``[robot]`` the other tables that are present are still validated.
    ``require_units`` as for :func:`parse_case`.
    """
    if "robot" in data:
        return parse_case(data, require_units=require_units)
    bare_si = _units_declared(data) or not require_units
    data = {k: v for k, v in data.items() if k not in _INFO_KEYS}
    with bare_numbers(bare_si):
        return _parse_field_only(data)


def _parse_field_only(data: Mapping[str, Any]) -> FieldCase:
    check_keys(data, [f.name for f in dataclasses.fields(Case)], "")
    hints = typing.get_type_hints(Case)
    for f in dataclasses.fields(Case):
        raw = data.get(f.name)
        if raw is None or f.name in ("name", "description", "field"):
            continue
        tp = hints[f.name]
        if dataclasses.is_dataclass(tp):
            if not isinstance(raw, Mapping):
                raise CaseError(f.name, raw, "must be a table")
            from_table(tp, raw, f.name)  # type: ignore[arg-type]
            continue
        item = typing.get_args(tp)[0]  # an array of tables
        if not isinstance(raw, list):
            raise CaseError(f.name, raw, "must be an array of tables")
        for i, entry in enumerate(raw):
            if not isinstance(entry, Mapping):
                raise CaseError(f"{f.name}[{i}]", entry, "must be a table")
            from_table(item, entry, f"{f.name}[{i}]")
    _check_name(data.get("name"))
    raw = data.get("description", "")
    if not isinstance(raw, str):
        raise CaseError("description", raw, "must be a string")
    field = from_table(FieldSpec, data.get("field", {}), "field")
    return FieldCase(name=data["name"], field=field, description=data.get("description", ""))


def load_field_case(path: str | Path, overrides: Iterable[str] = ()) -> Case | FieldCase:
    """Read, override and validate a case file for ``magfem field`` (``[robot]`` optional)."""
    data, source = _read(path, overrides)
    try:
        return parse_field_case(data, require_units=True)
    except CaseError as err:
        raise err.with_source(source) from None


def _read(path: str | Path, overrides: Iterable[str]) -> tuple[dict[str, Any], str]:
    """The parsed, overridden TOML document of ``path`` and its name for messages."""
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise CaseError(
            "(file)", MISSING, "no such case file" if not path.exists() else "not a file", source
        )
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise CaseError("(file)", MISSING, f"cannot read: {err}", source) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise CaseError("(file)", MISSING, f"TOML syntax error: {err}", source) from None
    try:
        return apply_overrides(data, overrides), source
    except CaseError as err:
        raise err.with_source(source) from None


def load_case(path: str | Path, overrides: Iterable[str] = ()) -> Case:
    """Read, override and validate a case file.

    Raises:
        CaseError: with the file name in the message, for every bad input
            (missing file, TOML syntax, unknown key, unit, range, ...).
    """
    data, source = _read(path, overrides)
    try:
        return parse_case(data, require_units=True)
    except CaseError as err:
        raise err.with_source(source) from None


def write_resolved_case(
    case: Case | FieldCase,
    path: str | Path,
    *,
    provenance: Mapping[str, str] | None = None,
    notes: Iterable[str] = (),
) -> Path:
    """Write the case with all defaults filled in, SI numbers (``units = "SI"``), as TOML.

    ``provenance`` (versions, commit) goes into the table ``[provenance]``,
    which :func:`parse_case` ignores: the file reads back as the same case.
    ``notes`` (e.g. the choices of ``[solver] accuracy``) become comment lines
    of the header.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    table = {UNITS_KEY: "SI"} | to_table(case)
    if provenance:
        table[PROVENANCE_KEY] = dict(provenance)
    header = "# Resolved case written by magfem: every value in SI units, defaults filled in.\n"
    header += "".join(f"# {line}\n" for line in notes)
    path.write_text(header + tomli_w.dumps(table), encoding="utf-8")
    return path
