"""The stage cache: content hashes of stage inputs, entries stored and loaded only from a trusted folder."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest
import scipy.sparse as sp

from fem2tmm.cache import MISSING, StageCache, digest
from fem2tmm.case import Optics


def test_digest_sees_values_dtypes_shapes_and_files(tmp_path):
    a = np.arange(6.0)
    assert digest(a) == digest(a.copy()) == digest(a[::1])
    assert digest(a) != digest(a.astype(np.float32))  # dtype
    assert digest(a) != digest(a.reshape(2, 3))  # shape
    b = a.copy()
    b[3] = np.nextafter(b[3], 10)  # one ulp
    assert digest(a) != digest(b)
    assert digest({"x": 1, "y": 2.0}) == digest({"y": 2.0, "x": 1})  # key order is not content
    assert digest(1) != digest(1.0) != digest("1") and digest(True) != digest(1)
    assert digest([1, 2]) != digest([[1, 2]])
    # sparse: the same matrix in any format / duplicate layout
    m = sp.coo_matrix(([1.0, 2.0, 3.0], ([0, 1, 1], [1, 0, 0])), shape=(2, 2))
    assert digest(m) == digest(m.tocsr()) == digest(sp.csc_matrix(m.toarray()))
    # dataclasses by their fields; files by their bytes
    assert digest(Optics("p", 0.8, 0.3)) != digest(Optics("p", 0.8, 0.4))
    f = tmp_path / "mesh.msh"
    f.write_bytes(b"abc")
    d1 = digest(f)
    os.utime(f, ns=(1, 1))
    f.write_bytes(b"abd")
    assert digest(f) != d1
    with pytest.raises(TypeError):
        digest(object())


def test_entries_round_trip_and_report_reuse(tmp_path):
    folder = tmp_path / "out" / ".cache"
    c = StageCache(folder)
    calls = []
    value, how = c.get_or_compute("cluster", "k1", lambda: calls.append(1) or {"labels": np.arange(4)}, "hot/cluster")
    assert how == "computed" and c.status == {"hot/cluster": "computed"}
    assert c.get_or_compute("cluster", "k1", lambda: calls.append(1), "cold/cluster")[1] == "reused"
    assert len(calls) == 1 and not folder.exists()  # nothing on disk before commit
    assert c.commit() == 1
    assert (folder.stat().st_mode & 0o777) == 0o700
    again = StageCache(folder)
    v, how = again.get_or_compute("cluster", "k1", lambda: pytest.fail("recomputed"))
    assert how == "reused" and np.array_equal(v["labels"], np.arange(4))
    assert again.get("cluster", "k2") is MISSING


def test_untrusted_or_foreign_entries_are_never_loaded(tmp_path):
    folder = tmp_path / "cache"
    c = StageCache(folder)
    c.put("reduce", "k", 1)
    c.commit()
    os.chmod(folder, 0o777)  # others may write: nothing in it is loaded
    assert StageCache(folder).get("reduce", "k") is MISSING
    os.chmod(folder, 0o700)
    assert StageCache(folder).get("reduce", "k") == 1
    # a file whose envelope names another key (copied or renamed) is ignored
    with open(folder / "reduce-other.pkl", "wb") as fh:
        pickle.dump({"format": 1, "stage": "reduce", "key": "k", "value": 2}, fh)
    os.chmod(folder / "reduce-other.pkl", 0o600)
    assert StageCache(folder).get("reduce", "other") is MISSING
    (folder / "reduce-bad.pkl").write_bytes(b"not a pickle")
    assert StageCache(folder).get("reduce", "bad") is MISSING


def test_concurrent_callers_compute_a_shared_entry_once():
    """Two load cases in client threads (a multi-case run on Dask) asking for the same entry: one computes it,
    the other waits and reuses it; a different key is computed independently."""
    import threading
    import time

    c = StageCache()
    calls, started = [], threading.Event()

    def slow():
        started.set()
        time.sleep(0.3)  # long enough for the other thread to arrive while this one computes
        calls.append(1)
        return np.arange(3)

    out = {}

    def case(name):
        out[name] = c.get_or_compute("reduce", "k", slow, f"{name}/reduce")

    a = threading.Thread(target=case, args=("a",))
    a.start()
    started.wait(5.0)
    b = threading.Thread(target=case, args=("b",))
    b.start()
    a.join(10.0)
    b.join(10.0)
    assert len(calls) == 1  # computed once, not once per thread
    assert out["a"][1] == "computed" and out["b"][1] == "reused"
    assert out["b"][0] is out["a"][0]
    assert c.status == {"a/reduce": "computed", "b/reduce": "reused"}
    # a caller whose computation fails leaves the entry missing: the next caller computes it itself
    with pytest.raises(ZeroDivisionError):
        c.get_or_compute("cluster", "k", lambda: 1 / 0)
    assert c.get_or_compute("cluster", "k", lambda: 7) == (7, "computed")
