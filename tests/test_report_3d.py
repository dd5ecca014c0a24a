"""The report's interactive 3-D view (fem2tmm.export.viewer), opened in headless Chromium with networking off: the
view renders (pixels drawn, coloured by temperature) and the page's data holds the run's numbers (super-node
temperatures equal summary.json's, the per-vertex fields span the same range as the nodes'), from the output folder
alone.  Skips, saying why, where Debian's ``chromium`` is missing."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import composite_box_case

from fem2tmm import meshes
from fem2tmm.export.viewer import distinct_colors, surface_triangles
from fem2tmm.pipeline import run

CHROMIUM = shutil.which("chromium") or (Path("/usr/bin/chromium").is_file() and "/usr/bin/chromium") or None
needs_chromium = pytest.mark.skipif(not CHROMIUM, reason="Debian's chromium is not installed (apt-get install chromium)")

#: Chromium with no network: every host name resolves to nothing and every request goes to a closed proxy port
OFFLINE = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", "--no-first-run", "--hide-scrollbars",
           "--host-resolver-rules=MAP * ~NOTFOUND", "--proxy-server=http://127.0.0.1:9", "--proxy-bypass-list=<-loopback>",
           "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--virtual-time-budget=8000"]


def open_in_chromium(page: Path, tmp: Path, screenshot: Path | None = None, width: int = 1200,
                     height: int = 1400, fragment: str = "") -> str:
    """The DOM of ``page`` (``#fragment`` appended) after its scripts ran (and, with ``screenshot``, a PNG of the
    window)."""
    args = [CHROMIUM, *OFFLINE, f"--user-data-dir={tmp / 'chromium-profile'}", f"--window-size={width},{height}"]
    url = page.resolve().as_uri() + (f"#{fragment}" if fragment else "")
    if screenshot is not None:
        subprocess.run([*args, f"--screenshot={screenshot}", url], capture_output=True, timeout=180, check=True)
    out = subprocess.run([*args, "--dump-dom", url], capture_output=True, timeout=180, check=True, text=True)
    return out.stdout


def view_state(dom: str) -> tuple[dict, dict]:
    """The 3-D view's attributes and the numbers it decoded (#f2t-check)."""
    tag = re.search(r'<div id="f2t-view"[^>]*>', dom).group(0)
    attrs = dict(re.findall(r'([\w-]+)="([^"]*)"', tag))
    check = re.search(r'<pre id="f2t-check"[^>]*>(.*?)</pre>', dom, re.S).group(1)
    return attrs, json.loads(check.replace("&quot;", '"').replace("&amp;", "&"))


def test_distinct_colors_stay_apart_for_hundreds_of_clusters():
    # golden-ratio hues with three lightness and two saturation levels: 500 different colours, and any two whose
    # numbers differ by at most 20 differ by at least 35 of 255 in some channel (measured 39); the tab20 map of
    # before gave the same colour to clusters 20 apart (distance 0)
    c = distinct_colors(500).astype(int)
    assert len({tuple(x) for x in c}) == 500
    d = np.abs(c[:, None, :] - c[None, :, :]).max(axis=2)
    i, j = np.indices(d.shape)
    assert d[(np.abs(i - j) <= 20) & (i != j)].min() >= 35


def test_surface_triangles_split_quads_and_subsample():
    faces = np.array([[0, 1, 2, 3], [2, 3, 4, -1]])
    nodes, tri, face, total = surface_triangles(faces)
    assert total == 3 and face.tolist() == [0, 1, 0]
    np.testing.assert_array_equal(nodes[tri], [[0, 1, 2], [2, 3, 4], [0, 2, 3]])
    nodes, tri, face, total = surface_triangles(faces, max_triangles=2)
    assert total == 3 and len(tri) == 2


@pytest.fixture(scope="module")
def box_run(tmp_path_factory):
    """A composite box held at its deck, 5 W on its top, run as a transient (3 output times); output folder
    moved elsewhere after writing, so that the report can only use what the folder holds."""
    tmp = tmp_path_factory.mktemp("report3d")
    case = composite_box_case(6)
    case = case.__class__.from_dict({**case.raw, "transient": {"end": 1200.0, "step": 300.0, "output_every": 600.0}})
    res = run(case, mesh=meshes.box(0.3, 0.2, 0.1, 6, 4, 2), out=tmp / "out")
    shutil.move(tmp / "out", tmp / "moved")
    return res, tmp / "moved", tmp


def test_report_names_no_outside_resource(box_run):
    _, out, _ = box_run
    html = (out / "report.html").read_text(encoding="utf-8")
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:|//|file:)""", html, re.I)
    assert "<link" not in html and "import(" not in html
    assert "three.js authors" in html  # the vendored library's MIT licence travels with it
    for name in re.findall(r'<img src="([^"]+)"', html):
        assert (out / name).is_file() and "/" not in name


