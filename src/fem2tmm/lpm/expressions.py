"""Arithmetic expressions of thermal decks (``0.5 * K_AL * 2.0D-3``, ``(T1 + 2)``), evaluated safely.

Numbers (Fortran ``D`` exponents too), named constants (case-insensitive), ``+ − * / **``, parentheses and the
functions ``SQRT, EXP, LOG, LOG10, SIN, COS, TAN, ABS, MIN, MAX``.  Anything else (array references, function
calls of the deck's own subroutines) is refused with the text that could not be read.
"""

from __future__ import annotations

import ast
import functools
import math
import operator
import re

_BIN = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
        ast.Pow: operator.pow}
_UN = {ast.UAdd: operator.pos, ast.USub: operator.neg}
_FUN = {"SQRT": math.sqrt, "EXP": math.exp, "LOG": math.log, "LOG10": math.log10, "SIN": math.sin,
        "COS": math.cos, "TAN": math.tan, "ABS": abs, "MIN": min, "MAX": max}
_FORTRAN_EXP = re.compile(r"(?<=[0-9.])[dD](?=[-+]?\d)")
_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eEdD][-+]?\d+)?$")


class ExpressionError(ValueError):
    """The expression text cannot be evaluated (message says why)."""


def number(text: str) -> float | None:
    """The value of ``text`` where it is a plain number (Fortran ``D`` exponents too; blanks around it), else None."""
    s = text.strip()
    return float(_FORTRAN_EXP.sub("e", s)) if _NUMBER.match(s) else None


def evaluate(text: str, names: dict[str, float] | None = None) -> float:
    """Value of ``text``; ``names`` maps UPPER-CASE constant names to values.  Raises :class:`ExpressionError`."""
    s = text.strip()
    if _NUMBER.match(s):  # fast path: a plain number
        return float(_FORTRAN_EXP.sub("e", s))
    tree = _parse(s)
    if tree is None:
        raise ExpressionError(f"cannot read the expression {text.strip()!r}")
    names = names or {}

    def ev(node):
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return float(node.value)
        if isinstance(node, ast.BinOp) and type(node.op) in _BIN:
            return _BIN[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UN:
            return _UN[type(node.op)](ev(node.operand))
        if isinstance(node, ast.Name):
            key = node.id.upper()
            if key not in names:
                raise ExpressionError(f"unknown constant {node.id!r} in {text.strip()!r}")
            return float(names[key])
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id.upper() in _FUN
                and not node.keywords):
            return float(_FUN[node.func.id.upper()](*[ev(a) for a in node.args]))
        raise ExpressionError(f"cannot evaluate {text.strip()!r} (only numbers, constants, + - * / ** and "
                              f"{', '.join(sorted(_FUN))} are understood)")

    try:
        value = ev(tree)
    except (ZeroDivisionError, OverflowError, ValueError, TypeError) as exc:
        if isinstance(exc, ExpressionError):
            raise
        raise ExpressionError(f"cannot evaluate {text.strip()!r} ({exc})") from None
    if not math.isfinite(value):
        raise ExpressionError(f"{text.strip()!r} is not finite")
    return value


@functools.lru_cache(maxsize=1 << 12)
def _parse(s: str):
    """The syntax tree of the stripped expression ``s`` (None: not Python syntax), kept for the next read of the same
    text: a deck read again with its constants edited (the validity range's states) parses the same expressions (a
    1 000-super-node deck has about 2 000: its loads and couplings to space).  The tree is only read, never
    changed."""
    try:
        return ast.parse(_FORTRAN_EXP.sub("e", s), mode="eval")
    except SyntaxError:
        return None


def split_top(text: str, sep: str = ",") -> list[str]:
    """Split ``text`` at ``sep`` outside quotes and parentheses."""
    if "(" not in text and ")" not in text:  # (an array's numbers, a node's attributes)
        cut = split_quoted(text, sep)
        if cut is not None:
            return cut
    return _split_scan(text, sep)


def split_quoted(text: str, sep: str, stop: str | None = None) -> list[str] | None:
    """``text`` cut at ``sep`` outside single quotes, and ended at the first ``stop`` outside them (a comment), by
    ``str`` methods; None where a double quote or an unclosed single quote leaves it to a character scan (the same
    pieces: tests/test_lpm.py compares them on random texts)."""
    if '"' in text:
        return None
    pieces = text.split("'")
    if not len(pieces) % 2:
        return None
    out, cur = [], ""
    for k, piece in enumerate(pieces):
        if k % 2:
            cur += "'" + piece + "'"
            continue
        ended = stop is not None and stop in piece
        cut = (piece.split(stop, 1)[0] if ended else piece).split(sep)
        cur += cut[0]
        if len(cut) > 1:
            out.append(cur)
            out.extend(cut[1:-1])
            cur = cut[-1]
        if ended:
            break
    out.append(cur)
    return out


def _split_scan(text: str, sep: str = ",") -> list[str]:
    """:func:`split_top` character by character: any quotes and parentheses."""
    out, depth, quote, start = [], 0, None, 0
    for i, ch in enumerate(text):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif ch == sep and depth == 0:
            out.append(text[start:i])
            start = i + 1
    out.append(text[start:])
    return out


def resolve(definitions, fail) -> dict[str, float]:
    """Values of named constants that may refer to each other in any order.

    ``definitions`` list of ``(line, NAME, expression)``; ``fail(line, message)`` raises for the first definition
    that cannot be evaluated (unknown name, cycle, bad syntax).  Returns {NAME: value}.
    """
    values: dict[str, float] = {}
    pending = list(definitions)
    while pending:
        left = []
        for item in pending:
            try:
                values[item[1]] = evaluate(item[2], values)
            except ExpressionError:
                left.append(item)
        if len(left) == len(pending):
            line, name, expr = left[0]
            try:
                evaluate(expr, values)
            except ExpressionError as exc:
                fail(line, f"constant {name}: {exc}")
        pending = left
    return values


__all__ = ["ExpressionError", "evaluate", "resolve", "split_quoted", "split_top"]
