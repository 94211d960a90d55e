// The octoarm viewer page: replays a recorded run (or a sweep's / results folder's runs) and
// shows a running simulation live. Rods are tapered tubes with their rest radii, coloured plain
// or by a strain component or muscle activation; obstacles, targets and the desired shape are
// drawn when the run has them; a time slider, play / pause / speed / stepping and the run's
// scalar series (plotted below, synced to the slider). Every asset comes from the local server.
import * as THREE from './vendor/three.js';

const $ = (id) => document.getElementById(id);
const TUBE = new THREE.Color(0x7b3fc4);      // the rods' plain colour (purple)
const RING = 14;                              // vertices around a tube
const state = {
  mode: null,            // 'replay' | 'live'
  scene: null,           // rods, obstacles, targets from scenario.toml
  rods: [],              // per rod: name, prefix, n, radius, meshes
  frames: [],            // per frame: { t, rods: [{ position, director, sigma, kappa, act, desired, target }] }
  series: [],            // [{ name, unit, t: Float32Array, lines: [{ label, v, colour }] }]
  extra: {},             // series.npz members by name
  index: 0, playing: false, speed: 1, simTime: 0,
  colour: 'plain', ranges: {},
  live: { frames: 0, last: null, status: null, planned: 0, duration: null, steps: [] },
  rendered: 0, follow: true, extent: 0.2, planar: true, tipPaths: [],
};

// --- three.js scene ---------------------------------------------------------------------
const view = $('view');
let renderer;
try {
  renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
} catch (e) {
  showMessage('WebGL is not available in this browser: ' + e.message);
  throw e;
}
renderer.setPixelRatio(window.devicePixelRatio || 1);
renderer.setClearColor(0xffffff);
renderer.domElement.className = 'gl';
view.appendChild(renderer.domElement);
const scene3 = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(35, 1, 1e-4, 100);
const controls = new THREE.OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
scene3.add(new THREE.HemisphereLight(0xffffff, 0x888888, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.4);
scene3.add(sun);
const world = new THREE.Group();
scene3.add(world);
let grid = null;

function resize() {
  const w = view.clientWidth, h = view.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
  drawPlots();
}
window.addEventListener('resize', resize);

function showMessage(text, info = false) {
  const m = $('message');
  m.textContent = text;
  m.className = info ? 'info' : '';
  m.hidden = !text;
}

// --- binary messages (see crates/viewer/src/blob.rs) --------------------------------------
function parseBlob(buffer) {
  const len = new DataView(buffer).getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, len)));
  const data = new Float32Array(buffer, 4 + len);
  const arrays = {};
  for (const a of header.arrays) {
    const size = a.shape.reduce((p, q) => p * q, 1);
    arrays[a.name] = { shape: a.shape, data: data.subarray(a.offset, a.offset + size) };
  }
  return { header, arrays };
}

// --- rods -------------------------------------------------------------------------------
// Rods are found from the arrays: `<prefix>position` with shape [.., n + 1, 3]; a lone rod has
// the plain names (prefix ''), a system `<name>/position`.
function rodPrefixes(names) {
  return names.filter((k) => k.endsWith('position') && !k.endsWith('desired_position'))
    .map((k) => k.slice(0, -'position'.length))
    .filter((p) => p === '' || p.endsWith('/'));
}

function setupRods(prefixes, shapes) {
  for (const r of state.rods) world.remove(r.group);
  state.rods = [];
  const sceneRods = (state.scene && state.scene.rods) || [];
  prefixes.forEach((prefix, i) => {
    const shape = shapes[prefix];
    const n = shape[shape.length - 2] - 1;
    const name = prefix ? prefix.slice(0, -1) : (sceneRods[0] && sceneRods[0].name) || 'rod';
    const spec = sceneRods.find((r) => r.name === name) || (prefixes.length === 1 ? sceneRods[0] : null);
    let radius = spec && spec.radius && spec.radius.length === n ? Float32Array.from(spec.radius) : null;
    const group = new THREE.Group();
    const geometry = tubeGeometry(n);
    const mesh = new THREE.Mesh(geometry, new THREE.MeshPhongMaterial({ vertexColors: true, shininess: 25, side: THREE.DoubleSide }));
    group.add(mesh);
    const frameGeom = new THREE.BufferGeometry();
    frameGeom.setAttribute('position', new THREE.BufferAttribute(new Float32Array(n * 4 * 3), 3));
    const frameColours = new Float32Array(n * 4 * 3);
    for (let j = 0; j < n; j++) {
      frameColours.set([0.9, 0.55, 0.1, 0.9, 0.55, 0.1, 0.1, 0.65, 0.75, 0.1, 0.65, 0.75], j * 12);
    }
    frameGeom.setAttribute('color', new THREE.BufferAttribute(frameColours, 3));
    const frameLines = new THREE.LineSegments(frameGeom, new THREE.LineBasicMaterial({ vertexColors: true }));
    frameLines.visible = false;
    group.add(frameLines);
    const desiredGeom = new THREE.BufferGeometry();
    desiredGeom.setAttribute('position', new THREE.BufferAttribute(new Float32Array((n + 1) * 3), 3));
    const desired = new THREE.Line(desiredGeom, new THREE.LineBasicMaterial({ color: 0x22a03c }));
    desired.visible = false;
    group.add(desired);
    const pathGeom = new THREE.BufferGeometry();
    const path = new THREE.Line(pathGeom, new THREE.LineBasicMaterial({ color: 0xaaaaaa }));
    group.add(path);
    world.add(group);
    state.rods.push({ name, prefix, n, radius, group, mesh, frameLines, desired, path, length: spec && spec.length });
  });
}

