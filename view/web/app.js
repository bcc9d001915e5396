// vol-view's page: the camera, the option form built from the server's
// description of vol-render's options, frames over the WebSocket (the
// newest only), the cost panel, slices and saves.
"use strict";

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
// The CSS size of the 3D view (`?view=N`), in pixels.
const VIEW = Math.max(128, Math.min(2048, Number(params.get("view")) || 512));
// Options the page's camera and size drive, and those of no use here.
const CAMERA = ["orbit", "eye", "look-at", "size"];
const UNUSED = ["print-scene", "json", "quiet", "repeat", "threads", "in-memory", "cell"];
// The tf dropdown's entry while the editor's function is in use.
const EDITED = "(the editor's, sent as tf-text)";
// Options shown at the top of the form (the rest under "All options").
const PRIMARY = ["mode", "tf", "iso", "shading", "step", "spp", "shadows", "ao", "light"];

const S = {
  ws: null,
  hello: null,
  seq: 0,
  shownSeq: 0,
  viewSeq: 0, // the seq of the last full (non-preview) request
  inflight: null, // { seq, preview }
  wantPreview: false,
  dragging: false,
  inputT: null,
  stopT: null,
  sent: new Map(),
  cam: null,
  values: {},
  tfEdit: false,
  // The transfer function of the view shown (the editor starts from it).
  currentTf: null,
  // The modes each option applies to, by name (absent: all).
  modes: {},
  last: null,
  stats: { latencies: [], firstFull: null, stopToFull: [], frames: 0, previews: 0, cancelled: 0, passes: [] },
  downloads: [],
};
window.volview = S;

function status(text, error) {
  const s = $("status");
  s.textContent = text;
  s.classList.toggle("error", !!error);
}

// --- the connection -------------------------------------------------

function connect() {
  const token = params.get("token");
  const url = `ws://${location.host}/ws` + (token ? `?token=${encodeURIComponent(token)}` : "");
  const ws = new WebSocket(url);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => (S.stats.openAt = performance.now());
  ws.onmessage = (e) => receive(e.data);
  ws.onclose = () => status("disconnected: reload the page when vol-view runs again", true);
  ws.onerror = () => status("connection error", true);
  S.ws = ws;
}

function receive(data) {
  if (typeof data === "string") return;
  const view = new DataView(data);
  const len = view.getUint32(0);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(data, 4, len)));
  const payload = new Uint8Array(data, 4 + len);
  switch (header.type) {
    case "hello": return hello(header);
    case "frame": return frame(header, payload);
    case "cancelled": S.stats.cancelled++; return settle(header.seq);
    case "psnr": return psnr(header);
    case "download": return download(header, payload);
    case "slice": return slice(header, payload);
    case "error":
      if (header.seq != null) settle(header.seq);
      return status(header.message, true);
  }
}

function send(msg) {
  if (S.ws && S.ws.readyState === WebSocket.OPEN) S.ws.send(JSON.stringify(msg));
}

// --- the camera -----------------------------------------------------

function round(x) { return Math.round(x * 1e4) / 1e4; }

// The mode the form asks for (the page's choice, else the startup
// scene's).
function currentMode() {
  return S.values.mode || (S.hello && S.hello.scene.mode) || "dvr";
}

// Whether option `long` applies in the current mode (the server says
// which modes each option is for; none: all).
function applies(long) {
  const modes = S.modes[long];
  return !modes || modes.includes(currentMode());
}

function pairs() {
  const p = {};
  for (const [k, v] of Object.entries(S.values)) if (applies(k)) p[k] = v;
  if (S.tfEdit) {
    delete p.tf;
    p["tf-text"] = S.tf.text();
  }
  const c = S.cam;
  p.orbit = [round(c.az), round(c.el), round(c.dist)];
  p["look-at"] = c.look.map(round);
  const dpr = window.devicePixelRatio || 1;
  const side = Math.round(VIEW * dpr);
  p.size = [side, side];
  return p;
}

function request(preview) {
  S.seq += 1;
  const seq = S.seq;
  S.inflight = { seq, preview };
  S.sent.set(seq, { inputT: S.inputT, t: performance.now(), preview });
  S.inputT = null;
  if (!preview) {
    S.viewSeq = seq;
    $("psnr").textContent = "–";
  }
  send({ type: "render", seq, pairs: pairs(), preview });
}

// The camera moved: a preview, one at a time (the newest camera is
// sent when the one in flight arrives).
function moved() {
  if (S.inputT == null) S.inputT = performance.now();
  if (S.inflight && S.inflight.preview) {
    S.wantPreview = true;
    return;
  }
  S.wantPreview = false;
  request(true);
}

