"""HTML report (``report.html`` + PNG images), opens offline from the output folder alone.

Contents: summary (with what negative GL mean), temperatures per part (result and reference side by side) and
per reduced node, the interactive 3-D view (:mod:`fem2tmm.export.viewer`), the heat flows with every input and
output named, per part and between parts (:mod:`fem2tmm.export.heatflow`), static maps for printing (clusters,
temperature and error seen from two opposite sides with the hottest face marked, absorbed solar flux),
exchange-factor line-sum-error histogram, stage timings and the case as the user wrote it.  Images are matplotlib
renderings of the radiating faces (shells and the outer faces of solids).
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from ..constants import KELVIN
from .summary import (NEGATIVE_GL_NOTE, UNIT_TEXT, allocation_rows, count_of, choice_text, parametric_rows,
                      refinement_rows, verified_rows)
from .orbit import orbit_plots
from .viewer import VIEWER_CSS, distinct_colors, face_super_nodes, view_data, viewer_html

#: faces drawn at most per image (larger meshes are sub-sampled uniformly; the caption says so)
MAX_FACES = 60_000


def _face_polygons(points: np.ndarray, faces: np.ndarray) -> list[np.ndarray]:
    quads = points[np.where(faces < 0, faces[:, :1], faces)]  # triangles repeat their first node
    return list(quads)


#: the isometric view of the front (elevation, azimuth in degrees) and the opposite one: together they show every
#: side of the model (each of the six axis directions faces one of them)
BOTH_SIDES = ((25.0, -60.0), (-25.0, 120.0))


def render_faces(path: Path, points: np.ndarray, faces: np.ndarray, values: np.ndarray, title: str, label: str,
                 cmap: str = "inferno", categorical: bool = False, symmetric: bool = False,
                 views: tuple[tuple[float, float], ...] = BOTH_SIDES[:1], mark_max: bool = False) -> str:
    """Render faces (f, 4) (-1 padded) coloured by ``values`` (f,) to ``path`` (PNG), one panel per view
    ((elevation, azimuth) degrees) with one colour bar; ``mark_max`` marks the face of the largest value in every
    panel.  Returns a caption note."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    note = ""
    idx = np.arange(len(faces))
    if len(idx) > MAX_FACES:
        idx = np.linspace(0, len(faces) - 1, MAX_FACES).astype(np.int64)
        note = f" ({MAX_FACES:,} of {len(faces):,} faces drawn)"
    f, v = faces[idx], np.asarray(values, float)[idx]
    fig = plt.figure(figsize=(7.5 * len(views) if len(views) > 1 else 7.5, 6.0), dpi=110)
    if categorical:  # the 3-D view's colours: distinct for hundreds of categories, grey for none
        k = int(np.nanmax(v)) + 1 if np.isfinite(v).any() else 1
        palette = np.vstack([distinct_colors(max(k, 1)) / 255.0, [[0.75, 0.75, 0.75]]])
        colors = palette[np.where(np.isfinite(v) & (v >= 0), np.nan_to_num(v, nan=-1), k).astype(np.int64)]
        norm = None
    else:
        finite = v[np.isfinite(v)]
        lo, hi = (finite.min(), finite.max()) if len(finite) else (0.0, 1.0)
        if symmetric:
            m = max(abs(lo), abs(hi), 1e-300)
            lo, hi = -m, m
        if hi <= lo:
            hi = lo + 1e-12
        norm = matplotlib.colors.Normalize(lo, hi)
        colors = plt.get_cmap(cmap)(norm(v))
    polys = _face_polygons(points, f)
    used = points[np.unique(f[f >= 0])]
    lo3, hi3 = used.min(axis=0), used.max(axis=0)
    c, r = (lo3 + hi3) / 2, (hi3 - lo3).max() / 2 or 1.0
    hot = None
    if mark_max and np.isfinite(v).any():
        j = int(np.nanargmax(v))
        hot = points[f[j][f[j] >= 0]].mean(axis=0)
    axes = []
    for k, (elev, azim) in enumerate(views):
        ax = fig.add_subplot(1, len(views), k + 1, projection="3d")
        ax.add_collection3d(Poly3DCollection(polys, facecolors=colors, edgecolors="none", linewidths=0))
        if hot is not None:
            ax.scatter(*hot, s=80, facecolors="none", edgecolors="cyan", linewidths=2, depthshade=False)
        ax.set_xlim(c[0] - r, c[0] + r)
        ax.set_ylim(c[1] - r, c[1] + r)
        ax.set_zlim(c[2] - r, c[2] + r)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elev, azim=azim)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_zlabel("z [m]")
        ax.set_title(f"{title}\n(view from {_direction(elev, azim)})" if len(views) > 1 else title,
                     pad=28 if len(views) > 1 else None)
        axes.append(ax)
    if norm is not None:
        sm = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
        fig.colorbar(sm, ax=axes, shrink=0.7, label=label)
    if hot is not None:
        note += (f"; the circle marks the element with the highest value, {np.nanmax(v):.4g} "
                 f"{label.split('[')[-1].rstrip(']')} (an element's mean: node extremes are in the tables)")
    fig.savefig(path)
    plt.close(fig)
    return note