// A tube of n + 1 rings of RING vertices, closed by a cap at each end.
function tubeGeometry(n) {
  const g = new THREE.BufferGeometry();
  const verts = (n + 1) * RING + 2;
  g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(verts * 3), 3));
  g.setAttribute('normal', new THREE.BufferAttribute(new Float32Array(verts * 3), 3));
  g.setAttribute('color', new THREE.BufferAttribute(new Float32Array(verts * 3), 3));
  const idx = [];
  for (let i = 0; i < n; i++) {
    for (let k = 0; k < RING; k++) {
      const a = i * RING + k, b = i * RING + (k + 1) % RING, c = a + RING, d = b + RING;
      idx.push(a, c, b, b, c, d);
    }
  }
  const c0 = (n + 1) * RING, c1 = c0 + 1;
  for (let k = 0; k < RING; k++) {
    idx.push(c0, k, (k + 1) % RING);
    idx.push(c1, n * RING + (k + 1) % RING, n * RING + k);
  }
  g.setIndex(idx);
  return g;
}

function sub(a, i, b, j) { return [a[3 * i] - b[3 * j], a[3 * i + 1] - b[3 * j + 1], a[3 * i + 2] - b[3 * j + 2]]; }
function norm(v) { const l = Math.hypot(v[0], v[1], v[2]) || 1; return [v[0] / l, v[1] / l, v[2] / l]; }
function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

function nodeRadius(rod, i) {
  const n = rod.n;
  const r = rod.radius || defaultRadius(rod);
  if (i === 0) return r[0];
  if (i === n) return r[n - 1];
  return 0.5 * (r[i - 1] + r[i]);
}

function defaultRadius(rod) {
  if (!rod.fallback) rod.fallback = new Float32Array(rod.n).fill(0.01 * (rod.length || state.extent));
  return rod.fallback;
}

// Update a rod's tube from node positions x [(n + 1) * 3] and, if given, directors [n * 9]
// (rows d1, d2, d3): the rings lie in the plane of d1, d2 (so the tube turns with the material
// frame), else in a frame transported along the centreline.
function updateTube(rod, x, director, colours) {
  const n = rod.n;
  const g = rod.mesh.geometry;
  const P = g.attributes.position.array, N = g.attributes.normal.array, C = g.attributes.color.array;
  let prevU = null;
  for (let i = 0; i <= n; i++) {
    const t = norm(i === 0 ? sub(x, 1, x, 0) : i === n ? sub(x, n, x, n - 1) : sub(x, i + 1, x, i - 1));
    let u;
    if (director) {
      const j0 = Math.max(0, i - 1), j1 = Math.min(n - 1, i);
      u = [director[9 * j0] + director[9 * j1], director[9 * j0 + 1] + director[9 * j1 + 1], director[9 * j0 + 2] + director[9 * j1 + 2]];
    } else if (prevU) {
      u = prevU;
    } else {
      u = Math.abs(t[2]) < 0.9 ? [0, 0, 1] : [1, 0, 0];
    }
    const d = dot(u, t);
    u = norm([u[0] - d * t[0], u[1] - d * t[1], u[2] - d * t[2]]);
    if (!Number.isFinite(u[0])) u = [0, 0, 1];
    prevU = u;
    const v = cross(t, u);
    const r = nodeRadius(rod, i);
    const col = colours ? colours[i] : TUBE;
    for (let k = 0; k < RING; k++) {
      const a = (2 * Math.PI * k) / RING, ca = Math.cos(a), sa = Math.sin(a);
      const nx = ca * u[0] + sa * v[0], ny = ca * u[1] + sa * v[1], nz = ca * u[2] + sa * v[2];
      const o = 3 * (i * RING + k);
      P[o] = x[3 * i] + r * nx; P[o + 1] = x[3 * i + 1] + r * ny; P[o + 2] = x[3 * i + 2] + r * nz;
      N[o] = nx; N[o + 1] = ny; N[o + 2] = nz;
      C[o] = col.r; C[o + 1] = col.g; C[o + 2] = col.b;
    }
    if (i === 0 || i === n) {
      const o = 3 * ((n + 1) * RING + (i === 0 ? 0 : 1));
      const s = i === 0 ? -1 : 1;
      P[o] = x[3 * i]; P[o + 1] = x[3 * i + 1]; P[o + 2] = x[3 * i + 2];
      N[o] = s * t[0]; N[o + 1] = s * t[1]; N[o + 2] = s * t[2];
      C[o] = col.r; C[o + 1] = col.g; C[o + 2] = col.b;
    }
  }
  g.attributes.position.needsUpdate = true;
  g.attributes.normal.needsUpdate = true;
  g.attributes.color.needsUpdate = true;
  g.computeBoundingSphere();
  // Material frame: d1 and d2 from each element's centre, 3 radii long.
  if (director && rod.frameLines.visible) {
    const F = rod.frameLines.geometry.attributes.position.array;
    for (let j = 0; j < n; j++) {
      const c = [0.5 * (x[3 * j] + x[3 * j + 3]), 0.5 * (x[3 * j + 1] + x[3 * j + 4]), 0.5 * (x[3 * j + 2] + x[3 * j + 5])];
      const l = 3 * (rod.radius ? rod.radius[j] : defaultRadius(rod)[j]);
      for (let q = 0; q < 2; q++) {
        const o = 12 * j + 6 * q;
        F.set([c[0], c[1], c[2], c[0] + l * director[9 * j + 3 * q], c[1] + l * director[9 * j + 3 * q + 1], c[2] + l * director[9 * j + 3 * q + 2]], o);
      }
    }
    rod.frameLines.geometry.attributes.position.needsUpdate = true;
    rod.frameLines.geometry.computeBoundingSphere();
  }
}

