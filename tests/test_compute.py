"""Work units in-process or on a Dask cluster: bit-for-bit the same results, faults, unreachable schedulers.

The clusters are real ``dask.distributed.LocalCluster`` s of single-threaded worker processes started here."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from fem2tmm.compute import DaskExecutor, SerialExecutor, current, open_executor, using
from fem2tmm.errors import Fem2TmmError
from fem2tmm.progress import reporting

distributed = pytest.importorskip("distributed")


def _scene():
    """The demo baffle (5184 quads): every active side a REF node; a Sun 45° off the axis."""
    from fem2tmm.demo import demo_case
    from fem2tmm.fem.model import build_model
    from fem2tmm.mesh.shapes import baffle
    from fem2tmm.stages.radiation import radiation_surface

    case = demo_case()
    model = build_model(baffle(), case)
    f = model.faces
    groups = np.full(2 * f.n, -1, np.int64)
    active = np.flatnonzero(f.active)
    groups[active] = np.arange(active.size)
    return radiation_surface(model), groups, case.environment.sun_direction


def _trace(surface, groups, sun):
    """An exchange run (~41 k rays) and a solar run (~20 k rays), both in batches of 4096 rays."""
    from fem2tmm.radiation import trace_exchange
    from fem2tmm.radiation.solar import trace_solar

    ex = trace_exchange(surface, groups, rays_per_group=4, batch=4096, seed=3)
    sol = trace_solar(surface, sun, 1000.0, rays_per_group=2, batch=4096, seed=3)
    return ex, sol


def _assert_identical(a, b):
    ea, sa = a
    eb, sb = b
    for name in ("indptr", "indices", "data"):
        assert np.array_equal(getattr(ea.tally, name), getattr(eb.tally, name))
        assert np.array_equal(getattr(ea.GR, name), getattr(eb.GR, name))
    assert ea.segments == eb.segments
    assert np.array_equal(sa.absorbed_side, sb.absorbed_side) and sa.segments == sb.segments


@pytest.fixture(scope="module")
def serial_run():
    surface, groups, sun = _scene()
    assert isinstance(current(), SerialExecutor)
    return (surface, groups, sun), _trace(surface, groups, sun)


def _cluster(n):
    cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                       silence_logs=50)
    return DaskExecutor(distributed.Client(cluster), cluster)


@pytest.fixture(scope="module")
def cluster2():
    ex = _cluster(2)
    yield ex
    ex.close()


def test_a_worker_killed_mid_run_is_replaced_with_identical_results(serial_run, cluster2):
    (surface, groups, sun), expected = serial_run
    ex = cluster2
    killed = []
    pids = sorted(ex.client.run(os.getpid).values())

    def kill_one(done, total, what):
        if not killed and done >= 2 and done < total - 2:  # units still to run
            os.kill(pids[0], signal.SIGKILL)
            killed.append((done, total))

    with using(ex), reporting(kill_one):
        got = _trace(surface, groups, sun)
    assert killed, "no worker was killed while units were pending"
    _assert_identical(got, expected)  # the rays are the same on 2 workers, one of them killed, as in this process


def test_the_scene_goes_to_the_workers_once_per_executor(serial_run, cluster2, monkeypatch):
    """Four traces of one geometry (two exchange, two solar, each building its own scene object) scatter the scene
    once; each trace sends only its job without the scene (optics, emitters, seeds), and the results stay
    bit-identical to this process's."""
    from fem2tmm.radiation.surfaces import TriangleScene

    (surface, groups, sun), expected = serial_run
    ex = cluster2
    ex.release_kept()
    sent = []
    real = ex.client.scatter

    def scatter(obj, **kw):
        sent.append(obj)
        return real(obj, **kw)

    monkeypatch.setattr(ex.client, "scatter", scatter)
    with using(ex):
        first, second = _trace(surface, groups, sun), _trace(surface, groups, sun)
    _assert_identical(first, expected)
    _assert_identical(second, expected)
    assert sum(isinstance(o, TriangleScene) for o in sent) == 1 and len(ex._kept) == 1
    blobs = [o[0] for o in sent if isinstance(o, tuple)]
    assert len(blobs) == 4  # one job per trace
    import io
    import pickle

    token = next(iter(ex._kept))[1]
    for blob in blobs:  # each job refers to the scene by its geometry digest instead of carrying it
        refs = []

        class Refs(pickle.Unpickler):
            def persistent_load(self, pid):
                refs.append(pid)
                return None

        Refs(io.BytesIO(blob[16:])).load()
        assert refs and all(r == ("scene", token) for r in refs)