def _direction(elev: float, azim: float) -> str:
    """'+x +y +z'-style octant a view (elevation, azimuth degrees) looks from."""
    e, a = np.radians(elev), np.radians(azim)
    d = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    return " ".join(f"{'+' if x > 0 else '-'}{n}" for x, n in zip(d, "xyz") if abs(x) > 1e-9)


def _histogram(path: Path, values: np.ndarray, title: str, xlabel: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 3.8), dpi=110)
    v = np.abs(np.asarray(values, float))
    v = v[np.isfinite(v) & (v > 0)]
    if len(v):
        bins = np.logspace(np.log10(v.min()), np.log10(v.max()) + 1e-9, 40)
        ax.hist(v, bins=bins, color="#3465a4")
        ax.set_xscale("log")
    else:  # an empty histogram with default axes reads as a broken plot
        ax.text(0.5, 0.5, "every value is 0\n(e.g. REFs of faces that see only space close exactly)",
                ha="center", va="center", transform=ax.transAxes)
        ax.set_xticks([])
        ax.set_yticks([])
    ax.set_xlabel(xlabel)
    ax.set_ylabel("count")
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _table(rows: list[tuple], header: tuple) -> str:
    h = "".join(f"<th>{html.escape(str(x))}</th>" for x in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(x))}</td>" for x in r) + "</tr>" for r in rows)
    return f"<table><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"


def _three(d: dict) -> tuple[str, str, str]:
    return tuple("—" if d.get(k) is None else f"{d[k]:.3f}" for k in ("min", "mean", "max"))


def _fmt(v, unit="") -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.6g}{unit}"
    return f"{v}{unit}"


