// The lab's page: follows motion-web's WebSocket (/ws) and draws what it says. Every message is a
// JSON object whose "type" is lab, axis, health, event, reply, active_moves or move (see
// services/web/include/motion/web/lab_view.hpp). On each (re)connection the server starts with a
// snapshot, so the page then starts from scratch.
//
// Controls: opened with ?token=... (the address `motion-web --controls` prints), the page shows
// buttons that send commands over the same WebSocket (services/web/include/motion/web/controls.hpp);
// motion-web answers each with a command_result naming the request, whose replies then arrive
// like everyone else's.
//
// The model is kept in window.motionWeb (axes, processes, events, moves, commands) for tests and
// the console.
'use strict';

const MAX_EVENTS = 500;
const MAX_MOVES = 30;
const REDRAW_MS = 200;
const CLIENT_GONE_S = 5;
const TERMINAL = new Set(['done', 'rejected', 'aborted', 'failed']);
const COLORS = ['#1f77b4', '#d62728', '#2ca02c', '#ff7f0e', '#9467bd', '#8c564b', '#e377c2', '#17becf', '#7f7f7f', '#bcbd22'];

const model = { lab: null, axes: {}, processes: {}, events: [], requests: {}, moves: {}, messages: 0, commands: {} };
const token = new URLSearchParams(location.search).get('token');
let socket = null;
let nextTag = 1;
window.motionWeb = model;

const $ = (id) => document.getElementById(id);
const fmt = (x, digits = 3) => (typeof x === 'number' && Number.isFinite(x) ? x.toFixed(digits) : '–');
const clock = (utime) => new Date(utime / 1000).toLocaleTimeString([], { hour12: false }) +
  '.' + String(Math.floor((utime / 1000) % 1000)).padStart(3, '0');

function el(tag, attrs = {}, text) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (text !== undefined) node.textContent = text;
  return node;
}

function colorOf(axis) {
  const names = model.lab ? model.lab.axes.map((a) => a.name) : Object.keys(model.axes).sort();
  const i = names.indexOf(axis);
  return COLORS[(i < 0 ? names.length : i) % COLORS.length];
}

// --- axes ----------------------------------------------------------------------------------
function axisRow(name) {
  let row = document.querySelector(`#axes tr[data-axis="${CSS.escape(name)}"]`);
  if (row) return row;
  row = el('tr', { 'data-axis': name, 'data-updates': '0' });
  for (const cls of ['name', 'family', 'where', 'position num', 'velocity num', 'state', 'fault']) row.appendChild(el('td', { class: cls }));
  row.querySelector('.name').textContent = name;
  $('axes').tBodies[0].appendChild(row);
  return row;
}

function showLab(lab) {
  model.lab = lab;
  showControlAxes(lab);
  $('lab-file').textContent = `${lab.file} (channels ${lab.prefix}*)`;
  for (const a of lab.axes) {
    const row = axisRow(a.name);
    row.querySelector('.family').textContent = a.family;
    row.querySelector('.where').textContent = `${a.bus} / ${a.node}`;
    row.querySelector('.position').dataset.unit = a.unit;
  }
}

function showAxis(s) {
  model.axes[s.axis] = s;
  const row = axisRow(s.axis);
  row.dataset.updates = String(Number(row.dataset.updates) + 1);
  const unit = row.querySelector('.position').dataset.unit || '';
  row.querySelector('.family').textContent = s.family;
  row.querySelector('.where').textContent = `${s.bus} / ${s.node}`;
  row.querySelector('.position').textContent = `${fmt(s.position, 4)} ${unit}`;
  row.querySelector('.velocity').textContent = `${fmt(s.velocity, 3)} ${unit}/s`;
  const words = [s.online ? 'online' : 'offline', s.enabled ? 'enabled' : 'disabled'];
  if (s.moving) words.push('moving');
  if (s.in_position) words.push('in position');
  if (s.homed) words.push('homed');
  const state = row.querySelector('.state');
  state.textContent = words.join(', ');
  state.className = 'state ' + (!s.online ? 'state-bad' : s.enabled ? 'state-ok' : 'state-warn');
  const fault = row.querySelector('.fault');
  fault.textContent = s.fault ? (s.fault_text || `code ${s.fault_code}`) : '';
  fault.className = 'fault' + (s.fault ? ' state-bad' : '');
  row.classList.toggle('moving', s.moving);
  for (const move of Object.values(model.moves)) {
    if (move.open && move.axes.includes(s.axis)) {
      (move.samples[s.axis] = move.samples[s.axis] || []).push([s.sample_utime || s.utime, s.position, s.velocity]);
      move.dirty = true;
    }
  }
}

