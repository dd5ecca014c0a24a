"""Closest-hit ray queries against a triangle soup: Embree or a slow pure-numpy fallback.

The engines answer one question: for rays (origin, unit direction), which triangle is hit first and at which
distance.  Robustness (origin offsets, self-hit rejection) lives one level up, in
:class:`fem2tmm.radiation.surfaces.TriangleScene`; every performance figure of the package is with Embree.

Embree is reached in one of two ways, both through the Embree 4 library that the ``embreex`` wheel ships:

* **direct** (the default where the library file is found): the scene is built through Embree's C API (ctypes)
  and queried by a compiled kernel that calls ``rtcIntersect1`` itself (an indirect call through the function's
  address, :func:`embree_intersect1`): the tracer's batches go from float64 rays to hits with no float32 copies
  and no per-ray output arrays.  The BVH is built at Embree's medium quality, as embreex's
  (measurements: docs/design-notes.md, radiation/engine.py).
* **embreex** (fallback, e.g. a wheel whose library is not where we look, or an Embree other than 4):
  embreex's ``EmbreeScene.run`` on float32 copies of each batch.  The environment variable
  ``FEM2TMM_EMBREE_DIRECT=0`` forces it; ``FEM2TMM_EMBREE_LIBRARY`` names the Embree 4 library to load instead of
  the one found next to embreex.

Both use Embree's robust (watertight) traversal, so rays cannot slip through the shared edge of two triangles, and
both translate the scene to its bounding-box centre before converting to float32, so the rounding is relative to
the size of the model, not to its distance from the origin of coordinates.
"""

from __future__ import annotations

import ctypes
import glob
import os

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

try:  # pragma: no cover - exercised through HAS_EMBREE
    from embreex import rtcore_scene as _rtcs
    from embreex.mesh_construction import TriangleMesh as _EmbreeTriangleMesh

    HAS_EMBREE = True
except Exception:  # noqa: BLE001 - any import problem of the compiled wheel means "no Embree"
    HAS_EMBREE = False

MISS = -1

# Embree 4 C API constants (rtcore_common.h, rtcore_buffer.h, rtcore_geometry.h, rtcore_scene.h, rtcore_device.h)
_GEOMETRY_TYPE_TRIANGLE = 0
_BUFFER_TYPE_INDEX, _BUFFER_TYPE_VERTEX = 0, 1
_FORMAT_UINT3, _FORMAT_FLOAT3 = 0x5003, 0x9003
_SCENE_FLAG_ROBUST = 1 << 2
_BUILD_QUALITY_MEDIUM = 1
_DEVICE_PROPERTY_VERSION_MAJOR = 1
#: RTCRayHit (Embree 4) in 4-byte words: ray org 0-2, tnear 3, dir 4-6, time 7, tfar 8, mask 9, id 10, flags 11;
#: hit Ng 12-14, u 15, v 16, primID 17, geomID 18, instID[0] 19 (instPrimID[0] 20); 96 bytes, 16-byte aligned
RAYHIT_WORDS = 32
INVALID_ID = 0xFFFFFFFF


def _find_embree_library():
    """Path of the Embree 4 shared library bundled with embreex (auditwheel/delocate/delvewheel layouts), or None."""
    if not HAS_EMBREE:
        return None
    pkg = os.path.dirname(os.path.abspath(_rtcs.__file__))
    patterns = [os.path.join(pkg + ".libs", "libembree4*"), os.path.join(pkg, ".dylibs", "libembree4*"),
                os.path.join(pkg, "libembree4*"), os.path.join(pkg + ".libs", "embree4*.dll"),
                os.path.join(pkg, "embree4*.dll")]
    for pattern in patterns:
        found = sorted(glob.glob(pattern))
        if found:
            return found[0]
    return None


