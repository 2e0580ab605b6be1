// The touch view page: draws the snapshots that /events streams (see touch_view/state.py for their shape).
// Plain JavaScript, SVG and canvas; no library, nothing fetched from outside this server.
'use strict';

const SVG_NS = 'http://www.w3.org/2000/svg';
const $ = (id) => document.getElementById(id);
let config = null;          // /config.json: body map and layout, panel names, rates
let clientId = null;        // this page's id on the server (its dropped-frame count is shown)
let lastFrameWall = 0;      // performance.now() of the last snapshot
const sensorDots = new Map();   // channel -> SVG circle
const regionShapes = [];        // [region, SVG element]

// ------------------------------------------------------------------ colours
const INFERNO = [[0, 0, 4], [87, 16, 110], [188, 55, 84], [249, 142, 9], [252, 255, 164]];
const LEVEL = [[236, 236, 236], [253, 186, 116], [234, 88, 12], [153, 27, 27]];
function ramp(anchors, v) {
  v = Math.min(1, Math.max(0, v)) * (anchors.length - 1);
  const i = Math.min(anchors.length - 2, Math.floor(v)), f = v - i, a = anchors[i], b = anchors[i + 1];
  return [0, 1, 2].map((k) => Math.round(a[k] + (b[k] - a[k]) * f));
}
const rgb = (c) => `rgb(${c[0]},${c[1]},${c[2]})`;
const CLASS_COLOURS = { stroke: '#1f77b4', tickle: '#d62728', push: '#2ca02c', slap: '#c020c0' };
const EXTRA_COLOURS = ['#ff7f0e', '#8c564b', '#17becf', '#7f7f7f'];
function classColour(name, index) { return CLASS_COLOURS[name] || EXTRA_COLOURS[index % EXTRA_COLOURS.length]; }

function decodeMap(b64) {  // base64 of uint8 cells -> Uint8Array (0..255 = 0..1)
  const bin = atob(b64), out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}
function fmt(x, digits = 2) { return x === null || x === undefined ? '–' : Number(x).toFixed(digits); }
function clear(el) { while (el.firstChild) el.removeChild(el.firstChild); }
// Rebuild a list only when what it shows changed, so the DOM is stable between snapshots.
function changed(el, content) {
  const key = JSON.stringify(content);
  if (el.dataset.key === key) return false;
  el.dataset.key = key;
  clear(el);
  return true;
}
function li(text, cls, data) {
  const item = document.createElement('li');
  item.textContent = text;
  if (cls) item.className = cls;
  for (const [k, v] of Object.entries(data || {})) item.dataset[k] = v;
  return item;
}

// ------------------------------------------------------------------ the bear's outline
// Shapes of one view, 200 x 290 units: [kind, region, attributes]. Regions as in config/bear_body.yaml;
// in the front view the bear's left is on the right.
function bodyShapes(front) {
  const L = (x) => (front ? x : 200 - x);  // mirror so that the bear's left is where it is seen
  return [
    ['ellipse', 'right_arm', { cx: L(38), cy: 152, rx: 14, ry: 40, transform: `rotate(${front ? 15 : -15} ${L(38)} 152)` }],
    ['ellipse', 'left_arm', { cx: L(162), cy: 152, rx: 14, ry: 40, transform: `rotate(${front ? -15 : 15} ${L(162)} 152)` }],
    ['ellipse', 'right_leg', { cx: L(75), cy: 228, rx: 20, ry: 28 }],
    ['ellipse', 'left_leg', { cx: L(125), cy: 228, rx: 20, ry: 28 }],
    ['ellipse', 'right_foot', { cx: L(72), cy: 268, rx: 23, ry: 12 }],
    ['ellipse', 'left_foot', { cx: L(128), cy: 268, rx: 23, ry: 12 }],
    ['ellipse', front ? 'torso_front' : 'torso_back', { cx: 100, cy: 160, rx: 46, ry: 60 }],
    ['ellipse', 'side_right', { cx: L(60), cy: 163, rx: 8, ry: 38 }],
    ['ellipse', 'side_left', { cx: L(140), cy: 163, rx: 8, ry: 38 }],
    ['ellipse', 'neck', { cx: 100, cy: 106, rx: 22, ry: 9 }],
    ['circle', 'head', { cx: L(60), cy: 28, r: 14 }],
    ['circle', 'head', { cx: L(140), cy: 28, r: 14 }],
    ['circle', 'head', { cx: 100, cy: 62, r: 40 }],
    ...(front ? [['ellipse', 'face', { cx: 100, cy: 80, rx: 22, ry: 19 }]] : []),
  ];
}