// --- processes and buses -------------------------------------------------------------------
function showHealth(h) {
  h.received = Date.now();
  model.processes[h.process] = h;
  drawProcesses();
}

function drawProcesses() {
  const now = Date.now();
  const body = $('processes').tBodies[0];
  const buses = $('buses').tBodies[0];
  body.replaceChildren();
  buses.replaceChildren();
  for (const name of Object.keys(model.processes).sort()) {
    const h = model.processes[name];
    const age = Math.max(0, now / 1000 - h.utime / 1e6);
    // Clients (motionctl, scripts) come and go: one silent for a while is gone, not lost.
    if (h.role === 'client' && age > CLIENT_GONE_S) {
      delete model.processes[name];
      continue;
    }
    const stale = age * 1000 > 3 * (h.period_ms || 500);
    const row = el('tr', { 'data-process': name });
    row.append(el('td', {}, name), el('td', {}, h.role),
      el('td', { class: h.state === 'ok' ? 'state-ok' : h.state === 'degraded' || h.state === 'starting' ? 'state-warn' : 'state-bad' }, h.state),
      el('td', { class: 'num' + (stale ? ' stale' : '') }, `${age.toFixed(1)} s`),
      el('td', { class: 'num' }, `${fmt(h.uptime_s, 0)} s`), el('td', { class: 'detail' }, h.detail));
    body.appendChild(row);
    for (const b of h.buses) {
      const bus = el('tr', { 'data-bus': b.name });
      bus.append(el('td', {}, b.name), el('td', {}, b.transport),
        el('td', { class: /off|closed|error-passive/.test(b.state) ? 'state-bad' : 'state-ok' }, b.state),
        el('td', { class: 'num' }, `${(100 * b.bus_load).toFixed(1)} %`), el('td', { class: 'num' }, `${b.tx_frames} / ${b.rx_frames}`),
        el('td', { class: 'num' + (b.errors ? ' state-bad' : '') }, String(b.errors)),
        el('td', { class: 'num' + (b.timeouts ? ' state-warn' : '') }, String(b.timeouts)),
        el('td', { class: 'num' }, String(b.retries)), el('td', { class: 'num' }, `${b.drives_online}/${b.drives_total}`));
      buses.appendChild(bus);
    }
  }
}

// --- events and requests -------------------------------------------------------------------
function showEvent(e) {
  model.events.push(e);
  const item = el('li', { class: `sev-${e.severity}`, 'data-kind': e.kind });
  item.append(el('span', { class: 'time' }, clock(e.utime)),
    el('strong', {}, `${e.kind}`), document.createTextNode(` ${e.axis || e.bus || ''} (${e.source}): ${e.text}`));
  const list = $('events');
  list.insertBefore(item, list.firstChild);
  while (list.children.length > MAX_EVENTS) list.removeChild(list.lastChild);
  if (model.events.length > MAX_EVENTS) model.events.shift();
}

function showReply(r) {
  model.requests[r.id] = r;
  let row = document.querySelector(`#requests tr[data-request="${CSS.escape(r.id)}"]`);
  if (!row) {
    row = el('tr', { 'data-request': r.id });
    for (const cls of ['time', 'id', 'axes', 'status', 'reason']) row.appendChild(el('td', { class: cls }));
    row.querySelector('.time').textContent = clock(r.utime);
    row.querySelector('.id').textContent = r.id;
    const body = $('requests').tBodies[0];
    body.insertBefore(row, body.firstChild);
    while (body.children.length > 100) body.removeChild(body.lastChild);
  }
  if (r.axes.length) row.querySelector('.axes').textContent = r.axes.join(' ');
  const status = row.querySelector('.status');
  status.textContent = r.status + (r.status === 'progress' ? ` ${Math.round(100 * r.progress)} %` : '');
  status.className = 'status ' + (r.status === 'done' ? 'state-ok' : TERMINAL.has(r.status) ? 'state-bad' : 'state-warn');
  row.querySelector('.reason').textContent = r.reason;
  drawControlStatus();
}

// --- moves ---------------------------------------------------------------------------------
// Vertical marks at a move's start and end (Chart.js has no annotation plugin in Debian).
const marksPlugin = {
  id: 'moveMarks',
  afterDatasetsDraw(chart) {
    const move = chart.config.options.plugins.moveMarks.move;
    const { ctx, chartArea, scales } = chart;
    const marks = [];
    if (move.started_utime) marks.push([move.started_utime, 'start', '#17803d']);
    if (move.started_utime && move.predicted_duration_s > 0) {
      marks.push([move.started_utime + move.predicted_duration_s * 1e6, 'planned arrival', '#6a3d9a']);
    }
    if (move.end_utime) marks.push([move.end_utime, move.status, move.status === 'done' ? '#1d2329' : '#c0262d']);
    ctx.save();
    for (const [utime, label, color] of marks) {
      const x = scales.x.getPixelForValue((utime - move.accepted_utime) / 1e6);
      if (x < chartArea.left || x > chartArea.right) continue;
      ctx.strokeStyle = color;
      ctx.fillStyle = color;
      ctx.setLineDash([4, 3]);
      ctx.beginPath();
      ctx.moveTo(x, chartArea.top);
      ctx.lineTo(x, chartArea.bottom);
      ctx.stroke();
      ctx.fillText(label, x + 3, chartArea.top + 10);
    }
    ctx.restore();
  },
};

