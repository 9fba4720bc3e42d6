// The console page: state arrives as JSON over the WebSocket (5 Hz), frames
// are fetched as JPEG when the state names a new one (never more than one
// request in flight per camera), buttons send {"command": VERB}.
'use strict';

const $ = (id) => document.getElementById(id);
let socket = null;

function connect() {
  socket = new WebSocket(`ws://${location.host}/ws`);
  socket.onopen = () => {
    $('link').textContent = 'live';
    $('link').className = 'ok';
  };
  socket.onclose = () => {
    $('link').textContent = 'console unreachable, retrying';
    $('link').className = 'bad';
    setTimeout(connect, 1000);
  };
  socket.onmessage = (ev) => {
    const s = JSON.parse(ev.data);
    if (s.error) {
      showAck({verb: '?', state: 'refused', detail: 'console: ' + s.error});
      return;
    }
    render(s);
  };
}

document.querySelectorAll('button[data-command]').forEach((b) => {
  b.addEventListener('click', () => {
    if (!socket || socket.readyState !== WebSocket.OPEN) {
      showAck({verb: b.dataset.command, state: 'failed', detail: 'not connected to the console'});
      return;
    }
    socket.send(JSON.stringify({command: b.dataset.command}));
    showAck({verb: b.dataset.command, state: 'waiting', detail: ''});
  });
});

function showAck(c) {
  const el = $('ack');
  if (!c) return;
  const cls = c.state === 'accepted' ? 'accepted' :
      c.state === 'waiting'          ? 'waiting' :
      c.state === 'refused'          ? 'refused' :
                                       'failed';
  el.className = cls;
  el.dataset.verb = c.verb;
  el.dataset.state = c.state;
  el.textContent = `${c.verb}: ${c.state}` + (c.detail ? ` — ${c.detail}` : '');
}

const fmt = (x, d = 3) => (x === null || x === undefined ? '–' : Number(x).toFixed(d));

function render(s) {
  const h = s.harvest;
  $('h-state').textContent = h ? h.state : 'no controller heard';
  $('h-flags').textContent = h ? (h.estop ? 'E-STOP ' : '') + (h.paused ? 'paused' : '') : '';
  $('h-flags').className = h && h.estop ? 'bad' : '';
  for (const [id, key] of [
           ['h-picked', 'picked'], ['h-lost', 'lost'], ['h-unreachable', 'unreachable'], ['h-failed', 'failed_grasp'],
           ['h-remaining', 'remaining']])
    $(id).textContent = h ? h[key] : '–';
  $('h-summary').textContent = h ? h.summary : '';

  const r = s.robot;
  $('r-mode').textContent = r ? r.mode : 'no robot state';
  $('r-speed').textContent = r ? fmt(r.speed_mps) : '–';
  $('r-pos').textContent = r ? r.tool_position.map((v) => fmt(v)).join(', ') : '–';
  $('r-fault').textContent = r ? r.fault_text : '';
  $('ir').textContent = s.ir ? `${fmt(s.ir.range_m)} m ${s.ir.validity}` : '–';
  $('grip').textContent = s.gripper ? `${s.gripper.state} ${fmt(s.gripper.position, 2)}` : '–';

  if (s.command) showAck(s.command);
  renderProcesses(s.processes);
  for (const name of ['fixed', 'hand']) renderCamera(name, (s.cameras || {})[name]);
}

function renderProcesses(list) {
  const body = $('proc-table').querySelector('tbody');
  body.replaceChildren();
  for (const p of list) {
    const tr = document.createElement('tr');
    tr.className = p.silent ? 'silent' : '';
    tr.dataset.instance = p.instance;
    const state = p.silent ? 'SILENT' : p.state;
    for (const text of [p.host, p.instance, p.process, p.pid, state, p.message, `${fmt(p.age_s, 1)} s ago`]) {
      const td = document.createElement('td');
      td.textContent = text;
      tr.appendChild(td);
    }
    tr.children[4].className = state === 'OK' ? 'ok' : state === 'DEGRADED' || state === 'STARTING' ? 'warn' : 'bad';
    body.appendChild(tr);
  }
}

const loading = {};
const shownSeq = {};
function renderCamera(name, cam) {
  const img = $('img-' + name);
  if (cam && cam.frame && cam.frame.seq !== shownSeq[name] && !loading[name]) {
    loading[name] = true;
    const seq = cam.frame.seq;
    img.onload = img.onerror = () => {
      loading[name] = false;
      shownSeq[name] = seq;
    };
    img.src = `/camera/${name}.jpg?seq=${seq}`;
  }
  $('cap-' + name).textContent =
      cam && cam.frame ? `frame ${cam.frame.seq}, ${fmt(cam.frame.age_s, 1)} s old` : 'no frame';
  drawDetections($('ov-' + name), cam);
}

// Boxes are in sensor pixels; the frame shows the region roi of the sensor.
function drawDetections(canvas, cam) {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  canvas.width = w;
  canvas.height = h;
  const g = canvas.getContext('2d');
  g.clearRect(0, 0, w, h);
  if (!cam || !cam.detections || !cam.frame) return;
  const roi = cam.frame.roi[2] > 0 ? cam.frame.roi : [0, 0, cam.frame.sensor_width, cam.frame.sensor_height];
  const sx = w / roi[2], sy = h / roi[3];
  for (const f of cam.detections.fruits) {
    const [x, y, bw, bh] = f.bbox;
    g.lineWidth = f.selected ? 3 : 1.5;
    g.strokeStyle = f.selected ? '#0f0' : '#ff0';
    g.strokeRect((x - roi[0]) * sx, (y - roi[1]) * sy, bw * sx, bh * sy);
    if (f.selected) {
      g.fillStyle = '#0f0';
      g.font = '14px sans-serif';
      g.fillText(`target ${f.id}`, (x - roi[0]) * sx, (y - roi[1]) * sy - 3);
    }
  }
}

connect();
