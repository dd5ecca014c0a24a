"""The user documents say what is true: the README's quickstart and Python snippet run as pasted, every command,
flag and case-file key they name exists, every relative link resolves, and they carry no internal issue numbers.

User documents: README.md, docs/*.md except docs/design-notes.md (the developers' notes), the examples' READMEs.
The commands are run in a temporary folder with this checkout's ``meshes/`` linked in, through the same Python and
the same fem2tmm package as the tests (``python -m fem2tmm.cli``), each within 30 s once the ray tracer's kernels are
compiled (the README's first set-up command, ``fem2tmm demo``, compiles them and is allowed the README's 45 s and
some margin)."""

from __future__ import annotations

import ast
import copy
import os
import re
import shlex
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

import fem2tmm
import fem2tmm.case
import fem2tmm.cli
from fem2tmm.errors import Fem2TmmError

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
USER_DOCS = [README] + sorted(p for p in (ROOT / "docs").glob("*.md") if p.name != "design-notes.md") \
    + sorted((ROOT / "examples").glob("*/README.md"))
COMMAND_LIMIT_S = 30.0  # the issue's bound for each quickstart command and the Python snippet
FIRST_RUN_LIMIT_S = 120.0  # fem2tmm demo right after an installation: ~45 s of numba compilation (README)


# ------------------------------------------------------------------------------------------- markdown reading
def fenced_blocks(text: str) -> list[tuple[str, str, str]]:
    """(language, body, the ``##`` section it is in) of every fenced code block, in order."""
    out, section, lang, body = [], "", None, []
    for line in text.splitlines():
        if lang is None:
            if line.startswith("## "):
                section = line[3:].strip()
            m = re.match(r"^```\s*([\w+-]*)\s*$", line)
            if m:
                lang, body = m.group(1), []
        elif line.startswith("```"):
            out.append((lang, "\n".join(body) + "\n", section))
            lang = None
        else:
            body.append(line)
    assert lang is None, "a fenced code block is not closed"
    return out


def prose(text: str) -> str:
    """The text outside fenced code blocks."""
    return re.sub(r"^```.*?^```[^\n]*$", "", text, flags=re.S | re.M)


def code_spans(text: str) -> list[str]:
    """Inline code spans of the prose (single backticks)."""
    return re.findall(r"`([^`\n]+)`", prose(text))


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped (letters, digits, _ and - kept), spaces -> -."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    for line in prose(path.read_text(encoding="utf-8")).splitlines():
        m = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if m:
            s = slug(m.group(1))
            n = seen.get(s, 0)
            out.add(s if n == 0 else f"{s}-{n}")
            seen[s] = n + 1
    return out


# ----------------------------------------------------------------------------------------- (e) README's size
def test_readme_is_short():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines (at most 250: move details to docs/)"
    long = [(i + 1, len(ln)) for i, ln in enumerate(lines) if len(ln) > 300]
    assert not long, f"README.md lines over 300 characters (line, length): {long}"