function svgEl(kind, attrs, parent) {
  const el = document.createElementNS(SVG_NS, kind);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  if (parent) parent.appendChild(el);
  return el;
}

function drawBear() {
  const svg = $('bear-svg');
  clear(svg);
  const views = { front: svgEl('g', { transform: 'translate(0,4)' }, svg),
                  back: svgEl('g', { transform: 'translate(220,4)' }, svg) };
  for (const [name, group] of Object.entries(views)) {
    for (const [kind, region, attrs] of bodyShapes(name === 'front')) {
      const shape = svgEl(kind, { ...attrs, class: 'body', 'data-region': region }, group);
      regionShapes.push([region, shape]);
    }
    const label = svgEl('text', { x: 100, y: 292, class: 'label' }, group);
    label.textContent = name === 'front' ? 'front (its left on your right)' : 'back';
  }
  for (const s of config.bear.sensors) {
    const dot = svgEl('circle', { cx: s.x, cy: s.y, r: s.size === 'large' ? 7.5 : 5.5, class: 'sensor',
                                  fill: rgb(LEVEL[0]), 'data-name': s.name }, views[s.view] || views.front);
    const title = svgEl('title', {}, dot);
    title.textContent = `${s.name} (${s.location}, channel ${s.channel})`;
    sensorDots.set(s.channel, { dot, title, sensor: s });
  }
}

function renderBear(bear) {
  const regions = new Set(bear.regions || []);
  for (const [region, shape] of regionShapes) shape.classList.toggle('hl', regions.has(region));
  if (bear.levels) {
    const levels = decodeMap(bear.levels), active = new Set(bear.active), faults = new Map(bear.faults);
    for (const [channel, { dot, title, sensor }] of sensorDots) {
      const level = levels[channel] / 255;
      dot.setAttribute('fill', rgb(ramp(LEVEL, level)));
      dot.classList.toggle('active', active.has(channel));
      dot.classList.toggle('fault', faults.has(channel));
      title.textContent = `${sensor.name} (${sensor.location}): level ${level.toFixed(2)}` +
        (faults.has(channel) ? ` FAULT ${faults.get(channel)}` : '');
    }
  }
  const gestures = $('bear-gestures');
  if (changed(gestures, bear.gestures.map((g) => [g.gesture, g.sensors.length]))) {
    for (const g of bear.gestures) gestures.appendChild(li(`${g.gesture} · ${g.sensors.length} sensors`, '', { gesture: g.gesture }));
    if (!bear.gestures.length) gestures.appendChild(li('none', 'none'));
  }
  const subtypes = $('bear-subtypes');
  const entries = Object.entries(bear.subtypes).sort();
  if (changed(subtypes, entries)) {
    for (const [sensor, subtype] of entries) subtypes.appendChild(li(`${subtype} on ${sensor}`, 'subtype', { subtype }));
    if (!entries.length) subtypes.appendChild(li('none', 'none'));
  }
}

