// scenespeak viewer: upload a stereo pair, draw the outlines and the top view, ask questions.
"use strict";
const COLORS = ["#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4", "#f032e6", "#9a6324"];
const $ = (id) => document.getElementById(id);
let lastForm = null;

function status(text, isError) {
  const s = $("status");
  s.textContent = text;
  s.className = isError ? "error" : "";
}

function pairForm() {
  const fd = new FormData();
  fd.append("left", $("left").files[0]);
  fd.append("right", $("right").files[0]);
  if ($("calib").files.length) fd.append("calib", $("calib").files[0]);
  return fd;
}

async function post(url, fd) {
  const res = await fetch(url, { method: "POST", body: fd });
  let body;
  try { body = await res.json(); } catch (e) { body = { error: `HTTP ${res.status}` }; }
  if (!res.ok) throw new Error(body.error || `HTTP ${res.status}`);
  return body;
}

function drawImage(file, scene) {
  return new Promise((resolve) => {
    const img = new Image();
    img.onload = () => {
      const c = $("image");
      c.width = img.naturalWidth; c.height = img.naturalHeight;
      const g = c.getContext("2d");
      g.drawImage(img, 0, 0);
      const outlines = (scene.image && scene.image.outlines) || [];
      g.lineWidth = Math.max(2, c.width / 320);
      g.font = `${Math.max(14, c.width / 40)}px sans-serif`;
      outlines.forEach((o, i) => {
        const col = COLORS[i % COLORS.length];
        g.strokeStyle = col; g.fillStyle = col;
        g.beginPath();
        o.outline.forEach(([x, y], k) => (k ? g.lineTo(x, y) : g.moveTo(x, y)));
        g.closePath(); g.stroke();
        const top = o.outline.reduce((a, p) => (p[1] < a[1] ? p : a), o.outline[0]);
        const w = g.measureText(o.label).width;
        g.fillRect(top[0] - 2, top[1] - 22, w + 6, 20);
        g.fillStyle = "#fff"; g.fillText(o.label, top[0] + 1, top[1] - 6);
      });
      URL.revokeObjectURL(img.src);
      resolve();
    };
    img.src = URL.createObjectURL(file);
  });
}

function drawTop(scene) {
  const c = $("top"), g = c.getContext("2d");
  g.fillStyle = "#fafafa"; g.fillRect(0, 0, c.width, c.height);
  const pts = scene.objects.flatMap((o) => o.hull);
  pts.push([0, 0]);
  const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
  const minx = Math.min(...xs), maxx = Math.max(...xs), miny = Math.min(...ys), maxy = Math.max(...ys);
  const span = Math.max(maxx - minx, maxy - miny, 0.2) * 1.2;
  const cx = (minx + maxx) / 2, cy = (miny + maxy) / 2;
  const s = c.width / span;
  const X = (x) => c.width / 2 + (x - cx) * s, Y = (y) => c.height / 2 - (y - cy) * s;
  g.fillStyle = "#222"; g.beginPath(); g.moveTo(X(0), Y(0)); g.lineTo(X(0) - 8, Y(0) + 12); g.lineTo(X(0) + 8, Y(0) + 12); g.fill();
  g.fillText("camera", X(0) + 10, Y(0) + 10);
  g.font = "14px sans-serif";
  scene.objects.forEach((o, i) => {
    const col = COLORS[i % COLORS.length];
    g.strokeStyle = col; g.fillStyle = col + "55"; g.lineWidth = 2;
    g.beginPath();
    o.hull.forEach(([x, y], k) => (k ? g.lineTo(X(x), Y(y)) : g.moveTo(X(x), Y(y))));
    g.closePath(); g.fill(); g.stroke();
    const mx = o.hull.reduce((a, p) => a + p[0], 0) / o.hull.length;
    const my = o.hull.reduce((a, p) => a + p[1], 0) / o.hull.length;
    g.fillStyle = col; g.fillText(o.label, X(mx) + 6, Y(my) - 6);
  });
}

function listScene(scene) {
  const objs = $("objects"); objs.innerHTML = "";
  scene.objects.forEach((o, i) => {
    const li = document.createElement("li");
    const sw = document.createElement("span");
    sw.className = "swatch"; sw.style.background = COLORS[i % COLORS.length];
    li.appendChild(sw);
    const z = o.centroid ? ` (${o.centroid[2].toFixed(2)} m away)` : "";
    li.appendChild(document.createTextNode(o.label + z));
    li.className = "object";
    objs.appendChild(li);
  });
  const ul = $("sentences"); ul.innerHTML = "";
  scene.relations.forEach((r) => {
    const li = document.createElement("li"); li.className = "sentence"; li.textContent = r.sentence; ul.appendChild(li);
  });
  (scene.skipped || []).forEach((s) => {
    const li = document.createElement("li"); li.textContent = `Not described: the ${s.label} (${s.reason}).`; ul.appendChild(li);
  });
  $("summary").textContent = scene.summary || "";
}

$("pair-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  if (!$("left").files.length || !$("right").files.length) { status("Choose both images.", true); return; }
  status("Describing…");
  const fd = pairForm(); fd.append("outlines", "true");
  try {
    const t0 = performance.now();
    const scene = await post("/api/describe", fd);
    lastForm = true;
    await drawImage($("left").files[0], scene);
    drawTop(scene);
    listScene(scene);
    const n = scene.objects.length;
    status(`${n} object${n === 1 ? "" : "s"} described in ${((performance.now() - t0) / 1000).toFixed(2)} s.`);
    document.body.dataset.described = "yes";
  } catch (e) {
    status(e.message, true);
  }
});

$("ask-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const a = $("answer");
  const q = $("question").value.trim();
  if (!q) { a.textContent = "Type a question."; a.className = "error"; return; }
  if (!lastForm) { a.textContent = "Describe a pair first."; a.className = "error"; return; }
  a.textContent = "Thinking…"; a.className = "";
  const fd = pairForm(); fd.append("question", q);
  try {
    const ans = await post("/api/ask", fd);
    a.textContent = ans.answer; a.dataset.kind = ans.kind;
  } catch (e) {
    a.textContent = e.message; a.className = "error";
  }
});