def write_report(folder: Path, result, case_text: str, before_html=None) -> list[str]:
    """Write ``report.html`` and its images into ``folder``; returns the image file names.  ``before_html()``,
    if given, is called after the images are rendered and before the page is composed (the caller updates
    ``result.summary["timings_s"]["write"]`` there)."""
    folder = Path(folder)
    model = result.model
    s = result.summary
    f = model.faces
    pts = model.mesh.points
    images: list[tuple[str, str]] = []

    def face_values(T_dof: np.ndarray) -> np.ndarray:
        return np.asarray(f.W @ T_dof).ravel()

    view = view_data(result)
    if result.reduced is not None:
        labels = face_super_nodes(result).astype(float)
        note = render_faces(folder / "clusters.png", pts, f.nodes, labels,
                            "Clusters (super nodes)", "cluster", categorical=True)
        images.append(("clusters.png", "Clusters: each colour is one super node (the colours of the 3-D view)" + note))
    T_dof = result.reduced.T_recovered if result.reduced is not None else result.detailed.solution.T
    kind = "recovered from the reduced model" if result.reduced is not None else "detailed model"
    note = render_faces(folder / "temperature.png", pts, f.nodes, face_values(T_dof) - KELVIN,
                        f"Temperature ({kind})", "T [°C]", cmap="turbo", views=BOTH_SIDES, mark_max=True)
    images.append(("temperature.png", f"Temperature, {kind}, seen from two opposite sides" + note))
    if result.reduced is not None and result.detailed.solution is not None:
        err = face_values(result.reduced.T_recovered - result.detailed.solution.T)
        note = render_faces(folder / "error.png", pts, f.nodes, err,
                            "Recovered minus detailed", "ΔT [K]", cmap="coolwarm", symmetric=True, views=BOTH_SIDES)
        images.append(("error.png", "Error of the recovered temperatures against the detailed reference" + note))
    solar = result.absorbed_solar_faces
    if solar is not None:
        note = render_faces(folder / "solar.png", pts, f.nodes, solar, "Absorbed solar flux", "q [W/m²]",
                            cmap="viridis")
        images.append(("solar.png", "Absorbed solar flux per face" + note))
    images += orbit_plots(folder, result)
    if result.reduced is not None and result.reduced.radiation is not None:
        _histogram(folder / "lse.png", result.reduced.radiation.lse, "Line-sum error of the super-face REFs",
                   "|LSE| (before closure)")
        images.append(("lse.png", "Exchange-factor line-sum errors (super faces)"))
    if result.transient is not None:
        from .transient import transient_plots

        images += transient_plots(folder, result)

    if before_html is not None:
        before_html()
    rows = [("mesh", f"{s['mesh']['nodes']:,} nodes, {s['mesh']['elements']:,} elements")]
    red = s.get("reduced")
    if red:
        rows.append(("reduced model", f"{red['super_nodes']} super nodes + "
                     f"{count_of(red['boundary_nodes'], 'boundary node')}; "
                     f"{red['conductive_links']} GL ({red['negative_links']} negative), {red['radiative_links']} GR, "
                     f"{red['super_faces']} super faces"))
        if red["negative_links"]:
            rows.append(("negative GL", f"{red['negative_links']} of {red['conductive_links']}: {NEGATIVE_GL_NOTE}"))
        rows += allocation_rows(red)
        if red.get("choice"):
            rows.append(("reduction", choice_text(red["choice"])))
        rows += parametric_rows(red)
        rows += refinement_rows(red)
    acc = s.get("accuracy") or {}
    if acc.get("rms_K") is not None:
        noise = acc.get("reference_noise_rms_K")
        rows.append(("recovered vs detailed", f"RMS {acc['rms_K']:.4g} K, max {acc['max_K']:.4g} K over {acc['nodes']:,} nodes"
                     + ("" if noise is None else f" (the reference's own noise: RMS {noise:.2g} K)")))
        if acc.get("radiation_share") is not None:
            rows.append(("heat out by radiation", f"{100 * acc['radiation_share']:.1f} % (detailed model)"))
        for e in acc.get("excludes") or ():
            rows.append(("not in the error", e))
    rows += verified_rows(red)
    pn = s.get("positive_network")
    if pn:
        text = (f"{pn['links']} positive GL between touching super nodes (exact: {pn['exact_links']} GL, "
                f"{pn['exact_negative_links']} negative); " + (
                    "the exact reduction has no physical steady solution to compare with" if pn["T_vs_exact_K"] is None
                    else f"max {pn['T_vs_exact_K']['max']:.3g} K from the exact reduction; criteria "
                         f"{'met' if pn['criteria']['met'] else 'NOT met'}"))
        err = pn.get("recovered_error_K")
        if err:
            text += (f"; recovered RMS {err['positive']['rms']:.4g} K against {err['exact']['rms']:.4g} K for the "
                     "exact reduction")
        rows.append(("positive network", text))
    tr = s.get("transient") or {}
    if tr:
        t_acc = tr.get("accuracy") or {}
        rows.append(("transient", f"{tr['method']}, {tr['start_s']:g} to {tr['end_s']:g} s, {len(tr['times_s'])} output "
                     f"times" + (f", {tr['periods']} periods" if tr.get("periods") else "")
                     + (f"; recovered vs detailed RMS {t_acc['rms_K']:.4g} K, max {t_acc['max_K']:.4g} K at "
                        f"{t_acc['time_of_max_s']:g} s" if t_acc else "")))
        for k, eb in (tr.get("energy_balance") or {}).items():
            rows.append((f"transient energy ({k})", f"stored {eb['stored_J']:.6g} J = applied {eb['applied_J']:.6g} J − "
                         f"to space {eb['to_space_J']:.6g} J − into fixed {eb['into_fixed_J']:.6g} J "
                         f"(imbalance {eb['relative']:.1e} relative)"))
    rad = s.get("radiation") or {}
    if rad.get("rays"):
        rows.append(("radiation (reduced)", f"{rad['rays']:,} rays, RMS LSE {rad['lse_rms']:.3g}"))
    if rad.get("detailed"):
        rows.append(("radiation (detailed)", f"{rad['detailed']['rays']:,} rays, RMS LSE {rad['detailed']['lse_rms']:.3g}"))

    tc = s.get("temperatures_C") or {}
    ref = (tc.get("reference") or {}).get("parts") or {}
    part_rows = [(name, *_three(d), *(_three(ref[name]) if name in ref else ()))
                 for name, d in (tc.get("parts") or {}).items()]
    head = "recovered" if str(tc.get("source", "")).startswith("recovered") else "detailed"
    part_head = ("part", f"min ({head})", "mean", "max") + (("min (detailed)", "mean", "max") if ref else ())
    sn_rows = [(k, f"{v:.3f}") for k, v in (tc.get("super_nodes") or {}).items()]

    flows_html = _heat_flows_html(s.get("heat_flows") or {}) + _step_table(result)
    timings = [(k, f"{v:.2f} s") for k, v in (s.get("timings_s") or {}).items()]
    verified = _verified_section((red or {}).get("verified"))

    wide = {"temperature.png", "error.png"}  # two views side by side: the full page width
    figs = "".join(f'<figure{" class=wide" if name in wide else ""}><img src="{name}" alt="{html.escape(cap)}">'
                   f"<figcaption>{html.escape(cap)}</figcaption></figure>" for name, cap in images)
    doc = _page(f"""<h1>fem2tmm report</h1>
<p>Case: <code>{html.escape(str(s.get('case')))}</code> — fem2tmm {html.escape(str(s.get('version')))}</p>
<h2>Summary</h2>{_table(rows, ("quantity", "value"))}
<h2>Temperatures per part [°C]</h2>{_table(part_rows, part_head)}
<p>Min and max over the part's nodes, mean = plain mean over its nodes.</p>
<details><summary>Temperatures of the {len(sn_rows)} reduced nodes [°C]</summary>{_table(sn_rows, ("node", "T [°C]"))}</details>
<h2>3-D view</h2>
<p>Turn, zoom and cut the model; colour it by temperature, super node or part; hover a face for its super node
(name, deck number as in <code>model.esatan</code>, part, area, capacitance, temperature).{_view_note(view)}</p>
{viewer_html(view) if view["n_triangles"] else "<p>The model has no radiating face to draw.</p>"}
<h2>Heat flows</h2>{flows_html}
{verified}<h2>Maps (static, for printing)</h2>{figs}
<h2>Stage timings</h2>{_table(timings, ("stage", "time"))}
<h2>Case</h2><pre>{html.escape(case_text)}</pre>
<h2>summary.json</h2><pre>{html.escape(json.dumps(s, indent=1, default=str))}</pre>""")
    (folder / "report.html").write_text(doc, encoding="utf-8")
    return [name for name, _ in images]


