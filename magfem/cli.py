"""The ``magfem`` command line.

    magfem check CASE [--set KEY=VALUE ...]     validate a case, print its summary
    magfem mesh  CASE [--out DIR] [--format F]  build the robot mesh, write DIR/<name>.msh (.vtu)
    magfem field CASE [--out DIR]               solve the applied field, write VTX/CSV/PNG
    magfem run   CASE [--out DIR]               mesh + field + dynamics, write all outputs
    magfem sweep CASE --param NAME=VALUES ...   parameter sweep, resumable (magfem.sweep)
    magfem report [--run] [--only SCENE ...]    assemble docs/scenes.md (magfem.report)

Safe under ``mpirun -n N``: every rank parses the case and takes part in the
collective work, only rank 0 prints. Bad input gives one line on stderr,
``magfem: error: FILE: KEY = VALUE: what is allowed``, and exit status 2,
with no traceback.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from mpi4py import MPI

from magfem import __version__
from magfem.case import Case, FieldCase, load_case, load_field_case, write_resolved_case
from magfem.config import CaseError
from magfem.field.run import run_field
from magfem.geometry.export import export_robot_mesh
from magfem.geometry.robot_mesh import create_robot_mesh
from magfem.parallel import rank0_print
from magfem.pipeline import describe_fluid_of, simulate
from magfem.report import build_report
from magfem.sweep import parse_param, run_sweep

__all__ = ["main"]

EXIT_USAGE = 2
EXIT_FAILURE = 1


def _say(comm: MPI.Comm, *args: object) -> None:
    rank0_print(*args, comm=comm)


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
    resolution = case.resolution()
    if resolution:
        lines.append(f"bending   {resolution}")
    lines += describe_fluid_of(case)
    return "\n".join(lines)


def _cmd_check(args: argparse.Namespace, case: Case, comm: MPI.Comm) -> int:
    _say(comm, _summary(case))
    _say(comm, f"{args.case}: OK")
    return 0


def _cmd_mesh(args: argparse.Namespace, case: Case, comm: MPI.Comm) -> int:
    out = Path(args.out) if args.out else Path("meshes")
    msh = out / f"{case.name}.msh"
    t0 = time.perf_counter()
    rm = create_robot_mesh(case.robot, case.mesh, comm, msh_path=msh)
    ncells = rm.mesh.topology.index_map(rm.mesh.topology.dim).size_global
    _say(comm, _summary(case))
    _say(
        comm, f"meshed    {ncells} cells in {time.perf_counter() - t0:.2f} s on {comm.size} rank(s)"
    )
    _say(comm, "groups    " + ", ".join(sorted(rm.groups)))
    _say(comm, f"wrote     {msh}")
    if args.format != "msh":
        path = export_robot_mesh(msh, args.format, comm, strip=rm.model == "strip")
        _say(comm, f"wrote     {path}")
    return 0


def _cmd_field(args: argparse.Namespace, case: Case | FieldCase, comm: MPI.Comm) -> int:
    outdir = _outdir(args, case)
    _write_resolved(case, outdir, comm)
    written = run_field(case, outdir, comm)
    for label, path in written.items():
        _say(comm, f"wrote     {label}: {path}")
    return 0


def _cmd_run(args: argparse.Namespace, case: Case, comm: MPI.Comm) -> int:
    outdir = _outdir(args, case)
    _say(comm, _summary(case))
    resolved = _write_resolved(case, outdir, comm)
    _say(comm, f"wrote     resolved case: {resolved}")
    t0 = time.perf_counter()
    result = simulate(case, outdir, comm, progress=not args.quiet)
    _say(comm, f"finished  in {time.perf_counter() - t0:.1f} s on {comm.size} rank(s)")
    for label, path in result.paths.items():
        _say(comm, f"wrote     {label}: {path}")
    return 0


def _write_resolved(case: Case | FieldCase, outdir: Path, comm: MPI.Comm) -> Path:
    path = outdir / "case.resolved.toml"
    if comm.rank == 0:
        write_resolved_case(case, path)
    comm.barrier()
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
        echo=None if args.quiet else print,
    )
    failed = [r["point"] for r in result.records if r.get("status") != "done"]
    _say(
        comm,
        f"sweep     {len(result.records)} point(s): ran {len(result.ran)}, "
        f"reused {len(result.skipped)}, not done {len(failed)}",
    )
    for label, path in result.paths.items():
        _say(comm, f"wrote     {label}: {path}")
    return 0 if not failed else EXIT_FAILURE


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
        echo=None if args.quiet else print,
    )
    _say(comm, f"wrote     report: {path}")
    return 0


_COMMANDS = {"check": _cmd_check, "mesh": _cmd_mesh, "run": _cmd_run}
_DRIVERS = {"sweep": _cmd_sweep, "report": _cmd_report}


def _add_overrides(parser: argparse.ArgumentParser, text: str) -> None:
    parser.add_argument(
        "--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE", help=text
    )


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="magfem",
        description="Finite-element simulation of untethered hard-magnetic soft robots.",
    )
    p.add_argument("--version", action="version", version=f"magfem {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    helps = {
        "check": "validate a case file without running it",
        "mesh": "build the robot mesh and write the .msh file (default under meshes/)",
        "field": "solve the applied magnetic field and write VTX/CSV/PNG",
        "run": "run the case end to end (mesh, field, dynamics, outputs)",
    }
    for name, text in helps.items():
        s = sub.add_parser(name, help=text, description=text)
        s.add_argument("case", help="case file (TOML)")
        _add_overrides(s, "override a case value, e.g. --set time.end=50ms")
        if name != "check":
            s.add_argument("--out", help="output directory (default output/<case name>)")
        if name == "run":
            s.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
        if name == "mesh":
            s.add_argument(
                "--format",
                choices=("msh", "vtu", "vtk"),
                default="msh",
                help="also write the mesh with its groups as VTK (vtu, vtk) for ParaView "
                "and other tools (default: only the gmsh .msh)",
            )
    text = "run a case over a grid of parameter values in parallel processes (resumable)"
    s = sub.add_parser("sweep", help=text, description=text)
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
    s.add_argument("--retry-failed", action="store_true", help="rerun points that failed")
    s.add_argument(
        "--paired",
        action="store_true",
        help="pair the --param lists element by element (equal lengths) instead of crossing them",
    )
    s.add_argument("-q", "--quiet", action="store_true", help="no per-point lines")
    text = "run (or reuse) the scene studies and write docs/scenes.md"
    s = sub.add_parser("report", help=text, description=text)
    s.add_argument("--run", action="store_true", help="run missing studies (else only read)")
    s.add_argument("--only", action="append", default=[], metavar="SCENE", help="scene id(s)")
    s.add_argument("--jobs", type=int, default=2, help="runs at the same time")
    s.add_argument("--out", default="output/report", help="where the runs go")
    s.add_argument("--docs", default="docs", help="docs directory (scenes.md, figures/)")
    s.add_argument("--retry-failed", action="store_true", help="rerun runs that failed")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``magfem`` console script; returns the exit status."""
    args = _parser().parse_args(argv)
    comm = MPI.COMM_WORLD
    try:
        if args.command in _DRIVERS:
            return _DRIVERS[args.command](args, comm)
        if args.command == "field":  # [robot], [mesh], [material] optional
            return _cmd_field(args, load_field_case(args.case, args.overrides), comm)
        case = load_case(args.case, args.overrides)
        return _COMMANDS[args.command](args, case, comm)
    except CaseError as err:
        if comm.rank == 0:
            print(f"magfem: error: {err}", file=sys.stderr, flush=True)
        return EXIT_USAGE
    except KeyboardInterrupt:
        if comm.rank == 0:
            print("magfem: interrupted; outputs written so far are kept", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