// --- colouring --------------------------------------------------------------------------
const VIRIDIS = [[68, 1, 84], [65, 68, 135], [42, 120, 142], [34, 168, 132], [122, 209, 81], [253, 231, 37]];
function viridis(u) {
  const x = Math.min(Math.max(u, 0), 1) * (VIRIDIS.length - 1);
  const i = Math.min(Math.floor(x), VIRIDIS.length - 2), f = x - i;
  const c = VIRIDIS[i].map((a, k) => (a + f * (VIRIDIS[i + 1][k] - a)) / 255);
  return new THREE.Color(c[0], c[1], c[2]);
}
function diverging(u) { // u in [-1, 1]: blue - white - red
  const a = Math.min(Math.max(u, -1), 1);
  return a < 0 ? new THREE.Color(1 + a * 0.8, 1 + a * 0.6, 1) : new THREE.Color(1, 1 - a * 0.6, 1 - a * 0.8);
}
const COLOURINGS = {
  bend: { signed: false, unit: '1/m', of: (f) => f.kappa && perNode(f.kappa, 'interior', (v, k) => Math.hypot(v[3 * k], v[3 * k + 1])) },
  twist: { signed: true, unit: '1/m', of: (f) => f.kappa && perNode(f.kappa, 'interior', (v, k) => v[3 * k + 2]) },
  stretch: { signed: true, unit: '', of: (f) => f.sigma && perNode(f.sigma, 'element', (v, k) => v[3 * k + 2]) },
  shear: { signed: false, unit: '', of: (f) => f.sigma && perNode(f.sigma, 'element', (v, k) => Math.hypot(v[3 * k], v[3 * k + 1])) },
  activation: { signed: false, unit: '', of: (f) => f.act && activationPerNode(f) },
};
// A per-element (n values) or per-interior-node (n - 1 values) quantity at the n + 1 nodes.
function perNode(v, domain, get) {
  const m = v.length / 3;
  const n = domain === 'element' ? m : m + 1;
  const out = new Float32Array(n + 1);
  for (let i = 0; i <= n; i++) {
    if (domain === 'element') {
      out[i] = i === 0 ? get(v, 0) : i === n ? get(v, n - 1) : 0.5 * (get(v, i - 1) + get(v, i));
    } else {
      out[i] = get(v, Math.min(Math.max(i - 1, 0), m - 1));
    }
  }
  return out;
}
// Muscle activation: the largest over groups, per element (or interior node), at the nodes.
function activationPerNode(f) {
  const { data, shape } = f.act;
  const cols = shape[shape.length - 1];
  const rows = data.length / cols;
  const best = new Float32Array(cols);
  for (let c = 0; c < cols; c++) {
    let b = 0;
    for (let r = 0; r < rows; r++) b = Math.max(b, data[r * cols + c]);
    best[c] = b;
  }
  const n = f.position.length / 3 - 1;
  const out = new Float32Array(n + 1);
  for (let i = 0; i <= n; i++) {
    const j = cols === n ? Math.min(Math.max(i - 1, 0), n - 1) : Math.min(Math.max(i - 1, 0), cols - 1);
    out[i] = cols === n && i > 0 && i < n ? 0.5 * (best[i - 1] + best[i]) : best[j];
  }
  return out;
}
function colourRange(mode) {
  if (state.ranges[mode] !== undefined) return state.ranges[mode];
  const c = COLOURINGS[mode];
  let lo = Infinity, hi = -Infinity;
  const step = Math.max(1, Math.floor(state.frames.length / 400));
  for (let k = 0; k < state.frames.length; k += step) {
    for (const f of state.frames[k].rods) {
      const v = c.of(f);
      if (!v) continue;
      for (const x of v) { if (Number.isFinite(x)) { lo = Math.min(lo, x); hi = Math.max(hi, x); } }
    }
  }
  if (!Number.isFinite(lo)) return null;
  if (mode === 'activation') { lo = 0; hi = Math.max(hi, 1e-9); }
  const r = c.signed ? { lo: -Math.max(Math.abs(lo), Math.abs(hi), 1e-12), hi: Math.max(Math.abs(lo), Math.abs(hi), 1e-12) } : { lo: Math.min(lo, 0), hi: Math.max(hi, 1e-12) };
  if (state.mode === 'replay') state.ranges[mode] = r;
  return r;
}
function nodeColours(f) {
  const mode = state.colour;
  if (mode === 'plain' || !COLOURINGS[mode]) return null;
  const v = COLOURINGS[mode].of(f);
  const r = colourRange(mode);
  if (!v || !r) return null;
  const out = [];
  for (const x of v) {
    out.push(COLOURINGS[mode].signed ? diverging(x / r.hi) : viridis((x - r.lo) / (r.hi - r.lo)));
  }
  return out;
}
function drawLegend() {
  const mode = state.colour;
  const r = mode !== 'plain' && COLOURINGS[mode] ? colourRange(mode) : null;
  $('legend').hidden = !r;
  if (!r) return;
  const cv = $('colourbar'), ctx = cv.getContext('2d');
  for (let y = 0; y < cv.height; y++) {
    const u = 1 - y / (cv.height - 1);
    const c = COLOURINGS[mode].signed ? diverging(2 * u - 1) : viridis(u);
    ctx.fillStyle = `rgb(${c.r * 255},${c.g * 255},${c.b * 255})`;
    ctx.fillRect(0, y, cv.width, 1);
  }
  const unit = COLOURINGS[mode].unit;
  $('legend-text').innerHTML = `<span>${fmt(r.hi)} ${unit}</span><span>${mode}</span><span>${fmt(r.lo)} ${unit}</span>`;
}
function fmt(x) { return Math.abs(x) >= 1e4 || (Math.abs(x) < 1e-3 && x !== 0) ? x.toExponential(2) : (+x.toPrecision(3)).toString(); }