def test_a_traces_job_goes_to_two_workers_not_all(serial_run):
    """On three workers each trace's job is placed on REPLICAS = 2 of them (one may die; the third fetches it from a
    peer when it runs a batch), the scene broadcast; results bit-identical."""
    from distributed import Future

    from fem2tmm.compute import REPLICAS

    (surface, groups, sun), expected = serial_run
    ex = _cluster(3)
    ex.client.wait_for_workers(3)  # all three registered before the scene is broadcast
    placed = []
    real_map = ex.client.map

    def map_(fn, items, **kw):  # where the shared data is when the units are submitted (none has run yet)
        futs = [f for v in kw.values() for f in (v if isinstance(v, (tuple, list)) else [v]) if isinstance(f, Future)]
        kept = {f.key for f in ex._kept.values()}
        where = ex.client.who_has(futs)
        placed.append({f.key: (len(where[f.key]), f.key in kept) for f in futs})
        return real_map(fn, items, **kw)

    ex.client.map = map_
    try:
        with using(ex):
            got = _trace(surface, groups, sun)
    finally:
        ex.close()
    _assert_identical(got, expected)
    assert len(placed) == 2  # the exchange and the solar trace
    for call in placed:  # the jobs on exactly 2 workers; the scene (broadcast: Dask may still be copying it) on some
        assert {n for n, kept in call.values() if not kept} == {REPLICAS}
        assert all(n >= 1 for n, kept in call.values() if kept) and sum(kept for _, kept in call.values()) == 1


def test_ctrl_c_cancels_the_submitted_units(serial_run, cluster2):
    (surface, groups, sun), _ = serial_run
    ex = cluster2

    def interrupt(done, total, what):
        if done == 2:
            raise KeyboardInterrupt

    with using(ex), reporting(interrupt), pytest.raises(KeyboardInterrupt):
        _trace(surface, groups, sun)
    deadline = time.perf_counter() + 10.0
    while any(ex.client.processing().values()) and time.perf_counter() < deadline:
        time.sleep(0.1)
    assert not any(ex.client.processing().values())  # nothing left running on the workers
    # no result and no per-call data left in the cluster: only the scene the executor keeps for later traces
    assert set(ex.client.who_has()) == {f.key for f in ex._kept.values()} and len(ex._kept) == 1
    ex.release_kept()  # what closing the executor does
    while ex.client.who_has() and time.perf_counter() < deadline + 10.0:
        time.sleep(0.1)
    assert not ex.client.who_has()


def test_cli_unreachable_scheduler_exits_2_before_computing(tmp_path):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    case = tmp_path / "case.toml"
    text = open(os.path.join(root, "examples", "baffle", "case.toml"), encoding="utf-8").read()
    case.write_text(text.replace("../../meshes/baffle.msh", os.path.join(root, "meshes", "baffle.msh")),
                    encoding="utf-8")
    out = tmp_path / "out"
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "fem2tmm.cli", "run", str(case), "--out", str(out), "--quiet",
                        "--scheduler", "tcp://127.0.0.1:9"], capture_output=True, text=True, timeout=60,
                       env={**os.environ, "PYTHONPATH": os.path.join(root, "src")})
    # the interpreter and the imports may take long on a loaded machine: the 10 s budget is checked in-process below
    assert time.perf_counter() - t0 < 30.0
    assert p.returncode == 2
    assert p.stderr.count("\n") == 1 and "cannot reach the Dask scheduler" in p.stderr and "Traceback" not in p.stderr
    assert not out.exists() and sorted(x.name for x in tmp_path.iterdir()) == ["case.toml"]


def test_an_unreachable_scheduler_is_one_error_within_10_s():
    t0 = time.perf_counter()
    with pytest.raises(Fem2TmmError, match=r"cannot reach the Dask scheduler at tcp://127.0.0.1:9 within"):
        open_executor("tcp://127.0.0.1:9")
    assert time.perf_counter() - t0 < 10.0


def test_serial_runs_never_import_dask():
    code = ("import sys, numpy as np\n"
            "from fem2tmm.radiation import exchange_factors\n"
            "from fem2tmm.compute import map_units\n"
            "exchange_factors(np.array([[0,0,0],[1,0,0],[0,1,0],[0,0,1.]]), [[0,1,2],[0,3,1]], rays_per_face=100)\n"
            "assert map_units(abs, [-1, 2]) == [1, 2]\n"
            "assert not any(m.split('.')[0] in ('dask', 'distributed') for m in sys.modules), 'dask imported'\n")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120,
                   env={**os.environ, "PYTHONPATH": os.path.join(root, "src")})