def _verified_section(v: dict | None) -> str:
    """The report's validity-range section: one row per verified state (summary.json ``reduced.verified``), or per
    estimated state where an unverified run's choices rested on the range (``reduced.verified.estimated``)."""
    if not v:
        return ""
    if v["status"] == "UNVERIFIED":
        est = v.get("estimated")
        if not est or not est.get("states"):
            return ""
        return (f"<h2>Validity range: UNVERIFIED; the error ESTIMATED at each state (no detailed reference)</h2>"
                f"{_range_table(est)}<p>Each state: <code>model.esatan</code> with those constants edited, read back "
                "and solved, recovered with the recovery of <code>reduced.npz</code>; its error is the a-posteriori "
                "estimate (Newton steps of the detailed problem at that state from the recovered field, beyond "
                f"its ray noise), not a comparison with the detailed model. {_RANGES} Why unverified: "
                f"{html.escape(v['reason'])}."
                "</p>")
    noise = v.get("reference_noise")
    return ("<h2>Validity range: <code>model.esatan</code> edited, solved and recovered against the detailed "
            "model</h2>"
            f"{_range_table(v)}<p>Each state: <code>model.esatan</code> with those constants edited, read back and "
            "solved, recovered with the recovery of <code>reduced.npz</code>, against the detailed model solved at "
            f"that state. {_RANGES} Reference noise (design state): "
            + ("not estimated" if noise is None else f"RMS {noise['rms_K']:.2g} K, max {noise['max_K']:.2g} K")
            + ".</p>")