def _load_embree():
    """ctypes handle of the Embree 4 library with the prototypes used here, or None when it cannot be loaded."""
    path = os.environ.get("FEM2TMM_EMBREE_LIBRARY") or _find_embree_library()
    if not path or os.environ.get("FEM2TMM_EMBREE_DIRECT", "1") == "0":
        return None
    try:
        lib = ctypes.CDLL(path)
        vp, c_int, c_uint, c_size = ctypes.c_void_p, ctypes.c_int, ctypes.c_uint, ctypes.c_size_t
        protos = {
            "rtcNewDevice": (vp, [ctypes.c_char_p]), "rtcReleaseDevice": (None, [vp]),
            "rtcGetDeviceError": (c_int, [vp]), "rtcGetDeviceProperty": (ctypes.c_ssize_t, [vp, c_int]),
            "rtcNewScene": (vp, [vp]), "rtcReleaseScene": (None, [vp]), "rtcCommitScene": (None, [vp]),
            "rtcSetSceneFlags": (None, [vp, c_int]), "rtcSetSceneBuildQuality": (None, [vp, c_int]),
            "rtcNewGeometry": (vp, [vp, c_int]), "rtcReleaseGeometry": (None, [vp]),
            "rtcCommitGeometry": (None, [vp]), "rtcAttachGeometry": (c_uint, [vp, vp]),
            "rtcSetNewGeometryBuffer": (vp, [vp, c_int, c_uint, c_int, c_size, c_size]),
            "rtcIntersect1": (None, [vp, vp, vp]),
        }
        for name, (res, args) in protos.items():
            fn = getattr(lib, name)
            fn.restype, fn.argtypes = res, args
        dev = lib.rtcNewDevice(None)
        if not dev:
            return None
        major = lib.rtcGetDeviceProperty(dev, _DEVICE_PROPERTY_VERSION_MAJOR)
        lib.rtcReleaseDevice(dev)
        return lib if major == 4 else None
    except (OSError, AttributeError):
        return None


_LIB = _load_embree()
#: True when Embree is queried through its C API by compiled kernels (see the module docstring)
HAS_DIRECT = _LIB is not None


@intrinsic
def _call_void3(typingctx, fptr, a, b, c):
    """Call the C function at address ``fptr`` (int) with three pointer arguments given as ints: lets compiled
    kernels call ``rtcIntersect1`` (the address is an argument, so the kernels stay cacheable)."""
    sig = types.void(fptr, a, b, c)

    def codegen(context, builder, signature, args):
        from llvmlite import ir

        i8p = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [i8p, i8p, i8p])
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(fn, [builder.inttoptr(x, i8p) for x in args[1:]])
        return context.get_dummy_value()

    return sig, codegen


def _prefetch_intrinsic_name() -> str:
    from llvmlite import binding

    return "llvm.prefetch.p0" if binding.llvm_version_info[0] >= 16 else "llvm.prefetch.p0i8"  # opaque pointers


