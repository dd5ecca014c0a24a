"""The exceptions of fem2tmm.

Every problem with user input (a file, a case key, a group, an element) raises :class:`Fem2TmmError`
with a message that names the culprit and says what to do.  The command line prints the message
without a traceback and exits with status 2.

A broken internal invariant (a bug, not bad input) raises :class:`InternalError`; the command line
prints it with a request to report it and exits with status 1.
"""

from __future__ import annotations


class Fem2TmmError(Exception):
    """A user-facing error: bad input, inconsistent case, unsolvable model."""


class NetworkRefusal(Fem2TmmError):
    """The reduced network has no physical solution for a property of its own, not of the model: the exact
    condensation's negative conductances drive its super nodes towards 0 K.  Another network of the same model (the
    positive one) may have one; the run falls back to it where the user left the choice to fem2tmm."""


class InternalError(RuntimeError):
    """An internal invariant does not hold: a bug in fem2tmm, not a problem of the input."""


def format_ids(ids, limit: int = 10) -> str:
    """Render a list of ids for an error message: at most ``limit`` of them, then '… (N in all)'."""
    ids = [int(i) for i in ids]
    if len(ids) <= limit:
        return ", ".join(str(i) for i in ids)
    return ", ".join(str(i) for i in ids[:limit]) + f", … ({len(ids)} in all)"


def either(options: list[str]) -> str:
    """Render the fixes a refusal advises: ``a``, ``a or b``, ``a, b or c``."""
    return f"{', '.join(options[:-1])}{' or ' if len(options) > 1 else ''}{options[-1]}"
