// dexwarp player: draws the geometry that dexwarp computed (src/player/data.rs) on a 2D
// canvas with its own perspective projection and a painter's sort. No library, no network.
(function () {
  'use strict';
  const errors = [];
  function fail(msg) {
    errors.push(String(msg));
    document.body.dataset.playerErrors = errors.join(' | ');
  }
  window.addEventListener('error', (e) => fail(e.message));

  const $ = (id) => document.getElementById(id);
  const canvas = $('pl-canvas');
  // Read back after each still frame (test hooks): a CPU canvas is the fast one for that.
  const ctx = canvas.getContext('2d', { willReadFrequently: true });
  const strip = $('pl-strip');
  const sctx = strip.getContext('2d');
  const slider = $('pl-slider');
  const statusEl = $('pl-status');
  const frameEl = $('pl-frame');
  const pick = $('pl-pick');
  const playBtn = $('pl-play');
  const modeSel = $('pl-mode');
  const BG = [244, 246, 248];
  const entries = dexwarpPlayerEntries;
  const loaded = {};
  let cur = null;
  let wanted = null;
  let frame = 0;
  let playing = false;
  let lastTime = 0;
  let clock = 0;
  let scheduled = false;
  const cam = { yaw: -2.2, pitch: 0.5, dist: 1.5, target: [0, 0, 1] };

  // ---- decoding ----
  function bytes(s) {
    const bin = atob(s);
    const u = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) u[i] = bin.charCodeAt(i);
    return u.buffer;
  }
  const i16 = (s) => new Int16Array(bytes(s));
  const u32 = (s) => new Uint32Array(bytes(s));

  // ---- vectors, quaternions [w, x, y, z], poses {p, q} ----
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  function norm(a) {
    const l = Math.hypot(a[0], a[1], a[2]) || 1;
    return [a[0] / l, a[1] / l, a[2] / l];
  }
  function qmul(a, b) {
    return [
      a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
      a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
      a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
      a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ];
  }
  function apply(T, v) {
    const w = T.q[0], x = T.q[1], y = T.q[2], z = T.q[3];
    const tx = 2 * (y * v[2] - z * v[1]);
    const ty = 2 * (z * v[0] - x * v[2]);
    const tz = 2 * (x * v[1] - y * v[0]);
    return [
      v[0] + w * tx + (y * tz - z * ty) + T.p[0],
      v[1] + w * ty + (z * tx - x * tz) + T.p[1],
      v[2] + w * tz + (x * ty - y * tx) + T.p[2],
    ];
  }
  const compose = (A, B) => ({ p: apply(A, B.p), q: qmul(A.q, B.q) });
  function poseOf(a) {
    const q = [a[3], a[4], a[5], a[6]];
    const l = Math.hypot(q[0], q[1], q[2], q[3]) || 1;
    return { p: [a[0], a[1], a[2]], q: [q[0] / l, q[1] / l, q[2] / l, q[3] / l] };
  }
  // Pose k of a quantized track (7 int16 each) on grid g = [ox, oy, oz, step].
  function trackPose(t, g, k) {
    const o = 7 * k;
    return poseOf([
      g[0] + g[3] * t[o], g[1] + g[3] * t[o + 1], g[2] + g[3] * t[o + 2],
      t[o + 3], t[o + 4], t[o + 5], t[o + 6],
    ]);
  }

  // ---- shapes as parts: {verts (local, flat), faces, cull} or capsules and balls ----
  function meshPart(m) {
    const v = i16(m.v);
    const g = m.grid;
    const verts = new Float64Array(v.length);
    for (let i = 0; i < v.length; i += 3) {
      verts[i] = g[0] + g[3] * v[i];
      verts[i + 1] = g[1] + g[3] * v[i + 1];
      verts[i + 2] = g[2] + g[3] * v[i + 2];
    }
    const t = u32(m.t);
    const faces = [];
    for (let i = 0; i + 2 < t.length; i += 3) faces.push([t[i], t[i + 1], t[i + 2]]);
    return { kind: 'poly', verts, faces, cull: true };
  }
  // A convex part from points and faces, faces turned outward about the centroid.
  function convexPart(pts, faces, T) {
    const w = pts.map((p) => apply(T, p));
    const c = [0, 0, 0];
    for (const p of w) { c[0] += p[0] / w.length; c[1] += p[1] / w.length; c[2] += p[2] / w.length; }
    const out = faces.map((f) => {
      const n = cross(sub(w[f[1]], w[f[0]]), sub(w[f[2]], w[f[0]]));
      return dot(n, sub(w[f[0]], c)) < 0 ? f.slice().reverse() : f;
    });
    const verts = new Float64Array(w.length * 3);
    w.forEach((p, i) => { verts[3 * i] = p[0]; verts[3 * i + 1] = p[1]; verts[3 * i + 2] = p[2]; });
    return { kind: 'poly', verts, faces: out, cull: true };
  }
  function partOf(s, T) {
    if (s.type === 'box') {
      const [a, b, c] = s.size.map((x) => x / 2);
      const pts = [];
      for (const x of [-a, a]) for (const y of [-b, b]) for (const z of [-c, c]) pts.push([x, y, z]);
      return convexPart(pts, [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]], T);
    }
    if (s.type === 'cylinder') {
      const n = 16, h = s.length / 2, pts = [], faces = [];
      for (let i = 0; i < n; i++) {
        const a = (2 * Math.PI * i) / n;
        pts.push([s.radius * Math.cos(a), s.radius * Math.sin(a), -h]);
      }
      for (let i = 0; i < n; i++) pts.push([pts[i][0], pts[i][1], h]);
      for (let i = 0; i < n; i++) faces.push([i, (i + 1) % n, n + ((i + 1) % n), n + i]);
      faces.push([...Array(n).keys()]);
      faces.push([...Array(n).keys()].map((i) => n + i));
      return convexPart(pts, faces, T);
    }
    if (s.type === 'capsule') {
      return { kind: 'cap', a: apply(T, [0, 0, -s.length / 2]), b: apply(T, [0, 0, s.length / 2]), r: s.radius };
    }
    if (s.type === 'sphere') return { kind: 'ball', c: T.p, r: s.radius };
    if (s.type === 'mesh') {
      const m = meshPart(s.mesh);
      for (let i = 0; i < m.verts.length; i += 3) {
        const p = apply(T, [m.verts[i], m.verts[i + 1], m.verts[i + 2]]);
        m.verts[i] = p[0]; m.verts[i + 1] = p[1]; m.verts[i + 2] = p[2];
      }
      return m;
    }
    return null;
  }

  function prepare(d) {
    const L = d.links.length;
    const P = i16(d.primary);
    const O = d.original ? i16(d.original) : null;
    const links = d.links.map((l) => l.shapes.map((s) => partOf(s, poseOf(s.pose))).filter(Boolean));
    const scene = d.scene.map((it) => ({ it, part: partOf(it.shape, poseOf(it.pose)) })).filter((x) => x.part);
    const counts = u32(d.contacts.count);
    const offsets = new Uint32Array(counts.length + 1);
    for (let i = 0; i < counts.length; i++) offsets[i + 1] = offsets[i] + counts[i];
    const source = u32(d.source);
    const inContact = u32(d.in_contact);
    const covered = new Uint8Array(d.n);
    if (d.tau) {
      for (const t of d.tau) {
        const k = Math.round(t);
        if (k >= 0 && k < d.n) covered[k] = 1;
      }
    } else covered.fill(1);
    const g = d.grid;
    const path = (t, n) => {
      const v = [];
      for (let f = 0; f < n; f++) v.push(trackPose(t, g, f * (L + 1)).p);
      return v;
    };
    const outPath = path(P, d.n);
    const lo = [1e9, 1e9, 1e9], hi = [-1e9, -1e9, -1e9];
    for (const p of outPath) for (let k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], p[k]); hi[k] = Math.max(hi[k], p[k]); }
    return {
      d, L, P, O, links, scene, counts, offsets, source, inContact, covered,
      contacts: i16(d.contacts.data),
      object: meshPart(d.object),
      outPath,
      origPath: O ? path(O, d.n_original) : null,
      centre: [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2],
      extent: Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]),
    };
  }

  // ---- camera and drawing ----
  let view = null;
  function setView(x0, y0, w, h) {
    const cp = Math.cos(cam.pitch);
    const eye = [
      cam.target[0] + cam.dist * cp * Math.cos(cam.yaw),
      cam.target[1] + cam.dist * cp * Math.sin(cam.yaw),
      cam.target[2] + cam.dist * Math.sin(cam.pitch),
    ];
    const f = norm(sub(cam.target, eye));
    const r = norm(cross(f, [0, 0, 1]));
    const u = cross(r, f);
    view = { eye, f, r, u, cx: x0 + w / 2, cy: y0 + h / 2, F: 1.2 * h };
  }
  function project(p) {
    const d = sub(p, view.eye);
    const z = dot(d, view.f);
    if (z < 0.02) return null;
    return [view.cx + (view.F * dot(d, view.r)) / z, view.cy - (view.F * dot(d, view.u)) / z, z];
  }
  const LIGHT = norm([0.35, -0.45, 0.82]);
  function rgba(c, s, a) {
    return 'rgba(' + Math.round(c[0] * s) + ',' + Math.round(c[1] * s) + ',' + Math.round(c[2] * s) + ',' + a + ')';
  }

  // Adds the faces of `part` placed by pose T (null: already in the world) to `items`.
  function addPart(items, part, T, color, alpha) {
    if (part.kind === 'cap' || part.kind === 'ball') {
      const a = project(T ? apply(T, part.a || part.c) : part.a || part.c);
      const b = part.kind === 'cap' ? project(T ? apply(T, part.b) : part.b) : a;
      if (!a || !b) return;
      const z = (a[2] + b[2]) / 2;
      items.push({ z, cap: true, a, b, w: Math.max(1, (2 * part.r * view.F) / z), color, alpha });
      return;
    }
    const v = part.verts;
    const n = v.length / 3;
    const W = new Float64Array(v.length);
    const S = new Float64Array(v.length);
    for (let i = 0; i < n; i++) {
      const p = T ? apply(T, [v[3 * i], v[3 * i + 1], v[3 * i + 2]]) : [v[3 * i], v[3 * i + 1], v[3 * i + 2]];
      W[3 * i] = p[0]; W[3 * i + 1] = p[1]; W[3 * i + 2] = p[2];
      const s = project(p);
      if (s) { S[3 * i] = s[0]; S[3 * i + 1] = s[1]; S[3 * i + 2] = s[2]; } else S[3 * i + 2] = -1;
    }
    const e = view.eye;
    for (const f of part.faces) {
      const i0 = 3 * f[0], i1 = 3 * f[1], i2 = 3 * f[2];
      const ax = W[i1] - W[i0], ay = W[i1 + 1] - W[i0 + 1], az = W[i1 + 2] - W[i0 + 2];
      const bx = W[i2] - W[i0], by = W[i2 + 1] - W[i0 + 1], bz = W[i2 + 2] - W[i0 + 2];
      let nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
      const facing = nx * (e[0] - W[i0]) + ny * (e[1] - W[i0 + 1]) + nz * (e[2] - W[i0 + 2]);
      if (part.cull && facing <= 0) continue;
      const l = Math.hypot(nx, ny, nz) || 1;
      nx /= l; ny /= l; nz /= l;
      let z = 0, ok = true;
      const pts = [];
      for (const k of f) {
        if (S[3 * k + 2] < 0) { ok = false; break; }
        pts.push(S[3 * k], S[3 * k + 1]);
        z += S[3 * k + 2];
      }
      if (!ok) continue;
      const shade = 0.5 + 0.5 * Math.abs(nx * LIGHT[0] + ny * LIGHT[1] + nz * LIGHT[2]);
      items.push({ z: z / f.length, pts, fill: rgba(color, shade, alpha) });
    }
  }

  function addBody(items, c, t, k, objColor, handColor, alpha) {
    const g = c.d.grid;
    const base = k * (c.L + 1);
    addPart(items, c.object, trackPose(t, g, base), objColor, alpha);
    for (let l = 0; l < c.L; l++) {
      const T = trackPose(t, g, base + 1 + l);
      for (const part of c.links[l]) addPart(items, part, T, handColor, alpha);
    }
  }

  function flush(items) {
    items.sort((a, b) => b.z - a.z);
    for (const it of items) {
      if (it.cap) {
        ctx.lineCap = 'round';
        ctx.strokeStyle = rgba(it.color, 0.55, it.alpha);
        ctx.lineWidth = it.w + 1.5;
        ctx.beginPath(); ctx.moveTo(it.a[0], it.a[1]); ctx.lineTo(it.b[0], it.b[1]); ctx.stroke();
        ctx.strokeStyle = rgba(it.color, 1, it.alpha);
        ctx.lineWidth = it.w;
        ctx.stroke();
      } else {
        const p = it.pts;
        ctx.fillStyle = it.fill;
        ctx.beginPath();
        ctx.moveTo(p[0], p[1]);
        for (let i = 2; i < p.length; i += 2) ctx.lineTo(p[i], p[i + 1]);
        ctx.closePath();
        ctx.fill();
      }
    }
  }

  function polyline(pts, color, width, dash) {
    ctx.strokeStyle = color; ctx.lineWidth = width; ctx.setLineDash(dash || []);
    ctx.beginPath();
    let pen = false;
    for (const p of pts) {
      const s = project(p);
      if (!s) { pen = false; continue; }
      if (pen) ctx.lineTo(s[0], s[1]); else ctx.moveTo(s[0], s[1]);
      pen = true;
    }
    ctx.stroke();
    ctx.setLineDash([]);
  }

  function grid() {
    ctx.strokeStyle = 'rgba(0,0,0,0.07)'; ctx.lineWidth = 1;
    const c = cam.target, R = 3, step = 0.25;
    const x0 = Math.round(c[0] / step) * step, y0 = Math.round(c[1] / step) * step;
    for (let k = -R / step; k <= R / step; k++) {
      for (const [a, b] of [[[x0 + k * step, y0 - R, 0], [x0 + k * step, y0 + R, 0]], [[x0 - R, y0 + k * step, 0], [x0 + R, y0 + k * step, 0]]]) {
        const sa = project(a), sb = project(b);
        if (!sa || !sb) continue;
        ctx.beginPath(); ctx.moveTo(sa[0], sa[1]); ctx.lineTo(sb[0], sb[1]); ctx.stroke();
      }
    }
  }

  function penetrating(c, f) {
    const p = c.d.penetration_mm[f];
    return p !== undefined && p !== null && p > c.d.penetration_limit_mm;
  }

  function contacts(c, t, k, sf, color) {
    const g = c.d.contacts.grid, cg = c.d.grid, D = c.contacts;
    const base = k * (c.L + 1);
    const obj = trackPose(t, cg, base);
    ctx.strokeStyle = color; ctx.fillStyle = color; ctx.lineWidth = 1.5;
    for (let j = c.offsets[sf]; j < c.offsets[sf + 1]; j++) {
      const o = 7 * j;
      const link = trackPose(t, cg, base + 1 + D[o]);
      const h = apply(link, [g[0] + g[3] * D[o + 1], g[1] + g[3] * D[o + 2], g[2] + g[3] * D[o + 3]]);
      const q = apply(obj, [g[0] + g[3] * D[o + 4], g[1] + g[3] * D[o + 5], g[2] + g[3] * D[o + 6]]);
      const a = project(h), b = project(q);
      if (!a || !b) continue;
      ctx.beginPath(); ctx.moveTo(a[0], a[1]); ctx.lineTo(b[0], b[1]); ctx.stroke();
      ctx.beginPath(); ctx.arc(b[0], b[1], 1.8, 0, 2 * Math.PI); ctx.fill();
    }
  }

  // One viewport: `which` is 'both', 'output' or 'original'.
  function drawView(c, x0, y0, w, h, which) {
    ctx.save();
    ctx.beginPath(); ctx.rect(x0, y0, w, h); ctx.clip();
    setView(x0, y0, w, h);
    grid();
    const d = c.d;
    const items = [];
    for (const s of c.scene) {
      const barrier = s.it.role === 'barrier';
      const color = barrier ? (s.it.active ? [205, 95, 85] : [175, 175, 185]) : [196, 186, 172];
      addPart(items, s.part, null, color, barrier ? 0.55 : 1);
    }
    const sf = c.source[frame];
    const showOrig = c.O && (which === 'both' || which === 'original');
    if (showOrig) {
      const a = which === 'both' ? 0.3 : 1;
      addBody(items, c, c.O, sf, [150, 150, 150], [160, 160, 160], a);
    }
    if (which !== 'original') {
      const red = penetrating(c, frame);
      addBody(items, c, c.P, frame, [70, 130, 200], red ? [225, 45, 40] : [236, 192, 156], 1);
    }
    flush(items);
    if ($('pl-paths').checked) {
      if (c.origPath && which !== 'output') polyline(c.origPath, 'rgba(90,90,90,0.8)', 1.5, [5, 4]);
      if (which !== 'original') polyline(c.outPath, 'rgba(31,119,180,0.95)', 2);
      for (const wp of d.waypoints) {
        const s = project(wp.p);
        if (!s) continue;
        ctx.strokeStyle = '#e6550d'; ctx.lineWidth = 2.5;
        ctx.beginPath(); ctx.arc(s[0], s[1], 7, 0, 2 * Math.PI); ctx.stroke();
        if (wp.t_new !== null && Math.abs(wp.t_new - frame) <= 1) { ctx.fillStyle = '#e6550d'; ctx.fill(); }
      }
    }
    if ($('pl-contacts').checked && c.inContact[frame]) {
      if (which !== 'original') contacts(c, c.P, frame, c.O ? sf : frame, 'rgba(20,150,40,0.95)');
      else if (c.O) contacts(c, c.O, sf, sf, 'rgba(20,150,40,0.95)');
    }
    ctx.fillStyle = '#333'; ctx.font = '13px sans-serif';
    const label = which === 'original' ? 'original, frame ' + sf : which === 'output' ? 'output' : 'output and original';
    ctx.fillText(label, x0 + 8, y0 + 18);
    ctx.restore();
  }

  function drawStrip(c) {
    const W = strip.width, H = strip.height, n = c.d.n;
    sctx.fillStyle = '#fff'; sctx.fillRect(0, 0, W, H);
    const x = (f) => (f / Math.max(1, n - 1)) * (W - 1);
    const cw = Math.max(1, W / n);
    for (let f = 0; f < n; f++) {
      if (c.covered[f]) { sctx.fillStyle = '#555'; sctx.fillRect(x(f) - cw / 2, 2, cw, 11); }
      if (c.inContact[f]) { sctx.fillStyle = '#9bd39b'; sctx.fillRect(x(f) - cw / 2, 15, cw, 5); }
      if (penetrating(c, f)) { sctx.fillStyle = '#e0302a'; sctx.fillRect(x(f) - cw / 2, 21, cw, 8); }
    }
    sctx.fillStyle = '#1f77b4';
    sctx.fillRect(x(frame) - 1, 0, 2, H);
  }

  function pixels() {
    const img = ctx.getImageData(0, 0, canvas.width, canvas.height).data;
    let ink = 0, hash = 0;
    for (let i = 0; i < img.length; i += 4) {
      if (Math.abs(img[i] - BG[0]) + Math.abs(img[i + 1] - BG[1]) + Math.abs(img[i + 2] - BG[2]) > 24) ink++;
      hash = (hash * 31 + img[i] + 7 * img[i + 1] + 13 * img[i + 2]) >>> 0;
    }
    return { ink, hash };
  }

  function draw() {
    scheduled = false;
    const c = cur;
    ctx.fillStyle = 'rgb(' + BG.join(',') + ')';
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    if (!c) return;
    const W = canvas.width, H = canvas.height, mode = modeSel.value;
    if (mode === 'side' && c.O) {
      drawView(c, 0, 0, W / 2, H, 'original');
      drawView(c, W / 2, 0, W / 2, H, 'output');
      ctx.fillStyle = '#999'; ctx.fillRect(W / 2 - 1, 0, 2, H);
    } else drawView(c, 0, 0, W, H, mode === 'output' || !c.O ? 'output' : 'both');
    drawStrip(c);
    const d = c.d;
    const pen = d.penetration_mm[frame];
    frameEl.textContent =
      'frame ' + frame + ' / ' + (d.n - 1) + ' (t = ' + (frame / d.fps).toFixed(2) + ' s)' +
      (c.O ? '; source frame t* = ' + c.source[frame] : '') +
      (c.inContact[frame] ? '; in contact' : '') +
      (pen !== undefined && pen !== null ? '; hand-object penetration ' + pen.toFixed(2) + ' mm (limit ' + d.penetration_limit_mm + ' mm)' : '');
    slider.value = String(frame);
    document.body.dataset.playerFrame = String(frame);
    document.body.dataset.playerId = pick.value;
    if (!playing) {
      const px = pixels();
      document.body.dataset.playerInk = String(px.ink);
      document.body.dataset.playerHash = String(px.hash);
    }
  }
  function schedule() {
    if (!scheduled) { scheduled = true; requestAnimationFrame(draw); }
  }

  function show(id, f) {
    const c = loaded[id];
    cur = c;
    const d = c.d;
    slider.max = String(d.n - 1);
    frame = Math.max(0, Math.min(d.n - 1, f || 0));
    cam.target = c.centre.slice();
    cam.dist = Math.max(0.6, 1.4 * c.extent + 0.45);
    statusEl.textContent = d.title + ': physics ' + (d.verdict || 'not run') + (d.reasons.length ? ' (' + d.reasons[0] + ')' : '') + '; ' + d.n + ' frames at ' + d.fps + ' Hz';
    draw();
    // Time from navigation to this first picture of the trajectory [ms] (load-time checks).
    document.body.dataset.playerShownMs = String(Math.round(performance.now()));
  }

  function select(id, f, selftest) {
    const e = entries.find((x) => x.id === id);
    if (!e) { fail('no trajectory ' + id); return; }
    pick.value = id;
    wanted = { id, f, selftest };
    if (loaded[id]) { finish(); return; }
    statusEl.textContent = 'loading ' + e.label + '...';
    const s = document.createElement('script');
    s.src = e.src;
    s.onerror = () => fail('could not load ' + e.src + ' (the data file next to the page)');
    document.head.appendChild(s);
  }
  function finish() {
    const w = wanted;
    if (!w || !loaded[w.id]) return;
    wanted = null;
    stop();
    show(w.id, w.f);
    if (w.selftest) selftest();
  }

  window.dexwarpPlayer = {
    loaded(id, data) {
      try {
        loaded[id] = prepare(data);
      } catch (err) {
        fail('trajectory ' + id + ': ' + err);
        return;
      }
      if (wanted && wanted.id === id) finish();
    },
  };

  // Moves the slider as a user would and records whether time and the picture followed.
  function selftest() {
    const before = { frame, hash: document.body.dataset.playerHash };
    const target = (frame + Math.floor(cur.d.n / 2)) % cur.d.n;
    slider.value = String(target);
    slider.dispatchEvent(new Event('input', { bubbles: true }));
    draw();
    const ok = frame === target && frame !== before.frame && document.body.dataset.playerHash !== before.hash;
    document.body.dataset.playerSelftest = (ok ? 'ok' : 'fail') + ': slider ' + before.frame + ' -> ' + target + ', frame ' + frame + ', picture ' + (document.body.dataset.playerHash !== before.hash ? 'changed' : 'unchanged');
  }

  // ---- controls ----
  function tick(t) {
    if (!playing || !cur) return;
    const dt = lastTime ? (t - lastTime) / 1000 : 0;
    lastTime = t;
    clock += dt * cur.d.fps;
    const step = Math.floor(clock);
    if (step > 0) {
      clock -= step;
      frame = (frame + step) % cur.d.n;
      draw();
    }
    requestAnimationFrame(tick);
  }
  function stop() {
    playing = false;
    playBtn.textContent = 'Play';
  }
  function toggle() {
    if (!cur) return;
    playing = !playing;
    playBtn.textContent = playing ? 'Pause' : 'Play';
    if (playing) { lastTime = 0; clock = 0; requestAnimationFrame(tick); } else draw();
  }
  playBtn.addEventListener('click', toggle);
  slider.addEventListener('input', () => { frame = Number(slider.value); if (!playing) draw(); });
  pick.addEventListener('change', () => select(pick.value, 0));
  for (const id of ['pl-mode', 'pl-contacts', 'pl-paths']) $(id).addEventListener('change', schedule);
  document.addEventListener('keydown', (e) => {
    if (e.code === 'Space' && e.target === document.body) { e.preventDefault(); toggle(); }
  });
  let drag = null;
  canvas.addEventListener('mousedown', (e) => { drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey }; });
  window.addEventListener('mouseup', () => { drag = null; });
  window.addEventListener('mousemove', (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.pan && view) {
      const s = cam.dist / 600;
      for (let k = 0; k < 3; k++) cam.target[k] += -dx * s * view.r[k] + dy * s * view.u[k];
    } else {
      cam.yaw -= dx * 0.01;
      cam.pitch = Math.max(-1.5, Math.min(1.5, cam.pitch + dy * 0.01));
    }
    schedule();
  });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    cam.dist = Math.max(0.05, Math.min(50, cam.dist * Math.exp(e.deltaY * 0.001)));
    schedule();
  }, { passive: false });

  function fromHash() {
    const h = new URLSearchParams(location.hash.slice(1));
    const id = h.get('play');
    if (!id) return false;
    if (h.get('only') === '1') document.body.classList.add('pl-only');
    select(id, Number(h.get('frame') || 0), h.get('selftest') === '1');
    $('player').scrollIntoView();
    return true;
  }
  window.addEventListener('hashchange', fromHash);
  if (!fromHash() && entries.length) select(entries[0].id, 0);
})();