@intrinsic
def prefetch(typingctx, arr, i, j):
    """Prefetch (for reading, into all cache levels) the cache line holding element (i, j) of the C-contiguous 2-D
    array ``arr``: a hint to the processor, no effect on results."""
    sig = types.void(arr, i, j)

    def codegen(context, builder, signature, args):
        from llvmlite import ir
        from numba.core import cgutils

        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        idx = [context.cast(builder, v, t, types.intp) for v, t in zip(args[1:], signature.args[1:])]
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, idx)
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]),
                                            _prefetch_intrinsic_name())
        builder.call(fn, [builder.bitcast(ptr, i8p), ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return sig, codegen


@njit(cache=True, nogil=True)
def rayhit_buffer():
    """A float32 scratch array holding one 16-byte aligned RTCRayHit: returns ``(words (32,) float32, ints (32,)
    uint32 view, first aligned word, its address)``."""
    buf = np.empty(RAYHIT_WORDS + 4, np.float32)
    addr = buf.ctypes.data
    base = ((16 - addr % 16) % 16) // 4
    return buf, buf.view(np.uint32), base, addr + 4 * base


@njit(cache=True, nogil=True, inline="always")
def embree_intersect1(fn, scene, buf, ib, base, addr, cx, cy, cz, ox, oy, oz, dx, dy, dz):
    """Closest hit of one ray (origin (ox, oy, oz) m, unit direction) in the Embree scene at ``scene`` (centred on
    (cx, cy, cz)): ``(primitive, distance m)``, (-1, inf) on a miss.  ``fn`` is the address of rtcIntersect1 and
    ``buf``/``ib``/``base``/``addr`` a :func:`rayhit_buffer`."""
    buf[base] = ox - cx
    buf[base + 1] = oy - cy
    buf[base + 2] = oz - cz
    buf[base + 3] = 0.0
    buf[base + 4] = dx
    buf[base + 5] = dy
    buf[base + 6] = dz
    buf[base + 7] = 0.0
    buf[base + 8] = np.inf
    ib[base + 9] = INVALID_ID
    ib[base + 10] = 0
    ib[base + 11] = 0
    ib[base + 17] = INVALID_ID
    ib[base + 18] = INVALID_ID
    ib[base + 19] = INVALID_ID
    _call_void3(fn, scene, addr, 0)
    p = ib[base + 17]
    if p == INVALID_ID:
        return -1, np.inf
    return np.int64(p), np.float64(buf[base + 8])


@njit(cache=True, nogil=True)
def _intersect_batch(fn, scene, center, o, d, prim, t):
    """:func:`embree_intersect1` for every ray of ``o``/``d`` (r, 3): fills ``prim`` (r,) int64 and ``t`` (r,)."""
    buf, ib, base, addr = rayhit_buffer()
    cx, cy, cz = center[0], center[1], center[2]
    for k in range(o.shape[0]):
        prim[k], t[k] = embree_intersect1(fn, scene, buf, ib, base, addr, cx, cy, cz, o[k, 0], o[k, 1], o[k, 2],
                                          d[k, 0], d[k, 1], d[k, 2])


class DirectEmbreeScene:
    """An Embree 4 scene over triangles ``vertices`` (t, 3, 3) m, built through the C API: robust traversal, medium
    build quality (embreex's), vertices in float32 relative to ``center`` (3,).  ``query`` is ``(address of rtcIntersect1,
    scene handle)`` for the compiled kernels.  Embree's queries on a committed scene are thread safe."""

    def __init__(self, vertices: np.ndarray, center: np.ndarray):
        lib = _LIB
        self._lib = lib
        self._device = lib.rtcNewDevice(None)
        self._scene = None
        if not self._device:
            raise RuntimeError("Embree: rtcNewDevice failed")
        try:
            self._scene = lib.rtcNewScene(self._device)
            lib.rtcSetSceneFlags(self._scene, _SCENE_FLAG_ROBUST)
            lib.rtcSetSceneBuildQuality(self._scene, _BUILD_QUALITY_MEDIUM)
            t = len(vertices)
            if t:
                geom = lib.rtcNewGeometry(self._device, _GEOMETRY_TYPE_TRIANGLE)
                vb = lib.rtcSetNewGeometryBuffer(geom, _BUFFER_TYPE_VERTEX, 0, _FORMAT_FLOAT3, 12, 3 * t)
                ibuf = lib.rtcSetNewGeometryBuffer(geom, _BUFFER_TYPE_INDEX, 0, _FORMAT_UINT3, 12, t)
                if not vb or not ibuf:
                    raise RuntimeError(f"Embree: cannot allocate buffers for {t} triangles "
                                       f"(error {lib.rtcGetDeviceError(self._device)})")
                v = np.ascontiguousarray(np.asarray(vertices, np.float64).reshape(-1, 3) - center, np.float32)
                ctypes.memmove(vb, v.ctypes.data, v.nbytes)
                idx = np.arange(3 * t, dtype=np.uint32)
                ctypes.memmove(ibuf, idx.ctypes.data, idx.nbytes)
                lib.rtcCommitGeometry(geom)
                lib.rtcAttachGeometry(self._scene, geom)
                lib.rtcReleaseGeometry(geom)
            lib.rtcCommitScene(self._scene)
            err = lib.rtcGetDeviceError(self._device)
            if err:
                raise RuntimeError(f"Embree: scene build failed (error {err})")
        except BaseException:
            self.close()
            raise
        self.query = (ctypes.cast(lib.rtcIntersect1, ctypes.c_void_p).value, int(self._scene))

    def close(self):
        if self._scene:
            self._lib.rtcReleaseScene(self._scene)
            self._scene = None
        if self._device:
            self._lib.rtcReleaseDevice(self._device)
            self._device = None

    def __del__(self):
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass


class EmbreeEngine:
    """Embree closest-hit queries over triangles ``vertices`` (t, 3, 3) m: through the C API
    (:class:`DirectEmbreeScene`, ``direct`` is then its ``query`` pair) or, without it, through embreex (``direct``
    is None).

    One scene, committed at construction (embreex commits lazily on the first query, which is not thread safe; a
    dummy query here makes later concurrent ``intersect`` calls from several Python threads safe).  Queries release
    the GIL either way.
    """

    name = "embree"

    def __init__(self, vertices: np.ndarray, direct: bool | None = None):
        if not HAS_EMBREE:
            raise ImportError("embreex is not importable")
        vertices = np.asarray(vertices, dtype=np.float64)
        self.center = 0.5 * (vertices.reshape(-1, 3).min(axis=0) + vertices.reshape(-1, 3).max(axis=0)) \
            if vertices.size else np.zeros(3)
        self.n_triangles = len(vertices)
        use_direct = HAS_DIRECT if direct is None else bool(direct) and HAS_DIRECT
        self._direct_scene = DirectEmbreeScene(vertices, self.center) if use_direct else None
        self.direct = self._direct_scene.query if use_direct else None
        self._scene = None
        if not use_direct:
            self._scene = _rtcs.EmbreeScene(robust=True)
            self._mesh = _EmbreeTriangleMesh(self._scene,
                                             np.ascontiguousarray(vertices - self.center, dtype=np.float32))
            self._scene.run(np.zeros((1, 3), np.float32), np.array([[0.0, 0.0, 1.0]], np.float32))  # commit now

    def intersect(self, origins: np.ndarray, directions: np.ndarray, out=None) -> tuple[np.ndarray, np.ndarray]:
        """Closest hit of each ray: ``(prim (r,) int, -1 = miss; t (r,) float distance in m, huge on a miss)``.

        ``origins`` (r, 3) m and ``directions`` (r, 3) unit vectors, any float dtype.  ``out``: optional
        ``(prim (r,) int64, t (r,) float64)`` arrays that the C-API path fills and returns.
        """
        if self.direct is not None:
            r = len(origins)
            prim, t = (np.empty(r, np.int64), np.empty(r)) if out is None else out
            _intersect_batch(self.direct[0], self.direct[1], self.center,
                             np.ascontiguousarray(origins, dtype=np.float64),
                             np.ascontiguousarray(directions, dtype=np.float64), prim, t)
            return prim, t
        o = np.empty(origins.shape, np.float32)
        np.subtract(origins, self.center, out=o, casting="unsafe")
        d = np.ascontiguousarray(directions, dtype=np.float32)
        out = self._scene.run(o, d, output=True)
        return out["primID"], out["tfar"]  # int32, float32 (1e37 on a miss)

    def raw(self, origins32: np.ndarray, directions32: np.ndarray) -> np.ndarray:
        """Bare embreex query (``EmbreeScene.run``) on float32 arrays already centred: the primitive ids.  The
        benchmark baseline; needs an engine built with ``direct=False``."""
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

    def intersect(self, origins: np.ndarray, directions: np.ndarray, out=None) -> tuple[np.ndarray, np.ndarray]:
        """Same contract as :meth:`EmbreeEngine.intersect` (``out`` is not used)."""
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
    (through its C API when available, else embreex), "embreex" (always through embreex's wrapper) or "numpy"."""
    if backend == "auto":
        backend = "embree" if HAS_EMBREE else "numpy"
    if backend == "embree":
        return EmbreeEngine(vertices)
    if backend == "embreex":
        return EmbreeEngine(vertices, direct=False)
    if backend == "numpy":
        return NumpyEngine(vertices)
    raise ValueError(f"unknown ray engine backend {backend!r}: use 'auto', 'embree', 'embreex' or 'numpy'")
