"""The ``magfem`` command line.

    magfem check CASE [--set KEY=VALUE ...]     validate a case, print its summary
    magfem mesh  CASE [--out DIR] [--format F]  build the robot mesh, write DIR/<name>.msh (.vtu)
                                                and the scene's picture DIR/<name>.png
    magfem field CASE [--out DIR]               solve the applied field, write VTX/CSV/PNG
                                                (field.png, and the scene's scene.png)
    magfem run   CASE [--out DIR]               mesh + field + dynamics, write all outputs
                 [--resume DIR | --overwrite]   continue a stopped run / replace a previous one
    magfem sweep CASE --param NAME=VALUES ...   parameter sweep, resumable (magfem.sweep)
    magfem report [--run] [--only SCENE ...]    assemble docs/scenes.md (magfem.report)

Every command takes ``-q/--quiet`` (warnings and errors only), ``-v/--verbose``
(debug messages too) and ``--debug`` (tracebacks with errors).

Safe under ``mpirun -n N``: every rank parses the case and takes part in the
collective work, only rank 0 prints. Every failure ends with one line on
stderr and an exit status per kind (:mod:`magfem.errors`): bad input
``magfem: error: FILE: KEY = VALUE: what is allowed`` and status 2, solver
3, I/O 4, SIGINT/SIGTERM during a run 130/143 after a checkpoint; no
traceback unless ``--debug``.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import sys
import time
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from mpi4py import MPI
from petsc4py import PETSc

from magfem import __version__
from magfem.accuracy import resolve_case, rod_adequacy
from magfem.case import Case, FieldCase, load_case, load_field_case, write_resolved_case
from magfem.config import CaseError
from magfem.errors import EXIT_FAILED, RunInterrupted, end_with
from magfem.field.run import run_field
from magfem.geometry.export import export_robot_mesh
from magfem.geometry.robot_mesh import create_robot_mesh
from magfem.mechanics.solver_options import check_petsc_options
from magfem.parallel import configure_logging, root_call
from magfem.pipeline import describe_fluid_of, simulate
from magfem.plot import plot_scene
from magfem.provenance import provenance
from magfem.report import build_report
from magfem.rundir import prepare_run_directory
from magfem.sanity import implausible
from magfem.signals import DriverSignals, StopSignals
from magfem.sweep import parse_engine_options, parse_param, run_sweep

__all__ = ["main"]

LOG = logging.getLogger("magfem.cli")


def _say(comm: MPI.Comm, *args: object) -> None:
    LOG.info(" ".join(str(a) for a in args))


def _warn_implausible(case: Case) -> None:
    for line in implausible(case):
        LOG.warning(line)


def _outdir(args: argparse.Namespace, case: Case | FieldCase) -> Path:
    return Path(args.out) if args.out else Path("output") / case.name


def _summary(case: Case) -> str:
    r, m = case.robot, case.mesh
    lines = [
        f"case      {case.name}" + (f" — {case.description}" if case.description else ""),
        f"robot     {r.shape}, thickness {r.thickness * 1e6:g} um, smallest feature "
        f"{r.min_feature * 1e3:g} mm",
        f"mesh      {m.model}, size {m.size * 1e3:g} mm, {m.layers} layer(s)",
        f"field     {len(case.field.sources)} source(s), model {case.field.model}",
    ]
    lines += _scene_lines(case)
    resolution = case.resolution()
    if resolution:
        lines.append(f"bending   {resolution}")
    rod = rod_adequacy(case)
    lines.append(f"rod       {'adequate' if rod.adequate else 'not adequate'}: {rod.reason}")
    for choice in resolve_case(case)[1]:
        lines.append(choice if choice.startswith("accuracy") else f"model     {choice}")
    lines += describe_fluid_of(case)
    return "\n".join(lines)


def _scene_lines(case: Case) -> list[str]:
    """The field's sources and iron (where they move) and the ``[[contacts]]``, one line each."""
    motions = {m.name: m for m in case.field.motions}

    def moving(part: object) -> str:
        name = getattr(part, "motion", "")
        if not name:
            return ""
        m = motions[name]
        return f", moves with '{name}' ({len(m.times)} keyframes to {m.times[-1]:g} s)"

    lines = []
    for k, src in enumerate(case.field.sources):
        where = getattr(src, "center", None)
        at = "" if where is None else " at (" + ", ".join(f"{1e3 * x:.3g}" for x in where) + ") mm"
        lines.append(f"source    {k}: {src.kind}{at}{moving(src)}")
    lines += [f"iron      {k}: {p.kind}{moving(p)}" for k, p in enumerate(case.field.iron)]
    lines += [f"contact   {spec.describe()}" for spec in case.contacts]
    env, init = case.environment, case.initial
    if not env.clamped and env.fixed_point is None:
        axis = ", ".join(f"{x:g}" for x in init.axis)
        turned = f", placed turned {math.degrees(init.angle):.3g} deg about ({axis})"
        lines.append("body      free" + (turned if init.angle else ""))
    return lines