function moveCard(move) {
  const card = el('div', { class: 'move', 'data-move-id': move.id });
  card.append(el('h3'), el('div', { class: 'chart' }));
  const canvas = el('canvas');
  card.querySelector('.chart').appendChild(canvas);
  const moves = $('moves');
  moves.insertBefore(card, moves.firstChild);
  move.chart = new Chart(canvas.getContext('2d'), {
    type: 'line',
    data: { datasets: [] },
    options: {
      animation: false,
      parsing: false,
      normalized: true,
      maintainAspectRatio: false,
      interaction: { mode: 'nearest', intersect: false },
      elements: { point: { radius: 0 }, line: { borderWidth: 1.5 } },
      scales: {
        x: { type: 'linear', title: { display: true, text: 's since accepted' } },
        y: { position: 'left', title: { display: true, text: 'position' } },
        v: { position: 'right', title: { display: true, text: 'velocity' }, grid: { drawOnChartArea: false } },
      },
      plugins: { moveMarks: { move }, legend: { labels: { boxWidth: 12 } } },
    },
    plugins: [marksPlugin],
  });
  return card;
}

function drawMove(move) {
  const card = document.querySelector(`#moves .move[data-move-id="${CSS.escape(move.id)}"]`) || moveCard(move);
  card.dataset.status = move.status;
  const end = move.end_utime ? `, ${((move.end_utime - (move.started_utime || move.accepted_utime)) / 1e6).toFixed(2)} s` : '';
  const phase = move.open && move.phase ? `, ${move.phase}` : '';
  card.querySelector('h3').textContent = `${move.kind} ${move.axes.join(' ')}: ${move.status}${phase}${end} (${move.id})` +
    (move.reason ? ` – ${move.reason}` : '');
  const t0 = move.accepted_utime;
  const sets = [];
  move.axes.forEach((axis, i) => {
    const points = move.samples[axis] || [];
    const color = colorOf(axis);
    sets.push({ label: `${axis} position`, axis, yAxisID: 'y', borderColor: color, backgroundColor: color,
      data: points.map((p) => ({ x: (p[0] - t0) / 1e6, y: p[1] })) });
    sets.push({ label: `${axis} velocity`, axis, yAxisID: 'v', borderColor: color, backgroundColor: color, borderDash: [6, 3],
      data: points.map((p) => ({ x: (p[0] - t0) / 1e6, y: p[2] })) });
    if (move.targets.length === move.axes.length && points.length) {
      const last = Math.max((points[points.length - 1][0] - t0) / 1e6, move.end_utime ? (move.end_utime - t0) / 1e6 : 0);
      sets.push({ label: `${axis} target`, axis, yAxisID: 'y', borderColor: color, backgroundColor: color, borderDash: [2, 2],
        borderWidth: 1, data: [{ x: 0, y: move.targets[i] }, { x: last, y: move.targets[i] }] });
    }
  });
  move.chart.data.datasets = sets;
  move.chart.update('none');
  move.dirty = false;
}

function showMove(m) {
  let move = model.moves[m.id];
  if (!move) {
    move = model.moves[m.id] = { samples: {} };
    const ids = Object.keys(model.moves);
    if (ids.length > MAX_MOVES) {
      const oldest = ids.sort((a, b) => model.moves[a].accepted_utime - model.moves[b].accepted_utime)[0];
      model.moves[oldest].chart?.destroy();
      document.querySelector(`#moves .move[data-move-id="${CSS.escape(oldest)}"]`)?.remove();
      delete model.moves[oldest];
    }
  }
  const samples = m.samples || move.samples;
  delete m.samples;
  Object.assign(move, m, { samples });
  drawMove(move);
}

// The coordinator's phase of each open move (arming: loading the drives; moving: triggered).
function showActiveMoves(m) {
  model.active_moves = m;
  for (const move of Object.values(model.moves)) {
    const row = m.rows.find((r) => r.id === move.id);
    const phase = row ? row.phase : '';
    if (phase !== move.phase) {
      move.phase = phase;
      move.dirty = true;
    }
  }
}