// --- obstacles, targets -------------------------------------------------------------------
const obstacleGroup = new THREE.Group(), targetGroup = new THREE.Group();
world.add(obstacleGroup); world.add(targetGroup);
const grey = () => new THREE.MeshPhongMaterial({ color: 0xb0b0b0, transparent: true, opacity: 0.55, side: THREE.DoubleSide, depthWrite: false });
function vec(v, d) { return Array.isArray(v) && v.length === 3 && v.every(Number.isFinite) ? v : d; }
function num(...xs) { for (const x of xs) if (Number.isFinite(x)) return x; return undefined; }
function buildObstacles() {
  obstacleGroup.clear();
  const sc = state.scene || {};
  const list = (sc.obstacles || []).slice();
  if (sc.grasp) list.push({ kind: 'sphere', center: sc.grasp.center, diameter: sc.grasp.diameter, grasp: true });
  for (const o of list) {
    const kind = o.kind || 'sphere';
    let mesh = null;
    if (kind === 'sphere') {
      const r = num(o.diameter / 2, o.radius);
      if (!r) continue;
      mesh = new THREE.Mesh(new THREE.SphereGeometry(r, 40, 24), grey());
      mesh.userData = { center: vec(o.center, [0, 0, 0]), velocity: vec(o.velocity, [0, 0, 0]) };
    } else if (kind === 'cylinder') {
      const r = num(o.diameter / 2, o.radius);
      let a = vec(o.start, null), b = vec(o.end, null);
      const axis = norm(vec(o.axis || o.direction, [0, 0, 1]));
      const len = num(o.length, o.height, 10 * state.extent);
      const c = vec(o.center || o.position || o.origin, [0, 0, 0]);
      if (!a || !b) { a = c.map((x, k) => x - 0.5 * len * axis[k]); b = c.map((x, k) => x + 0.5 * len * axis[k]); }
      if (!r) continue;
      const d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
      const h = Math.hypot(...d);
      mesh = new THREE.Mesh(new THREE.CylinderGeometry(r, r, h, 40, 1, false), grey());
      mesh.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), new THREE.Vector3(...norm(d)));
      mesh.userData = { center: [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2], velocity: vec(o.velocity, [0, 0, 0]) };
    } else if (kind === 'plane') {
      const normal = norm(vec(o.normal, [0, 0, 1]));
      const p = vec(o.point || o.origin || o.center || o.position, [0, 0, 0]);
      const size = 6 * state.extent;
      mesh = new THREE.Mesh(new THREE.PlaneGeometry(size, size), grey());
      mesh.quaternion.setFromUnitVectors(new THREE.Vector3(0, 0, 1), new THREE.Vector3(...normal));
      mesh.userData = { center: p, velocity: [0, 0, 0] };
    }
    if (mesh) { mesh.position.set(...mesh.userData.center); obstacleGroup.add(mesh); }
  }
}
function placeObstacles(t) {
  for (const m of obstacleGroup.children) {
    const { center, velocity } = m.userData;
    m.position.set(center[0] + velocity[0] * t, center[1] + velocity[1] * t, center[2] + velocity[2] * t);
  }
}
const targetMesh = new THREE.Mesh(new THREE.SphereGeometry(1, 20, 12), new THREE.MeshBasicMaterial({ color: 0xdc141e }));
targetGroup.add(targetMesh);
function sceneTarget(t) {
  const ts = (state.scene && state.scene.targets) || [];
  let cur = null;
  for (const g of ts) if ((g.from || 0) <= t + 1e-12) cur = g;
  if (!cur) return null;
  const p = vec(cur.position, null), v = vec(cur.velocity, [0, 0, 0]);
  if (!p) return null;
  const dt = t - (cur.from || 0);
  return [p[0] + v[0] * dt, p[1] + v[1] * dt, p[2] + v[2] * dt];
}

// --- showing a frame ----------------------------------------------------------------------
function showFrame(k) {
  if (!state.frames.length) return;
  k = Math.min(Math.max(k, 0), state.frames.length - 1);
  state.index = k;
  const f = state.frames[k];
  state.rods.forEach((rod, r) => {
    const fr = f.rods[r];
    if (!fr) return;
    rod.frameLines.visible = $('show-frame').checked && !!fr.director;
    updateTube(rod, fr.position, fr.director, nodeColours(fr));
    rod.desired.visible = $('show-desired').checked && !!fr.desired && Number.isFinite(fr.desired[0]);
    if (rod.desired.visible) {
      rod.desired.geometry.attributes.position.array.set(fr.desired);
      rod.desired.geometry.attributes.position.needsUpdate = true;
      rod.desired.geometry.computeBoundingSphere();
    }
  });
  let target = null;
  for (const fr of f.rods) if (fr.target && Number.isFinite(fr.target[0])) target = Array.from(fr.target);
  if (!target) target = sceneTarget(f.t);
  targetMesh.visible = $('show-targets').checked && !!target;
  if (target) { targetMesh.position.set(...target); targetMesh.scale.setScalar(0.012 * state.extent); }
  obstacleGroup.visible = $('show-obstacles').checked;
  placeObstacles(f.t);
  for (const rod of state.rods) rod.path.visible = $('show-path').checked;
  const slider = $('frame');
  slider.max = String(state.frames.length - 1);
  slider.value = String(k);
  $('time').textContent = `t = ${f.t.toFixed(4)} s  (${k + 1}/${state.frames.length})`;
  drawLegend();
  drawCursor();
  render();
}

function render() {
  renderer.render(scene3, camera);
  state.rendered += 1;
}

// --- camera -------------------------------------------------------------------------------
function bounds() {
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  const add = (x, y, z, r = 0) => {
    if (![x, y, z].every(Number.isFinite)) return;
    lo[0] = Math.min(lo[0], x - r); lo[1] = Math.min(lo[1], y - r); lo[2] = Math.min(lo[2], z - r);
    hi[0] = Math.max(hi[0], x + r); hi[1] = Math.max(hi[1], y + r); hi[2] = Math.max(hi[2], z + r);
  };
  const step = Math.max(1, Math.floor(state.frames.length / 200));
  for (let k = 0; k < state.frames.length; k += step) {
    for (const fr of state.frames[k].rods) for (let i = 0; i < fr.position.length; i += 3) add(fr.position[i], fr.position[i + 1], fr.position[i + 2]);
  }
  const last = state.frames[state.frames.length - 1];
  if (last) for (const fr of last.rods) for (let i = 0; i < fr.position.length; i += 3) add(fr.position[i], fr.position[i + 1], fr.position[i + 2]);
  if (state.mode === 'live') {
    for (const r of (state.scene && state.scene.rods) || []) {
      const b = vec(r.base_position, [0, 0, 0]), L = r.length || 0;
      add(b[0], b[1], b[2], L);
    }
  }
  for (const m of obstacleGroup.children) if (m.geometry.type === 'SphereGeometry') add(...m.userData.center, m.geometry.parameters.radius);
  const t = sceneTarget(0); if (t) add(...t);
  if (!Number.isFinite(lo[0])) return { lo: [-0.1, -0.1, -0.1], hi: [0.1, 0.1, 0.1] };
  return { lo, hi };
}

