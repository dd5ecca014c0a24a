"""The package's layout rules, checked on the source text (``ast``), not by importing anything.

* Imports go one way along the stage order (mesh, io, case, fem, cluster, reduce, radiation, solve, then the
  run's result, the exporters that write it, the reduction methods (reductors), and the orchestration: the
  stage adapters (stages), pipeline, demo/cli): no module imports a later stage, and nothing imports the
  package root or the benchmarks (only the ``fem2tmm bench`` entry of the CLI runs the checkout's benchmarks/).
* A reduction method (``reductors``) and every stage package stand on the domain modules below them and never import
  the adapters (``stages``), the pipeline or the CLI ("a method never imports the orchestrator"); the solver knows
  matrices, not reductions (``solve`` takes from ``reduce`` only the reduced network's arrays, ``reduce.network``).
* No import circle anywhere in the package, function-level imports included; no source file over ``MAX_LINES``.
* The installed package holds only the product: no benchmark or study module, no path that leaves the package.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = SRC / "fem2tmm"

#: rank of each top-level module or sub-package: a module may import only modules of a lower or equal rank
#: (equal: inside its own package).  ``case`` (the TOML schema) sits above ``io`` because it checks the mesh unit.
RANK = {
    "_version": 0, "errors": 0, "constants": 0, "progress": 0, "linalg": 0, "arrays": 0, "_validation": 0, "timefunc": 0,
    "cache": 0, "compute": 0,  # stage cache (content hashes) and the executor (in-process or Dask): infrastructure
    "orbit": 0,  # orbit mechanics (planet, Kepler orbit, Sun, eclipses, attitude): an input description, like timefunc
    "mesh": 1,
    "io": 2,
    "case": 3, "loadcases": 3,  # [[cases]]/[sweep] expansion: validated by case, checked from case
    "fem": 4,
    "cluster": 5,
    "reduce": 6,
    "radiation": 7,
    "solve": 8,
    "result": 9, "keys": 9,  # the stage cache's keys: digests of what each stage reads (case, model, network)
    "export": 10,
    "lpm": 11,  # reduction of existing thermal networks (decks in, decks out); its positive-network algorithm
    "reductors": 12,  # the reduction methods (reduce, export, reconstruct): on the domain modules, never the adapters
    "stages": 13, "inspection": 13,  # the adapters from a Case to each stage's plain arrays
    "pipeline": 14,
    "handover": 14, "recovering": 14,  # the network handed over read back and checked; outside temperatures back
    "verify": 14,  # the validity range of the network handed over, checked against the detailed model
    "range_checks": 14,  # the network delivered, its range checked (measured or estimated), the choices made there
    "demo": 15, "cli": 16,
}
#: the stage packages and the reduction methods: never the orchestration, the CLI or a benchmark ("a method never
#: imports the orchestrator")
STAGES = ("mesh", "io", "fem", "cluster", "reduce", "radiation", "solve", "export", "reductors")
#: no source file is longer than this (issue 45: a newcomer reads a module, not a chapter)
MAX_LINES = 900


def _top(pkg: Path, path: Path) -> str:
    """The top-level module or sub-package of ``path`` inside the package folder ``pkg``."""
    return path.relative_to(pkg).with_suffix("").parts[0]


def _imports(src: Path, path: Path) -> list[tuple[int, str]]:
    """(line, absolute dotted module) of every import in ``path`` below ``src`` (function-level imports
    included); ``from . import x`` yields ``package.x`` (x may be a module)."""
    package = list(path.relative_to(src).with_suffix("").parts[:-1])
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            mod = ".".join(base + ([node.module] if node.module else []))
            if node.module is None or mod == "fem2tmm":
                out += [(node.lineno, f"{mod}.{a.name}") for a in node.names]
            else:
                out.append((node.lineno, mod))
    return out


def _violations(src: Path) -> list[str]:
    """Every import of a later stage, of the package root or of the benchmarks in the package below ``src``."""
    pkg = src / "fem2tmm"
    bad = []
    for path in sorted(pkg.rglob("*.py")):
        me = _top(pkg, path)
        if me == "__init__":
            continue  # the package root re-exports the public API
        where = path.relative_to(src)
        for line, mod in _imports(src, path):
            parts = mod.split(".")
            if parts[0] == "benchmarks" and me != "cli":  # only ``fem2tmm bench`` runs the checkout's benchmarks
                bad.append(f"{where}:{line} imports the benchmarks ({mod})")
            if parts[0] != "fem2tmm":
                continue
            if len(parts) == 1 or parts[1] not in RANK:
                bad.append(f"{where}:{line} imports {mod} (the package root or an unranked module)")
            elif RANK[parts[1]] > RANK[me]:
                bad.append(f"{where}:{line} ({me}, rank {RANK[me]}) imports {mod} (rank {RANK[parts[1]]})")
    return bad


def test_every_module_has_a_rank():
    missing = {_top(PKG, p) for p in PKG.rglob("*.py")} - set(RANK) - {"__init__"}
    assert not missing, f"place these modules in the stage order (RANK in {__file__}): {sorted(missing)}"


def test_imports_follow_the_stage_order():
    bad = _violations(SRC)
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("stage", STAGES)
def test_stage_packages_never_import_orchestration(stage):
    later = ("pipeline", "cli", "stages", "demo")
    bad = [f"{p.relative_to(SRC)}:{line} imports {mod}" for p in sorted((PKG / stage).rglob("*.py"))
           for line, mod in _imports(SRC, p)
           if mod.split(".")[0] == "benchmarks" or any(mod.startswith(f"fem2tmm.{x}") for x in later)]
    assert not bad, "\n".join(bad)


def _module_of(src: Path, dotted: str) -> str | None:
    """The module (dotted, a package as itself) that ``dotted`` names below ``src``, or its package when it names an
    object (``fem2tmm.radiation.Surface`` -> ``fem2tmm.radiation``); None outside the package."""
    parts = dotted.split(".")
    if parts[0] != "fem2tmm":
        return None
    while parts:
        base = src.joinpath(*parts)
        if base.with_suffix(".py").is_file() or (base / "__init__.py").is_file():
            return ".".join(parts)
        parts = parts[:-1]
    return None


def _import_graph(src: Path) -> dict[str, set[str]]:
    """module -> the package's modules it imports (module-level and function-level imports alike)."""
    graph = {}
    for path in sorted((src / "fem2tmm").rglob("*.py")):
        rel = path.relative_to(src).with_suffix("")
        me = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        deps = {_module_of(src, mod) for _, mod in _imports(src, path)} - {None, me}
        graph[me] = deps
    return graph


