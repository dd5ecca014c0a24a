"""Stage results keyed by a content hash of exactly the inputs each stage depends on.

A key is :func:`digest` of the stage's name and its inputs as the stage receives them (the mesh's arrays, the
elements and attributes of every part, the optical arrays of the band traced, the settings, the seeds), not of
the case file's text: a key of the case file that does not change a stage's inputs (a heater power for the
clustering, an absorptivity for the IR exchange factors) keeps its cached result, and any change that does,
including keys added to the case file later, changes the key.  The keys per stage are chosen by the pipeline
(:mod:`fem2tmm.pipeline`); this module only hashes, stores and loads.

Entries live in ``<out>/.cache/`` (or ``--cache DIR``), one pickle per entry, ``<stage>-<key>.pkl``, written
atomically.  Pickles can run code when loaded, so entries are read only from a folder this user owns that no one
else may write to, and only when the file's envelope names the same stage, key and format; anything else is
ignored (recomputed), never loaded.  Delete the folder to empty the cache.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import pickle
import stat
import tempfile
import threading
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

#: bump when the layout of a cached value changes
CACHE_FORMAT = 1
CACHE_DIR = ".cache"
MISSING = object()


# ---------------------------------------------------------------------------------------------------- hashing
_FILE_DIGESTS: dict[tuple, str] = {}


def file_digest(path: str | Path) -> str:
    """sha256 of a file's bytes (memoised by path, size and modification time)."""
    p = Path(path).resolve()
    st = p.stat()
    memo = (str(p), st.st_size, st.st_mtime_ns)
    if memo not in _FILE_DIGESTS:
        h = hashlib.sha256()
        with open(p, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 22), b""):
                h.update(chunk)
        _FILE_DIGESTS[memo] = h.hexdigest()
    return _FILE_DIGESTS[memo]


def digest(*objs: Any) -> str:
    """A sha256 hex digest of plain data: None, bool, int, float, str, bytes, paths (by the file's bytes when
    the file exists), numpy arrays and scalars (dtype, shape and bytes), scipy sparse matrices (canonical CSR),
    mappings (sorted keys), lists/tuples and dataclass instances (class name and every field).  Anything else is
    a TypeError: no hash from a ``repr``."""
    h = hashlib.sha256(f"fem2tmm-cache-{CACHE_FORMAT}".encode())
    for o in objs:
        _feed(h, o)
    return h.hexdigest()


def _feed(h, o) -> None:
    import scipy.sparse as sp

    if o is None:
        h.update(b"N")
    elif isinstance(o, (bool, np.bool_)):
        h.update(b"B1" if o else b"B0")
    elif isinstance(o, (int, np.integer)):
        h.update(b"I%d;" % int(o))
    elif isinstance(o, (float, np.floating)):
        h.update(b"F" + float(o).hex().encode() + b";")
    elif isinstance(o, str):
        b = o.encode("utf-8")
        h.update(b"S%d:" % len(b) + b)
    elif isinstance(o, bytes):
        h.update(b"Y%d:" % len(o) + o)
    elif isinstance(o, Path):
        h.update(b"P" + (file_digest(o).encode() if o.is_file() else str(o).encode()) + b";")
    elif isinstance(o, np.ndarray):
        if o.dtype == object or o.dtype.kind in "US":
            h.update(b"O%s:" % str(o.shape).encode())
            for x in o.ravel().tolist():
                _feed(h, x)
        else:
            a = np.ascontiguousarray(o)
            h.update(b"A" + a.dtype.str.encode() + str(a.shape).encode() + b":")
            h.update(memoryview(a).cast("B"))
    elif sp.issparse(o):
        m = sp.csr_matrix(o, copy=True)
        m.sum_duplicates()
        m.sort_indices()
        h.update(b"X" + str(m.shape).encode())
        for a in (m.indptr.astype(np.int64), m.indices.astype(np.int64), m.data):
            _feed(h, a)
    elif isinstance(o, Mapping):
        h.update(b"D%d:" % len(o))
        for k in sorted(o, key=str):
            _feed(h, str(k))
            _feed(h, o[k])
    elif isinstance(o, (list, tuple)):
        h.update(b"L%d:" % len(o))
        for x in o:
            _feed(h, x)
    elif dataclasses.is_dataclass(o) and not isinstance(o, type):
        h.update(b"C" + type(o).__qualname__.encode() + b":")
        for f in dataclasses.fields(o):
            _feed(h, f.name)
            _feed(h, getattr(o, f.name))
    else:
        raise TypeError(f"cache.digest: cannot hash a {type(o).__name__}; pass its arrays or settings")


