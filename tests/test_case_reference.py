"""docs/case-file.md lists every key the case-file parser accepts, each in the table of its own section, so the
reference cannot fall behind the code.

The accepted keys are read from the parser's source (fem2tmm/case.py): every ``self.table(data, where, allowed,
...)`` call names its section (``where``: "[mesh]", f"[materials.{name}]", f"[[parts]][{i}]", "case" for the top
level, ...) and its allowed keys (a set literal, or a module-level set/frozenset/dict constant).  A table whose
keys are user-chosen names (``[materials]``, ``[optics]``: ``set(...)`` of the data) has no fixed keys.  A call
whose keys cannot be read this way fails the test, so a new way of declaring keys cannot slip through unchecked."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import fem2tmm.case

DOC = Path(__file__).resolve().parents[1] / "docs" / "case-file.md"


def _section(node: ast.expr, local: dict[str, ast.expr]) -> str:
    """The section name of a ``where`` argument (a string, an f-string, or a local variable holding one):
    "[mesh]" -> "mesh", f"[materials.{name}]" -> "materials", f"[[parts]][{i}]" -> "parts", "case" -> ""."""
    if isinstance(node, ast.Name) and node.id in local:
        node = local[node.id]
    if isinstance(node, ast.Constant):
        text = node.value
    elif isinstance(node, ast.JoinedStr):
        text = "".join(v.value if isinstance(v, ast.Constant) else "{}" for v in node.values)
    else:
        raise AssertionError(f"case.py line {node.lineno}: cannot read the section of a table() call")
    if text == "case":
        return ""
    m = re.match(r"\[*([A-Za-z_]+)", text)
    assert m, f"case.py line {node.lineno}: unexpected section {text!r}"
    return m.group(1)


def _constants(tree: ast.Module) -> dict[str, ast.expr]:
    out = {}
    for st in tree.body:
        if isinstance(st, (ast.Assign, ast.AnnAssign)):
            targets = st.targets if isinstance(st, ast.Assign) else [st.target]
            for t in targets:
                if isinstance(t, ast.Name) and st.value is not None:
                    out[t.id] = st.value
    return out


def _keys(node: ast.expr, consts: dict[str, ast.expr]) -> set[str] | None:
    """The string keys of an ``allowed`` argument; None for user-named tables (``set(data)``)."""
    if isinstance(node, ast.Name) and node.id in consts:
        return _keys(consts[node.id], consts)
    if isinstance(node, (ast.Set, ast.List, ast.Tuple)):
        return {e.value for e in node.elts if isinstance(e, ast.Constant)}
    if isinstance(node, ast.Dict):
        return {k.value for k in node.keys if isinstance(k, ast.Constant)}
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        if node.func.id == "frozenset" and node.args:
            return _keys(node.args[0], consts)
        if node.func.id == "set":  # set(<the data>): a table of user-chosen names
            return None
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitOr):  # a | b
        a, b = _keys(node.left, consts), _keys(node.right, consts)
        return (a or set()) | (b or set())
    raise AssertionError(f"case.py line {node.lineno}: cannot read the allowed keys of a table() call")


def accepted_keys() -> dict[str, set[str]]:
    """Section name ("" = top level) -> keys the parser accepts there."""
    # the case package, every module of it read as one (its tables are split by module)
    tree = ast.Module(body=[node for f in sorted(Path(fem2tmm.case.__file__).parent.glob("*.py"))
                            for node in ast.parse(f.read_text(encoding="utf-8")).body], type_ignores=[])
    consts = _constants(tree)
    out: dict[str, set[str]] = {}
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef):
            continue
        local: dict[str, ast.expr] = {}  # the first string assigned to each local name (where = "[...]")
        for st in ast.walk(fn):
            if isinstance(st, ast.Assign) and isinstance(st.value, (ast.Constant, ast.JoinedStr)):
                for t in st.targets:
                    if isinstance(t, ast.Name):
                        local.setdefault(t.id, st.value)
        for node in ast.walk(fn):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "table"
                    and len(node.args) >= 3):
                keys = _keys(node.args[2], consts)
                if keys is not None:
                    out.setdefault(_section(node.args[1], local), set()).update(keys)
    return out


def documented_keys() -> dict[str, set[str]]:
    """Section name -> keys in the first column of the tables under its heading ("## Top level" = "", then
    "### [name]", "### [name.NAME]", "### [[name]]")."""
    out: dict[str, set[str]] = {}
    section = None
    for line in DOC.read_text(encoding="utf-8").splitlines():
        if line.startswith("#"):
            m = re.match(r"#+\s*\[*([A-Za-z_]+)", line)
            section = "" if line.strip() == "## Top level" else (m.group(1) if m and "[" in line else None)
            continue
        m = re.match(r"\|\s*`([A-Za-z_0-9]+)`\s*\|", line)
        if m and section is not None:
            out.setdefault(section, set()).add(m.group(1))
    return out


def test_every_accepted_key_is_in_the_reference():
    acc, doc = accepted_keys(), documented_keys()
    # the reading itself: the sections and keys we know are there
    assert {"", "mesh", "materials", "optics", "parts", "boundary", "environment", "radiation", "reduction",
            "clustering", "reference", "solver"} <= set(acc)
    assert {"conductivity", "density", "specific_heat"} <= acc["materials"] and "sun_direction" in acc["environment"]
    missing = sorted(f"[{s or 'top level'}] {k}" for s, keys in acc.items() for k in keys - doc.get(s, set()))
    assert not missing, f"keys accepted by case.py but not documented in {DOC.name} (add a table row): {missing}"
    # and nothing documented that the parser refuses (a renamed or removed key)
    stale = sorted(f"[{s or 'top level'}] {k}" for s, keys in doc.items() if s in acc for k in keys - acc[s])
    assert not stale, f"keys documented in {DOC.name} that case.py does not accept: {stale}"