def _circles(src: Path) -> list[list[str]]:
    """Every import circle (a strongly connected set of modules, as one cycle through it) below ``src``."""
    import networkx as nx

    g = nx.DiGraph([(a, b) for a, deps in _import_graph(src).items() for b in deps])
    return [nx.find_cycle(g.subgraph(c)) for c in nx.strongly_connected_components(g) if len(c) > 1]


def test_no_import_circle():
    # issue 45: case <-> loadcases and io.nastran <-> io.nastran_loads were circles through function-level imports
    circles = _circles(SRC)
    assert not circles, "\n".join(" -> ".join(a for a, _ in c) + f" -> {c[0][0]}" for c in circles)


def test_no_source_file_is_over_the_limit():
    long = {str(p.relative_to(SRC)): n for p in PKG.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, f"split these files by concern (at most {MAX_LINES} lines): {long}"


def test_the_solver_knows_matrices_not_reductions():
    bad = [f"{p.relative_to(SRC)}:{line} imports {mod}" for p in sorted((PKG / "solve").rglob("*.py"))
           for line, mod in _imports(SRC, p)
           if mod.startswith("fem2tmm.reduce") and not mod.startswith("fem2tmm.reduce.network")]
    assert not bad, "\n".join(bad)


def test_the_checker_reports_a_circle(tmp_path):
    # the rule can fail: a function-level import that closes a circle is reported (and only the circle)
    (tmp_path / "fem2tmm" / "io").mkdir(parents=True)
    (tmp_path / "fem2tmm" / "__init__.py").write_text("")
    (tmp_path / "fem2tmm" / "io" / "__init__.py").write_text("")
    (tmp_path / "fem2tmm" / "io" / "a.py").write_text("from .b import f\n")
    (tmp_path / "fem2tmm" / "io" / "b.py").write_text("def f():\n    from .a import g\n")
    (tmp_path / "fem2tmm" / "io" / "c.py").write_text("from . import a\n")
    [circle] = _circles(tmp_path)
    assert {a for a, _ in circle} == {"fem2tmm.io.a", "fem2tmm.io.b"}, circle


def test_the_checker_reports_a_backward_import(tmp_path):
    # the rule can fail: a mesh module importing the FE model (also lazily), the root, or a benchmark is reported
    (tmp_path / "fem2tmm" / "mesh").mkdir(parents=True)
    (tmp_path / "fem2tmm" / "mesh" / "bad.py").write_text(
        "from ..fem.model import FEModel\nfrom .. import pipeline\n\n\ndef f():\n    import fem2tmm\n"
        "    from benchmarks.run import main\n")
    (tmp_path / "fem2tmm" / "fem").mkdir()
    (tmp_path / "fem2tmm" / "fem" / "ok.py").write_text("from ..mesh import Mesh\nfrom ..errors import Fem2TmmError\n")
    bad = _violations(tmp_path)
    assert len(bad) == 4 and all(b.startswith("fem2tmm/mesh/bad.py") for b in bad), bad


def test_package_holds_no_benchmark_and_no_path_out_of_it():
    """What setuptools puts in the wheel (``packages.find`` under src/): no benchmark or study module, and no
    source that climbs out of the package to find repository files."""
    from setuptools import find_packages

    packages = find_packages(where=str(SRC))
    assert "fem2tmm" in packages and "fem2tmm.mesh" in packages
    files = [p for pkg in packages for p in (SRC / pkg.replace(".", "/")).glob("*.py")]
    assert len(files) > 40
    named = [str(p.relative_to(SRC)) for p in files if re.search(r"bench|stud(y|ies)", p.name)]
    assert not named, f"benchmark modules inside the package: {named}"
    climbing = [f"{p.relative_to(SRC)}:{i}" for p in files
                for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
                if re.search(r"parents\[\d\]|\.\./\.\.|__file__.*\bparent\.parent", line)]
    assert not climbing, f"paths that leave the package: {climbing}"


def test_internal_error_exits_1_and_asks_for_a_report(monkeypatch, capsys):
    from fem2tmm import cli
    from fem2tmm.errors import InternalError

    def broken(args):
        raise InternalError("an invariant")

    monkeypatch.setattr(cli, "_run", broken)
    assert cli.main(["run", "case.toml"]) == 1
    err = capsys.readouterr().err
    assert "internal error: an invariant" in err and "please report" in err


def test_bench_outside_a_checkout_is_a_clear_user_error(tmp_path, monkeypatch, capsys):
    # an installed wheel: neither the working directory nor the package lies in a checkout with benchmarks/run.py
    from fem2tmm import cli

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(cli, "__file__", str(tmp_path / "site-packages" / "fem2tmm" / "cli.py"))
    assert cli.main(["bench", "list"]) == 2
    assert "run it from a source checkout" in capsys.readouterr().err
    (tmp_path / "benchmarks").mkdir()
    (tmp_path / "benchmarks" / "run.py").write_text("")
    assert cli._checkout() == tmp_path  # found from the working directory


def test_only_the_pipeline_imports_the_stage_adapters():
    # issue 45: the reduction methods stand on the domain modules, not on the adapters (a stage may use another)
    users = sorted({str(p.relative_to(SRC)) for p in PKG.rglob("*.py") for _, mod in _imports(SRC, p)
                    if mod == "fem2tmm.stages" or mod.startswith("fem2tmm.stages.")})
    assert "fem2tmm/pipeline.py" in users
    # the orchestrator: pipeline.py and its delivery step (the network written, its range checked, the choices there)
    orchestrator = ("fem2tmm/pipeline.py", "fem2tmm/range_checks.py")
    assert all(u in orchestrator or u.startswith("fem2tmm/stages/") for u in users), users


def test_a_reduction_method_is_one_module_with_one_reductor():
    # issue 29 item 5: adding a method means adding a file (and its name in REDUCTORS)
    from fem2tmm.reductors import REDUCTORS
    from fem2tmm.reductors.base import Reductor

    assert set(REDUCTORS) == {"thesis", "positive", "radiation_aware"}
    modules = {cls.__module__ for cls in REDUCTORS.values()}
    assert len(modules) == len(REDUCTORS)  # one module each
    for name, cls in REDUCTORS.items():
        assert issubclass(cls, Reductor) and cls.name == name
        assert cls.reduce is not Reductor.reduce  # each method reduces its own way (export, reconstruct: inherited)