def _cmd_check(args: argparse.Namespace, case: Case, comm: MPI.Comm) -> int:
    check_petsc_options(case.solver)
    _say(comm, _summary(case))
    _warn_implausible(case)
    _say(comm, f"{args.case}: OK")
    return 0


def _make_directory(path: Path, comm: MPI.Comm) -> None:
    """Create ``path`` on rank 0; its failure raises on every rank (collective)."""
    root_call(comm, lambda: Path(path).mkdir(parents=True, exist_ok=True))


def _cmd_mesh(args: argparse.Namespace, case: Case, comm: MPI.Comm) -> int:
    out = Path(args.out) if args.out else Path("meshes")
    msh = out / f"{case.name}.msh"
    _make_directory(out, comm)
    t0 = time.perf_counter()
    mesh = resolve_case(case)[0].mesh  # the mesh a run would use (accuracy, auto)
    rm = create_robot_mesh(case.robot, mesh, comm, msh_path=msh)
    ncells = rm.mesh.topology.index_map(rm.mesh.topology.dim).size_global
    _say(comm, _summary(case))
    _say(
        comm, f"meshed    {ncells} cells in {time.perf_counter() - t0:.2f} s on {comm.size} rank(s)"
    )
    _say(comm, "groups    " + ", ".join(sorted(rm.groups)))
    _say(comm, f"wrote     {msh}")
    png = out / f"{case.name}.png"
    plot_scene(case, png, robot=rm, comm=comm)
    _say(comm, f"wrote     {png}")
    if args.format != "msh":
        path = export_robot_mesh(msh, args.format, comm, strip=rm.model == "strip")
        _say(comm, f"wrote     {path}")
    return 0


def _cmd_field(args: argparse.Namespace, case: Case | FieldCase, comm: MPI.Comm) -> int:
    outdir = _outdir(args, case)
    _make_directory(outdir, comm)
    _write_resolved(case, outdir, comm)
    written = run_field(case, outdir, comm)
    written["scene"] = outdir / "scene.png"
    plot_scene(case, written["scene"], comm=comm)
    for label, path in written.items():
        _say(comm, f"wrote     {label}: {path}")
    return 0


def _cmd_run(args: argparse.Namespace, case: Case, comm: MPI.Comm, stop: StopSignals) -> int:
    resume = args.resume is not None
    if resume and args.out and Path(args.out) != Path(args.resume):
        raise CaseError("--out", args.out, "give --resume DIR alone: the run continues in DIR")
    outdir = Path(args.resume) if resume else _outdir(args, case)
    check_petsc_options(case.solver)
    root_call(comm, lambda: prepare_run_directory(outdir, resume=resume, overwrite=args.overwrite))
    _say(comm, _summary(case))
    _warn_implausible(case)
    case, choices = resolve_case(case)  # what _summary said; the run and its record use it
    written = _write_resolved(case, outdir, comm, notes=choices)
    _say(comm, f"wrote     resolved case: {written}")
    t0 = time.perf_counter()
    try:
        result = simulate(
            case, outdir, comm, progress=not args.quiet, stop=stop.agreed, resume=resume
        )
    except RunInterrupted as err:
        hint = f"continue with: magfem run {args.case} --resume {outdir}"
        raise RunInterrupted(err.signum, f"{err.message}; {hint}") from None
    _say(comm, f"finished  in {time.perf_counter() - t0:.1f} s on {comm.size} rank(s)")
    _say(comm, solver_effort(result.effort, result.timings))
    for label, path in result.paths.items():
        _say(comm, f"wrote     {label}: {path}")
    return 0


def solver_effort(effort: Mapping[str, int], timings: Mapping[str, float]) -> str:
    """The run's Newton work in one line: iterations, Jacobians (why rebuilt), times (s)."""
    gmres = f" ({effort['gmres_iterations']} GMRES)" if "gmres_iterations" in effort else ""
    line = (
        f"solver    {effort['iterations']} Newton iterations{gmres},"
        f" {effort['jacobians']} Jacobians"
    )
    if "rebuilt_start" in effort:
        krylov = effort.get("rebuilt_krylov", 0)
        line += (
            f" (kept for {effort['iterations'] - effort['jacobians']} iterations; rebuilt after"
            f" slow contraction {effort['rebuilt_contraction']},"
            + (f" slow GMRES {krylov}," if krylov else "")
            + f" a new time step {effort['rebuilt_time_step']},"
            f" a start or failed solve {effort['rebuilt_start']})"
        )
    return (
        line
        + "; "
        + ", ".join(
            f"{key.replace('_', ' ')} {timings[key]:.1f} s"
            for key in ("residual", "jacobian", "linear_solve")
        )
    )