// ------------------------------------------------------------------ maps
function drawMap(canvas, b64, rows, cols, outline) {
  const cells = decodeMap(b64), inside = outline ? decodeMap(outline) : null;
  const ctx = canvas.getContext('2d'), w = canvas.width / cols, h = canvas.height / rows;
  for (let r = 0; r < rows; r++) {
    for (let c = 0; c < cols; c++) {
      const i = r * cols + c;
      ctx.fillStyle = inside && !inside[i] ? '#2a2a2a' : rgb(ramp(INFERNO, cells[i] / 255));
      ctx.fillRect(c * w, r * h, Math.ceil(w), Math.ceil(h));
    }
  }
}

function renderPatch(patch) {
  if (patch.activation) drawMap($('patch-map'), patch.activation, 16, 16, patch.outline);
  const panels = $('patch-panels');
  if (changed(panels, patch.panels || [])) (patch.panels || []).forEach((contact, i) => panels.appendChild(
    li(patch.panel_names[i] || `panel ${i}`, contact ? 'contact' : '', { contact: contact ? '1' : '0' })));
  const last = $('patch-last-event');
  if (patch.last_event) {
    last.textContent = `${patch.last_event.gesture}  (p = ${fmt(patch.last_event.p, 3)}, at ${fmt(patch.last_event.t, 1)} s)`;
    last.dataset.gesture = patch.last_event.gesture;
  }
  drawPosteriors(patch.posteriors, patch.events || []);
}

function drawPosteriors(post, events) {
  const canvas = $('patch-posteriors'), ctx = canvas.getContext('2d');
  const W = canvas.width, H = canvas.height, left = 34, right = 8, top = 8, bottom = 34;
  const pw = W - left - right, ph = H - top - bottom;
  ctx.clearRect(0, 0, W, H);
  ctx.strokeStyle = '#d1d5db'; ctx.fillStyle = '#6b7280'; ctx.font = '11px sans-serif'; ctx.lineWidth = 1;
  const windowS = post ? post.window_s : 10;
  const X = (t) => left + (t + windowS) / windowS * pw, Y = (p) => top + (1 - p) * ph;
  for (const p of [0, 0.5, 1]) {
    ctx.beginPath(); ctx.moveTo(left, Y(p)); ctx.lineTo(W - right, Y(p)); ctx.stroke();
    ctx.fillText(p.toFixed(1), 6, Y(p) + 4);
  }
  for (let t = -windowS; t <= 0; t += 2) ctx.fillText(`${t} s`, X(t) - 10, H - bottom + 14);
  if (!post) { ctx.fillText('no posteriors yet (/patch/posteriors)', left + 10, top + 20); return; }
  const legend = $('posterior-legend');
  if (legend.dataset.classes !== post.classes.join()) {
    legend.dataset.classes = post.classes.join();
    legend.innerHTML = post.classes.map((c, k) =>
      `<span><i style="background:${classColour(c, k)}"></i>${c}</span>`).join('');
  }
  post.classes.forEach((name, k) => {
    ctx.strokeStyle = classColour(name, k); ctx.lineWidth = 1.6; ctx.beginPath();
    post.t.forEach((t, i) => { const y = Y(post.p[i][k] ?? 0); if (i) ctx.lineTo(X(t), y); else ctx.moveTo(X(t), y); });
    ctx.stroke();
  });
  for (const e of events) {   // the events, below the curves (the paper's ground-truth row holds the events)
    const k = post.classes.indexOf(e.gesture), x = X(e.t);
    ctx.fillStyle = classColour(e.gesture, k < 0 ? 0 : k);
    ctx.beginPath(); ctx.moveTo(x, H - bottom + 18); ctx.lineTo(x - 5, H - 2); ctx.lineTo(x + 5, H - 2); ctx.fill();
    ctx.strokeStyle = ctx.fillStyle; ctx.setLineDash([3, 3]); ctx.beginPath();
    ctx.moveTo(x, top); ctx.lineTo(x, H - bottom); ctx.stroke(); ctx.setLineDash([]);
    ctx.fillText(e.gesture, Math.min(x + 6, W - 40), H - 4);
  }
}