#: how the automatic ranges are chosen (docs/case-file.md, ``[reduction] verify``)
_RANGES = ("The ranges, unless <code>[reduction] verify</code> sets them: each named power or flux from 0 to 4 x its "
           "design value, each named held temperature 50 K either side of it, the sink from -270 °C up to the design "
           "state's warmest temperature (a unit inside a warmer enclosure sees a sink that warm); each constant at "
           "either end with the others at design, then all low and all high.")


def _range_table(v: dict) -> str:
    """One row per state of a verified (or estimated) range record: the constants, RMS, max, the state's time, and
    whether it is flagged (the record's ``threshold``) or has no solution."""
    names = [r["name"] for r in v["range"]]
    g = lambda x, digits=4: "—" if x is None else f"{x:.{digits}g}"  # noqa: E731
    t = v.get("threshold") or {}
    flag = (f"flagged: above {t['factor']:g} x the design error and {t['rms_K']:g} K RMS or {t['max_K']:g} K max"
            if t else "flagged")
    rows = [("design", *(g(r["nominal"]) for r in v["range"]), g(v["design"]["rms_K"], 3),
             g(v["design"]["max_K"], 3), "", "")]
    for st in v["states"]:
        checked = st.get("checked", True) is not False
        rows.append((st["label"], *(g(st["values"][n]) for n in names), g(st["rms_K"], 3), g(st["max_K"], 3),
                     "" if not checked else f"{st.get('seconds') or 0.0:.2f}",
                     st["error"] or (flag if st["flagged"] else "" if checked else "not checked")))
    head = ("state", *(f"{r['name']} [{UNIT_TEXT.get(r['unit'], r['unit'])}]" for r in v["range"]), "RMS [K]",
            "max [K]", "time [s]", "remark")
    return _table(rows, head)


def _step_table(result) -> str:
    """Collapsed: the orbital inputs at each orbit position, and the transient's heat flows step by step (reduced
    network, else detailed)."""
    from .heatflow import position_inputs, step_powers

    out = ""
    cols, data = position_inputs(result, "reduced" if result.reduced is not None else "detailed")
    if len(data):
        head = ("true anomaly [°]", "time [s]", *(c.removesuffix("_W") + " [W]" for c in cols[2:]))
        rows = [(f"{r[0]:.4g}", f"{r[1]:.6g}", *(f"{v:.5g}" for v in r[2:])) for r in data]
        out += (f"<details><summary>Absorbed orbital power at each of the {len(rows)} orbit positions (repeated at "
                "eclipse boundaries)</summary>" + _table(rows, head) + "<p>Linear in time between positions; the "
                "orbit averages above are the time averages of these tables.</p></details>")
    if result.transient is None:
        return out
    model = "reduced" if result.transient.reduced is not None else "detailed"
    cols, data = step_powers(result, model)
    if not len(data):
        return out
    head = ("end of step [s]", *(c.removesuffix("_W") + " [W]" for c in cols[1:]))
    rows = [(f"{r[0]:.6g}", *(f"{v:.5g}" for v in r[1:])) for r in data]
    return out + (f"<details><summary>Heat flows at each of the {len(rows)} time steps ({model} model, mean power over "
            "the step)</summary>" + _table(rows, head) + "<p>Each orbital kind: the exact integral of its table over "
            "the step divided by the step; all inputs: the solver's quadrature (Crank-Nicolson: the step's two ends).</p>"
            "</details>")