// The camera stopped, or an option changed: the full frame at once
// (the server cancels what is in flight).
function stopped() {
  S.wantPreview = false;
  S.stopT = performance.now();
  request(false);
}

function settle(seq) {
  if (S.inflight && S.inflight.seq === seq) {
    S.inflight = null;
    if (S.wantPreview) {
      S.wantPreview = false;
      request(true);
    }
  }
}

function offsetDir(c) {
  const b = S.hello.camera;
  const az = (c.az * Math.PI) / 180, el = (c.el * Math.PI) / 180;
  return [0, 1, 2].map((i) => b.side[i] * Math.cos(el) * Math.sin(az) + b.up[i] * Math.sin(el) + b.front[i] * Math.cos(el) * Math.cos(az));
}
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => { const l = Math.hypot(...a) || 1; return a.map((v) => v / l); };

function orbit(dx, dy) {
  S.cam.az -= dx * 0.4;
  S.cam.el = Math.max(-89, Math.min(89, S.cam.el + dy * 0.4));
}

function pan(dx, dy) {
  const c = S.cam;
  const forward = offsetDir(c).map((v) => -v);
  const right = norm(cross(forward, S.hello.camera.up));
  const up = cross(right, forward);
  const fov = Number(S.values.fov || S.hello.camera.fov);
  const scale = (2 * c.dist * Math.tan((fov * Math.PI) / 360)) / VIEW;
  c.look = c.look.map((v, i) => v + (-dx * right[i] + dy * up[i]) * scale);
}

function zoom(factor) {
  S.cam.dist = Math.max(1e-3, S.cam.dist * factor);
}

function resetCamera() {
  const c = S.hello.camera;
  S.cam = { az: c.orbit[0], el: c.orbit[1], dist: c.orbit[2], look: c.look_at.slice() };
}

function cameraInput() {
  const canvas = $("view");
  const pointers = new Map();
  let pinch = null;
  canvas.addEventListener("pointerdown", (e) => {
    canvas.setPointerCapture(e.pointerId);
    pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2 });
    S.dragging = true;
  });
  canvas.addEventListener("pointermove", (e) => {
    const p = pointers.get(e.pointerId);
    if (!p) return;
    const dx = e.clientX - p.x, dy = e.clientY - p.y;
    p.x = e.clientX;
    p.y = e.clientY;
    if (pointers.size === 2) {
      const [a, b] = [...pointers.values()];
      const d = Math.hypot(a.x - b.x, a.y - b.y);
      if (pinch) zoom(pinch / Math.max(d, 1));
      pinch = d;
    } else if (p.pan) {
      pan(dx, dy);
    } else {
      orbit(dx, dy);
    }
    if (dx || dy) moved();
  });
  const end = (e) => {
    if (!pointers.delete(e.pointerId)) return;
    pinch = null;
    if (pointers.size === 0) {
      S.dragging = false;
      stopped();
    }
  };
  canvas.addEventListener("pointerup", end);
  canvas.addEventListener("pointercancel", end);
  canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  let wheelTimer = null;
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    zoom(Math.exp(e.deltaY * 0.001));
    moved();
    clearTimeout(wheelTimer);
    wheelTimer = setTimeout(stopped, 150);
  }, { passive: false });
  let keyTimer = null;
  canvas.addEventListener("keydown", (e) => {
    const keys = { ArrowLeft: () => orbit(-12, 0), ArrowRight: () => orbit(12, 0), ArrowUp: () => orbit(0, -12),
      ArrowDown: () => orbit(0, 12), "+": () => zoom(0.9), "=": () => zoom(0.9), "-": () => zoom(1.1) };
    const k = keys[e.key];
    if (!k) return;
    e.preventDefault();
    k();
    moved();
    clearTimeout(keyTimer);
    keyTimer = setTimeout(stopped, 200);
  });
}

// --- frames ---------------------------------------------------------