def _write_resolved(
    case: Case | FieldCase, outdir: Path, comm: MPI.Comm, *, notes: Sequence[str] = ()
) -> Path:
    path = outdir / "case.resolved.toml"
    info = provenance() if comm.rank == 0 else None
    root_call(comm, lambda: write_resolved_case(case, path, provenance=info, notes=notes))
    return path


def _cmd_sweep(args: argparse.Namespace, comm: MPI.Comm) -> int:
    for text in args.params:  # syntax errors first, on every rank
        parse_param(text)
    if comm.size > 1:  # the driver is serial; each point may use --np ranks itself
        raise CaseError("sweep", f"{comm.size} ranks", "run the sweep driver without mpirun")
    out = Path(args.out) if args.out else Path("output") / "sweeps" / Path(args.case).stem
    result = run_sweep(
        args.case,
        args.params,
        out,
        base_overrides=args.overrides,
        jobs=args.jobs,
        ranks=args.np,
        retry_failed=args.retry_failed,
        paired=args.paired,
        engine=args.engine,
        engine_options=parse_engine_options(args.engine_options),
        echo=None if args.quiet else LOG.info,
    )
    failed = [r["point"] for r in result.records if r.get("status") != "done"]
    _say(
        comm,
        f"sweep     {len(result.records)} point(s): ran {len(result.ran)}, "
        f"reused {len(result.skipped)}, not done {len(failed)}",
    )
    for label, path in result.paths.items():
        _say(comm, f"wrote     {label}: {path}")
    return 0 if not failed else EXIT_FAILED


def _cmd_report(args: argparse.Namespace, comm: MPI.Comm) -> int:
    if comm.size > 1:
        raise CaseError("report", f"{comm.size} ranks", "run the report driver without mpirun")
    path = build_report(
        Path(args.out),
        run=args.run,
        only=args.only,
        jobs=args.jobs,
        retry_failed=args.retry_failed,
        docs=Path(args.docs),
        echo=None if args.quiet else LOG.info,
    )
    _say(comm, f"wrote     report: {path}")
    return 0


_COMMANDS = {"check": _cmd_check, "mesh": _cmd_mesh}
_DRIVERS = {"sweep": _cmd_sweep, "report": _cmd_report}


def _add_overrides(parser: argparse.ArgumentParser, text: str) -> None:
    parser.add_argument(
        "--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE", help=text
    )


def _common() -> argparse.ArgumentParser:
    """Options every command takes (after the command's name)."""
    c = argparse.ArgumentParser(add_help=False)
    level = c.add_mutually_exclusive_group()
    level.add_argument(
        "-q", "--quiet", action="store_true", help="warnings and errors only, no progress bar"
    )
    level.add_argument("-v", "--verbose", action="store_true", help="debug messages too")
    c.add_argument("--debug", action="store_true", help="print the traceback of an error")
    return c