# ------------------------------------------------------------------------------------------------------ store
def _trusted(folder: Path) -> bool:
    """Whether entries may be loaded from ``folder``: it exists, belongs to this user and only they may write
    to it (POSIX; on other systems: it exists)."""
    try:
        st = folder.stat()
    except OSError:
        return False
    if not stat.S_ISDIR(st.st_mode):
        return False
    if hasattr(os, "getuid"):
        return st.st_uid == os.getuid() and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)
    return True


class StageCache:
    """Stage results by ``(stage, key)``: in memory for this run, on disk in ``folder`` across runs.

    :meth:`get_or_compute` returns a cached value or computes and remembers it; :attr:`status` records per
    label (e.g. ``"hot/cluster"``) whether it was "computed" or "reused".  New entries are written to disk by
    :meth:`commit` (the pipeline commits once the run has succeeded).  ``folder`` None: memory only.

    Thread-safe: load cases running concurrently (:func:`fem2tmm.pipeline.run` on a Dask executor) that need the
    same ``(stage, key)`` compute it once; :meth:`get_or_compute` holds a lock per key while computing, and the
    other callers wait for the value and report it "reused".
    """

    def __init__(self, folder: str | Path | None = None):
        self.folder = None if folder is None else Path(folder)
        self._memory: dict[tuple[str, str], Any] = {}
        self._pending: list[tuple[str, str]] = []
        self.status: dict[str, str] = {}
        self._guard = threading.Lock()  # guards _locks
        self._locks: dict[tuple[str, str], threading.Lock] = {}

    def path(self, stage: str, key: str, folder: Path | None = None) -> Path:
        return Path(folder or self.folder) / f"{stage}-{key}.pkl"

    def get(self, stage: str, key: str) -> Any:
        """The value stored for ``(stage, key)``, or :data:`MISSING`."""
        if (stage, key) in self._memory:
            return self._memory[(stage, key)]
        if self.folder is None or not _trusted(self.folder):
            return MISSING
        p = self.path(stage, key)
        try:
            st = p.stat()
            if hasattr(os, "getuid") and (st.st_uid != os.getuid() or st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)):
                return MISSING
            with open(p, "rb") as fh:
                env = pickle.load(fh)  # noqa: S301 - our own entry in a folder only this user can write to
        except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError, TypeError, ValueError):
            return MISSING
        if not (isinstance(env, dict) and env.get("format") == CACHE_FORMAT and env.get("stage") == stage
                and env.get("key") == key):
            return MISSING
        self._memory[(stage, key)] = env["value"]
        return env["value"]

    def put(self, stage: str, key: str, value: Any) -> None:
        """Remember ``value`` for this run; written to disk by :meth:`commit`."""
        self._memory[(stage, key)] = value
        self._pending.append((stage, key))

    def get_or_compute(self, stage: str, key: str, compute: Callable[[], Any], label: str | None = None):
        """``(value, "reused" | "computed")``; records the status under ``label`` (default ``stage``).  A caller
        in another thread asking for the same ``(stage, key)`` meanwhile waits and gets the value "reused" (if
        ``compute`` raised, it computes itself)."""
        with self._guard:
            lock = self._locks.setdefault((stage, key), threading.Lock())
        with lock:
            value = self.get(stage, key)
            how = "reused"
            if value is MISSING:
                value, how = compute(), "computed"
                self.put(stage, key, value)
        self.status[label or stage] = how
        return value, how

    def commit(self, folder: str | Path | None = None) -> int:
        """Write the entries computed in this run to ``folder`` (default: the cache's own folder), each
        atomically; returns the number written.  The folder is created private to this user."""
        target = Path(folder) if folder is not None else self.folder
        if target is None or not self._pending:
            return 0
        target.mkdir(mode=0o700, parents=True, exist_ok=True)
        written = 0
        for stage, key in dict.fromkeys(self._pending):
            fd, tmp = tempfile.mkstemp(prefix=f".{stage}-", dir=target)
            try:
                with os.fdopen(fd, "wb") as fh:
                    pickle.dump({"format": CACHE_FORMAT, "stage": stage, "key": key,
                                 "value": self._memory[(stage, key)]}, fh, protocol=pickle.HIGHEST_PROTOCOL)
                os.replace(tmp, self.path(stage, key, target))
                written += 1
            except BaseException:
                Path(tmp).unlink(missing_ok=True)
                raise
        self._pending.clear()
        return written