// --- controls ------------------------------------------------------------------------------
function showControlAxes(lab) {
  const box = $('control-axes');
  if (box.children.length) return;  // kept across reconnections, with what the user typed
  for (const a of lab.axes) {
    const label = el('label', { 'data-axis': a.name });
    label.append(el('input', { type: 'checkbox', class: 'pick' }), document.createTextNode(` ${a.name} `),
      el('input', { type: 'number', step: 'any', value: '0', class: 'value', title: `${a.name} (${a.unit})` }),
      document.createTextNode(` ${a.unit}`));
    box.appendChild(label);
  }
}

// Sends one command; ESTOP always stops every axis, STOP every axis when none is ticked.
function sendCommand(kind) {
  const picked = [...document.querySelectorAll('#control-axes label')].filter((l) => l.querySelector('.pick').checked);
  const axes = kind === 'ESTOP' ? [] : picked.map((l) => l.dataset.axis);
  const command = { type: 'command', token, tag: nextTag++, kind, axes };
  if (['MOVE_ABSOLUTE', 'MOVE_RELATIVE', 'JOG'].includes(kind)) {
    command.values = picked.map((l) => Number(l.querySelector('.value').value));
    command.velocity_scale = Number($('control-speed').value);
  }
  model.commands[command.tag] = { kind, axes, sent: Date.now() };
  if (!socket || socket.readyState !== WebSocket.OPEN) {
    Object.assign(model.commands[command.tag], { ok: false, error: 'not connected to motion-web' });
  } else {
    socket.send(JSON.stringify(command));
  }
  drawControlStatus();
}

function showCommandResult(r) {
  const command = model.commands[r.tag];
  if (command) Object.assign(command, { ok: r.ok, id: r.id, error: r.error });
  else model.commands[`unmatched-${Date.now()}`] = { kind: '?', axes: [], ok: r.ok, id: r.id, error: r.error };
  drawControlStatus();
}

// The last command: refused by motion-web, or its request's latest status from the coordinator.
function drawControlStatus() {
  const tags = Object.keys(model.commands);
  if (!tags.length) return;
  const c = model.commands[tags[tags.length - 1]];
  const line = $('control-status');
  const what = `${c.kind.toLowerCase()} ${c.axes.join(' ') || 'all axes'}`;
  let text; let cls;
  if (c.ok === false) {
    [text, cls] = [`${what}: refused by motion-web: ${c.error}`, 'state-bad'];
  } else if (!c.id) {
    [text, cls] = [`${what}: sent…`, 'state-warn'];
  } else {
    const r = model.requests[c.id];
    const status = r ? r.status : 'sent';
    [text, cls] = [`${what}: ${status} (${c.id})${r && r.reason ? ' – ' + r.reason : ''}`,
      status === 'done' ? 'state-ok' : TERMINAL.has(status) ? 'state-bad' : 'state-warn'];
  }
  line.textContent = text;
  line.className = cls;
  line.dataset.status = c.ok === false ? 'refused' : (c.id && model.requests[c.id] ? model.requests[c.id].status : 'sent');
  line.dataset.request = c.id || '';
}

function setUpControls() {
  if (!token) return;
  $('controls-section').hidden = false;
  $('mode').textContent = 'controls on';
  for (const button of document.querySelectorAll('#controls-section button[data-kind]')) {
    button.addEventListener('click', () => sendCommand(button.dataset.kind));
  }
}

// --- connection ----------------------------------------------------------------------------
function reset() {
  for (const move of Object.values(model.moves)) move.chart?.destroy();
  Object.assign(model, { lab: null, axes: {}, processes: {}, events: [], requests: {}, moves: {}, messages: 0 });  // commands kept
  for (const id of ['axes', 'processes', 'buses', 'requests']) $(id).tBodies[0].replaceChildren();
  $('events').replaceChildren();
  $('moves').replaceChildren();
}

const handlers = {
  lab: showLab,
  axis: showAxis,
  health: showHealth,
  event: showEvent,
  reply: showReply,
  move: showMove,
  active_moves: showActiveMoves,
  command_result: showCommandResult,
};

function connect() {
  const ws = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  socket = ws;
  const status = $('connection');
  ws.onopen = () => {
    reset();
    status.textContent = 'live';
    status.className = 'state-ok';
  };
  ws.onmessage = (msg) => {
    const m = JSON.parse(msg.data);
    model.messages += 1;
    const handler = handlers[m.type];
    if (handler) handler(m);
  };
  ws.onclose = () => {
    status.textContent = 'disconnected: reconnecting…';
    status.className = 'state-bad';
    setTimeout(connect, 1000);
  };
}

setInterval(() => {
  for (const move of Object.values(model.moves)) if (move.dirty) drawMove(move);
  drawProcesses();
}, REDRAW_MS);
setUpControls();
connect();