@needs_chromium
def test_report_3d_view_renders_and_holds_the_run(box_run):
    res, out, tmp = box_run
    dom = open_in_chromium(out / "report.html", tmp)
    attrs, check = view_state(dom)
    assert attrs["data-rendered"] == "1"
    x, y, w, h = (int(v) for v in attrs["data-canvas-rect"].split(","))
    # the model covers a good part of the canvas (white background): at least 5 % of its pixels
    assert int(attrs["data-nonblank-pixels"]) > 0.05 * w * h
    s = json.loads((out / "summary.json").read_text())
    # the page's super-node temperatures are summary.json's (the same float64 numbers through JSON)
    assert check["super_nodes_C"].keys() == s["temperatures_C"]["super_nodes"].keys()
    for k, v in s["temperatures_C"]["super_nodes"].items():
        assert check["super_nodes_C"][k] == pytest.approx(v, abs=1e-9)
    # every node of the box is on its surface: the float32 fields decoded in the page span the nodes' range
    # (float32 rounding at ~300 K: 3e-5 K)
    parts = s["temperatures_C"]["parts"].values()
    lo, hi = min(p["min"] for p in parts), max(p["max"] for p in parts)
    assert check["fields"]["recovered"]["min"] == pytest.approx(lo, abs=1e-4)
    assert check["fields"]["recovered"]["max"] == pytest.approx(hi, abs=1e-4)
    ref = s["temperatures_C"]["reference"]["parts"].values()
    assert check["fields"]["detailed"]["max"] == pytest.approx(max(p["max"] for p in ref), abs=1e-4)
    # the transient's frames: 3 output times, the last super-node temperatures those of transient.npz
    tr = np.load(out / "transient.npz")
    assert check["frames"] == len(tr["times"]) == 3
    np.testing.assert_allclose(check["transient_last_C"], tr["sn_temperature"][-1], atol=1e-8)
    assert check["triangles"] == 2 * res.model.faces.n  # quads, none sub-sampled


@needs_chromium
def test_report_3d_view_names_a_super_node_as_the_deck_does(box_run):
    # a super node named in the address (as a click would select it): the page shows its deck number as written in
    # model.esatan (D<number> = 'name'), its part, area, capacitance and temperature from reduced.npz
    res, out, tmp = box_run
    deck = (out / "model.esatan").read_text()
    name = "panels_2"
    number = re.search(rf"D(\d+) = '{name}'", deck).group(1)
    dom = open_in_chromium(out / "report.html", tmp, fragment=f"sn={name}&mode=cluster")
    info = re.sub(r"<[^>]+>", "", re.search(r'<div id="f2t-info">(.*?)</div>', dom, re.S).group(1))
    net = np.load(out / "reduced.npz")
    i = list(net["names"]).index(name)
    assert f"{name} (D{number})" in info and "part panels" in info
    # shown with 4 significant digits (C, area) and 0.01 K (T)
    assert float(re.search(r"C ([-\d.e+]+) J/K", info).group(1)) == pytest.approx(net["C"][i], rel=1e-3)
    tr = np.load(out / "transient.npz")  # the first frame of the transient
    assert float(re.search(r"T ([-\d.]+) °C \(t = 0 s\)", info).group(1)) == pytest.approx(
        tr["sn_temperature"][0, i], abs=0.006)
    _, check = view_state(dom)
    assert check["mode"] == "cluster"


@needs_chromium
def test_report_3d_view_screenshot_is_coloured_by_temperature(box_run):
    _, out, tmp = box_run
    dom = open_in_chromium(out / "report.html", tmp)
    attrs, _ = view_state(dom)
    x, y, w, h = (int(v) for v in attrs["data-canvas-rect"].split(","))
    shot = tmp / "report_3d.png"
    open_in_chromium(out / "report.html", tmp, screenshot=shot, height=y + h + 40)
    import matplotlib.image

    img = matplotlib.image.imread(shot)[y:y + h, x:x + w, :3]
    px = np.round(img.reshape(-1, 3) * 255).astype(int)
    drawn = px[(px < 245).any(axis=1)]
    print(f"screenshot: {shot}")
    assert len(drawn) > 0.05 * w * h
    # coloured, not grey: the turbo map spans blue to red; both ends of the field are on the surface
    assert (drawn[:, 2] - drawn[:, 0] > 80).sum() > 100 and (drawn[:, 0] - drawn[:, 2] > 80).sum() > 100


@pytest.mark.slow
@needs_chromium
def test_smallsat_transient_report_renders_the_satellite(tmp_path):
    # the acceptance case of the 3-D report: examples/smallsat/case_transient.toml (about 40 s); the screenshot is
    # left in the test's folder, or in $FEM2TMM_SCREENSHOTS (its path printed with -s)
    from fem2tmm.case import Case

    root = Path(__file__).resolve().parents[1]
    run(Case.from_toml(root / "examples" / "smallsat" / "case_transient.toml"), out=tmp_path / "out")
    out = tmp_path / "out"
    dom = open_in_chromium(out / "report.html", tmp_path)
    attrs, check = view_state(dom)
    assert attrs["data-rendered"] == "1"
    x, y, w, h = (int(v) for v in attrs["data-canvas-rect"].split(","))
    assert int(attrs["data-nonblank-pixels"]) > 0.05 * w * h
    s = json.loads((out / "summary.json").read_text())
    for k, v in s["temperatures_C"]["super_nodes"].items():
        assert check["super_nodes_C"][k] == pytest.approx(v, abs=1e-9)
    shot = tmp_path / "smallsat_3d.png"
    open_in_chromium(out / "report.html", tmp_path, screenshot=shot, height=y + h + 40)
    import matplotlib.image

    img = matplotlib.image.imread(shot)[y:y + h, x:x + w, :3]
    px = np.round(img.reshape(-1, 3) * 255).astype(int)
    assert ((px < 245).any(axis=1)).sum() > 0.05 * w * h
    keep = os.environ.get("FEM2TMM_SCREENSHOTS")  # a folder that outlives pytest's rotating temporary folders
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, Path(keep) / shot.name)
        shot = Path(keep) / shot.name
    print(f"screenshot: {shot}")