async function frame(h, png) {
  if (h.final) settle(h.seq);
  if (h.seq < S.shownSeq) return; // never over a newer frame
  const bitmap = await createImageBitmap(new Blob([png], { type: "image/png" }));
  if (h.seq < S.shownSeq) return; // a newer frame was drawn meanwhile
  S.shownSeq = h.seq;
  const canvas = $("view");
  const ctx = canvas.getContext("2d");
  ctx.imageSmoothingEnabled = true;
  ctx.drawImage(bitmap, 0, 0, canvas.width, canvas.height);
  bitmap.close();
  const now = performance.now();
  const sent = S.sent.get(h.seq);
  S.stats.frames++;
  if (h.preview) S.stats.previews++;
  if (h.cost && h.cost.spp != null) S.stats.passes.push({ seq: h.seq, spp: h.cost.spp, error: h.cost.relative_error });
  if (sent && sent.inputT != null && h.preview && !sent.counted) {
    sent.counted = true;
    S.stats.latencies.push(now - sent.inputT);
  }
  if (!h.preview && h.final !== undefined) {
    if (S.stats.firstFull == null) S.stats.firstFull = now;
    if (S.stopT != null && sent && !sent.full) {
      sent.full = true;
      S.stats.stopToFull.push(now - S.stopT);
      S.stopT = null;
    }
  }
  S.last = { header: h, drawnAt: now };
  if (!S.tfEdit && !h.preview) S.currentTf = h.tf;
  showFrame(h);
}

function showFrame(h) {
  const c = h.cost || {};
  const spp = c.spp != null;
  $("cost-time").textContent = `${(c.render_s * 1000).toFixed(1)} ms` + (spp ? " (last pass)" : "");
  $("cost-samples").textContent = c.samples != null ? `${(c.samples / 1e6).toFixed(2)} M` + (spp ? " density lookups" : "") : "–";
  $("cost-skipped").textContent = c.skipped_fraction != null
    ? `${(c.skipped_fraction * 100).toFixed(1)}%` + (spp ? " empty majorant cells" : " of a plain march")
    : "–";
  $("row-spp").hidden = !spp;
  if (spp) {
    const err = c.relative_error != null ? `${(c.relative_error * 100).toFixed(2)}%` : "–";
    $("cost-spp").textContent = `${c.spp}${h.target_spp ? " / " + h.target_spp : ""} spp, relative error ${err}`;
  }
  const lines = [];
  if (h.note) lines.push(h.note);
  else lines.push(`${h.width}x${h.height}` + (spp ? `, ${c.spp} spp` : "") + (h.final ? "" : " …"));
  const overlay = $("overlay");
  overlay.textContent = lines.join("\n");
  overlay.hidden = false;
  $("command").textContent = h.command;
  $("scene").textContent = h.scene;
  $("notes").textContent = (h.notes || []).join("\n");
  status(h.preview ? "moving" : h.final ? "ready" : "refining");
}

function psnr(h) {
  if (h.seq !== S.viewSeq && h.seq !== S.shownSeq) return;
  const db = h.identical ? "identical" : `${h.db.toFixed(2)} dB`;
  $("psnr").textContent = `${db} vs ${h.reference} (${h.reference_s.toFixed(2)} s)`;
  S.lastPsnr = h;
}

function download(h, bytes) {
  S.downloads.push({ name: h.name, saved: h.saved, size: bytes.length });
  const a = $("download");
  const url = URL.createObjectURL(new Blob([bytes], { type: h.mime }));
  a.href = url;
  a.download = h.name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
  status(`saved ${h.name}` + (h.saved ? ` (also ${h.saved})` : "") + (h.command ? `: ${h.command}` : ""));
}

// --- the option form ------------------------------------------------

function initialValue(o) {
  const v = S.hello.scene[o.long];
  if (v === undefined || v === null) return o.defaults.length ? o.defaults.join(",") : "";
  if (Array.isArray(v)) return v.join(",");
  return String(v);
}

function optionRow(o) {
  const row = document.createElement("div");
  row.className = "opt";
  if (o.modes) {
    S.modes[o.long] = o.modes;
    row.dataset.modes = o.modes.join(" ");
  }
  const label = document.createElement("label");
  label.textContent = o.long;
  label.title = o.long_help || o.help || "";
  let input;
  if (o.kind === "flag") {
    input = document.createElement("input");
    input.type = "checkbox";
    input.checked = S.hello.scene[o.long] === true;
  } else if (o.choices.length) {
    input = document.createElement("select");
    const initial = initialValue(o);
    const choices = o.choices.slice();
    if (initial === "" || !choices.includes(initial)) choices.unshift(initial);
    for (const c of choices) {
      const opt = document.createElement("option");
      opt.value = c;
      opt.textContent = c === "" ? "(default)" : c;
      input.append(opt);
    }
    input.value = initial;
  } else {
    input = document.createElement("input");
    input.type = "text";
    input.value = initialValue(o);
    input.placeholder = o.defaults.join(",") || (o.value_name || []).join(" ");
  }
  input.id = "opt-" + o.long;
  input.title = label.title;
  label.htmlFor = input.id;
  input.addEventListener("change", () => {
    let v;
    if (o.kind === "flag") v = input.checked;
    else if (input.value.trim() === "") v = null;
    else if (o.kind === "list") v = input.value.split(/\s+/).filter(Boolean);
    else v = input.value.trim();
    if (v === null) delete S.values[o.long];
    else S.values[o.long] = v;
    row.classList.toggle("changed", v !== null);
    if (o.long === "tf" && S.tfEdit) {
      S.tfEdit = false;
      $("tf-edit").checked = false;
    }
    if (o.long === "mode") showModeOptions();
    stopped();
  });
  row.append(label, input);
  return row;
}

