"""First run after an install: the pipeline says when numba will compile the ray tracer's kernels (issue 15)."""

import importlib
import subprocess
import sys

from fem2tmm.radiation.compiled import COMPILE_SECONDS, KEY_KERNELS, compile_estimate, kernels_cached
from fem2tmm.radiation.tracer import exchange_factors


def test_cached_after_a_trace_and_cold_with_an_empty_cache(tmp_path):
    # after one trace in this process every kernel it used is cached (the in-tree cache is writable here)
    exchange_factors([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [0, 1, 1]],
                     [[0, 1, 2, 3], [0, 3, 5, 4]], emissivity=0.8, specular=0.3, rays_per_face=50)
    # every key kernel is one that an exchange trace dispatches (so a run that traced leaves it cached) ...
    for module, name in KEY_KERNELS:
        assert getattr(importlib.import_module(f"fem2tmm.radiation.{module}"), name).signatures, (module, name)
    # ... and after it all of them are in the cache
    assert kernels_cached() == (len(KEY_KERNELS), len(KEY_KERNELS)) and compile_estimate() == 0.0
    total = len(KEY_KERNELS)
    # a fresh process with an empty numba cache folder: nothing cached, the full estimate
    code = "from fem2tmm.radiation.compiled import kernels_cached, compile_estimate; print(*kernels_cached(), " \
           "compile_estimate())"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                       env={"NUMBA_CACHE_DIR": str(tmp_path), "PATH": "/usr/bin:/bin",
                            "PYTHONPATH": ":".join(sys.path)})
    c, t, est = r.stdout.split()
    assert int(c) == 0 and int(t) == total and float(est) == COMPILE_SECONDS


def test_the_pipeline_says_when_it_compiles(monkeypatch, capsys):
    from conftest import make_case

    import fem2tmm.pipeline as pipeline
    from fem2tmm import meshes

    case = make_case([{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
                       "back": "black", "super_nodes": 2}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": 20.0}],
                     radiation={"rays_per_face": 20}, reference={"detailed": False})
    for estimate, said in ((12.4, True), (0.0, False)):
        monkeypatch.setattr(pipeline, "compile_estimate", lambda: estimate)
        pipeline.run(case, mesh=meshes.plate(1.0, 1.0, 4, 4), quiet=False)
        err = capsys.readouterr().err
        assert ("[fem2tmm] compiling the ray tracer's kernels (first run after an install, ~12 s)" in err) == said