def _heat_flows_html(hf: dict) -> str:
    """The heat-flow section: the steady (or orbit-averaged) and transient books, reduced against detailed, every
    input and output named; the balance of each part; the flows between parts (summary.json ``heat_flows``)."""
    from .heatflow import book_rows, flow_text

    out = []
    steady = hf.get("steady") or {}
    if steady:
        basis = next(iter(steady.values())).get("basis", "steady")
        models, rows = book_rows(steady, lambda v: flow_text(v, "W"))
        out.append(f"<h3>Steady solution ({html.escape(basis)}) [W]</h3>" + _table(rows, ("", *models)))
    tr = hf.get("transient") or {}
    if tr:
        b = next(iter(tr.values()))
        models, rows = book_rows(tr, lambda v: flow_text(v, "J"))
        out.append(f"<h3>Transient: energy from {b['start_s']:g} s to {b['end_s']:g} s [J]</h3>"
                   "<p>The interval of the solver's energy books (the last period of a periodic run). Stored heat "
                   "is an output: the model's heat content at the end minus at the start.</p>" + _table(rows, ("", *models)))
    out.append("<p>Signs: inputs heat the model; outputs are positive when the model loses heat (radiated to space, "
               "into a fixed boundary, stored): a negative flow into a fixed boundary is heat that boundary supplies "
               "to the model. The imbalance is relative to the larger of the inputs' and the outputs' "
               "sums.</p>")
    parts = hf.get("parts") or []
    if parts:
        rows = [(p["part"], _fmt(p["in_W"], " W"), _fmt(p["to_space_W"], " W"), _fmt(p["to_held_W"], " W"),
                 _fmt(p["to_other_parts_W"], " W"), _fmt(p["imbalance_W"], " W")) for p in parts]
        out.append("<h3>Balance of each part (reduced network, steady) [W]</h3>"
                   + _table(rows, ("part", "into its nodes (Q)", "radiated to space", "to fixed boundaries",
                                   "to other parts (GL and GR, net)", "imbalance"))
                   + "<p>Q is the load the network puts on the part's nodes (applied, absorbed and, for a "
                     "radiation-aware network with a correction load, that load); a radiation-aware network's "
                     "hot-spot nodes take the share of each load that its footprint radiates inside its own super "
                     "nodes and radiate it to space. The exchanges are the network's conductors at its solved "
                     "temperatures.</p>")
    absorbed = hf.get("part_absorbed")
    if absorbed:
        rows = [(p, *(flow_text(v, "W") for v in row)) for p, row in zip(absorbed["parts"], absorbed["W"])]
        rows.append(("all parts", *(flow_text(v, "W") for v in np.sum(absorbed["W"], axis=0))))
        out.append("<h3>Absorbed by each part (detailed model, FE faces) [W]</h3>"
                   + _table(rows, ("part", *absorbed["columns"])))
    matrix = hf.get("part_to_part")
    if matrix:
        names, W = list(matrix["names"]), np.asarray(matrix["W"], float)
        held = matrix.get("held") or []
        if held and len(held) <= 3:  # the held nodes by their boundaries' names
            names[-2] = "held: " + ", ".join(held)
        # a part with no node in the network (all its nodes held) has no row or column of its own
        keep = [i for i in range(len(names)) if i >= len(names) - 2 or np.any(W[i]) or np.any(W[:, i])]
        rows = [(names[i], *(f"{W[i, j] + 0.0:.4g}" if i != j else "—" for j in keep)) for i in keep]
        out.append("<h3>Heat from part (row) to part (column) [W]</h3>"
                   + _table(rows, ("from \\ to", *(names[j] for j in keep)))
                   + f"<p>{html.escape(matrix.get('note', ''))}</p>")
    return "".join(out)


def _view_note(view: dict) -> str:
    """What the 3-D view leaves out (sub-sampled triangles or output times), in a sentence; empty when nothing."""
    out = ""
    if view["n_triangles"] < view["triangles_total"]:
        out += (f" It draws {view['n_triangles']:,} of the {view['triangles_total']:,} surface triangles (at most "
                f"{view['max_triangles']:,}, sub-sampled uniformly: holes show where faces are left out).")
    tr = view.get("transient")
    if tr and len(tr["times_s"]) < tr["frames_total"]:
        out += f" It plays {len(tr['times_s'])} of the {tr['frames_total']} output times (evenly spaced)."
    return out