def test_emitters_and_optics_travel_compactly_and_come_back_unchanged(serial_run):
    """A trace's job goes to the workers by pickle: the emitter tables' indices in int32/int8 (restored to the
    build's dtypes), the optics without their cached tables; everything equal after the round trip."""
    import pickle

    from fem2tmm.radiation.solar import sunlit_emitters
    from fem2tmm.radiation.surfaces import TriangleScene

    (surface, groups, sun), _ = serial_run
    scene = TriangleScene(surface, "numpy")
    em = sunlit_emitters(scene, np.arange(2 * surface.n_faces), 2 * surface.n_faces, np.asarray(sun, float))
    optics = surface.optics("solar")
    optics.rows  # a cached table, not pickled
    for obj in (em, optics):
        back = pickle.loads(pickle.dumps(obj))
        for k, v in vars(back).items():
            assert np.array_equal(v, vars(obj)[k]) and v.dtype == vars(obj)[k].dtype, k
    assert len(pickle.dumps(em)) < 0.8 * sum(v.nbytes for v in vars(em).values())
    assert "rows" not in vars(pickle.loads(pickle.dumps(optics)))



def _reduction_problem():
    """A fixed 80 x 60 quad plate in Voronoi clusters, a floating 6 x 6 plate (one cluster) and two one-element
    clusters (no interior node)."""
    from fem2tmm.fem.assembly import conduction_matrices, to_coo, volume_shares
    from fem2tmm.reduce import build_supernodes

    def grid(nx, ny, x0):
        x, y = np.meshgrid(np.linspace(x0, x0 + nx / 100, nx + 1), np.linspace(0, ny / 100, ny + 1), indexing="ij")
        g = np.arange(x.size).reshape(nx + 1, ny + 1)
        return (np.c_[x.ravel(), y.ravel(), np.zeros(x.size)],
                np.stack([g[:-1, :-1], g[1:, :-1], g[1:, 1:], g[:-1, 1:]], -1).reshape(-1, 4))

    p1, c1 = grid(80, 60, 0.0)
    p2, c2 = grid(6, 6, 2.0)
    pts, cells = np.vstack([p1, p2]), np.vstack([c1, c2 + len(p1)])
    m = len(cells)
    t = np.full(m, 1e-3)
    coo = to_coo(cells, conduction_matrices(pts, cells, "quad4", np.full(m, 170.0), t), np.arange(m))
    cen = pts[cells].mean(axis=1)
    seeds = np.random.default_rng(0).uniform([0.0, 0.0], [0.8, 0.6], (10, 2))
    labels = 1 + np.argmin(((cen[:, None, :2] - seeds[None]) ** 2).sum(-1), axis=1)
    labels[len(c1):] = 0  # the floating plate
    labels[[40 * 60 + 30, 70 * 60 + 5]] = [11, 12]  # one-element clusters
    sn = build_supernodes(len(pts), cells, volume_shares(pts, cells, "quad4", t), labels, boundary=[len(p1) - 1])
    return coo, sn, labels


def _set_band_max(value):
    from fem2tmm.reduce import recovery

    recovery.BAND_MAX = value


@pytest.mark.parametrize("sparse", [False, True])
def test_the_local_reduction_on_dask_is_bit_identical(cluster2, sparse, monkeypatch):
    """The per-cluster local step as Dask tasks (batches of clusters on two worker processes) gives the same bits
    as in this process: K_SN, the distributed loads, the recovered field, and which factorisations are kept under
    a memory budget (a tight one: some are recomputed at each recovery).  ``sparse``: SuperLU for every cluster
    (on the workers too), the dense and banded paths otherwise."""
    from fem2tmm.reduce import recovery, reduce_conduction

    coo, sn, labels = _reduction_problem()
    rng = np.random.default_rng(1)
    q, T_sn = rng.normal(size=(sn.n_dof, 2)), rng.normal(size=sn.n_sn)
    kw = {"dense_below": 0, "factor_memory_mb": 0.2} if sparse else {}
    default = recovery.BAND_MAX
    band = 0 if sparse else default
    monkeypatch.setattr(recovery, "BAND_MAX", band)
    cluster2.client.run(_set_band_max, band)
    try:
        runs = []
        for ex in (SerialExecutor(), cluster2):
            units = []
            with using(ex), reporting(lambda done, total, what: units.append(what)):
                red = reduce_conduction(coo, sn, labels, **kw)
            kept = [cl._solver is not None for cl in red.operator.clusters if cl.P is not None]
            runs.append((red, kept, units))
    finally:
        cluster2.client.run(_set_band_max, default)
    (a, kept_a, units_a), (b, kept_b, units_b) = runs
    assert "cluster batches on 2 workers" in units_b and not any("on 2 workers" in u for u in units_a)
    kinds = {"banded": 7, "cholesky": 3, "lu": 1, "none": 2} if not sparse else {"sparse": 10, "sparse_lu": 1, "none": 2}
    assert a.diagnostics["cluster_solvers"] == kinds and b.diagnostics["cluster_solvers"] == kinds
    assert kept_a == kept_b and (0 < sum(kept_a) < len(kept_a) if sparse else all(kept_a))
    assert np.array_equal(a.K, b.K)
    assert np.array_equal(a.distribute(q), b.distribute(q))
    assert np.array_equal(a.recover(T_sn, q[:, 0]), b.recover(T_sn, q[:, 0]))