function setView(kind) {
  const { lo, hi } = bounds();
  const c = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
  const ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
  state.extent = Math.max(...ext, 1e-3);
  const fov = (camera.fov * Math.PI) / 180;
  const fit = (w, h) => {
    const hh = Math.max(h, w / camera.aspect, 1e-3) * 0.5 * 1.15;
    return hh / Math.tan(fov / 2);
  };
  let dir, up, dist;
  if (kind === 'xy') { dir = [0, 0, 1]; up = [0, 1, 0]; dist = fit(ext[0], ext[1]) + ext[2] / 2; }
  else if (kind === 'xz') { dir = [0, -1, 0]; up = [0, 0, 1]; dist = fit(ext[0], ext[2]) + ext[1] / 2; }
  else if (kind === 'yz') { dir = [1, 0, 0]; up = [0, 0, 1]; dist = fit(ext[1], ext[2]) + ext[0] / 2; }
  else { dir = norm([0.9, -1.3, 0.8]); up = [0, 0, 1]; dist = 1.1 * fit(Math.hypot(ext[0], ext[1]), Math.max(ext[2], 0.6 * Math.hypot(ext[0], ext[1]))); }
  camera.up.set(...up);
  camera.position.set(c[0] + dir[0] * dist, c[1] + dir[1] * dist, c[2] + dir[2] * dist);
  camera.near = dist / 1000; camera.far = dist * 100;
  camera.updateProjectionMatrix();
  controls.target.set(...c);
  controls.update();
  sun.position.set(c[0] + dir[0] * dist + up[0] * dist, c[1] + dir[1] * dist + up[1] * dist, c[2] + dir[2] * dist + up[2] * dist);
  if (grid) world.remove(grid);
  // A grid twice the run's extent, lines every 10^k m (about 10 to 100 of them).
  const gstep = Math.pow(10, Math.floor(Math.log10((2 * state.extent) / 10)));
  const gdiv = Math.max(2, Math.ceil((2 * state.extent) / gstep));
  grid = new THREE.GridHelper(gdiv * gstep, gdiv, 0xcccccc, 0xe6e6e6);
  grid.rotation.x = Math.PI / 2;
  grid.position.set(c[0], c[1], lo[2] - 0.05 * state.extent);
  world.add(grid);
  state.view = kind;
  if (state.frames.length) showFrame(state.index); else render();
}
controls.addEventListener('change', () => render());

// --- plots --------------------------------------------------------------------------------
const plotCanvas = $('plots');
let plotCache = null;
function timeRange() {
  if (state.mode === 'live' && state.live.duration) return [0, state.live.duration];
  const f = state.frames;
  if (!f.length) return [0, 1];
  return [f[0].t, Math.max(f[f.length - 1].t, f[0].t + 1e-9)];
}
function drawPlots() {
  const w = plotCanvas.clientWidth, h = plotCanvas.clientHeight;
  if (!w || !h) return;
  plotCanvas.width = w; plotCanvas.height = h;
  const ctx = plotCanvas.getContext('2d', { willReadFrequently: true });
  ctx.fillStyle = '#fafafa'; ctx.fillRect(0, 0, w, h);
  const panels = state.series.slice();
  const extra = $('extra-series').value;
  if (extra && state.extra[extra]) panels.push({ name: extra, unit: '', t: state.extra.time, lines: [{ label: extra, v: state.extra[extra], colour: '#444' }] });
  const [t0, t1] = timeRange();
  const pw = panels.length ? w / panels.length : w;
  panels.forEach((p, i) => {
    const x0 = i * pw + 52, x1 = (i + 1) * pw - 10, y0 = 18, y1 = h - 20;
    let lo = Infinity, hi = -Infinity;
    for (const l of p.lines) for (let k = 0; k < l.v.length; k++) { const v = l.v[k]; if (Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); } }
    if (!Number.isFinite(lo)) { lo = 0; hi = 1; }
    if (hi - lo < 1e-30) { hi = lo + Math.max(Math.abs(lo) * 1e-3, 1e-12); }
    ctx.strokeStyle = '#bbb'; ctx.strokeRect(x0, y0, x1 - x0, y1 - y0);
    ctx.fillStyle = '#333'; ctx.font = '11px sans-serif';
    ctx.fillText(`${p.name}${p.unit ? ' [' + p.unit + ']' : ''}`, x0, 12);
    ctx.fillText(fmt(hi), i * pw + 2, y0 + 9); ctx.fillText(fmt(lo), i * pw + 2, y1);
    ctx.fillText(`${fmt(t0)} s`, x0, h - 6); ctx.fillText(`${fmt(t1)} s`, x1 - 40, h - 6);
    let lx = x0 + 120;
    for (const l of p.lines) {
      ctx.strokeStyle = l.colour; ctx.lineWidth = 1.5; ctx.beginPath();
      const n = Math.min(l.v.length, p.t.length);
      let started = false;
      for (let k = 0; k < n; k++) {
        const v = l.v[k];
        if (!Number.isFinite(v)) { started = false; continue; }
        const X = x0 + ((p.t[k] - t0) / (t1 - t0)) * (x1 - x0), Y = y1 - ((v - lo) / (hi - lo)) * (y1 - y0);
        if (started) ctx.lineTo(X, Y); else { ctx.moveTo(X, Y); started = true; }
      }
      ctx.stroke();
      if (p.lines.length > 1) { ctx.fillStyle = l.colour; ctx.fillText(l.label, lx, 12); lx += ctx.measureText(l.label).width + 10; }
    }
  });
  plotCache = { image: ctx.getImageData(0, 0, w, h), panels: panels.length, pw, t0, t1 };
  drawCursor();
}
function drawCursor() {
  if (!plotCache || !state.frames.length) return;
  const ctx = plotCanvas.getContext('2d', { willReadFrequently: true });
  ctx.putImageData(plotCache.image, 0, 0);
  const t = state.frames[state.index].t;
  const { pw, t0, t1 } = plotCache;
  ctx.strokeStyle = '#c33'; ctx.lineWidth = 1;
  for (let i = 0; i < plotCache.panels; i++) {
    const x0 = i * pw + 52, x1 = (i + 1) * pw - 10;
    const X = x0 + ((t - t0) / (t1 - t0)) * (x1 - x0);
    ctx.beginPath(); ctx.moveTo(X, 18); ctx.lineTo(X, plotCanvas.height - 20); ctx.stroke();
  }
}

