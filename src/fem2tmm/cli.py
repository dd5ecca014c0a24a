"""Command line: ``fem2tmm run | demo | bench | inspect | network reduce | --version``.

Exit status: 0 success, 2 user error (:class:`~fem2tmm.errors.Fem2TmmError`: one message, no traceback),
1 internal error (:class:`~fem2tmm.errors.InternalError`: a bug, to be reported).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from ._version import __version__
from .case.types import TRANSIENT_METHODS
from .errors import Fem2TmmError, InternalError


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fem2tmm", description="Structural FE mesh -> reduced thermal model.")
    p.add_argument("--version", action="version", version=f"fem2tmm {__version__}")
    sub = p.add_subparsers(dest="command")
    r = sub.add_parser("run", help="run a case file")
    r.add_argument("case", help="case file (TOML)")
    r.add_argument("--out", default=None, help="output folder (default: <case name>-out next to the case)")
    r.add_argument("--no-reference", action="store_true", help="do not solve the detailed reference model")
    r.add_argument("--quiet", action="store_true", help="no progress output (the result table and the output folder "
                                                       "are printed)")
    r.add_argument("--scheduler", default=None,
                   help="where the work runs: serial (default, in-process), local (a Dask LocalCluster on this "
                        "machine's cores) or a Dask scheduler address tcp://host:8786; overrides [compute] scheduler")
    r.add_argument("--cache", default=None, metavar="DIR",
                   help="stage cache folder shared by runs (default: <out>/.cache)")
    d = sub.add_parser("demo", help="built-in baffle study (no input files needed)")
    d.add_argument("--out", default="fem2tmm-demo", help="output folder (default: ./fem2tmm-demo)")
    d.add_argument("--quiet", action="store_true", help="no progress output")
    b = sub.add_parser("bench", help="benchmarks of a source checkout (benchmarks/); one JSON object per line")
    b.add_argument("names", nargs="*", help="benchmarks to run (default: all); 'list' lists them")
    i = sub.add_parser("inspect", help="what a mesh holds: groups, regions, pieces, cards (before writing a case); "
                                       "given a case file, also what its parts' counts do")
    i.add_argument("mesh", help="mesh file (Nastran bulk data or Gmsh .msh), or a case file (.toml)")
    i.add_argument("--unit", default="m", help="length unit of the file (default m)")
    i.add_argument("--unit-system", default=None, help="Nastran unit system of material values (e.g. mm-t-s)")
    i.add_argument("--json", action="store_true", help="print the report as JSON")
    rc = sub.add_parser("recover", help="temperatures computed outside fem2tmm (CSV: super node, columns in degC) "
                                          "back onto every FE node")
    rc.add_argument("out_dir", help="output folder of a fem2tmm run (its reduced.npz and temperatures.vtu)")
    rc.add_argument("--temperatures", required=True,
                    help="CSV with a header row: super-node name, then one column per time or case (degC); optional "
                         "rows: a named load (W or W/m2), 'sink' (degC), and 'time' (s: that time's orbital loads) "
                         "or 'position' (orbit position from 1: its loads) per column")
    rc.add_argument("--out", default=None, help="output folder (default: <OUT_DIR>-recovered next to it)")
    rc.add_argument("--in-time", action="store_true",
                    help="the columns are one transient (a 'time' row, increasing; the first column its start): "
                         "integrate the heat stored inside each super node between them instead of recovering "
                         "each column on its own; loads and sink linear between columns (give a column at each "
                         "change of a load)")
    rc.add_argument("--step", type=float, default=None, help="with --in-time: largest sub-step (s; default: "
                                                               "one step per interval between columns)")
    rc.add_argument("--scheme", default="crank-nicolson", choices=TRANSIENT_METHODS,
                    help="with --in-time: the time scheme (default crank-nicolson, as ESATAN's SLCRNC)")
    _network_parser(sub)
    return p


def _network_parser(sub) -> None:
    """``fem2tmm network reduce DECK [--case net.toml] [--pf P] [--dtmax K] [--coordinates nodes.csv] --out DIR``."""
    n = sub.add_parser("network", help="reduce an existing thermal network (ESATAN / SINDA deck, reduced.npz)")
    nsub = n.add_subparsers(dest="network_command")
    r = nsub.add_parser("reduce", help="automatic grouping (or TMRT sets) of a network deck")
    r.add_argument("deck", help="ESATAN input deck, SINDA/FLUINT deck or fem2tmm reduced.npz")
    r.add_argument("--case", default=None, help="network case file (TOML): grouping, criteria, load cases, tmrt")
    r.add_argument("--pf", type=float, default=None, help="conductance filter p_f (default: the sweep's best)")
    r.add_argument("--dtmax", type=float, default=None, help="temperature filter in K (default: the sweep's best)")
    r.add_argument("--coordinates", default=None, help="nodes.csv with columns node,x,y,z in m")
    r.add_argument("--out", required=True, help="output folder (new or empty)")
    r.add_argument("--quiet", action="store_true", help="no summary line")


def _network(args) -> int:
    """``fem2tmm network reduce``: see :mod:`fem2tmm.lpm.driver`."""
    if args.network_command != "reduce":
        raise Fem2TmmError("usage: fem2tmm network reduce DECK [--case net.toml] [--pf P] [--dtmax K] "
                           "[--coordinates nodes.csv] --out DIR")
    from .lpm.driver import network_reduce

    res = network_reduce(args.deck, case=args.case, pf=args.pf, dtmax=args.dtmax, coordinates=args.coordinates,
                         out=args.out)
    if not args.quiet:
        print(f"{res.detailed.n} -> {res.reduced.n} nodes (r_r = {res.ratio:.3f}), criteria "
              f"{'met' if res.passed else 'NOT met'}; outputs in {args.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command is None:
        _parser().print_help()
        return 2
    old_format = warnings.formatwarning
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            warnings.formatwarning = lambda msg, cat, *a, **k: f"warning: {msg}\n"
            if args.command == "run":
                return _run(args)
            if args.command == "demo":
                from .demo import run_demo

                return run_demo(out=args.out, quiet=args.quiet)
            if args.command == "network":
                return _network(args)
            if args.command == "inspect":
                return _inspect(args)
            if args.command == "recover":
                return _recover(args)
            if args.command == "bench":
                return _bench(args.names)
    except Fem2TmmError as exc:
        print(f"fem2tmm: error: {exc}", file=sys.stderr)
        return 2
    except InternalError as exc:
        print(f"fem2tmm: internal error: {exc}\nThis is a bug in fem2tmm {__version__}: please report it with the "
              "case file and this message.", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("fem2tmm: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the output went to a command that stopped reading it (fem2tmm inspect ... | head)
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # nothing more to flush at exit
        return 0
    finally:
        warnings.formatwarning = old_format
    return 0


def _recover(args) -> int:
    import numpy as np

    from .recovering import recover

    src = Path(args.out_dir)
    out = Path(args.out) if args.out else src.with_name(src.name + "-recovered")
    if not args.in_time and (args.step is not None or args.scheme != "crank-nicolson"):
        raise Fem2TmmError("--step and --scheme go with --in-time (recovering the columns as one transient)")
    res = recover(src, args.temperatures, out=out, in_time=args.in_time, step=args.step, scheme=args.scheme)
    T = res["temperature"]
    print(f"{T.shape[1]} column(s) recovered onto {int(np.isfinite(T[:, 0]).sum())} nodes "
          f"({np.nanmin(T):.2f} .. {np.nanmax(T):.2f} °C); outputs in {res['out']}")
    return 0


def _inspect(args) -> int:
    import json

    from .inspection import inspect_mesh, inspection_text, with_case_thickness

    if str(args.mesh).lower().endswith(".toml"):  # a case: its mesh, with its parts' counts
        from .case import Case
        from .pipeline import check_mesh_file

        case = Case.from_toml(args.mesh)
        check_mesh_file(case)
        parts = [(p.name, list(p.groups), p.super_nodes) for p in case.parts]
        system = args.unit_system or getattr(case.mesh, "unit_system", None)
        rep = with_case_thickness(inspect_mesh(case.mesh.file, unit=case.mesh.unit, unit_system=system, parts=parts),
                                  case)
        rep["unit_key"] = "[mesh] unit"  # where the unit comes from (what a size warning advises to change)
    else:
        rep = inspect_mesh(args.mesh, unit=args.unit, unit_system=args.unit_system)
    print(json.dumps(rep, indent=2) if args.json else inspection_text(rep))
    return 0


def _run(args) -> int:
    from .case import Case
    from .export.output import check_output_place

    case = Case.from_toml(args.case)
    if args.scheduler is not None:
        from dataclasses import replace

        from .case import check_scheduler

        case = replace(case, compute=replace(case.compute, scheduler=check_scheduler(args.scheduler, "--scheduler")))
    out = Path(args.out) if args.out else Path(args.case).with_name(Path(args.case).stem + "-out")
    check_output_place(out)  # within a second, before the heavy imports and any computation

    from .pipeline import run

    result = run(case, out=out, quiet=args.quiet, reference=False if args.no_reference else None,
                 cache=Path(args.cache) if args.cache else None)
    from .export.summary import cases_table, summary_table  # --quiet hides the progress, never the result

    print(cases_table(result.summary) if "cases" in result.summary else summary_table(result.summary))
    print(f"outputs in {result.out}")
    return 0


def _checkout() -> Path:
    """The source checkout whose ``benchmarks/run.py`` ``fem2tmm bench`` runs: the first folder holding one, searched
    upwards from the current directory, then from this package's source file."""
    for start in (Path.cwd(), Path(__file__).resolve().parent):
        for folder in (start, *start.parents):
            if (folder / "benchmarks" / "run.py").is_file():
                return folder
    raise Fem2TmmError("fem2tmm bench runs the benchmarks of a source checkout (benchmarks/run.py), and none was "
                       "found above the current directory or the installed package: run it from a source checkout "
                       "of fem2tmm")


def _bench(names: list[str]) -> int:
    root = str(_checkout())
    if root not in sys.path:
        sys.path.insert(0, root)
    from benchmarks.run import main as bench_main

    return bench_main(names)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
