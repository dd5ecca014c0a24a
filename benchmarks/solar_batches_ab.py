"""A/B of the solar batch results (issue 19), run against two source trees in turn (not a registered bench: it
compares code versions).  Export the old tree with ``git archive <rev> src | tar -x -C /tmp/old``, then per tree:

    PYTHONPATH=<tree>/src python benchmarks/solar_batches_ab.py N DENSITY MODE OUT.npz

on a V-groove of two specular plates of N x N quads (2 N² faces, both sides active, α 0.1-0.3, 90 % specular),
the Sun into the groove at ``DENSITY`` rays per m².  MODE ``bytes``: every batch job and result through pickle in
this process (as to and from a Dask worker), prints the pickled bytes per batch and saves the traced arrays (compare
the two trees' files with ``np.array_equal``); ``serial``: the time of the second ``trace_solar`` (2 threads);
``localN``: the same on a ``LocalCluster(N)``.  2026-12-02 rows in the README: N = 224 and 707, DENSITY 1e6.
"""
import sys, time, pickle, json
import numpy as np
from fem2tmm.mesh import shapes
from fem2tmm.radiation.surfaces import Surface, TriangleScene
from fem2tmm.radiation.solar import trace_solar
from fem2tmm import compute

def main():

    n, density, mode, out = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3], sys.argv[4]
    a = shapes.plate(1.0, 1.0, n, n)
    b = shapes.transform(shapes.plate(1.0, 1.0, n, n), shapes.rotation("y", 90.0), (0.0, 0.0, 0.0))
    # plate a: z=0 front +z; plate b: rotated about y by -90 -> in plane x=0; pick orientation so front faces +x
    pa, fa = a.points, a.blocks[0].cells
    pb, fb = b.points, b.blocks[0].cells
    pts = np.concatenate([pa, pb]); faces = np.concatenate([fa, fb[:, ::-1] + len(pa)])
    m = len(faces)
    rng = np.random.default_rng(0)
    surf = Surface(pts, faces, emissivity=0.0, absorptivity=np.stack([rng.uniform(0.1, 0.3, m), np.zeros(m)], 1),
                   specular=np.stack([np.full(m, 0.9), np.zeros(m)], 1),
                   active=np.ones((m, 2), bool))
    scene = TriangleScene(surf)
    sun = np.array([1.0, 0.3, 1.0])
    sizes = []
    class Recording(compute.SerialExecutor):
        distributed = True
        def map(self, fn, items, shared=None, what=""):
            res = super().map(fn, items, shared, what)
            sizes.extend(len(pickle.dumps(r, protocol=5)) for r in res)
            return res
    kw = dict(ray_density=density, scene=scene, threads=2)
    if mode == "bytes":
        with compute.using(Recording()):
            r = trace_solar(surf, sun, 1361.0, **kw)
        np.savez(out, absorbed=r.absorbed_side, incident=r.incident_side,
                 tot=np.array([r.incident, r.shadowed, r.escaped, r.blocked, r.capped, r.segments]))
        print(json.dumps({"faces": m, "rays": r.rays, "batches": len(sizes), "bytes_per_batch_median": float(np.median(sizes)),
                          "bytes_max": max(sizes), "segments": r.segments}))
    elif mode == "serial":
        trace_solar(surf, sun, 1361.0, **kw)  # warm
        t = time.perf_counter(); trace_solar(surf, sun, 1361.0, **kw); print(json.dumps({"t": time.perf_counter() - t}))
    else:
        with compute.executing("local", workers=int(mode[5:])):
            trace_solar(surf, sun, 1361.0, **kw)  # warm (scene to workers etc.)
            t = time.perf_counter(); r = trace_solar(surf, sun, 1361.0, **kw); dt = time.perf_counter() - t
        print(json.dumps({"t": dt}))
        np.savez(out, absorbed=r.absorbed_side, incident=r.incident_side)


if __name__ == '__main__':
    main()