function renderSkin(skin) {
  const canvas = $('skin-map'), ctx = canvas.getContext('2d');
  if (skin.pressure) drawMap(canvas, skin.pressure, 12, 12, null);
  const mm = canvas.width / config.skin.side_mm;
  const trace = (points, colour, dash) => {
    if (points.length < 2) return;
    ctx.strokeStyle = colour; ctx.lineWidth = 2.5; ctx.setLineDash(dash); ctx.beginPath();
    points.forEach(([x, y], i) => (i ? ctx.lineTo(x * mm, y * mm) : ctx.moveTo(x * mm, y * mm)));
    ctx.stroke(); ctx.setLineDash([]);
  };
  trace(skin.last, '#9ca3af', [6, 4]);
  trace(skin.current, '#38bdf8', []);
  const force = skin.force || [null, null, null];
  if (skin.point && skin.point[0] !== null) {
    const [x, y] = [skin.point[0] * mm, skin.point[1] * mm];
    ctx.fillStyle = '#38bdf8'; ctx.beginPath(); ctx.arc(x, y, 5, 0, 2 * Math.PI); ctx.fill();
    if (force[0] !== null) {   // the shear force in the skin's plane, 30 px per N
      const fx = force[0] * 30, fy = force[1] * 30, len = Math.hypot(fx, fy);
      if (len > 2) {
        ctx.strokeStyle = '#f8fafc'; ctx.fillStyle = '#f8fafc'; ctx.lineWidth = 2.5; ctx.beginPath();
        ctx.moveTo(x, y); ctx.lineTo(x + fx, y + fy); ctx.stroke();
        const a = Math.atan2(fy, fx); ctx.beginPath(); ctx.moveTo(x + fx, y + fy);
        ctx.lineTo(x + fx - 9 * Math.cos(a - 0.4), y + fy - 9 * Math.sin(a - 0.4));
        ctx.lineTo(x + fx - 9 * Math.cos(a + 0.4), y + fy - 9 * Math.sin(a + 0.4)); ctx.fill();
      }
    }
  }
  $('skin-force').textContent = skin.contact
    ? `contact at (${fmt(skin.point[0], 1)}, ${fmt(skin.point[1], 1)}) mm; force (${fmt(force[0])}, ${fmt(force[1])}, ` +
      `${fmt(force[2])}) N, total normal ${fmt(skin.total_force)} N`
    : 'no contact';
  const cmd = skin.command;
  const box = $('skin-command'), detail = $('skin-command-detail');
  if (cmd && box.dataset.t !== String(cmd.t)) {
    box.textContent = cmd.command; box.dataset.command = cmd.command; box.dataset.t = String(cmd.t);
    detail.innerHTML = '';
    for (const [k, v] of [['gesture', cmd.gesture], ['recogniser', cmd.recogniser], ['distance', fmt(cmd.distance, 3)],
      ['margin', fmt(cmd.margin, 3)], ['duration', `${fmt(cmd.duration_s)} s, ${cmd.frames} frames`],
      ['at', `${fmt(cmd.t, 1)} s`]]) {
      const dt = document.createElement('dt'), dd = document.createElement('dd');
      dt.textContent = k; dd.textContent = v; dd.id = `skin-command-${k}`; detail.append(dt, dd);
    }
  }
}

// ------------------------------------------------------------------ sensors, drivers, log
function renderSensors(sensors) {
  const badges = $('sensor-badges');
  let any = false;
  for (const [name, s] of Object.entries(sensors)) {
    const card = $(`${name}-card`);
    card.hidden = !s.present;
    let badge = $(`sensor-${name}`);
    if (!s.present) { if (badge) badge.remove(); continue; }
    any = true;
    card.classList.toggle('silent', s.silent);
    const silentFor = s.age_s === null ? 'no frame yet' : `no frame for ${fmt(s.age_s, 1)} s`;
    card.querySelector('.silent-banner').textContent = `SILENT: ${silentFor}`;
    if (!badge) {
      badge = document.createElement('span');
      badge.id = `sensor-${name}`;
      badges.appendChild(badge);
    }
    badge.className = `badge ${s.silent ? 'bad' : 'ok'}`;
    badge.dataset.state = s.silent ? 'silent' : 'live';
    badge.textContent = s.silent ? `${name}: SILENT (${silentFor})` : `${name}: live`;
  }
  $('no-sensor').hidden = any;
}