// Show the options that apply to the current mode only.
function showModeOptions() {
  for (const row of document.querySelectorAll(".opt[data-modes]")) {
    row.hidden = !row.dataset.modes.split(" ").includes(currentMode());
  }
}

function buildForm(options) {
  const primary = $("primary"), rest = $("options");
  // Each heading once, in the order of its first option.
  const groups = new Map();
  for (const o of options) {
    if (!o.long || o.path || CAMERA.includes(o.long) || UNUSED.includes(o.long)) continue;
    if (o.long === "tf") {
      // Presets only: files come from the --scene file vol-view starts with.
      o.choices = S.hello.presets.slice();
    }
    const row = optionRow(o);
    if (PRIMARY.includes(o.long)) {
      primary.append(row);
      continue;
    }
    const h = o.heading || "Options";
    if (!groups.has(h)) {
      const g = document.createElement("div");
      const title = document.createElement("div");
      title.className = "group";
      title.textContent = h;
      g.append(title);
      rest.append(g);
      groups.set(h, g);
    }
    groups.get(h).append(row);
  }
  showModeOptions();
}

// --- slices ---------------------------------------------------------

const AXES = { x: [1, 2], y: [0, 2], z: [0, 1] };
const NAMES = "xyz";

function slice(h, bytes) {
  const values = new Float32Array(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
  const s = (S.slices[h.axis] = { ...h, values });
  const vol = S.hello.volume;
  const [u, v] = AXES[h.axis];
  const canvas = $("slice-" + h.axis);
  canvas.width = h.width;
  canvas.height = h.height;
  // The data's geometry: each axis in world units (voxels × spacing).
  const wu = vol.dims[u] * vol.spacing[u], wv = vol.dims[v] * vol.spacing[v];
  const k = 140 / Math.max(wu, wv);
  canvas.style.width = `${wu * k}px`;
  canvas.style.height = `${wv * k}px`;
  const ctx = canvas.getContext("2d");
  const img = ctx.createImageData(h.width, h.height);
  const [lo, hi] = vol.range;
  const span = hi > lo ? hi - lo : 1;
  // Rows from the top: z up for the coronal and sagittal slices.
  const flip = h.axis !== "z";
  for (let r = 0; r < h.height; r++) {
    const src = flip ? h.height - 1 - r : r;
    for (let c = 0; c < h.width; c++) {
      const g = Math.max(0, Math.min(255, ((values[src * h.width + c] - lo) / span) * 255));
      const o = 4 * (r * h.width + c);
      img.data[o] = img.data[o + 1] = img.data[o + 2] = g;
      img.data[o + 3] = 255;
    }
  }
  ctx.putImageData(img, 0, 0);
  // The point the three slices go through, at least a screen pixel wide
  // however far the slice is shrunk (its pixels are sampled, not
  // averaged: a thinner line would fall between them).
  const lw = Math.max(1, Math.ceil(h.width / (wu * k)));
  const start = (i) => i - Math.floor((lw - 1) / 2);
  const col = Math.floor(S.point[u] / h.stride);
  const r = Math.floor(S.point[v] / h.stride);
  ctx.fillStyle = "rgba(255,200,60,0.7)";
  ctx.fillRect(start(col), 0, lw, h.height);
  ctx.fillRect(0, start(flip ? h.height - 1 - r : r), h.width, lw);
  s.flip = flip;
}

function requestSlices() {
  for (const a of NAMES) send({ type: "slice", axis: a, index: S.point[NAMES.indexOf(a)] });
}

function sliceInput() {
  for (const a of NAMES) {
    const canvas = $("slice-" + a);
    const at = (e) => {
      const s = S.slices[a];
      if (!s) return null;
      const r = canvas.getBoundingClientRect();
      const c = Math.floor(((e.clientX - r.left) / r.width) * s.width);
      let row = Math.floor(((e.clientY - r.top) / r.height) * s.height);
      if (c < 0 || row < 0 || c >= s.width || row >= s.height) return null;
      if (s.flip) row = s.height - 1 - row;
      const [u, v] = AXES[a];
      const ijk = S.point.slice();
      ijk[u] = c * s.stride;
      ijk[v] = row * s.stride;
      return { ijk, value: s.values[row * s.width + c] };
    };
    canvas.addEventListener("mousemove", (e) => {
      const p = at(e);
      if (!p) return;
      const vol = S.hello.volume;
      const world = p.ijk.map((i, k) => (i * vol.spacing[k]).toFixed(2));
      $("probe").textContent = `voxel (${p.ijk.join(", ")}) at (${world.join(", ")}) world units: value ${p.value}`;
      S.probe = p;
    });
    canvas.addEventListener("click", (e) => {
      const p = at(e);
      if (!p) return;
      S.point = p.ijk;
      NAMES.split("").forEach((n, k) => ($("pos-" + n).value = S.point[k]));
      requestSlices();
    });
    $("pos-" + a).addEventListener("input", (e) => {
      S.point[NAMES.indexOf(a)] = Number(e.target.value);
      requestSlices();
    });
  }
}

// --- start ----------------------------------------------------------

function hello(h) {
  S.stats.helloAt = performance.now();
  S.hello = h;
  $("volume-name").textContent = `${h.volume.name}: ${h.volume.dims.join("x")} ${h.volume.type}, spacing ${h.volume.spacing.join(",")}`;
  resetCamera();
  buildForm(h.options);
  const dpr = window.devicePixelRatio || 1;
  const canvas = $("view");
  canvas.width = Math.round(VIEW * dpr);
  canvas.height = Math.round(VIEW * dpr);
  $("view-box").style.width = $("view-box").style.height = `${VIEW}px`;
  const hist = h.histogram;
  S.tf.setHistogram(hist ? hist.lo : h.volume.range[0], hist ? hist.hi : h.volume.range[1], hist ? hist.counts : []);
  S.currentTf = h.tf;
  S.slices = {};
  S.point = h.volume.dims.map((d) => Math.floor(d / 2));
  NAMES.split("").forEach((n, k) => {
    $("pos-" + n).max = h.volume.dims[k] - 1;
    $("pos-" + n).value = S.point[k];
  });
  requestSlices();
  status("rendering");
  stopped();
}

function start() {
  S.tf = new TfEditor($("tf-canvas"), $("tf-colour"), (dragging) => {
    if (!S.tfEdit) return;
    if (dragging) moved(); else stopped();
  });
  $("tf-edit").addEventListener("change", (e) => {
    S.tfEdit = e.target.checked;
    // Start from the transfer function shown (a 2D one cannot be edited
    // here: a grey ramp then).
    if (S.tfEdit) {
      S.tf.load(S.currentTf);
      if (!S.currentTf) status("the transfer function shown is 2D: the editor starts from a grey ramp");
    }
    // The dropdown says the editor's function is in use, and gets its
    // choice back when editing stops.
    const tf = $("opt-tf");
    if (tf) {
      if (S.tfEdit) {
        S.tfChoice = tf.value;
        const o = document.createElement("option");
        o.value = o.textContent = EDITED;
        tf.append(o);
        tf.value = EDITED;
      } else {
        for (const o of [...tf.options]) if (o.value === EDITED) o.remove();
        if (S.tfChoice != null) tf.value = S.tfChoice;
      }
      tf.disabled = S.tfEdit;
      tf.classList.toggle("edited", S.tfEdit);
    }
    stopped();
  });
  cameraInput();
  sliceInput();
  $("reset-camera").onclick = () => { resetCamera(); stopped(); };
  $("psnr-button").onclick = () => {
    $("psnr").textContent = "rendering the reference…";
    // The frame shown: the full view's, or a preview's while one is.
    send({ type: "psnr", seq: S.shownSeq || S.viewSeq });
  };
  for (const what of ["png", "pfm", "scene"]) $("save-" + what).onclick = () => send({ type: "save", what });
  const copy = (id) => () => navigator.clipboard && navigator.clipboard.writeText($(id).textContent);
  $("copy-command").onclick = copy("command");
  $("copy-scene").onclick = copy("scene");
  // A new device pixel ratio (another screen, browser zoom): sharp frames.
  const watchDpr = () => {
    matchMedia(`(resolution: ${window.devicePixelRatio}dppx)`).addEventListener("change", () => {
      if (!S.hello) return;
      const canvas = $("view");
      canvas.width = Math.round(VIEW * window.devicePixelRatio);
      canvas.height = canvas.width;
      stopped();
      watchDpr();
    }, { once: true });
  };
  watchDpr();
  connect();
}

start();
