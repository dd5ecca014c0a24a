// fem2tmm report: the interactive 3-D view (three.js). Reads the JSON in #f2t-data (fem2tmm.export.viewer.view_data).
// After the first frame it sets data-rendered="1" and data-nonblank-pixels on #f2t-view and writes what it decoded
// into #f2t-check (JSON), so that a headless browser can check the page.
(function () {
  "use strict";
  const root = document.getElementById("f2t-view");
  const D = JSON.parse(document.getElementById("f2t-data").textContent);

  function decode(b64, Type) {
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new Type(bytes.buffer);
  }
  const pos = decode(D.positions, Float32Array);
  const tri = decode(D.triangles, Int32Array);
  const triSN = decode(D.tri_sn, Int32Array);
  const triPart = decode(D.tri_part, Int32Array);
  const snColors = decode(D.sn_colors || "", Uint8Array);
  const nt = D.n_triangles, nv = D.n_vertices;
  const fields = {};
  for (const f of D.fields) fields[f.name] = Object.assign({}, f, { data: decode(f.values, Float32Array) });
  const tr = D.transient;
  const frames = {};
  if (tr) for (const k in tr.fields) frames[k] = decode(tr.fields[k], Float32Array);
  const nFrames = tr ? tr.times_s.length : 0;

  // ---- colour helpers (sRGB bytes -> linear floats: three.js shades in linear light)
  const toLin = new Float32Array(256);
  for (let i = 0; i < 256; i++) { const c = i / 255; toLin[i] = c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4); }
  function niceTicks(lo, hi, n) {
    const span = hi - lo || 1, step0 = span / n, mag = Math.pow(10, Math.floor(Math.log10(step0)));
    const step = [1, 2, 2.5, 5, 10].map(m => m * mag).find(s => s >= step0) || step0;
    const out = [];
    for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-9 * span; v += step) out.push(Math.abs(v) < 1e-12 * span ? 0 : v);
    return { ticks: out, step: step };
  }
  function fmt(v, step) {
    const d = Math.max(0, Math.min(6, -Math.floor(Math.log10(step || 1) + 1e-9)));
    return v.toFixed(d);
  }

  // ---- scene
  const host = document.getElementById("f2t-canvas");
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.localClippingEnabled = true;
  host.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  const BG = 0xffffff;
  scene.background = new THREE.Color(BG);
  const camera = new THREE.PerspectiveCamera(30, 1, 1e-3, 1e3);
  camera.up.set(0, 0, 1);
  scene.add(camera);
  scene.add(new THREE.AmbientLight(0xffffff, 1.6));
  const light = new THREE.DirectionalLight(0xffffff, 1.5);
  light.position.set(0.3, 0.5, 1);
  camera.add(light);

  // non-indexed geometry: each triangle its own three vertices, so that cluster and part colours stay flat
  const P = new Float32Array(nt * 9);
  for (let t = 0; t < nt; t++) for (let c = 0; c < 3; c++) {
    const v = tri[3 * t + c];
    P[9 * t + 3 * c] = pos[3 * v]; P[9 * t + 3 * c + 1] = pos[3 * v + 1]; P[9 * t + 3 * c + 2] = pos[3 * v + 2];
  }
  const geom = new THREE.BufferGeometry();
  geom.setAttribute("position", new THREE.BufferAttribute(P, 3));
  geom.computeVertexNormals();
  const colors = new Float32Array(nt * 9);
  geom.setAttribute("color", new THREE.BufferAttribute(colors, 3));
  const clipPlane = new THREE.Plane(new THREE.Vector3(1, 0, 0), 0);
  const material = new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide,
    polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
  const mesh = new THREE.Mesh(geom, material);
  scene.add(mesh);

  function lines(b64, color, opacity) {
    const e = decode(b64, Int32Array);
    const L = new Float32Array(e.length * 3);
    for (let i = 0; i < e.length; i++) { const v = e[i]; L[3 * i] = pos[3 * v]; L[3 * i + 1] = pos[3 * v + 1]; L[3 * i + 2] = pos[3 * v + 2]; }
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(L, 3));
    const m = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: color, transparent: opacity < 1, opacity: opacity }));
    scene.add(m);
    return m;
  }
  const clusterEdges = lines(D.cluster_edges, 0x202020, 0.9);
  const meshEdges = lines(D.mesh_edges, 0x606060, 0.35);
  meshEdges.visible = false;
  const highlight = new THREE.Mesh(new THREE.BufferGeometry(), new THREE.MeshBasicMaterial({ color: 0x00e5ff,
    side: THREE.DoubleSide, transparent: true, opacity: 0.55, depthTest: true, polygonOffset: true,
    polygonOffsetFactor: -1, polygonOffsetUnits: -1 }));
  scene.add(highlight);
  const clipped = [material, clusterEdges.material, meshEdges.material, highlight.material];

  // ---- framing
  const box = new THREE.Box3().setFromBufferAttribute(geom.getAttribute("position"));
  const center = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3());
  const radius = Math.max(0.5 * size.length(), 1e-9);
  camera.near = radius / 100; camera.far = radius * 100; camera.updateProjectionMatrix();
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  controls.target.copy(center);
  controls.enableDamping = false;
  controls.screenSpacePanning = true;
  function isoDirection() {
    // a flat model (one extent under 5 % of the largest) is seen from its thin axis, tilted; others obliquely
    const ext = [size.x, size.y, size.z], big = Math.max(...ext), thin = ext.indexOf(Math.min(...ext));
    if (ext[thin] < 0.05 * big) {
      const d = [0.35, -0.45, 0.35]; d[thin] = 1.0;
      return new THREE.Vector3(...d).normalize();
    }
    const e = 25 * Math.PI / 180, a = -60 * Math.PI / 180;
    return new THREE.Vector3(Math.cos(e) * Math.cos(a), Math.cos(e) * Math.sin(a), Math.sin(e));
  }
  function setView(name) {
    const dirs = { "+x": [1, 0, 0], "-x": [-1, 0, 0], "+y": [0, 1, 0], "-y": [0, -1, 0], "+z": [0, 0, 1], "-z": [0, 0, -1] };
    const d = name in dirs ? new THREE.Vector3(...dirs[name]) : isoDirection();
    camera.up.set(0, 0, 1);
    if (Math.abs(d.z) > 0.99) camera.up.set(0, 1, 0);
    // the nearest distance at which the 8 corners of the bounding box fit the view (5 % margin)
    const tv = Math.tan(camera.fov * Math.PI / 360), th = tv * Math.max(camera.aspect, 1e-3);
    const right = new THREE.Vector3().crossVectors(d, camera.up).normalize(), up = new THREE.Vector3().crossVectors(right, d);
    let dist = 0;
    for (let k = 0; k < 8; k++) {
      const c = new THREE.Vector3(k & 1 ? box.max.x : box.min.x, k & 2 ? box.max.y : box.min.y, k & 4 ? box.max.z : box.min.z).sub(center);
      dist = Math.max(dist, c.dot(d) + Math.max(Math.abs(c.dot(right)) / th, Math.abs(c.dot(up)) / tv) * 1.05);
    }
    dist = Math.max(dist, radius * 0.1);
    camera.position.copy(center).addScaledVector(d, dist);
    controls.target.copy(center);
    camera.lookAt(center);
    controls.update();
    draw();
  }

  // ---- colouring
  const modes = [];
  for (const f of D.fields) modes.push({ value: "field:" + f.name, text: f.label + " [" + f.unit + "]" });
  if (D.super_nodes.length) modes.push({ value: "cluster", text: "Super node (cluster), " + D.super_nodes.length });
  modes.push({ value: "part", text: "Part, " + D.parts.length });
  const modeSel = document.getElementById("f2t-mode");
  for (const m of modes) { const o = document.createElement("option"); o.value = m.value; o.textContent = m.text; modeSel.appendChild(o); }
  let mode = modes[0].value, frame = -1, selected = -1;  // frame -1: the steady field
  const legend = document.getElementById("f2t-legend");

  function fieldValues(name) {
    if (frame >= 0 && frames[name]) return frames[name].subarray(frame * nv, (frame + 1) * nv);
    return fields[name].data;
  }
  function valueRange(a, symmetric) {
    let lo = Infinity, hi = -Infinity;
    for (let i = 0; i < a.length; i++) { const v = a[i]; if (v === v) { if (v < lo) lo = v; if (v > hi) hi = v; } }
    if (!(hi > lo)) { hi = lo + 1e-6; lo -= 1e-6; }
    if (symmetric) { const m = Math.max(Math.abs(lo), Math.abs(hi)); lo = -m; hi = m; }
    return [lo, hi];
  }
  function fieldRange(name) {  // over every frame too, so that colours compare between times
    const [a, b] = valueRange(fields[name].data, fields[name].symmetric);
    if (!frames[name]) return [a, b];
    const [c, d] = valueRange(frames[name], fields[name].symmetric);
    return [Math.min(a, c), Math.max(b, d)];
  }
  let localRange = false;
  const ranges = {};
  for (const f of D.fields) ranges[f.name] = fieldRange(f.name);

  function paint() {
    const setTri = (t, rgb, o) => { for (let c = 0; c < 3; c++) { colors[9 * t + 3 * c] = toLin[rgb[o]]; colors[9 * t + 3 * c + 1] = toLin[rgb[o + 1]]; colors[9 * t + 3 * c + 2] = toLin[rgb[o + 2]]; } };
    if (mode.startsWith("field:")) {
      const name = mode.slice(6), f = fields[name], lut = D.colormaps[f.cmap], vals = fieldValues(name);
      const [lo, hi] = localRange && frame >= 0 && frames[name] ? valueRange(vals, f.symmetric) : ranges[name];
      for (let t = 0; t < nt; t++) for (let c = 0; c < 3; c++) {
        const v = vals[tri[3 * t + c]];
        const k = v === v ? Math.max(0, Math.min(255, Math.round((v - lo) / (hi - lo) * 255))) : -1;
        const o = 9 * t + 3 * c;
        if (k < 0) { colors[o] = colors[o + 1] = colors[o + 2] = 0.5; continue; }
        colors[o] = toLin[lut[3 * k]]; colors[o + 1] = toLin[lut[3 * k + 1]]; colors[o + 2] = toLin[lut[3 * k + 2]];
      }
      drawColorbar(f, lo, hi);
    } else if (mode === "cluster") {
      const grey = [190, 190, 190];
      for (let t = 0; t < nt; t++) { const s = triSN[t]; if (s >= 0) setTri(t, snColors, 3 * s); else setTri(t, grey, 0); }
      legend.innerHTML = "<div class='f2t-cat'>" + D.super_nodes.filter(s => s.kind === "cluster").length +
        " super nodes, each its own colour; hover a face for its name and deck number" +
        (triSN.some(s => s < 0) ? "; grey: faces in no super node (fixed-temperature boundary)" : "") + "</div>";
    } else {
      for (let t = 0; t < nt; t++) setTri(t, D.part_colors, 3 * triPart[t]);
      legend.innerHTML = D.parts.map((p, i) => "<div class='f2t-cat'><span style='display:inline-block;width:12px;height:12px;margin-right:5px;background:rgb(" +
        D.part_colors.slice(3 * i, 3 * i + 3).join(",") + ")'></span>" + esc(p) + "</div>").join("");
    }
    geom.getAttribute("color").needsUpdate = true;
    draw();
  }
  function esc(s) { return String(s).replace(/[&<>"]/g, c => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c])); }
  function drawColorbar(f, lo, hi) {
    const lut = D.colormaps[f.cmap];
    const stops = [];
    for (let k = 0; k <= 16; k++) { const j = Math.round(k * 255 / 16); stops.push("rgb(" + lut[3 * j] + "," + lut[3 * j + 1] + "," + lut[3 * j + 2] + ") " + (k * 100 / 16) + "%"); }
    const { ticks, step } = niceTicks(lo, hi, 6);
    let html = "<div class='f2t-cbtitle'>" + esc(f.label) + " [" + esc(f.unit) + "]" +
      (frame >= 0 && tr ? "<br>t = " + tr.times_s[frame].toFixed(0) + " s" : "") + "</div>" +
      "<div class='f2t-cb' style='background:linear-gradient(to top," + stops.join(",") + ")'>";
    for (const v of ticks) html += "<div class='f2t-tick' style='bottom:" + ((v - lo) / (hi - lo) * 100) + "%'>" + fmt(v, step) + " " + esc(f.unit) + "</div>";
    html += "</div><div class='f2t-cbnote'>range " + fmt(lo, step / 10) + " to " + fmt(hi, step / 10) + " " + esc(f.unit) +
      (frames[f.name] && frame >= 0 ? (localRange ? " at this time" : " over all times") : "") + "</div>";
    legend.innerHTML = html;
  }

  // ---- picking
  const tip = document.getElementById("f2t-tip"), info = document.getElementById("f2t-info");
  const ray = new THREE.Raycaster();
  function snText(s, sep) {
    const sn = D.super_nodes[s];
    if (!sn) return "";
    let T = sn.T_C, when = "steady";
    if (frame >= 0 && tr && tr.super_nodes_T_C) { T = tr.super_nodes_T_C[frame][s]; when = "t = " + tr.times_s[frame].toFixed(0) + " s"; }
    const num = (v, d, u) => v === null || v === undefined ? "—" : v.toPrecision(d) + " " + u;
    return "<b>" + esc(sn.name) + "</b> (D" + sn.number + ")" + sep + "part " + esc(sn.part === null ? "—" : sn.part) + sep +
      "area " + num(sn.area_m2, 4, "m²") + sep + "C " + num(sn.C_J_per_K, 4, "J/K") + sep + "T " + T.toFixed(2) + " °C (" + when + ")";
  }
  function pick(ev) {
    const r = renderer.domElement.getBoundingClientRect();
    const m = new THREE.Vector2((ev.clientX - r.left) / r.width * 2 - 1, -(ev.clientY - r.top) / r.height * 2 + 1);
    ray.setFromCamera(m, camera);
    const hits = ray.intersectObject(mesh).filter(h => !clipOn() || clipPlane.distanceToPoint(h.point) >= 0);
    if (!hits.length) return null;
    const t = hits[0].faceIndex;
    return { t: t, sn: triSN[t], part: triPart[t], x: ev.clientX - r.left, y: ev.clientY - r.top };
  }
  renderer.domElement.addEventListener("pointermove", ev => {
    const h = pick(ev);
    if (!h) { tip.hidden = true; return; }
    tip.innerHTML = h.sn >= 0 ? snText(h.sn, "<br>") : "part " + esc(D.parts[h.part]) + "<br>(in no super node)";
    tip.style.left = Math.min(h.x + 14, renderer.domElement.clientWidth - 260) + "px"; tip.style.top = (h.y + 14) + "px"; tip.hidden = false;
  });
  renderer.domElement.addEventListener("pointerleave", () => { tip.hidden = true; });
  let down = null;
  renderer.domElement.addEventListener("pointerdown", ev => { down = [ev.clientX, ev.clientY]; });
  renderer.domElement.addEventListener("pointerup", ev => {
    if (!down || Math.hypot(ev.clientX - down[0], ev.clientY - down[1]) > 4) return;  // a drag turns, a click picks
    const h = pick(ev);
    select(h && h.sn >= 0 ? h.sn : -1);
  });
  function select(s) {
    selected = s;
    if (s < 0) { highlight.visible = false; info.innerHTML = "Drag to turn, wheel to zoom, right-drag to pan. Hover a face for its super node, click to keep it."; draw(); return; }
    const idx = [];
    for (let t = 0; t < nt; t++) if (triSN[t] === s) idx.push(t);
    const H = new Float32Array(idx.length * 9);
    idx.forEach((t, j) => H.set(P.subarray(9 * t, 9 * t + 9), 9 * j));
    highlight.geometry.dispose();
    highlight.geometry = new THREE.BufferGeometry();
    highlight.geometry.setAttribute("position", new THREE.BufferAttribute(H, 3));
    highlight.visible = true;
    info.innerHTML = "Selected: " + snText(s, " · ") + " — click empty space to clear";
    draw();
  }

  // ---- clipping
  const clipSel = document.getElementById("f2t-clip"), cut = document.getElementById("f2t-cut"), flip = document.getElementById("f2t-flip");
  function clipOn() { return clipSel.value !== ""; }
  function updateClip() {
    const on = clipOn();
    cut.disabled = flip.disabled = !on;
    for (const m of clipped) { m.clippingPlanes = on ? [clipPlane] : []; m.needsUpdate = true; }
    if (on) {
      const ax = "xyz".indexOf(clipSel.value), s = flip.checked ? 1 : -1;
      const lo = box.min.getComponent(ax), hi = box.max.getComponent(ax);
      const x = lo + (hi - lo) * (cut.value / 1000);
      const n = new THREE.Vector3(); n.setComponent(ax, s);
      clipPlane.set(n, -s * x);  // keeps the points with s·(p - x) >= 0
    }
    draw();
  }
  clipSel.addEventListener("change", updateClip); cut.addEventListener("input", updateClip); flip.addEventListener("change", updateClip);
  document.getElementById("f2t-edges").addEventListener("change", ev => { clusterEdges.visible = ev.target.checked; draw(); });
  const meshBox = document.getElementById("f2t-mesh");
  if (!decode(D.mesh_edges, Int32Array).length) { meshBox.disabled = true; meshBox.parentElement.title = "more than the limit of triangles: mesh edges not drawn"; }
  meshBox.addEventListener("change", ev => { meshEdges.visible = ev.target.checked; draw(); });
  modeSel.addEventListener("change", () => { mode = modeSel.value; paint(); if (selected >= 0) select(selected); });
  for (const b of root.querySelectorAll("[data-view]")) b.addEventListener("click", () => setView(b.dataset.view));

  // ---- axes triad (bottom left)
  const axHost = document.getElementById("f2t-axes");
  const axR = new THREE.WebGLRenderer({ antialias: true, alpha: true });
  axR.setSize(90, 90); axHost.appendChild(axR.domElement);
  const axScene = new THREE.Scene(), axCam = new THREE.PerspectiveCamera(30, 1, 0.1, 10);
  axScene.add(new THREE.AxesHelper(1));
  const axLabels = ["x", "y", "z"].map((n, i) => { const d = document.createElement("div"); d.className = "f2t-axl"; d.textContent = n; d.style.color = ["#d00", "#080", "#00c"][i]; axHost.appendChild(d); return d; });

  // ---- draw
  function resize() {
    const w = host.clientWidth, h = host.clientHeight;
    renderer.setSize(w, h, true);
    camera.aspect = w / Math.max(h, 1); camera.updateProjectionMatrix();
  }
  function draw() {
    renderer.render(scene, camera);
    const d = new THREE.Vector3().subVectors(camera.position, controls.target).normalize().multiplyScalar(3.2);
    axCam.position.copy(d); axCam.up.copy(camera.up); axCam.lookAt(0, 0, 0);
    axR.render(axScene, axCam);
    const v = new THREE.Vector3();
    axLabels.forEach((el, i) => { v.set(i === 0 ? 1.15 : 0, i === 1 ? 1.15 : 0, i === 2 ? 1.15 : 0).project(axCam); el.style.left = ((v.x + 1) / 2 * 90 - 4) + "px"; el.style.top = ((1 - v.y) / 2 * 90 - 8) + "px"; });
  }
  controls.addEventListener("change", draw);
  window.addEventListener("resize", () => { resize(); draw(); });

  function report() {  // what a headless browser reads back: pixels drawn and the numbers decoded
    const gl = renderer.getContext(), w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const px = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    let n = 0;
    for (let i = 0; i < px.length; i += 4) if (px[i] < 250 || px[i + 1] < 250 || px[i + 2] < 250) n++;
    const check = { triangles: nt, vertices: nv, frames: nFrames, mode: mode, fields: {}, super_nodes_C: {} };
    for (const k in fields) {
      let lo = Infinity, hi = -Infinity; const a = fields[k].data;
      for (let i = 0; i < a.length; i++) { if (a[i] < lo) lo = a[i]; if (a[i] > hi) hi = a[i]; }
      check.fields[k] = { min: lo, max: hi };
    }
    for (const s of D.super_nodes) check.super_nodes_C[s.name] = s.T_C;
    if (tr && tr.super_nodes_T_C) check.transient_last_C = tr.super_nodes_T_C[nFrames - 1];
    document.getElementById("f2t-check").textContent = JSON.stringify(check);
    root.setAttribute("data-nonblank-pixels", String(n));
    const r = renderer.domElement.getBoundingClientRect();
    root.setAttribute("data-canvas-rect", [r.left + window.scrollX, r.top + window.scrollY, r.width, r.height].map(Math.round).join(","));
    root.setAttribute("data-rendered", "1");
  }

  // ---- time
  if (tr && nFrames > 0) {
    const box_ = document.getElementById("f2t-timebox"), slider = document.getElementById("f2t-time"), label = document.getElementById("f2t-tlabel");
    const play = document.getElementById("f2t-play");
    box_.hidden = false; slider.max = String(nFrames - 1);
    const setFrame = k => {
      frame = k; slider.value = String(k);
      label.textContent = "t = " + tr.times_s[k].toFixed(0) + " s (" + (k + 1) + "/" + nFrames + (tr.frames_total > nFrames ? " of " + tr.frames_total + " output times" : "") + ")";
      paint(); if (selected >= 0) select(selected);
    };
    slider.addEventListener("input", () => setFrame(+slider.value));
    document.getElementById("f2t-local").addEventListener("change", ev => { localRange = ev.target.checked; paint(); });
    let timer = null;
    play.addEventListener("click", () => {
      if (timer) { clearInterval(timer); timer = null; play.textContent = "▶ play"; return; }
      play.textContent = "❚❚ pause";
      timer = setInterval(() => setFrame((frame + 1) % nFrames), 120);
    });
    frame = 0;
    slider.value = "0";
    label.textContent = "t = " + tr.times_s[0].toFixed(0) + " s (1/" + nFrames + ")";
  }

  // ---- a view named in the address: #mode=cluster&sn=walls_1&t=10&range=local&view=+x&cut=z:0.5:flip
  const want = {};
  for (const kv of decodeURIComponent(location.hash.slice(1)).split("&")) { const i = kv.indexOf("="); if (i > 0) want[kv.slice(0, i)] = kv.slice(i + 1); }
  resize();
  setView(want.view || "iso");
  if (want.mode && modes.some(m => m.value === want.mode || m.value === "field:" + want.mode)) {
    mode = modes.find(m => m.value === want.mode || m.value === "field:" + want.mode).value; modeSel.value = mode;
  }
  if (want.t !== undefined && tr && nFrames) {  // the output frame nearest to t seconds
    let k = 0;
    for (let i = 0; i < nFrames; i++) if (Math.abs(tr.times_s[i] - +want.t) < Math.abs(tr.times_s[k] - +want.t)) k = i;
    const sl = document.getElementById("f2t-time"); sl.value = String(k); sl.dispatchEvent(new Event("input"));
  }
  if (want.range === "local" && tr) { localRange = true; document.getElementById("f2t-local").checked = true; }
  if (want.cut) {
    const [ax, at, fl] = want.cut.split(":");
    if ("xyz".includes(ax) && ax) { clipSel.value = ax; cut.value = String(Math.round(1000 * (+at || 0.5))); flip.checked = fl === "flip"; updateClip(); }
  }
  paint();
  if (want.sn) { const s = D.super_nodes.findIndex(x => x.name === want.sn || "D" + x.number === want.sn); if (s >= 0) select(s); }
  report();
})();