// Series of a run: distance (series.npz), energies of all rods (trajectory.npz), control effort.
function buildSeries(arrays, frameTimes) {
  state.series = [];
  state.extra = {};
  const get = (k) => arrays[k] && arrays[k].data;
  const st = get('series/time');
  if (st) {
    if (get('series/distance')) state.series.push({ name: 'distance / L0', unit: '', t: st, lines: [{ label: 'distance', v: get('series/distance'), colour: '#f0821e' }] });
    const ef = get('series/control_force_effort'), ec = get('series/control_couple_effort');
    if (ef || ec) {
      const lines = [];
      if (ef) lines.push({ label: 'force', v: ef, colour: '#1f64c8' });
      if (ec) lines.push({ label: 'couple', v: ec, colour: '#2ca02c' });
      state.series.push({ name: 'control effort', unit: '', t: st, lines });
    }
    state.extra.time = st;
    const sel = $('extra-series');
    sel.innerHTML = '<option value="">—</option>';
    for (const k of Object.keys(arrays)) {
      if (k.startsWith('series/') && k !== 'series/time') {
        const name = k.slice(7);
        state.extra[name] = arrays[k].data;
        const o = document.createElement('option'); o.value = name; o.textContent = name; sel.appendChild(o);
      }
    }
  }
  const F = frameTimes.length;
  const kin = new Float32Array(F), str = new Float32Array(F);
  let have = false;
  for (const rod of state.rods) {
    const e = (n) => get(`trajectory/${rod.prefix}${n}`);
    const tr = e('energy_translational'), ro = e('energy_rotational'), s = e('energy_stretch'), b = e('energy_bend');
    if (!tr || !ro || !s || !b) continue;
    have = true;
    for (let k = 0; k < F; k++) { kin[k] += tr[k] + ro[k]; str[k] += s[k] + b[k]; }
  }
  if (have) {
    const tot = kin.map((v, k) => v + str[k]);
    state.series.splice(Math.min(1, state.series.length), 0, { name: 'energy', unit: 'J', t: frameTimes, lines: [
      { label: 'kinetic', v: kin, colour: '#1f77b4' }, { label: 'strain', v: str, colour: '#ff7f0e' }, { label: 'total', v: tot, colour: '#222' }] });
  }
}

// --- loading a recorded run ---------------------------------------------------------------
function framesFrom(arrays, F) {
  const names = Object.keys(arrays).filter((k) => k.startsWith('trajectory/')).map((k) => k.slice(11));
  const prefixes = rodPrefixes(names);
  const shapes = {};
  for (const p of prefixes) shapes[p] = arrays[`trajectory/${p}position`].shape;
  setupRods(prefixes, shapes);
  const time = arrays['trajectory/time'] ? arrays['trajectory/time'].data : new Float32Array(F);
  const frames = [];
  const slice = (name, k) => {
    const a = arrays[`trajectory/${name}`];
    if (!a || a.shape[0] !== F) return null;
    const per = a.data.length / F;
    return a.data.subarray(k * per, (k + 1) * per);
  };
  const actName = (p) => names.find((k) => k.startsWith(p) && k.slice(p.length).startsWith('activation') && !k.slice(p.length).includes('/'));
  for (let k = 0; k < F; k++) {
    frames.push({
      t: time[k],
      rods: state.rods.map((rod) => {
        const an = actName(rod.prefix);
        const a = an ? arrays[`trajectory/${an}`] : null;
        return {
          position: slice(`${rod.prefix}position`, k),
          director: slice(`${rod.prefix}director`, k),
          sigma: slice(`${rod.prefix}sigma`, k),
          kappa: slice(`${rod.prefix}kappa`, k),
          desired: slice(`${rod.prefix}desired`, k),
          target: slice(`${rod.prefix}target`, k),
          act: a && a.shape[0] === F ? { shape: a.shape.slice(1), data: slice(an, k) } : null,
        };
      }),
    });
  }
  return { frames, time };
}

function updateColourOptions() {
  const sel = $('colour');
  const hasAct = state.frames.length && state.frames[0].rods.some((r) => r.act);
  let opt = sel.querySelector('option[value="activation"]');
  if (hasAct && !opt) { opt = document.createElement('option'); opt.value = 'activation'; opt.textContent = 'muscle activation (max over groups)'; sel.appendChild(opt); }
  if (!hasAct && opt) opt.remove();
}

function planarOf(frames) {
  let lo = Infinity, hi = -Infinity, ext = 0;
  const step = Math.max(1, Math.floor(frames.length / 200));
  for (let k = 0; k < frames.length; k += step) for (const r of frames[k].rods) {
    for (let i = 0; i < r.position.length; i += 3) { lo = Math.min(lo, r.position[i + 2]); hi = Math.max(hi, r.position[i + 2]); ext = Math.max(ext, Math.abs(r.position[i]), Math.abs(r.position[i + 1])); }
  }
  return !(hi - lo > 1e-3 * Math.max(ext, 1e-6));
}

