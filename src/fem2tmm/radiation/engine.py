"""Closest-hit ray queries against a triangle soup: Embree (through ``embreex``) or a slow pure-numpy fallback.

The engines answer one question: for rays (origin, unit direction), which triangle is hit first and at which
distance.  Robustness (origin offsets, self-hit rejection) lives one level up, in
:class:`fem2tmm.radiation.surfaces.TriangleScene`; every performance figure of the package is with Embree.

Embree works in float32.  The engine translates the scene to its bounding-box centre before converting, so the
float32 rounding is relative to the size of the model, not to its distance from the origin of coordinates.
"""

from __future__ import annotations

import numpy as np

try:  # pragma: no cover - exercised through HAS_EMBREE
    from embreex import rtcore_scene as _rtcs
    from embreex.mesh_construction import TriangleMesh as _EmbreeTriangleMesh

    HAS_EMBREE = True
except Exception:  # noqa: BLE001 - any import problem of the compiled wheel means "no Embree"
    HAS_EMBREE = False

MISS = -1


class EmbreeEngine:
    """Embree closest-hit queries over triangles ``vertices`` (t, 3, 3) m.

    One scene, committed at construction (embreex commits lazily on the first query, which is not thread
    safe; a dummy query here makes later concurrent ``intersect`` calls from several Python threads safe -
    embreex releases the GIL while Embree traces).  Built with Embree's robust (watertight) traversal so rays
    cannot slip through the shared edge of two triangles.
    """

    name = "embree"

    def __init__(self, vertices: np.ndarray):
        if not HAS_EMBREE:
            raise ImportError("embreex is not importable")
        vertices = np.asarray(vertices, dtype=np.float64)
        self.center = 0.5 * (vertices.reshape(-1, 3).min(axis=0) + vertices.reshape(-1, 3).max(axis=0))
        self.n_triangles = len(vertices)
        self._scene = _rtcs.EmbreeScene(robust=True)
        self._mesh = _EmbreeTriangleMesh(self._scene, np.ascontiguousarray(vertices - self.center, dtype=np.float32))
        self._scene.run(np.zeros((1, 3), np.float32), np.array([[0.0, 0.0, 1.0]], np.float32))  # commit now

    def intersect(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closest hit of each ray: ``(prim (r,) int, -1 = miss; t (r,) float distance in m, huge on a miss)``.

        ``origins`` (r, 3) m and ``directions`` (r, 3) unit vectors, any float dtype.
        """
        o = np.empty(origins.shape, np.float32)
        np.subtract(origins, self.center, out=o, casting="unsafe")
        d = np.ascontiguousarray(directions, dtype=np.float32)
        out = self._scene.run(o, d, output=True)
        return out["primID"], out["tfar"]  # int32, float32 (1e37 on a miss)

    def raw(self, origins32: np.ndarray, directions32: np.ndarray) -> np.ndarray:
        """Bare embreex query on float32 arrays already centred (benchmark baseline): returns the primitive ids."""
        return self._scene.run(origins32, directions32, output=True)["primID"]


class NumpyEngine:
    """Pure-numpy Möller–Trumbore closest hit over all triangles (O(rays x triangles)): fallback and test oracle.

    Only for small scenes or platforms without the embreex wheel.  Works in float64.
    """

    name = "numpy"

    def __init__(self, vertices: np.ndarray, chunk: int = 2_000_000):
        vertices = np.asarray(vertices, dtype=np.float64)
        self.n_triangles = len(vertices)
        self.center = np.zeros(3)
        self._p0 = vertices[:, 0]
        self._e1 = vertices[:, 1] - vertices[:, 0]
        self._e2 = vertices[:, 2] - vertices[:, 0]
        self._chunk = int(chunk)

    def intersect(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Same contract as :meth:`EmbreeEngine.intersect`."""
        origins = np.asarray(origins, dtype=np.float64)
        directions = np.asarray(directions, dtype=np.float64)
        r = len(origins)
        best_t = np.full(r, np.inf)
        best_p = np.full(r, MISS, dtype=np.int64)
        nt = self.n_triangles
        if nt == 0 or r == 0:
            return best_p, best_t
        step = max(1, self._chunk // max(nt, 1))
        for a in range(0, r, step):  # loop over ray chunks; each chunk is tested against all triangles at once
            o = origins[a : a + step, None, :]
            d = directions[a : a + step, None, :]
            pvec = np.cross(d, self._e2[None])
            det = np.einsum("rtk,tk->rt", pvec, self._e1)
            with np.errstate(divide="ignore", invalid="ignore"):
                inv = 1.0 / det
                s = o - self._p0[None]
                u = np.einsum("rtk,rtk->rt", s, pvec) * inv
                q = np.cross(s, self._e1[None])
                v = np.einsum("rtk,rtk->rt", d, q) * inv
                t = np.einsum("rtk,tk->rt", q, self._e2) * inv
            ok = (np.abs(det) > 1e-300) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
            t = np.where(ok, t, np.inf)
            j = np.argmin(t, axis=1)
            tj = t[np.arange(len(j)), j]
            hit = np.isfinite(tj)
            best_t[a : a + step] = tj
            best_p[a : a + step] = np.where(hit, j, MISS)
        return best_p, best_t


def make_engine(vertices: np.ndarray, backend: str = "auto"):
    """Ray engine over triangles ``vertices`` (t, 3, 3) m: ``backend`` "auto" (Embree if importable), "embree"
    or "numpy"."""
    if backend == "auto":
        backend = "embree" if HAS_EMBREE else "numpy"
    if backend == "embree":
        return EmbreeEngine(vertices)
    if backend == "numpy":
        return NumpyEngine(vertices)
    raise ValueError(f"unknown ray engine backend {backend!r}: use 'auto', 'embree' or 'numpy'")