# ------------------------------------------------------------------------------- (a) the README as pasted
def _env(tmp: Path) -> dict:
    """This test's Python and fem2tmm package for the pasted commands: a ``fem2tmm`` on PATH that runs
    ``python -m fem2tmm.cli`` with the package the tests import."""
    bin_dir = tmp / ".bin"
    bin_dir.mkdir()
    shim = bin_dir / "fem2tmm"
    shim.write_text(f'#!/bin/sh\nexec {shlex.quote(sys.executable)} -m fem2tmm.cli "$@"\n')
    shim.chmod(0o755)
    env = dict(os.environ)
    src = str(Path(fem2tmm.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([src, str(ROOT)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    env["PATH"] = os.pathsep.join([str(bin_dir), env.get("PATH", "")])
    return env


def _run(cmd: list[str] | str, cwd: Path, env: dict, limit: float) -> float:
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, env=env, shell=isinstance(cmd, str), capture_output=True, text=True,
                       timeout=limit + 60)
    dt = time.perf_counter() - t0
    assert p.returncode == 0, f"{cmd!r} exited {p.returncode}:\n{p.stdout[-3000:]}\n{p.stderr[-3000:]}"
    assert "Traceback" not in p.stderr, f"{cmd!r} printed a traceback:\n{p.stderr[-3000:]}"
    assert dt < limit, f"{cmd!r} took {dt:.1f} s (limit {limit:.0f} s)"
    return dt


def _shell_lines(body: str) -> list[str]:
    """The command lines of a bash block (comment-only and empty lines dropped; trailing comments are bash's)."""
    return [ln for ln in body.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


def _setup_commands() -> list[str]:
    blocks = [b for lang, b, sec in fenced_blocks(README.read_text(encoding="utf-8"))
              if sec == "Set up" and lang == "bash"]
    assert len(blocks) == 1, "the README's 'Set up' section has one bash block"
    cmds = _shell_lines(blocks[0])
    assert len(cmds) == 2, f"the README gives exactly two set-up commands, found {cmds}"
    return cmds


def test_setup_commands_make_a_venv_and_ci_runs_the_test_command():
    """Both set-up commands create or enter a virtual environment (Debian's Python refuses pip install otherwise),
    the second is the test command, and .ci/run runs it exactly as written."""
    install, tests = _setup_commands()
    for cmd in (install, tests):
        assert cmd.startswith("python3 -m venv .venv && . .venv/bin/activate && "), cmd
    assert "fem2tmm demo" in install and tests.endswith("python -m pytest")
    assert "python3-venv" in README.read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert tests in [ln.strip() for ln in ci], f".ci/run does not run the README's test command {tests!r}"


def test_quickstart_and_snippet_run_as_pasted(tmp_path):
    """The demo of set-up command 1, then every command of the quickstart in order, its case file written where
    its first line says, and the Python snippet: each exits 0 within 30 s, and they write what the README says."""
    env = _env(tmp_path)
    (tmp_path / "meshes").symlink_to(ROOT / "meshes", target_is_directory=True)
    install, _ = _setup_commands()
    demo = install.split("&&")[-1].strip()
    assert demo == "fem2tmm demo"
    _run(demo, tmp_path, env, FIRST_RUN_LIMIT_S)
    assert (tmp_path / "fem2tmm-demo" / "summary.json").is_file()

    blocks = [(lang, b) for lang, b, sec in fenced_blocks(README.read_text(encoding="utf-8"))
              if sec.startswith("Quickstart")]
    assert [lang for lang, _ in blocks].count("python") == 1 and any(lang == "toml" for lang, _ in blocks)
    ran = 0
    for lang, body in blocks:
        if lang == "bash":
            for line in _shell_lines(body):
                _run(line, tmp_path, env, COMMAND_LIMIT_S)
                ran += 1
        elif lang == "toml":
            first = body.splitlines()[0]
            m = re.match(r"^#\s*(\S+\.toml)\s*$", first)
            assert m, f"a quickstart TOML block starts with '# <its file name>', got {first!r}"
            target = tmp_path / m.group(1)
            assert target.parent.is_dir(), f"{m.group(1)}: its folder is made by an earlier quickstart command"
            target.write_text(body, encoding="utf-8")
        elif lang == "python":
            script = tmp_path / "snippet.py"
            script.write_text(body, encoding="utf-8")
            _run([sys.executable, str(script)], tmp_path, env, COMMAND_LIMIT_S)
            ran += 1
        else:
            pytest.fail(f"quickstart block of unexpected language {lang!r}")
    assert ran >= 4
    assert (tmp_path / "my-study" / "case-out" / "summary.json").is_file()
    assert (tmp_path / "my-study" / "case-out" / "model.esatan").is_file()
    assert (tmp_path / "my-study" / "python-out" / "summary.json").is_file()


# ------------------------------------------------------------------ (b) commands, flags and keys exist
def _cli_tree():
    """{command path (tuple): set of its option strings} and {command path: set of its subcommands}."""
    import argparse

    options: dict[tuple, set[str]] = {}
    subs: dict[tuple, set[str]] = {}

    def walk(parser, path):
        options[path] = {s for a in parser._actions for s in a.option_strings}
        for a in parser._actions:
            if isinstance(a, argparse._SubParsersAction):
                subs[path] = set(a.choices)
                for name, p in a.choices.items():
                    walk(p, path + (name,))

    walk(fem2tmm.cli._parser(), ())
    return options, subs


def _command_mentions(text: str) -> list[str]:
    """Every ``fem2tmm ...`` command as written: code-block lines and inline code spans, up to a comment, a pipe,
    ``&&`` or ``;``."""
    out = []
    for lang, body, _ in fenced_blocks(text):
        if lang in ("toml", "python"):
            continue
        out += [ln for ln in body.splitlines()]
    out += code_spans(text)
    cmds = []
    for s in out:
        s = s.split(" #")[0]
        for part in re.split(r"&&|\|(?!\s*[\w-]+\|)|;", s):
            m = re.search(r"(?:^|\s)fem2tmm(\s+.*)$", part)
            if m:
                cmds.append(m.group(1).strip())
    return cmds


def _bench_names() -> set[str]:
    sys.path.insert(0, str(ROOT))
    try:
        from benchmarks.run import REGISTRY
    finally:
        sys.path.remove(str(ROOT))
    return set(REGISTRY) | {"pipeline", "list"}


@pytest.mark.parametrize("doc", USER_DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_commands_and_flags_named_exist(doc):
    options, subs = _cli_tree()
    every_flag = set().union(*options.values())
    benches = _bench_names()
    text = doc.read_text(encoding="utf-8")
    bad = []
    for cmd in _command_mentions(text):
        words = cmd.replace("[", " ").replace("]", " ").replace("|", " ").split()
        path: tuple = ()
        i = 0
        while path in subs and i < len(words) and not words[i].startswith("-"):
            w = words[i]
            if w not in subs[path]:
                if re.fullmatch(r"[a-z][a-z_]*", w):
                    bad.append(f"fem2tmm {cmd}: no command {' '.join(path + (w,))!r}")
                break
            path += (w,)
            i += 1
        if path == ("bench",):
            for w in words[i:]:
                if re.fullmatch(r"[a-z][a-z0-9_]*", w) and w not in benches:
                    bad.append(f"fem2tmm {cmd}: no benchmark {w!r}")
        for w in words[i:]:
            if w.startswith("--"):
                flag = w.split("=")[0].rstrip(",.)`")
                if flag not in options.get(path, set()):
                    bad.append(f"fem2tmm {cmd}: {' '.join(('fem2tmm',) + path)} has no option {flag}")
    # a flag named on its own (`--no-reference`) belongs to some fem2tmm command
    for span in code_spans(text):
        m = re.fullmatch(r"(--[a-z][a-z-]*)(\s+\S+)?", span.strip())
        if m and m.group(1) not in every_flag:
            bad.append(f"`{span}`: no fem2tmm command has the option {m.group(1)}")
    assert not bad, f"{doc.relative_to(ROOT)}:\n" + "\n".join(bad)


def _probe_base() -> tuple[dict, Path]:
    folder = ROOT / "examples" / "smallsat"
    return tomllib.loads((folder / "case_transient.toml").read_text(encoding="utf-8")), folder


def _allowed(section: str, mutate) -> set[str]:
    """The keys the case parser accepts in ``section``, read from its own refusal of an unknown key (the public
    ``fem2tmm.case.Case.from_dict``: no reading of the parser's source)."""
    raw, folder = _probe_base()
    data = copy.deepcopy(raw)
    mutate(data, {"zz_unknown_key": 1})
    with pytest.raises(Fem2TmmError) as info:
        fem2tmm.case.Case.from_dict(data, base_dir=folder, source="probe")
    m = re.search(r"unknown key\(s\) 'zz_unknown_key'; allowed: (.*)$", str(info.value))
    assert m, f"[{section}]: the parser's refusal of an unknown key changed its form: {info.value}"
    return {k.strip() for k in m.group(1).split(",")}


_PROBES = {
    "": lambda d, x: d.update(x),
    "mesh": lambda d, x: d["mesh"].update(x),
    "materials": lambda d, x: next(iter(d["materials"].values())).update(x),
    "optics": lambda d, x: next(iter(d["optics"].values())).update(x),
    "parts": lambda d, x: d["parts"][0].update(x),
    "joints": lambda d, x: d.__setitem__("joints", [x]),
    "boundary": lambda d, x: d["boundary"][0].update(x),
    "environment": lambda d, x: d["environment"].update(x),
    "radiation": lambda d, x: d["radiation"].update(x),
    "reduction": lambda d, x: d.__setitem__("reduction", x),
    "clustering": lambda d, x: d.__setitem__("clustering", x),
    "reference": lambda d, x: d["reference"].update(x),
    "transient": lambda d, x: d["transient"].update(x),
    "solver": lambda d, x: d.__setitem__("solver", x),
    "sweep": lambda d, x: d.__setitem__("sweep", x),
    "export": lambda d, x: d.__setitem__("export", x),
    "compute": lambda d, x: d.__setitem__("compute", x),
    "orbit": lambda d, x: d["orbit"].update(x),
    "orbit.planet": lambda d, x: d["orbit"].__setitem__("planet", x),
    "orbit.attitude": lambda d, x: d["orbit"]["attitude"].update(x),
}


@pytest.fixture(scope="module")
def schema() -> dict[str, set[str]]:
    out = {s: _allowed(s, f) for s, f in _PROBES.items()}
    assert set(out[""]) - {"cases"} <= {s.split(".")[0] for s in out} | {"sweep"}, \
        f"a top-level section this test does not probe: {sorted(set(out['']) - set(out))}"
    # [[cases]]: a name, and any top-level key except cases, sweep, compute (docs/case-file.md, [[cases]])
    out["cases"] = {"name"} | (out[""] - {"cases", "sweep", "compute"})
    return out


_NAMED = {"materials", "optics"}  # tables of user-named entries
_ARRAYS = {"parts", "joints", "boundary"}  # arrays of tables
_OPEN = {("reduction", "parametric"), ("sweep", "grid"), ("sweep", "zip"), ("sweep", "random")}  # user-named keys


def _check_table(data: dict, section: str, schema: dict, where: str, bad: list):
    allowed = schema[section]
    for key, value in data.items():
        if key not in allowed:
            bad.append(f"{where}: [{section or 'top level'}] has no key {key!r}")
            continue
        sub = f"{section}.{key}" if section else key
        if (section, key) in _OPEN or not isinstance(value, (dict, list)):
            continue
        if section == "cases" or section == "":
            if key in _NAMED and isinstance(value, dict):
                for name, entry in value.items():
                    _check_table(entry, key, schema, f"{where} [{key}.{name}]", bad)
            elif key in _ARRAYS:
                entries = value if isinstance(value, list) else list(value.values())  # [cases.boundary.heater]
                for entry in entries:
                    _check_table(entry, key, schema, f"{where} [[{key}]]", bad)
            elif key == "cases":
                for entry in value:
                    _check_table(entry, "cases", schema, f"{where} [[cases]]", bad)
            elif key in schema and isinstance(value, dict):
                _check_table(value, key, schema, f"{where} [{key}]", bad)
        elif sub in schema and isinstance(value, dict):
            _check_table(value, sub, schema, f"{where} [{sub}]", bad)


@pytest.mark.parametrize("doc", USER_DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_case_keys_named_exist(doc, schema):
    """Every key of every TOML block, every ``[section] key`` named in an inline code span, and every key in the
    tables of docs/case-file.md's case sections is one the case parser accepts."""
    text = doc.read_text(encoding="utf-8")
    bad: list[str] = []
    network = text.find("## Network case file")  # fem2tmm network's own case file: another schema
    for lang, body, section in fenced_blocks(text):
        if lang != "toml" or section.startswith("Network case file"):
            continue
        try:
            data = tomllib.loads(body)
        except tomllib.TOMLDecodeError as e:
            pytest.fail(f"{doc.relative_to(ROOT)}: a TOML block does not parse ({e}):\n{body}")
        _check_table(data, "", schema, str(doc.relative_to(ROOT)), bad)
    for span in code_spans(text[:network] if network >= 0 else text):
        for sec, key in re.findall(r"\[\[?([a-z_]+(?:\.[a-z_]+)?)\]\]?\s+([a-z_]+)\b", span):
            sec = re.sub(r"^(materials|optics)\.[a-z_]+$", r"\1", sec)
            if sec in schema and key not in schema[sec]:
                bad.append(f"`{span}`: [{sec}] has no key {key!r}")
    if doc.name == "case-file.md":
        section = None
        for line in (text[:network] if network >= 0 else text).splitlines():
            m = re.match(r"^###\s+\[\[?([a-z_.A-Z]+)\]\]?\s*$", line)
            if m:
                section = re.sub(r"\.(NAME|[A-Z]+)$", "", m.group(1))
                continue
            if line.startswith("## "):
                section = None
            m = re.match(r"^\|\s*`([a-z_]+)`\s*\|", line)
            if section is not None and m and section in schema and m.group(1) not in schema[section]:
                bad.append(f"docs/case-file.md [{section}] table: no key {m.group(1)!r}")
    assert not bad, "\n".join(bad)


# -------------------------------------------------------------------------------------- (c) link check
@pytest.mark.parametrize("doc", USER_DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc):
    bad = []
    for target in re.findall(r"!?\[[^\]]*\]\(([^)\s]+)\)", prose(doc.read_text(encoding="utf-8"))):
        if re.match(r"^[a-z]+:", target):
            continue  # http(s), mailto: not checked offline
        path, _, anchor = target.partition("#")
        file = (doc.parent / path).resolve() if path else doc
        if not file.exists():
            bad.append(f"{target}: no file {file}")
        elif anchor and (file.suffix != ".md" or anchor not in anchors(file)):
            bad.append(f"{target}: no heading #{anchor} in {file.relative_to(ROOT)}")
    assert not bad, f"{doc.relative_to(ROOT)}: dead links:\n" + "\n".join(bad)


def test_no_design_md_that_is_not_there():
    if (ROOT / "DESIGN.md").exists():
        return
    for doc in USER_DOCS:
        assert "DESIGN.md" not in doc.read_text(encoding="utf-8"), f"{doc.relative_to(ROOT)} names a DESIGN.md"


# ----------------------------------------------------------------------------- (d) no internal issue numbers
ISSUE = re.compile(r"\b[Ii]ssues?\s+#?\d+|(?<![\w&/#])#\d{1,2}\b")


@pytest.mark.parametrize("doc", USER_DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_internal_issue_numbers_in_user_documents(doc):
    hits = [(i + 1, m.group(0)) for i, ln in enumerate(doc.read_text(encoding="utf-8").splitlines())
            for m in ISSUE.finditer(ln)]
    assert not hits, f"{doc.relative_to(ROOT)}: internal issue numbers (line, text): {hits}"


def test_no_internal_issue_numbers_in_cli_output():
    """The strings of the package that can reach a user (every string constant but docstrings)."""
    hits = []
    for f in sorted(Path(fem2tmm.__file__).parent.rglob("*.py")):
        tree = ast.parse(f.read_text(encoding="utf-8"))
        docs = {id(n.body[0].value) for n in ast.walk(tree)
                if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                and n.body and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
        for n in ast.walk(tree):
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs:
                m = ISSUE.search(n.value)
                if m:
                    hits.append(f"{f.relative_to(ROOT)}:{n.lineno}: {m.group(0)!r}")
    assert not hits, "internal issue numbers in strings of the package:\n" + "\n".join(hits)


def test_the_checks_can_fail():
    """The readers above find what they look for: a dead link, an issue number, an unknown flag, a bad key."""
    assert slug("## Network case file (`fem2tmm network reduce`)".lstrip("# ")) == "network-case-file-fem2tmm-network-reduce"
    assert slug("model.esatan, model.sinda") == "modelesatan-modelsinda"
    assert ISSUE.search("see issue 29") and ISSUE.search("goal (#8)") and not ISSUE.search("color: #222;")
    assert _command_mentions("run `fem2tmm run x.toml --nope` # c") == ["run x.toml --nope"]
    options, _ = _cli_tree()
    assert "--nope" not in options[("run",)] and "--out" in options[("run",)]


def test_every_benchmark_says_what_it_measures(capsys):
    # `fem2tmm bench list` gives each benchmark one line a user can read
    sys.path.insert(0, str(ROOT))
    try:
        from benchmarks.run import ABOUT, REGISTRY, main
    finally:
        sys.path.remove(str(ROOT))
    assert set(ABOUT) == set(REGISTRY)
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == len(REGISTRY) and all(len(ln.split(None, 1)) == 2 for ln in lines)