function tipPaths() {
  state.rods.forEach((rod, r) => {
    const pts = new Float32Array(state.frames.length * 3);
    state.frames.forEach((f, k) => { const p = f.rods[r].position; const o = p.length - 3; pts.set([p[o], p[o + 1], p[o + 2]], 3 * k); });
    rod.path.geometry.setAttribute('position', new THREE.BufferAttribute(pts, 3));
    rod.path.geometry.computeBoundingSphere();
  });
}

function info(summary, extra = '') {
  if (!summary) { $('info').textContent = extra; return; }
  const lines = [];
  if (summary.name) lines.push(summary.name);
  if (summary.status) lines.push(`status: ${summary.status}`);
  if (summary.failure && summary.failure.message) lines.push(`failure: ${summary.failure.message}`);
  if (summary.frames !== undefined) lines.push(`frames: ${summary.frames}`);
  if (summary.dt) lines.push(`dt: ${summary.dt} s`);
  if (summary.control && summary.control.final_distance !== undefined) lines.push(`final distance: ${fmt(summary.control.final_distance)} L0`);
  $('info').textContent = lines.join('\n') + (extra ? '\n' + extra : '');
  const bad = summary.status && summary.status !== 'completed';
  $('status').textContent = summary.status ? `${summary.status}${bad && summary.failure ? ': ' + summary.failure.message : ''}` : '';
  $('status').className = bad ? 'bad' : '';
}

async function loadRun(id) {
  stop();
  showMessage('loading…', true);
  const res = await fetch(`api/run?id=${encodeURIComponent(id)}`);
  if (!res.ok) { showMessage(`cannot load run ${id}: ${await res.text()}`); return; }
  const { header, arrays } = parseBlob(await res.arrayBuffer());
  state.mode = 'replay';
  state.scene = header.scene;
  state.ranges = {};
  const F = header.frames;
  if (!F) { showMessage('this run recorded no frames'); return; }
  const { frames, time } = framesFrom(arrays, F);
  if (!state.rods.length) { showMessage('no rod positions in trajectory.npz'); return; }
  state.frames = frames;
  state.planar = planarOf(frames);
  state.extent = 0.2;
  buildObstacles();
  updateColourOptions();
  buildSeries(arrays, time);
  tipPaths();
  $('title').textContent = header.label || id;
  const thinned = header.frames < header.frames_total ? `showing ${header.frames} of ${header.frames_total} frames (evenly spaced)` : '';
  info(header.summary, thinned);
  showMessage('');
  state.index = 0;
  setView(state.planar ? 'xy' : '3d');
  buildObstacles();
  drawPlots();
  showFrame(0);
  window.__octoarm.ready = true;
}