function renderDrivers(drivers) {
  const body = $('drivers').tBodies[0];
  if (!changed(body, drivers.map((d) => [d.name, d.level, d.message, d.values, d.age_s > 3]))) return;
  for (const d of drivers) {
    const row = body.insertRow(), v = d.values, stale = d.age_s > 3;
    row.className = `level-${d.level}${stale ? ' stale' : ''}`;
    const state = stale ? `no report for ${fmt(d.age_s, 0)} s` : ['OK', 'WARN', 'ERROR', 'STALE'][d.level] || d.level;
    const cells = [d.name.replace(/^social_touch: /, ''), `${state}${d.message && !stale ? ': ' + d.message : ''}`,
      fmt(v.rate_hz, 1), v.frames, v.dropped_bytes, v.checksum_errors, v.sequence_gaps, v.reconnects];
    cells.forEach((text, i) => { const c = row.insertCell(); c.textContent = text ?? '–'; if (i > 1) c.className = 'num'; });
    row.title = d.hardware_id;
  }
}

function renderLog(log) {
  const list = $('log');
  const newest = log.length ? log[log.length - 1].id : 0;
  if (list.dataset.newest === String(newest)) return;
  list.dataset.newest = String(newest);
  clear(list);
  for (const e of log.slice().reverse()) {
    const item = li('', '', { source: e.source });
    item.innerHTML = `<span class="t">[${fmt(e.t, 2).padStart(8)} s]</span> <span class="src"></span> <span class="text"></span>`;
    item.querySelector('.src').textContent = e.source;
    item.querySelector('.text').textContent = e.text;
    list.appendChild(item);
  }
}

function render(state) {
  document.body.dataset.frames = String(Number(document.body.dataset.frames) + 1);
  renderSensors(state.sensors);
  const prompt = $('collect-prompt');   // a social-touch collect session's prompt, while one runs
  prompt.hidden = !state.prompt;
  prompt.textContent = state.prompt ? `collect: ${state.prompt}` : '';
  if (state.sensors.bear.present) renderBear(state.bear);
  if (state.sensors.patch.present) renderPatch(state.patch);
  if (state.sensors.skin.present) renderSkin(state.skin);
  renderDrivers(state.drivers);
  renderLog(state.log);
  $('graph-time').textContent = `graph time ${fmt(state.graph_time, 1)} s`;
  const me = state.server.clients.find((c) => c.id === clientId);
  $('client-stats').textContent = `${state.server.connected} page(s) connected` +
    (me ? `; this page: ${me.sent} frames, ${me.dropped} dropped` : '');
}

// ------------------------------------------------------------------ connection
function connect() {
  const source = new EventSource('/events');
  const status = $('connection');
  source.addEventListener('hello', (e) => { clientId = JSON.parse(e.data).client; });
  source.addEventListener('state', (e) => {
    lastFrameWall = performance.now();
    status.textContent = 'live'; status.className = 'badge ok';
    render(JSON.parse(e.data));
  });
  source.onerror = () => { status.textContent = 'view server unreachable: retrying'; status.className = 'badge bad'; };
  setInterval(() => {
    if (lastFrameWall && performance.now() - lastFrameWall > 2000 && source.readyState === EventSource.OPEN) {
      status.textContent = 'no data for 2 s'; status.className = 'badge warn';
    }
  }, 500);
}

fetch('/config.json').then((r) => r.json()).then((c) => { config = c; drawBear(); connect(); })
  .catch((err) => { $('connection').textContent = `cannot load /config.json: ${err}`; });
