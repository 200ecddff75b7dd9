// mocapd's web view: camera images with the projected outline, the 3D view (three.js r111 from
// Debian's libjs-three), the status table and the controls. Poses arrive as server-sent events.
'use strict';

const OUTLINE = '#ff00ff';
let token = sessionStorage.getItem('mocapd-token') || '';
let scene = null;
let latestPose = null;
const cameraViews = [];

function withToken(url) {
  if (!token) return url;
  return url + (url.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(token);
}

// Fetches, asking once for the daemon's bearer token when it answers 401.
async function api(url, options = {}) {
  options.headers = Object.assign({}, options.headers || {});
  if (token) options.headers['Authorization'] = 'Bearer ' + token;
  let response = await fetch(url, options);
  if (response.status === 401) {
    token = window.prompt('This daemon needs its access token:') || '';
    sessionStorage.setItem('mocapd-token', token);
    options.headers['Authorization'] = 'Bearer ' + token;
    response = await fetch(url, options);
  }
  return response;
}

// Draws the camera's newest image and the outline over it; `view.shows` says what the canvas
// shows now (the browser test waits for both).
function drawCamera(view) {
  const ctx = view.canvas.getContext('2d');
  view.shows = { image: view.image !== null, outline: false };
  if (view.shows.image) {
    ctx.drawImage(view.image, 0, 0, view.canvas.width, view.canvas.height);
  } else {
    ctx.fillStyle = '#000';
    ctx.fillRect(0, 0, view.canvas.width, view.canvas.height);
  }
  if (!latestPose || !latestPose.projected[view.index]) return;
  view.shows.outline = true;
  const pixels = latestPose.projected[view.index];
  ctx.strokeStyle = OUTLINE;
  ctx.fillStyle = OUTLINE;
  ctx.lineWidth = Math.max(4, view.canvas.width / 130);
  ctx.beginPath();
  for (const [a, b] of latestPose.lines) {
    if (!pixels[a] || !pixels[b]) continue;
    ctx.moveTo(pixels[a][0], pixels[a][1]);
    ctx.lineTo(pixels[b][0], pixels[b][1]);
  }
  ctx.stroke();
  for (const p of pixels) {
    if (!p) continue;
    ctx.beginPath();
    ctx.arc(p[0], p[1], ctx.lineWidth * 1.2, 0, 2 * Math.PI);
    ctx.fill();
  }
}

// Each camera's image is fetched again once the last one arrived: a slow browser asks less. The
// canvas keeps showing the last image while the next one loads.
function refreshImage(view) {
  const next = new Image();
  next.onload = () => {
    view.image = next;
    drawCamera(view);
    setTimeout(() => refreshImage(view), 200);
  };
  next.onerror = () => setTimeout(() => refreshImage(view), 500);
  next.src = withToken('/api/camera/' + view.index + '.jpg?t=' + Date.now());
}

function makeCameraViews() {
  const box = document.getElementById('cameras');
  for (const camera of scene.cameras) {
    const div = document.createElement('div');
    div.className = 'camera';
    const canvas = document.createElement('canvas');
    canvas.width = camera.width;
    canvas.height = camera.height;
    const label = document.createElement('div');
    label.className = 'small';
    label.textContent = 'camera ' + camera.index + ': ' + camera.name;
    div.appendChild(canvas);
    div.appendChild(label);
    box.appendChild(div);
    const view = { index: camera.index, canvas: canvas, image: null };
    cameraViews.push(view);
    refreshImage(view);
  }
}

const world = {};

function makeWorld() {
  const canvas = document.getElementById('world');
  world.renderer = new THREE.WebGLRenderer({ canvas: canvas, antialias: true,
                                             preserveDrawingBuffer: true });
  world.scene = new THREE.Scene();
  world.scene.background = new THREE.Color(0x202428);
  const half = scene.floor_half_size;
  world.camera = new THREE.PerspectiveCamera(50, canvas.width / canvas.height, 0.01, 100);
  world.camera.up.set(0, 0, 1);  // the daemon's world frame: Z up
  world.camera.position.set(half * 1.6, -half * 1.6, half * 1.2);
  world.controls = new THREE.OrbitControls(world.camera, canvas);
  world.controls.target.set(0, 0, 0.5);
  world.controls.update();
  const grid = new THREE.GridHelper(2 * half, Math.round(4 * half), 0x888888, 0x444444);
  grid.rotation.x = Math.PI / 2;  // GridHelper lies in XZ; the floor is XY
  world.scene.add(grid);
  world.scene.add(new THREE.AxesHelper(0.3));
  const frustum = new THREE.LineBasicMaterial({ color: 0x66ccff });
  for (const camera of scene.cameras) {
    const c = new THREE.Vector3(...camera.center);
    const corners = camera.corner_rays.map(r => new THREE.Vector3(...r).multiplyScalar(0.6).add(c));
    const points = [];
    for (let i = 0; i < 4; ++i) points.push(c, corners[i], corners[i], corners[(i + 1) % 4]);
    const geometry = new THREE.BufferGeometry().setFromPoints(points);
    world.scene.add(new THREE.LineSegments(geometry, frustum));
  }
  world.skeleton = new THREE.LineSegments(new THREE.BufferGeometry(),
                                          new THREE.LineBasicMaterial({ color: 0xff00ff }));
  world.joints = new THREE.Points(new THREE.BufferGeometry(),
                                  new THREE.PointsMaterial({ color: 0xffffff, size: 0.03 }));
  world.scene.add(world.skeleton);
  world.scene.add(world.joints);
  world.controls.addEventListener('change', renderWorld);
  renderWorld();
}

// Renders once at the next frame, when the pose or the viewpoint changed: an idle view costs
// nothing (software WebGL renders at a CPU's cost).
function renderWorld() {
  if (world.renderPending) return;
  world.renderPending = true;
  requestAnimationFrame(() => {
    world.renderPending = false;
    world.renderer.render(world.scene, world.camera);
  });
}

function showPose(pose) {
  latestPose = pose;
  for (const view of cameraViews) drawCamera(view);
  if (!world.skeleton) return;
  const points = [];
  for (const [a, b] of pose.lines) points.push(new THREE.Vector3(...pose.points[a]),
                                               new THREE.Vector3(...pose.points[b]));
  world.skeleton.geometry.dispose();
  world.skeleton.geometry = new THREE.BufferGeometry().setFromPoints(points);
  world.joints.geometry.dispose();
  world.joints.geometry = new THREE.BufferGeometry().setFromPoints(
      pose.points.map(p => new THREE.Vector3(...p)));
  renderWorld();
}

function streamPoses() {
  const events = new EventSource(withToken('/api/poses'));
  events.onmessage = (event) => showPose(JSON.parse(event.data));
}

function cell(row, text, header) {
  const td = document.createElement(header ? 'th' : 'td');
  td.textContent = text;
  row.appendChild(td);
}

function fixed(value, digits) { return value === null || value === undefined ? '-' : value.toFixed(digits); }

async function refreshStatus() {
  try {
    const response = await api('/api/status');
    if (response.ok) {
      const s = await response.json();
      const fit = latestPose ? fixed(latestPose.silhouette_fit, 3) : '-';
      document.getElementById('summary').textContent =
          `${s.mode}, ${s.tracking ? 'tracking' : 'searching: ' + s.search_failure} at ` +
          `${s.tracker_fps.toFixed(1)} poses/s, silhouette fit ${fit}, latency p50 ` +
          `${s.latency_ms.p50.toFixed(1)} ms p99 ${s.latency_ms.p99.toFixed(1)} ms, ` +
          `${s.losses} losses, ${s.acquisitions} acquisitions, sets skipped ` +
          `${s.frame_sets_skipped}` +
          (s.recording.active ? `, recording ${s.recording.path}` : '') +
          (s.stage_latency_ms.length ? '; by stage (p50/p99 ms) ' +
                   s.stage_latency_ms.map(t => `${t.stage} ${t.p50.toFixed(1)}/${t.p99.toFixed(1)}`)
                       .join(', ') :
                                       '');
      const table = document.getElementById('camera-status');
      table.textContent = '';
      const head = table.insertRow();
      for (const h of ['camera', 'fps', 'received', 'dropped', 'lost by driver', 'silhouettes'])
        cell(head, h, true);
      for (const c of s.cameras) {
        const row = table.insertRow();
        cell(row, c.index + ' ' + c.driver);
        cell(row, c.fps.toFixed(1));
        cell(row, c.frames_received);
        cell(row, c.dropped);
        cell(row, c.lost_by_driver);
        cell(row, c.silhouettes);
      }
    }
  } finally {
    setTimeout(refreshStatus, 1000);
  }
}

function wireControls() {
  for (const button of document.querySelectorAll('button[data-post]')) {
    button.onclick = async () => {
      const message = document.getElementById('message');
      message.textContent = button.textContent + '...';
      const response = await api(button.dataset.post, { method: 'POST' });
      const body = await response.json().catch(() => ({}));
      message.textContent = button.textContent + ': ' + (response.ok ? 'done' : 'refused') +
          (body.message ? ' (' + body.message + ')' : '');
    };
  }
}

async function main() {
  wireControls();
  const response = await api('/api/scene');
  scene = await response.json();
  makeCameraViews();
  try {
    makeWorld();
  } catch (error) {
    document.getElementById('message').textContent = '3D view unavailable: ' + error;
  }
  streamPoses();
  refreshStatus();
}

main();