// --- live ---------------------------------------------------------------------------------
const MAX_LIVE_FRAMES = 5000;
function connectLive() {
  state.mode = 'live';
  const ws = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/api/live`);
  ws.binaryType = 'arraybuffer';
  $('progress').hidden = false;
  ws.onmessage = (ev) => {
    if (typeof ev.data === 'string') {
      const m = JSON.parse(ev.data);
      if (m.type === 'hello') {
        state.scene = m.scene;
        state.live.duration = m.scene.duration || null;
        $('title').textContent = `live: ${m.scene.name || ''}`;
        buildObstacles();
      } else if (m.type === 'status') liveStatus(m);
      return;
    }
    const { header, arrays } = parseBlob(ev.data);
    liveFrame(header, arrays);
  };
  ws.onclose = () => { if (!state.live.status || state.live.status.state !== 'finished') $('status').textContent = 'disconnected from the run'; };
}

function liveFrame(header, arrays) {
  const names = Object.keys(arrays);
  if (!state.rods.length) {
    const prefixes = rodPrefixes(names);
    const shapes = {};
    for (const p of prefixes) shapes[p] = arrays[`${p}position`].shape.slice();
    for (const p of prefixes) shapes[p].unshift(1);
    setupRods(prefixes, shapes);
    state.frames = [];
  }
  const get = (n) => (arrays[n] ? arrays[n].data : null);
  const frame = {
    t: header.time, step: header.step,
    rods: state.rods.map((rod) => {
      const an = names.find((k) => k.startsWith(rod.prefix) && k.slice(rod.prefix.length).startsWith('activation'));
      return {
        position: get(`${rod.prefix}position`), director: get(`${rod.prefix}director`),
        sigma: get(`${rod.prefix}sigma`), kappa: get(`${rod.prefix}kappa`),
        desired: get(`${rod.prefix}desired`), target: get(`${rod.prefix}target`),
        act: an ? { shape: arrays[an].shape, data: arrays[an].data } : null,
      };
    }),
  };
  const follow = state.index >= state.frames.length - 1;
  state.frames.push(frame);
  if (state.frames.length > MAX_LIVE_FRAMES) { // keep every other old frame, the newest always
    state.frames = state.frames.filter((f, k) => k % 2 === 0 || k === state.frames.length - 1);
  }
  state.live.frames += 1;
  state.live.last = frame;
  if (!(state.live.status && state.live.status.state === 'finished') && state.live.steps.length < 100000) state.live.steps.push(header.step);
  state.live.planned = header.planned;
  if (state.live.frames === 1) {
    state.planar = planarOf(state.frames);
    updateColourOptions();
    setView(state.planar ? 'xy' : '3d');
    buildObstacles();
    window.__octoarm.ready = true;
  }
  // Progress: steps of the run, simulated and wall time.
  const p = header.planned ? header.step / header.planned : 0;
  $('progress-bar').style.width = `${(100 * p).toFixed(1)}%`;
  $('progress-text').textContent = `${(100 * p).toFixed(1)} %  t = ${header.time.toFixed(3)} s  wall ${header.wall.toFixed(1)} s`;
  liveSeries();
  if (follow && !state.playing) showFrame(state.frames.length - 1);
  else { $('frame').max = String(state.frames.length - 1); }
}

function liveSeries() {
  const F = state.frames.length;
  const t = new Float32Array(F);
  state.frames.forEach((f, k) => { t[k] = f.t; });
  // Tip height over time as a cheap live series; energies are in the recorded output.
  const lines = state.rods.map((rod, r) => {
    const v = new Float32Array(F);
    state.frames.forEach((f, k) => { const p = f.rods[r].position; const o = p.length - 3; v[k] = Math.hypot(p[o], p[o + 1], p[o + 2]); });
    return { label: rod.name, v, colour: ['#7b3fc4', '#1f77b4', '#2ca02c', '#d62728'][r % 4] };
  });
  state.series = [{ name: 'tip distance from the origin', unit: 'm', t, lines }];
  if (F % 5 === 1 || F < 5) drawPlots(); else drawCursor();
}

function liveStatus(m) {
  state.live.status = m;
  window.__octoarm.status = m;
  if (m.state === 'waiting') $('status').textContent = 'waiting for the run to start';
  else if (m.state === 'running') $('status').textContent = 'running';
  else if (m.state === 'finished') {
    const bad = m.status !== 'completed';
    $('status').textContent = bad ? `${m.status}: ${m.message || ''}` : `completed: outputs in ${m.out_dir}`;
    $('status').className = bad ? 'bad' : '';
    if (bad) showMessage(`The run stopped (${m.status}): ${m.message || ''}\nWhat was recorded until then is in ${m.out_dir}.`);
    if (!bad) $('progress-bar').style.width = '100%';
    drawPlots();
  }
}

// --- transport ----------------------------------------------------------------------------
function stop() { state.playing = false; $('play').textContent = 'play'; }
function play() {
  if (!state.frames.length) return;
  if (state.index >= state.frames.length - 1) state.index = 0;
  state.playing = true; state.simTime = state.frames[state.index].t; $('play').textContent = 'pause';
  lastTick = performance.now();
}
let lastTick = 0;
function tick(now) {
  if (state.playing && state.frames.length) {
    const dt = (now - lastTick) / 1000;
    state.simTime += dt * state.speed;
    const f = state.frames;
    let k = state.index;
    while (k < f.length - 1 && f[k + 1].t <= state.simTime) k++;
    if (k !== state.index) showFrame(k);
    if (k >= f.length - 1 && state.mode === 'replay') stop();
  }
  lastTick = now;
  requestAnimationFrame(tick);
}
requestAnimationFrame(tick);
$('play').onclick = () => (state.playing ? stop() : play());
$('first').onclick = () => { stop(); showFrame(0); };
$('last').onclick = () => { stop(); showFrame(state.frames.length - 1); };
$('back').onclick = () => { stop(); showFrame(state.index - 1); };
$('next').onclick = () => { stop(); showFrame(state.index + 1); };
$('frame').addEventListener('input', (e) => { stop(); showFrame(+e.target.value); });
$('speed').onchange = (e) => { state.speed = +e.target.value; };
$('colour').onchange = (e) => { state.colour = e.target.value; showFrame(state.index); };
$('extra-series').onchange = () => drawPlots();
for (const id of ['show-frame', 'show-desired', 'show-targets', 'show-obstacles', 'show-path']) $(id).onchange = () => showFrame(state.index);
for (const b of document.querySelectorAll('[data-view]')) b.onclick = () => setView(b.dataset.view);
$('fit').onclick = () => setView(state.view || '3d');
document.addEventListener('keydown', (e) => {
  if (e.target.tagName === 'SELECT') return;
  if (e.key === ' ' && e.target.tagName !== 'INPUT') { e.preventDefault(); state.playing ? stop() : play(); }
  else if (e.key === 'ArrowRight' && e.target.tagName !== 'INPUT') { stop(); showFrame(state.index + 1); }
  else if (e.key === 'ArrowLeft' && e.target.tagName !== 'INPUT') { stop(); showFrame(state.index - 1); }
});

// --- what tests and scripts read --------------------------------------------------------------
window.__octoarm = {
  ready: false, status: null,
  rendered: () => state.rendered,
  frameIndex: () => state.index,
  frameCount: () => state.frames.length,
  liveFrames: () => state.live.frames,
  // Steps of the live frames received before the run's final status, and the planned steps.
  liveStepsBeforeFinish: () => state.live.steps.slice(),
  livePlanned: () => state.live.planned,
  // Screen position (CSS pixels, page coordinates) of the world point p.
  project: (p) => {
    const v = new THREE.Vector3(...p).project(camera);
    const r = renderer.domElement.getBoundingClientRect();
    return [r.left + ((v.x + 1) / 2) * r.width, r.top + ((1 - v.y) / 2) * r.height];
  },
  // Node positions of rod r at frame k (default: the shown frame), as a plain array.
  positions: (k = state.index, r = 0) => Array.from(state.frames[k].rods[r].position),
  lastLive: () => state.live.last && { time: state.live.last.t, step: state.live.last.step, position: Array.from(state.live.last.rods[0].position) },
  setView,
};

// --- start --------------------------------------------------------------------------------
async function start() {
  resize();
  const res = await fetch('api/catalog');
  const cat = await res.json();
  if (cat.kind === 'live') { connectLive(); return; }
  const sel = $('run');
  for (const r of cat.runs) { const o = document.createElement('option'); o.value = r.id; o.textContent = r.label; sel.appendChild(o); }
  $('picker').hidden = cat.runs.length < 2;
  sel.onchange = () => loadRun(sel.value);
  const wanted = new URLSearchParams(location.search).get('run');
  const first = cat.runs.find((r) => r.id === wanted) || cat.runs[0];
  sel.value = first.id;
  await loadRun(first.id);
}
start().catch((e) => { showMessage(`error: ${e.message}`); console.error(e); });
