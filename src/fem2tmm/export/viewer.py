"""The report's interactive 3-D view: the data it shows and the HTML that shows it, offline.

:func:`view_data` gathers what the page draws from a run: the radiating faces as triangles (the faces the PNG maps
draw: shells and the outer faces of solids), the temperature fields at the face nodes (recovered, detailed, their
difference; every output time of a transient), the super node of each triangle and each super node's name, deck
number (:func:`fem2tmm.export.deliverable.deck_node_numbers`), part, area, capacitance and temperature.  Large
arrays travel as base64 float32 / int32 (little endian), the super-node table as plain JSON numbers.

:func:`viewer_html` returns the HTML section: the vendored three.js build (``assets/three.fem2tmm.min.js``, MIT
licence in ``assets/three.LICENSE``, inlined with its licence text) and the page's own script (``assets/viewer.js``),
so that ``report.html`` opens from the output folder alone with no network access.
"""

from __future__ import annotations

import base64
import json
from importlib import resources

import numpy as np

from ..constants import KELVIN

#: triangles drawn at most (a larger surface is sub-sampled uniformly; the page says how many it draws)
MAX_TRIANGLES = 300_000
#: float32 values of the transient frames at most, over all fields (more output times are sub-sampled uniformly,
#: keeping the first and the last): 6e6 values are 24 MB of data, 32 MB in the page
MAX_FRAME_VALUES = 6_000_000
#: the vendored three.js (assets/README.md says how the bundle was made)
THREE_VERSION = "0.187.0"
#: mesh edges drawn only up to this many triangles (the cluster boundaries are always drawn)
MAX_EDGE_TRIANGLES = 60_000


def distinct_colors(n: int) -> np.ndarray:
    """(n, 3) uint8 sRGB colours that stay distinct for hundreds of categories: hues spaced by the golden ratio
    (each new hue falls in the largest gap left by the previous ones), lightness and saturation cycling over
    three and two levels so that neighbouring hues that come back after many steps differ in lightness too."""
    k = np.arange(n)
    h = (k * 0.6180339887498949 + 0.08) % 1.0
    light = np.array([0.55, 0.40, 0.70])[k % 3]
    sat = np.array([0.80, 0.55])[(k // 3) % 2]
    # HSL to RGB (vectorised)
    c = (1 - np.abs(2 * light - 1)) * sat
    hp = h * 6.0
    x = c * (1 - np.abs(hp % 2 - 1))
    zero = np.zeros(n)
    sector = np.floor(hp).astype(int) % 6
    rgb = np.select([sector[:, None] == s for s in range(6)],
                    [np.stack(v, axis=1) for v in ((c, x, zero), (x, c, zero), (zero, c, x), (zero, x, c),
                                                   (x, zero, c), (c, zero, x))])
    rgb = rgb + (light - c / 2)[:, None]
    return np.clip(np.round(rgb * 255), 0, 255).astype(np.uint8)


def _b64(a: np.ndarray, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=np.dtype(dtype).newbyteorder("<")).tobytes()).decode()


def _lut(name: str) -> list[int]:
    """A matplotlib colour map as 256 sRGB triples (flat list of uint8), the same map as the PNG pictures."""
    import matplotlib

    cm = matplotlib.colormaps[name]
    return np.round(cm(np.linspace(0, 1, 256))[:, :3] * 255).astype(int).ravel().tolist()


def surface_triangles(faces_nodes: np.ndarray, max_triangles: int = MAX_TRIANGLES):
    """Triangles of faces (f, 4) mesh node indices (-1 pad for triangles): quads split along their 0-2 diagonal.

    Returns ``nodes`` (v,) the mesh nodes used, ``tri`` (t, 3) int32 indices into ``nodes``, ``face`` (t,) the
    face of each triangle, and ``total`` the number of triangles before sub-sampling to ``max_triangles``
    (uniformly over the faces: holes show where faces are left out).
    """
    f = np.asarray(faces_nodes, np.int64)
    quad = f[:, 3] >= 0
    tri = np.concatenate([f[:, [0, 1, 2]], f[quad][:, [0, 2, 3]]])
    face = np.concatenate([np.arange(len(f)), np.flatnonzero(quad)])
    total = len(tri)
    if total > max_triangles:
        keep = np.linspace(0, total - 1, max_triangles).astype(np.int64)
        tri, face = tri[keep], face[keep]
    nodes, inv = np.unique(tri, return_inverse=True)
    return nodes, inv.reshape(-1, 3).astype(np.int32), face, total


def _edges(faces_nodes: np.ndarray, face_label: np.ndarray, with_mesh: bool) -> tuple[np.ndarray, np.ndarray]:
    """Edges (e, 2) of the faces' polygons (mesh node indices) between faces of different labels or on the
    surface's border (the cluster boundaries), and (``with_mesh``) every polygon edge."""
    f = np.asarray(faces_nodes, np.int64)
    a = f
    b = np.where(np.roll(f, -1, axis=1) >= 0, np.roll(f, -1, axis=1), f[:, :1])  # next corner (triangles close)
    ok = a >= 0
    a, b = a[ok], b[ok]
    lab = np.broadcast_to(face_label[:, None], f.shape)[ok]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keep = lo != hi
    lo, hi, lab = lo[keep], hi[keep], lab[keep]
    if not len(lo):
        return np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64)
    key = lo * (int(f.max(initial=0)) + 1) + hi
    order = np.lexsort((lab, key))
    key, lab, lo, hi = key[order], lab[order], lo[order], hi[order]
    start = np.r_[True, key[1:] != key[:-1]]
    grp = np.cumsum(start) - 1
    count = np.bincount(grp)
    mixed = np.zeros(len(count), bool)
    np.logical_or.at(mixed, grp[1:], (lab[1:] != lab[:-1]) & ~start[1:])
    first = np.flatnonzero(start)
    border = (count == 1) | mixed
    boundary = np.stack([lo[first][border], hi[first][border]], axis=1)
    mesh = np.stack([lo[first], hi[first]], axis=1) if with_mesh else np.zeros((0, 2), np.int64)
    return boundary, mesh