def _page(body: str, title: str = "fem2tmm report") -> str:
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body {{ font-family: sans-serif; margin: 2em; max-width: 1100px; color: #222; }}
table {{ border-collapse: collapse; margin: 1em 0; }} td, th {{ border: 1px solid #bbb; padding: 4px 10px; text-align: left; }}
figure {{ display: inline-block; margin: 0.5em; vertical-align: top; }} img {{ max-width: 520px; border: 1px solid #ddd; }}
figure.wide {{ display: block; }} figure.wide img {{ max-width: 100%; }}
pre {{ background: #f6f6f6; padding: 1em; overflow-x: auto; }}
{VIEWER_CSS}</style></head><body>
{body}
</body></html>
"""


def _part_ranges_plot(path: Path, cases: list[dict]) -> None:
    """Per part, the min..max temperature of every case as a bar (cases side by side)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    parts = list(cases[0]["parts"])
    k = len(cases)
    width = 0.8 / k
    fig, ax = plt.subplots(figsize=(max(6.5, 1.2 * len(parts) * max(1, k / 4)), 4.2), dpi=110)
    for j, c in enumerate(cases):  # loop over cases
        lo = np.array([np.nan if c["parts"][p]["min"] is None else c["parts"][p]["min"] for p in parts])
        hi = np.array([np.nan if c["parts"][p]["max"] is None else c["parts"][p]["max"] for p in parts])
        ax.bar(np.arange(len(parts)) + (j - (k - 1) / 2) * width, hi - lo, width, bottom=lo, label=c["name"])
    ax.set_xticks(np.arange(len(parts)), parts, rotation=30, ha="right")
    ax.set_ylabel("T [°C] (min .. max)")
    ax.set_title("Temperature range of each part per case")
    if k <= 12:
        ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_cases_report(folder: Path, s: dict, case_text: str) -> None:
    """``report.html`` (and ``parts.png``) comparing the cases of a multi-case run from its summary ``s``: one row
    per case (parameters, range, accuracy, stages reused, time; link to the case's own report), per part min/max
    per case, and the envelope."""
    folder = Path(folder)
    cases = s["cases"]
    rows = []
    for c in cases:
        acc = c.get("accuracy") or {}
        params = ", ".join(f"{k} = {v:.6g}" if isinstance(v, float) else f"{k} = {v}"
                           for k, v in c["parameters"].items())
        reused = [k for k, v in (c.get("cache") or {}).items() if v == "reused"]
        rows.append((c["name"], params or "—", _fmt(c["T_min_C"], " °C"), _fmt(c["T_max_C"], " °C"),
                     _fmt(acc.get("rms_K"), " K"), ", ".join(reused) or "—", f"{c['time_s']:.2f} s"))
    parts = list(cases[0]["parts"])
    part_rows = [(p, *(f"{_fmt(c['parts'][p]['min'])} .. {_fmt(c['parts'][p]['max'])}" for c in cases))
                 for p in parts]
    _part_ranges_plot(folder / "parts.png", cases)
    env = s.get("envelope")
    env_html = "<p>The cases do not share one mesh: no envelope.</p>"
    if env:
        env_rows = [(n, env["coldest_nodes"][n], env["hottest_nodes"][n]) for n in env["coldest_nodes"]]
        env_html = (f"<p>{_fmt(env['T_min_C'], ' °C')} .. {_fmt(env['T_max_C'], ' °C')}; files "
                    f"<code>envelope.vtu</code> (temperature_min/max, case_of_min/max = row of the table above, "
                    f"from 0), <code>envelope_hot.bdf</code> (SID {env['sids']['hot']}), <code>envelope_cold.bdf</code> "
                    f"(SID {env['sids']['cold']}).</p>" + _table(env_rows, ("case", "nodes coldest", "nodes hottest")))
    links = " ".join(f'<a href="{html.escape(c["folder"])}/report.html">{html.escape(c["name"])}</a>' for c in cases)
    compute = s.get("compute") or {}
    doc = _page(f"""<h1>fem2tmm report: {len(cases)} load cases</h1>
<p>Case file: <code>{html.escape(str(s.get('case')))}</code> — fem2tmm {html.escape(str(s.get('version')))} —
scheduler {html.escape(str(compute.get('scheduler')))} ({compute.get('workers')} workers),
{s['timings_s']['total']:.1f} s</p>
<h2>Cases</h2>{_table(rows, ("case", "parameters", "T min", "T max", "RMS error", "stages reused", "time"))}
<p>Each case's own report: {links}</p>
<h2>Per part: min .. max °C per case</h2>{_table(part_rows, ("part", *(c["name"] for c in cases)))}
<figure><img src="parts.png" alt="part ranges"><figcaption>Temperature range of each part per case</figcaption></figure>
<h2>Envelope over the cases</h2>{env_html}
<h2>Case file</h2><pre>{html.escape(case_text)}</pre>""", title="fem2tmm load cases")
    (folder / "report.html").write_text(doc, encoding="utf-8")
