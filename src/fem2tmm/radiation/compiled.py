"""Whether the ray tracer's compiled kernels are already in numba's on-disk cache.

The kernels (``@njit(cache=True)`` in :mod:`engine`, :mod:`_tracer_kernels`, :mod:`sampling`, :mod:`smoothing`,
:mod:`tracer`) are compiled on their first call after an install (or after their source changed) and cached next
to the sources (or in ``NUMBA_CACHE_DIR``); later runs load them in well under a second.  The first run would
otherwise sit silently at "ray batches: 0/…" while numba compiles, so the pipeline asks :func:`compile_estimate`
and says so.
"""

from __future__ import annotations

import importlib

#: kernels every exchange-factor trace dispatches from Python (module, name); the helpers they call are compiled
#: into them and have no cache entry of their own, so they cannot tell whether a run will compile
KEY_KERNELS = (
    ("_tracer_kernels", "bounce"), ("_tracer_kernels", "emit_groups"), ("_tracer_kernels", "hit_sides"),
    ("_tracer_kernels", "empty_pages"), ("sampling", "_radical_inverse"), ("smoothing", "_column_counts"),
    ("smoothing", "_weigh_transpose"), ("smoothing", "_merge_rows"), ("smoothing", "dense_columns"),
    ("tracer", "_batch_rays"), ("tracer", "_batch_tally"), ("tracer", "runs_to_csr"),
)
#: wall time (s) to compile the ray tracer's kernels from a cold cache on the reference machine (2 shared cores)
#: (measurements: docs/design-notes.md, radiation/compiled.py)
COMPILE_SECONDS = 40.0


def kernels_cached() -> tuple[int, int]:
    """``(cached, total)``: how many of :data:`KEY_KERNELS` have a valid entry in numba's on-disk cache (an index
    whose source stamp matches the current source)."""
    cached = 0
    for name, func in KEY_KERNELS:
        disp = getattr(importlib.import_module(f"{__package__}.{name}"), func)
        cache = getattr(disp, "_cache", None)
        try:
            ok = cache is not None and bool(cache._cache_file._load_index())  # {} when missing or stale
        except Exception:  # a numba version without this layout: do not claim anything
            ok = True
        cached += ok
    return cached, len(KEY_KERNELS)


def compile_estimate() -> float:
    """Seconds the first ray tracing of this process will spend compiling kernels (0 when all are cached):
    :data:`COMPILE_SECONDS` times the fraction of :data:`KEY_KERNELS` not cached."""
    cached, total = kernels_cached()
    return COMPILE_SECONDS * (total - cached) / total