def _frames(n_times: int, n_values: int, n_fields: int) -> np.ndarray:
    """Indices of the output times kept so that ``n_fields`` fields of ``n_values`` each fit MAX_FRAME_VALUES."""
    k = max(2, MAX_FRAME_VALUES // max(1, n_values * n_fields))
    if n_times <= k:
        return np.arange(n_times)
    return np.unique(np.linspace(0, n_times - 1, k).round().astype(np.int64))


def face_super_nodes(result) -> np.ndarray:
    """(f,) the reduced-network node (row of ``result.reduced.network``, deck order) of each radiating face's
    element; -1 where the element is in no super node (all its nodes fixed)."""
    model = result.model
    elem_row = np.full(model.mesh.n_elements, -1, np.int64)
    elem_row[model.elements] = np.arange(len(model.elements))
    row = elem_row[model.faces.element]
    return np.where(row >= 0, result.reduced.network.element_cluster[np.maximum(row, 0)], -1)


def view_data(result) -> dict:
    """What the 3-D view draws (plain JSON types; arrays as base64 little-endian float32 / int32 / uint8)."""
    model = result.model
    f = model.faces
    nodes, tri, face, total = surface_triangles(f.nodes)
    index = np.full(model.mesh.n_nodes, -1, np.int64)
    index[nodes] = np.arange(len(nodes))
    pts = model.mesh.points[nodes]
    red = result.reduced
    parts = [p.name for p in model.parts]
    sn_of_face = np.full(f.n, -1, np.int64)
    super_nodes, sn_colors = [], np.zeros((0, 3), np.uint8)
    if red is not None:
        from .deliverable import deck_node_numbers

        rm = red.network
        sn_of_face = face_super_nodes(result)
        numbers = deck_node_numbers(result)
        C = rm.C if rm.C is not None else np.full(rm.n, np.nan)
        area = rm.area if rm.area is not None else np.full(rm.n, np.nan)
        for i in range(rm.n):
            super_nodes.append({"name": str(rm.names[i]), "number": int(numbers[i]), "kind": str(rm.kind[i]),
                                "part": parts[rm.part[i]] if rm.part[i] >= 0 else None,
                                "area_m2": None if not np.isfinite(area[i]) else float(area[i]),
                                "C_J_per_K": None if not np.isfinite(C[i]) else float(C[i]),
                                "T_C": float(red.solution.T[i] - KELVIN)})
        sn_colors = distinct_colors(rm.n)

    def at_vertices(T_dof: np.ndarray) -> np.ndarray:
        return (model.node_temperatures(T_dof) - KELVIN)[nodes]

    fields = []
    det = result.detailed.solution
    if red is not None:
        fields.append(("recovered", "Temperature, recovered from the reduced model", "°C", red.T_recovered, "turbo"))
    if det is not None:
        fields.append(("detailed", "Temperature, detailed model", "°C", det.T, "turbo"))
    field_data = [{"name": n, "label": lab, "unit": u, "cmap": cm, "symmetric": False,
                   "values": _b64(at_vertices(T), "<f4")} for n, lab, u, T, cm in fields]
    if red is not None and det is not None:
        err = (model.node_temperatures(red.T_recovered) - model.node_temperatures(det.T))[nodes]
        field_data.append({"name": "error", "label": "Recovered minus detailed", "unit": "K", "cmap": "coolwarm",
                           "symmetric": True, "values": _b64(err, "<f4")})
    transient = None
    run = result.transient
    if run is not None and run.T_result is not None:
        series = [("recovered" if run.T_recovered is not None else "detailed", run.T_result)]
        if run.T_recovered is not None and run.detailed is not None:
            series.append(("detailed", run.detailed.T))
        keep = _frames(len(run.times), len(nodes), len(series) + (len(series) > 1))
        node_dof = model.node_dof[nodes]
        ok = node_dof >= 0
        frames = {}
        for name, T in series:
            v = np.full((len(keep), len(nodes)), np.nan)
            v[:, ok] = np.asarray(T)[keep][:, node_dof[ok]] - KELVIN
            frames[name] = v
        if len(series) > 1:
            frames["error"] = frames["recovered"] - frames["detailed"]
        transient = {"times_s": [float(t) for t in run.times[keep]], "frames_total": int(len(run.times)),
                     "fields": {k: _b64(v, "<f4") for k, v in frames.items()},
                     "super_nodes_T_C": None if run.reduced is None else
                     np.round(np.asarray(run.reduced.T)[keep] - KELVIN, 9).tolist()}
    boundary, mesh_edges = _edges(f.nodes, sn_of_face if red is not None else f.part,
                                  with_mesh=len(tri) <= MAX_EDGE_TRIANGLES)
    boundary = boundary[(index[boundary] >= 0).all(axis=1)]
    mesh_edges = mesh_edges[(index[mesh_edges] >= 0).all(axis=1)]
    return {
        "positions": _b64(pts, "<f4"), "n_vertices": int(len(nodes)),
        "triangles": _b64(tri, "<i4"), "n_triangles": int(len(tri)), "triangles_total": int(total),
        "max_triangles": MAX_TRIANGLES,
        "tri_sn": _b64(sn_of_face[face], "<i4"), "tri_part": _b64(f.part[face], "<i4"),
        "cluster_edges": _b64(index[boundary], "<i4"), "mesh_edges": _b64(index[mesh_edges], "<i4"),
        "parts": parts, "part_colors": distinct_colors(len(parts)).ravel().tolist(),
        "super_nodes": super_nodes, "sn_colors": _b64(sn_colors, "u1"),
        "fields": field_data, "transient": transient,
        "colormaps": {name: _lut(name) for name in ("turbo", "coolwarm")},
    }


def _asset(name: str) -> str:
    return resources.files("fem2tmm.export").joinpath("assets", name).read_text(encoding="utf-8")


def viewer_html(data: dict) -> str:
    """The HTML section of the 3-D view: its controls, the data (JSON), three.js under its licence and the page's
    script; nothing is fetched at view time."""
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    licence = _asset("three.LICENSE").replace("*/", "* /")
    return f"""<div id="f2t-view" class="f2t-view" data-rendered="0">
<div class="f2t-bar">
 <label>Colour by <select id="f2t-mode"></select></label>
 <span id="f2t-timebox" hidden><button id="f2t-play" type="button">▶ play</button>
  <input id="f2t-time" type="range" min="0" max="0" value="0"> <span id="f2t-tlabel"></span>
  <label title="colour range of the time shown, not of every time"><input id="f2t-local" type="checkbox"> range of this time</label></span>
 <label>Cut <select id="f2t-clip"><option value="">none</option><option>x</option><option>y</option><option>z</option></select></label>
 <input id="f2t-cut" type="range" min="0" max="1000" value="500" disabled>
 <label><input id="f2t-flip" type="checkbox" disabled> flip</label>
 <label><input id="f2t-edges" type="checkbox" checked> super-node borders</label>
 <label><input id="f2t-mesh" type="checkbox"> mesh</label>
 <span class="f2t-views">View <button type="button" data-view="iso">iso</button><button type="button" data-view="+x">+x</button><button type="button" data-view="-x">−x</button><button type="button" data-view="+y">+y</button><button type="button" data-view="-y">−y</button><button type="button" data-view="+z">+z</button><button type="button" data-view="-z">−z</button></span>
</div>
<div class="f2t-stage"><div id="f2t-canvas"></div><div id="f2t-legend"></div><div id="f2t-tip" hidden></div>
<div id="f2t-axes"></div></div>
<div id="f2t-info">Drag to turn, wheel to zoom, right-drag to pan. Hover a face for its super node, click to keep it.</div>
<pre id="f2t-check" hidden></pre>
</div>
<script type="application/json" id="f2t-data">{payload}</script>
<script>/* three.js {THREE_VERSION} (subset bundled for fem2tmm, see fem2tmm/export/assets/README.md)
{licence}*/
{_asset("three.fem2tmm.min.js")}</script>
<script>{_asset("viewer.js")}</script>"""


VIEWER_CSS = """
.f2t-view { border: 1px solid #bbb; margin: 1em 0; background: #fafafa; }
.f2t-bar { padding: 6px 8px; display: flex; flex-wrap: wrap; gap: 6px 14px; align-items: center; font-size: 14px;
  border-bottom: 1px solid #ddd; }
.f2t-bar button { font-size: 13px; margin: 0 1px; }
.f2t-stage { position: relative; height: 620px; }
#f2t-canvas { position: absolute; left: 0; top: 0; bottom: 0; right: 175px; }
#f2t-legend { position: absolute; right: 8px; top: 10px; bottom: 10px; width: 160px; font-size: 13px;
  pointer-events: none; }
.f2t-cbtitle { font-weight: bold; height: 3.4em; overflow: hidden; }
.f2t-cb { position: absolute; top: 3.8em; bottom: 2.8em; left: 0; width: 24px; border: 1px solid #666; }
.f2t-tick { position: absolute; left: 34px; transform: translateY(50%); white-space: nowrap; }
.f2t-tick::before { content: ""; position: absolute; left: -9px; top: 50%; width: 7px; border-top: 1px solid #333; }
.f2t-cbnote { position: absolute; bottom: 0; font-size: 11px; color: #444; }
.f2t-cat { margin: 2px 0; }
.f2t-axl { position: absolute; font-weight: bold; font-size: 13px; }
#f2t-tip { position: absolute; background: rgba(255,255,255,0.95); border: 1px solid #888; padding: 5px 8px;
  font-size: 13px; pointer-events: none; white-space: nowrap; box-shadow: 1px 1px 4px rgba(0,0,0,0.2); }
#f2t-axes { position: absolute; left: 8px; bottom: 8px; width: 90px; height: 90px; pointer-events: none; }
#f2t-info { padding: 6px 8px; font-size: 13px; border-top: 1px solid #ddd; min-height: 1.4em; }
@media print { .f2t-view { display: none; } }
"""

__all__ = ["MAX_TRIANGLES", "MAX_FRAME_VALUES", "distinct_colors", "face_super_nodes", "surface_triangles", "view_data", "viewer_html",
           "VIEWER_CSS"]
