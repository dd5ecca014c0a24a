"""Benchmarks of the mesh readers (``fem2tmm bench nastran``).

Each function returns a list of dicts, one per measurement, with the median of repeated timings.
"""

from __future__ import annotations

import gc
import os
import statistics
import tempfile
import time
import tracemalloc
import warnings
from pathlib import Path

from .cases import write_plate_deck

__all__ = ["bench_nastran"]


def bench_nastran(n_side: int = 1000, repeats: int = 3, trace_memory: bool = False, workdir=None) -> list[dict]:
    """Read a generated ``n_side`` x ``n_side`` CQUAD4 small-field deck (10^6 elements by default).

    Returns one dict: ``bench``, ``elements``, ``nodes``, ``file_MB``, ``median_s`` (wall time of
    :func:`fem2tmm.io.nastran.read_nastran`, GRIDs + elements + groups), ``times_s`` (every repeat),
    ``write_s`` (time to generate the deck, not part of the measurement) and, with ``trace_memory``,
    ``peak_traced_MB`` (peak of the memory traced by ``tracemalloc`` during one further read, numpy
    buffers included; ``fem2tmm bench`` reports the process's peak RSS anyway).
    """
    from fem2tmm.io.nastran import read_nastran

    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        deck = Path(tmp) / "plate.bdf"
        t0 = time.perf_counter()
        write_plate_deck(deck, n_side, n_side)
        write_s = time.perf_counter() - t0
        times = []
        mesh = None
        for _ in range(repeats):
            del mesh
            gc.collect()
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mesh = read_nastran(deck)
            times.append(time.perf_counter() - t0)
        n_el, n_nd = mesh.n_elements, mesh.n_nodes
        del mesh
        row = {
            "bench": "nastran",
            "what": "read_nastran of a small-field CQUAD4 plate deck",
            "elements": int(n_el),
            "nodes": int(n_nd),
            "file_MB": round(os.path.getsize(deck) / 2**20, 1),
            "median_s": round(statistics.median(times), 3),
            "times_s": [round(t, 3) for t in times],
            "write_s": round(write_s, 2),
            "goal": "tens of seconds at most for 1e6 elements",
        }
        if trace_memory:
            gc.collect()
            tracemalloc.start()
            try:
                read_nastran(deck)
                row["peak_traced_MB"] = round(tracemalloc.get_traced_memory()[1] / 2**20, 1)
            finally:
                tracemalloc.stop()
    return [row]