def _add_sweep_parser(sub: Any, common: list[argparse.ArgumentParser]) -> None:
    """The ``sweep`` command's arguments."""
    text = "run a case over a grid of parameter values in parallel processes (resumable)"
    s = sub.add_parser("sweep", help=text, description=text, parents=common)
    s.add_argument("case", help="base case file (TOML)")
    s.add_argument(
        "--param",
        dest="params",
        action="append",
        default=[],
        metavar="NAME=VALUES",
        help="swept key: NAME=V1,V2,... or NAME=START:STOP:STEP[unit], e.g. "
        "field.sources.0.waveform.frequency=10:200:20Hz (repeat for a grid)",
    )
    _add_overrides(s, "override applied to every point")
    s.add_argument("--jobs", type=int, default=1, help="points run at the same time")
    s.add_argument("--np", type=int, default=1, help="MPI ranks per point (mpirun -n)")
    s.add_argument("--out", help="sweep directory (default output/sweeps/<case stem>)")
    s.add_argument(
        "--engine",
        default="local",
        help="where points run: local processes (default), slurm (a job array through "
        "submitit), submitit-local (the same jobs as local processes)",
    )
    s.add_argument(
        "--engine-option",
        dest="engine_options",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a cluster engine's parameter, e.g. partition=short, time=60 (minutes), mem=4GB",
    )
    s.add_argument("--retry-failed", action="store_true", help="rerun points that failed")
    s.add_argument(
        "--paired",
        action="store_true",
        help="pair the --param lists element by element (equal lengths) instead of crossing them",
    )


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="magfem",
        description="Finite-element simulation of untethered hard-magnetic soft robots.",
    )
    p.add_argument("--version", action="version", version=f"magfem {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    common = [_common()]
    helps = {
        "check": "validate a case file without running it",
        "mesh": "build the robot mesh and write the .msh file (default under meshes/)",
        "field": "solve the applied magnetic field and write VTX/CSV/PNG",
        "run": "run the case end to end (mesh, field, dynamics, outputs)",
    }
    for name, text in helps.items():
        s = sub.add_parser(name, help=text, description=text, parents=common)
        s.add_argument("case", help="case file (TOML)")
        _add_overrides(s, "override a case value, e.g. --set time.end=50ms")
        if name != "check":
            s.add_argument("--out", help="output directory (default output/<case name>)")
        if name == "run":
            again = s.add_mutually_exclusive_group()
            again.add_argument(
                "--resume",
                metavar="DIR",
                help="continue the run whose checkpoint is in DIR (same case, same ranks; "
                "time.end may be later)",
            )
            again.add_argument(
                "--overwrite",
                action="store_true",
                help="delete the outputs of a previous run in the output directory first",
            )
        if name == "mesh":
            s.add_argument(
                "--format",
                choices=("msh", "vtu", "vtk"),
                default="msh",
                help="also write the mesh with its groups as VTK (vtu, vtk) for ParaView "
                "and other tools (default: only the gmsh .msh)",
            )
    _add_sweep_parser(sub, common)
    text = "run (or reuse) the scene studies and write docs/scenes.md"
    s = sub.add_parser("report", help=text, description=text, parents=common)
    s.add_argument("--run", action="store_true", help="run missing studies (else only read)")
    s.add_argument("--only", action="append", default=[], metavar="SCENE", help="scene id(s)")
    s.add_argument("--jobs", type=int, default=2, help="runs at the same time")
    s.add_argument("--out", default="output/report", help="where the runs go")
    s.add_argument("--docs", default="docs", help="docs directory (scenes.md, figures/)")
    s.add_argument("--retry-failed", action="store_true", help="rerun runs that failed")
    return p


def _field_only(path: str) -> bool:
    """Whether the file is a field-only case: a ``[field]`` and no robot, mesh or material.

    Unreadable files are not (the case loader reports them).
    """
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False
    return "field" in data and not {"robot", "mesh", "material"} & data.keys()


def _dispatch(args: argparse.Namespace, comm: MPI.Comm, stop: StopSignals) -> int:
    if args.command in _DRIVERS:
        return _DRIVERS[args.command](args, comm)
    if args.command == "field":  # [robot], [mesh], [material] optional
        return _cmd_field(args, load_field_case(args.case, args.overrides), comm)
    if args.command == "check" and _field_only(args.case):
        checked = load_field_case(args.case, args.overrides)
        if isinstance(checked, FieldCase):  # a field-only case: what magfem field needs
            parts = len(checked.field.sources) + len(checked.field.iron)
            _say(comm, f"field     {parts} source(s) and iron part(s); no [robot]: field only")
            _say(comm, f"{args.case}: OK")
            return 0
    case = load_case(args.case, args.overrides)
    if args.command == "run":
        return _cmd_run(args, case, comm, stop)
    return _COMMANDS[args.command](args, case, comm)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``magfem`` console script; returns the exit status.

    Under MPI every rank returns the same status; a rank that fails alone
    while the others wait in a collective call ends the job instead
    (:func:`magfem.errors.end_with`).
    """
    args = _parser().parse_args(argv)
    comm = MPI.COMM_WORLD
    level = logging.WARNING if args.quiet else logging.DEBUG if args.verbose else logging.INFO
    configure_logging(comm, level)
    failures = comm.Dup()
    # a run stops at the end of a step on SIGINT/SIGTERM, check/mesh/field at once; sweep and
    # report stop the runs they started on KeyboardInterrupt, which SIGTERM raises there too
    with contextlib.ExitStack() as stack:
        stop = StopSignals(immediate=args.command != "run")
        stack.enter_context(DriverSignals() if args.command in _DRIVERS else stop)
        try:
            status = _dispatch(args, comm, stop)
        except BaseException as err:  # every failure: one line and its status, on every rank
            if isinstance(err, SystemExit):
                raise
            if stop.received and isinstance(err, PETSc.Error):
                # a signal raised inside a PETSc callback surfaces as a PETSc error
                stopped = RunInterrupted(stop.received, "before the time loop; nothing to resume")
                stopped.__cause__, err = err, stopped
            status = end_with(err, comm, failures, debug=args.debug)
    failures.Free()
    return status


if __name__ == "__main__":
    sys.exit(main())
