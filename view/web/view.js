// The browser side of modal-rt view (view/README.md): the display basis is fetched once, then each
// WebSocket frame carries the modal state q and the contacts' static corrections; a vertex shader
// reconstructs u = Phi q (+ corrections) from a texture of Phi on the GPU.
// three.js by its path: an import map would be an inline script, which the page's CSP forbids.
import * as THREE from '/three/build/three.module.js';
import { OrbitControls } from '/three/examples/jsm/controls/OrbitControls.js';
import { api, socketUrl } from '/access.js';

const $ = (id) => document.getElementById(id);
// Text from the basis or report.json (names) as HTML text: a crafted name stays text.
const escaped = (text) => String(text).replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
const params = new URLSearchParams(location.search);
// The mouse is a device through a virtual spring: a drag of s metres (the pointer's travel, measured
// in the scene at the pressed point's depth) pushes along the inward normal with F = k s.
const springNPerM = Number(params.get('spring') ?? 200); // [N/m] (0.2 N/mm)
// With sliding contacts (modal-rt view --contact proxy) a drag over the part slides the HIP there,
// pressing with this force along the inward normal.
const slideForceN = Number(params.get('force') ?? 0.5); // [N]

const state = window.viewState = {
  ready: false, frames: 0, renderedFrames: 0, fps: 0, receivedFps: 0, bytesPerFrame: 0, basisBytes: 0,
  ageMs: [], ageP50: NaN, ageP95: NaN, hips: [], space: 0, tick: 0, mode: 'live',
};

// ------------------------------------------------------------------------------------- the basis
const info = await (await api('/api/info')).json();
const basisBuffer = await (await api('/api/basis')).arrayBuffer();
state.basisBytes = basisBuffer.byteLength;
let report = null;
try { const r = await api('/api/report'); if (r.ok) report = await r.json(); } catch (e) { /* none */ }
// Design B's felt-stiffness map read at this basis's vertices (modal-rt view --compare B.mrt): the
// Stiffness tab's difference map.
const comparison = info.comparison ? await (await api('/api/comparison')).json() : null;
$('file').textContent = info.file.split('/').pop();
// Who drives the HIPs: the mouse (`modal-rt view`), or a session file / UDP device (`run`/`serve
// --view`): then the page only watches.
const session = info.session ?? { driver: 'mouse', watch_only: false, hips: 2 };
state.watchOnly = session.watch_only;
state.sliding = session.contact === 'proxy' && !state.watchOnly; // the mouse slides proxies
$('spring').textContent = state.sliding ? `slide: ${slideForceN.toPrecision(3)} N along the inward normal`
  : `${(springNPerM / 1000).toPrecision(3)} N/mm (F = k · drag)`;
if (state.watchOnly) {
  $('contacts-title').innerHTML = `Contacts <small>(watch-only: driven by <b>modal-rt ${session.driver}</b>; the mouse turns the view)</small>`;
  for (const id of ['mouse-spring', 'mouse-hold']) $(id).style.display = 'none';
}

function parseBasis(buffer) {
  const dv = new DataView(buffer);
  let o = 8;
  const nv = dv.getUint32(o, true), nt = dv.getUint32(o + 4, true), ns = dv.getUint32(o + 8, true);
  const scalarBytes = dv.getUint32(o + 12, true);
  o += 16;
  const take = (Type, n) => { const a = new Type(buffer.slice(o, o + n * Type.BYTES_PER_ELEMENT)); o += n * Type.BYTES_PER_ELEMENT; return a; };
  const vertices = take(Float32Array, 3 * nv), triangles = take(Uint32Array, 3 * nt);
  const normals = take(Float32Array, 3 * nv), regions = take(Uint32Array, nv);
  const spaces = [];
  for (let s = 0; s < ns; ++s) {
    const r = dv.getUint32(o, true); o += 8;
    const phi32 = take(Float32Array, 3 * nv * r);
    const phi64 = scalarBytes === 8 ? take(Float64Array, 3 * nv * r) : null;
    spaces.push({ r, phi32, phi64 });
  }
  const stiffness = take(Float32Array, nv); // [N/mm] the scene's felt-stiffness map, 0: not computed
  return { nv, nt, vertices, triangles, normals, regions, spaces, stiffness };
}
const basis = parseBasis(basisBuffer);
const rho = info.patch_radius_m;

// ------------------------------------------------------------------------------------- the scene
const container = $('canvas');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
container.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1d2026);
const lo = new THREE.Vector3(...info.bounds_min), hi = new THREE.Vector3(...info.bounds_max);
const centre = lo.clone().add(hi).multiplyScalar(0.5), size = hi.clone().sub(lo).length();
const camera = new THREE.PerspectiveCamera(35, 1, size * 0.01, size * 20);
camera.up.set(0, 0, 1);
// Far enough that the part's bounding sphere (radius size / 2) fits the narrower field of view.
const fitDistance = (aspect) => (0.55 * size) / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2) * Math.min(1, aspect));
const viewDirection = new THREE.Vector3(0.35, -1.0, 0.8).normalize();
camera.position.copy(centre).addScaledVector(viewDirection, fitDistance(1));
const controls = new OrbitControls(camera, renderer.domElement);
controls.target.copy(centre);
controls.update();

// Colour maps, defined once for the shader and the legends. Turbo (Google's polynomial fit) is used
// between TURBO_LOW and TURBO_HIGH only: its ends are near-black (luminance 0.10 at 0), and the part at
// rest (|u| = 0) must stand out from the dark background (a blue of luminance 0.41).
const TURBO = {
  r: [0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943],
  g: [0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604],
  b: [0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973],
};
const TURBO_LOW = 0.12, TURBO_HIGH = 0.88;
const polynomial = (c, x) => c.reduce((sum, k, i) => sum + k * x ** i, 0);
const glslPolynomial = (c) => `dot(v4, vec4(${c.slice(0, 4).join(', ')})) + dot(v2, vec2(${c.slice(4).join(', ')}))`;
// The difference map's colours, as the shader's diverging(): B softer than A cool, stiffer warm, the
// neutral grey-white at no difference (within the noise floor).
const COOL = [0.23, 0.30, 0.75], NEUTRAL = [0.87, 0.87, 0.87], WARM = [0.71, 0.02, 0.15];
const glslVec3 = (c) => `vec3(${c.map((x) => x.toFixed(2)).join(', ')})`;
function diverging(x) { // x in [-1, 1] -> THREE.Color
  const end = x < 0 ? COOL : WARM, t = Math.min(1, Math.abs(x));
  return new THREE.Color(...NEUTRAL.map((n, c) => n + (end[c] - n) * t));
}
function turbo(x) { // x in [0, 1] -> THREE.Color, as the shader's turbo()
  const t = TURBO_LOW + (TURBO_HIGH - TURBO_LOW) * Math.min(1, Math.max(0, x));
  const channel = (c) => Math.min(1, Math.max(0, polynomial(c, t)));
  return new THREE.Color().setRGB(channel(TURBO.r), channel(TURBO.g), channel(TURBO.b), THREE.SRGBColorSpace);
}
// Validation errors: log scale 1e-12 ... 1, blue to red.
function errorColor(e) {
  const x = Math.min(1, Math.max(0, (Math.log10(Math.max(e, 1e-12)) + 12) / 12));
  return new THREE.Color().setHSL(0.66 * (1 - x), 0.9, 0.55, THREE.SRGBColorSpace);
}

// Phi as an RGBA32F texture: texel (v r + i) holds mode i at vertex v.
const texWidth = 2048;
function phiTexture(space) {
  const n = basis.nv * space.r, height = Math.max(1, Math.ceil(n / texWidth));
  const data = new Float32Array(texWidth * height * 4);
  for (let t = 0; t < n; ++t) {
    data[4 * t] = space.phi32[3 * t]; data[4 * t + 1] = space.phi32[3 * t + 1]; data[4 * t + 2] = space.phi32[3 * t + 2];
  }
  const tex = new THREE.DataTexture(data, texWidth, height, THREE.RGBAFormat, THREE.FloatType);
  tex.needsUpdate = true;
  return tex;
}
const textures = basis.spaces.map(phiTexture);
const maxModes = 256;

const uniforms = {
  phi: { value: textures[0] }, r: { value: basis.spaces[0].r }, texWidth: { value: texWidth },
  q: { value: Array.from({ length: maxModes / 4 }, () => new THREE.Vector4()) },
  exaggeration: { value: 1 }, scaleMax: { value: 1e-3 }, rho: { value: rho }, plain: { value: 0 },
  stiffnessOn: { value: 0 }, stiffnessLogLow: { value: 0 }, stiffnessLogHigh: { value: 1 },
  differenceOn: { value: 0 }, differenceRange: { value: 10 }, noiseFloor: { value: 1 },
  contactOn: { value: [0, 0] }, contactVertex: { value: [0, 0] },
  contactPos: { value: [new THREE.Vector3(), new THREE.Vector3()] }, contactC: { value: [new THREE.Vector3(), new THREE.Vector3()] },
};
const material = new THREE.ShaderMaterial({
  glslVersion: THREE.GLSL3, uniforms, side: THREE.DoubleSide,
  vertexShader: `
    precision highp float; precision highp int; precision highp sampler2D;
    uniform sampler2D phi; uniform int r; uniform int texWidth; uniform vec4 q[${maxModes / 4}];
    uniform float exaggeration; uniform float scaleMax; uniform float rho;
    uniform float contactOn[2]; uniform int contactVertex[2]; uniform vec3 contactPos[2]; uniform vec3 contactC[2];
    in float stiffness; // [N/mm] the felt-stiffness map, 0: not computed
    in float difference; in float compared; // [%] design B against this basis (--compare), 1: compared here
    out float vMagnitude; out vec3 vPosition; out float vComputed; out float vLogStiffness;
    out float vCompared; out float vDifference;
    void main() {
      vCompared = compared; vDifference = compared * difference;
      vComputed = stiffness > 0.0 ? 1.0 : 0.0;
      vLogStiffness = vComputed * log(max(stiffness, 1e-30)); // over the computed corners only (divided by vComputed)
      int v = gl_VertexID;
      vec3 u = vec3(0.0);
      for (int i = 0; i < r; ++i) {
        int t = v * r + i;
        u += q[i >> 2][i & 3] * texelFetch(phi, ivec2(t % texWidth, t / texWidth), 0).xyz;
      }
      for (int k = 0; k < 2; ++k) {
        if (contactOn[k] < 0.5) continue;
        float w = v == contactVertex[k] ? 1.0 : 0.0;
        if (rho > 0.0) { vec3 d = position - contactPos[k]; float s = max(0.0, 1.0 - dot(d, d) / (rho * rho)); w = s * s; }
        u += w * contactC[k];
      }
      vMagnitude = length(u) / scaleMax;
      vec4 world = modelMatrix * vec4(position + exaggeration * u, 1.0);
      vPosition = world.xyz;
      gl_Position = projectionMatrix * viewMatrix * world;
    }`,
  fragmentShader: `
    precision highp float;
    uniform float plain; // 1: a neutral grey (the Validation tab's part at rest: its colours are the points')
    uniform float stiffnessOn; uniform float stiffnessLogLow; uniform float stiffnessLogHigh; // the Stiffness tab
    uniform float differenceOn; uniform float differenceRange; uniform float noiseFloor; // its difference map [%]
    in float vMagnitude; in vec3 vPosition; in float vComputed; in float vLogStiffness; out vec4 color;
    in float vCompared; in float vDifference;
    vec3 diverging(float x) { return mix(${glslVec3(NEUTRAL)}, x < 0.0 ? ${glslVec3(COOL)} : ${glslVec3(WARM)}, min(1.0, abs(x))); }
    vec3 turbo(float x) {
      x = mix(${TURBO_LOW}, ${TURBO_HIGH}, clamp(x, 0.0, 1.0));
      vec4 v4 = vec4(1.0, x, x * x, x * x * x); vec2 v2 = v4.zw * v4.z;
      return clamp(vec3(${glslPolynomial(TURBO.r)}, ${glslPolynomial(TURBO.g)}, ${glslPolynomial(TURBO.b)}), 0.0, 1.0);
    }
    void main() {
      // A headlight: the faces the viewer looks at are lit, whatever the orbit.
      vec3 n = normalize(cross(dFdx(vPosition), dFdy(vPosition)));
      float light = 0.6 + 0.4 * abs(dot(n, normalize(cameraPosition - vPosition)));
      vec3 base = mix(turbo(vMagnitude), vec3(0.62, 0.66, 0.72), plain);
      if (stiffnessOn > 0.5) { // log scale; grey where the map has no value (blended across a triangle's edge)
        float x = (vLogStiffness / max(vComputed, 1e-6) - stiffnessLogLow) / max(stiffnessLogHigh - stiffnessLogLow, 1e-6);
        base = mix(vec3(0.45, 0.47, 0.50), turbo(x), vComputed);
      }
      if (differenceOn > 0.5) { // B - A in % of A; within the noise floor: no difference; grey: not compared
        float d = vDifference / max(vCompared, 1e-6);
        float x = abs(d) <= noiseFloor ? 0.0 : d / max(differenceRange, 1e-6);
        base = mix(vec3(0.45, 0.47, 0.50), diverging(x), vCompared);
      }
      color = vec4(base * light, 1.0);
    }`,
});
const geometry = new THREE.BufferGeometry();
geometry.setAttribute('position', new THREE.BufferAttribute(basis.vertices, 3));
geometry.setAttribute('stiffness', new THREE.BufferAttribute(basis.stiffness, 1));
const differencePercent = new Float32Array(basis.nv), differenceCompared = new Float32Array(basis.nv);
if (comparison) comparison.percent.forEach((p, v) => { differencePercent[v] = p ?? 0; differenceCompared[v] = p === null ? 0 : 1; });
geometry.setAttribute('difference', new THREE.BufferAttribute(differencePercent, 1));
geometry.setAttribute('compared', new THREE.BufferAttribute(differenceCompared, 1));
geometry.setIndex(new THREE.BufferAttribute(basis.triangles, 1));
geometry.computeBoundingSphere();
geometry.boundingSphere.radius *= 4; // the shader moves the vertices
const mesh = new THREE.Mesh(geometry, material);
scene.add(mesh);

// VOI boxes: the bounding box of each space's display region (space 0, the global space, has none).
const voiBoxes = info.spaces.map((s, index) => {
  if (index === 0) return null;
  const box = new THREE.Box3();
  for (let v = 0; v < basis.nv; ++v)
    if (basis.regions[v] === index) box.expandByPoint(new THREE.Vector3(basis.vertices[3 * v], basis.vertices[3 * v + 1], basis.vertices[3 * v + 2]));
  if (box.isEmpty()) return null;
  box.expandByScalar(size * 0.005);
  const helper = new THREE.Box3Helper(box, 0x8899aa);
  scene.add(helper);
  return helper;
});

// HIPs: a sphere at the felt position (a sliding contact's proxy), the force arrow, the proxy's path.
const PATH_POINTS = 20000;
const hipColors = Array.from({ length: session.hips }, (_, h) => [0xff4fd8, 0x4fffe0, 0xffd24f, 0x8fff4f][h % 4]);
// A HIP whose force is beyond its contact's validity force (MODALRT_HIP_BEYOND_VALIDITY, flag 256: the
// linear model's stiffness no longer holds to the kernel's level there) is drawn white (the one colour
// the live |u| scale never uses: the part under a hard press is dark red), its panel row in red.
const BEYOND_VALIDITY = 256, beyondColor = 0xffffff, beyondText = '#ff5a3a';
const validityLevel = session.validity_level ?? 5;
const hips = hipColors.map((_, h) => {
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(size * 0.006), new THREE.MeshBasicMaterial({ color: hipColors[h] }));
  const arrow = new THREE.ArrowHelper(new THREE.Vector3(0, 0, -1), new THREE.Vector3(), size * 0.1, hipColors[h]);
  sphere.visible = arrow.visible = false;
  scene.add(sphere, arrow);
  const label = document.createElement('div');
  label.className = 'label'; label.style.display = 'none'; label.style.color = '#' + hipColors[h].toString(16);
  $('labels').appendChild(label);
  // The proxy's path over the part while in contact (a sliding contact; a snap contact's stays a dot).
  const pathGeometry = new THREE.BufferGeometry();
  pathGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * PATH_POINTS), 3));
  pathGeometry.setDrawRange(0, 0);
  const path = new THREE.Line(pathGeometry, new THREE.LineBasicMaterial({ color: hipColors[h], depthTest: false }));
  path.renderOrder = 1;
  scene.add(path);
  return { sphere, arrow, label, history: [], vertex: null, path, pathPoints: 0, validityForce: 0 }; // vertex: of the press the history is of
});

// Validation points (offline side).
const validationPoints = new THREE.Points(new THREE.BufferGeometry(), new THREE.PointsMaterial({ size: 9, sizeAttenuation: false, vertexColors: true }));
validationPoints.visible = false;
scene.add(validationPoints);

function resize() {
  const w = container.clientWidth, h = container.clientHeight;
  renderer.setSize(w, h); camera.aspect = w / h; camera.updateProjectionMatrix();
  if (!resize.done) camera.position.copy(centre).addScaledVector(viewDirection, fitDistance(camera.aspect));
  resize.done = true; // later resizes keep the user's view
}
window.addEventListener('resize', resize);
resize();

// ------------------------------------------------------------------------------------- frames
let latest = null, freshFrame = false, received = 0, lastSecond = performance.now(), rendered = 0;
function parseFrame(buffer) {
  const dv = new DataView(buffer);
  if (dv.getUint32(0, true) !== 0x4654524d) return null;
  const f = { tickWallMs: dv.getFloat64(8, true), sendWallMs: dv.getFloat64(16, true), tick: dv.getFloat64(24, true), time: dv.getFloat64(32, true) };
  f.space = dv.getUint32(40, true); f.r = dv.getUint32(44, true);
  const hipCount = dv.getUint32(48, true), contactCount = dv.getUint32(52, true);
  f.stats = Array.from({ length: 8 }, (_, i) => dv.getFloat64(56 + 8 * i, true));
  let o = 120;
  f.q = new Float64Array(buffer.slice(o, o + 8 * f.r)); o += 8 * f.r;
  f.contacts = [];
  for (let k = 0; k < contactCount; ++k, o += 32)
    f.contacts.push({ vertex: dv.getUint32(o, true), c: [dv.getFloat64(o + 8, true), dv.getFloat64(o + 16, true), dv.getFloat64(o + 24, true)] });
  f.hips = [];
  for (let h = 0; h < hipCount; ++h, o += 104) {
    const v3 = (p) => [dv.getFloat64(p, true), dv.getFloat64(p + 8, true), dv.getFloat64(p + 16, true)];
    f.hips.push({ inContact: dv.getUint32(o, true), vertex: dv.getUint32(o + 4, true), fullFe: dv.getUint32(o + 8, true),
      flags: dv.getUint32(o + 12, true), force: v3(o + 16), kernelDisplacement: v3(o + 40), felt: v3(o + 64),
      staticStiffness: dv.getFloat64(o + 88, true), validityForce: dv.getFloat64(o + 96, true) });
  }
  f.bytes = buffer.byteLength;
  return f;
}

// The displacement of one vertex in double, from the same Phi, q and corrections as the shader:
// what the panel prints and the browser test compares with the kernel's own reconstruction.
function vertexDisplacement(frame, v) {
  const space = basis.spaces[frame.space], r = frame.r, phi = space.phi64 ?? space.phi32;
  const u = [0, 0, 0];
  for (let i = 0; i < r; ++i) for (let c = 0; c < 3; ++c) u[c] += frame.q[i] * phi[(v * r + i) * 3 + c];
  for (const contact of frame.contacts) {
    let w = contact.vertex === v ? 1 : 0;
    if (rho > 0) {
      let d2 = 0;
      for (let c = 0; c < 3; ++c) { const d = basis.vertices[3 * v + c] - basis.vertices[3 * contact.vertex + c]; d2 += d * d; }
      const s = Math.max(0, 1 - d2 / (rho * rho)); w = s * s;
    }
    for (let c = 0; c < 3; ++c) u[c] += w * contact.c[c];
  }
  return u;
}

// ------------------------------------------------------------------------------------- the tabs
// Each tab owns its display state: what the colours mean (its legend), its amplification, its status
// word and the space it shows. A tab draws from its own state only, so a visit to Modes or Validation
// leaves Live as it was.
const SCALE_FLOOR = 1e-6; // [m] the top of the live colour scale at rest
const live = state.live = { status: 'connecting…', scaleMax: SCALE_FLOOR, autoExaggeration: true };
const orbitHint = 'drag the background: rotate · right-drag: pan · wheel: zoom';
const hints = {
  live: state.watchOnly ? `${orbitHint} · watch-only: the session drives the HIPs`
    : state.sliding ? `press the part: HIP 0 pushes there with ${slideForceN} N (shift: HIP 1); drag over the part: it slides · ${orbitHint}`
    : `click the part: HIP 0 presses there (shift-click: HIP 1), drag away to press harder · ${orbitHint}`,
  modes: `${orbitHint} · presses only on the Live tab`,
  validation: `${orbitHint} · presses only on the Live tab`,
  stiffness: `point at the part: its stiffness at the contact there${comparison ? ' (and design B\'s)' : ''} · ${orbitHint} · presses only on the Live tab`,
};
const statusOf = {
  live: () => live.status,
  modes: () => `modes (offline): ${$('mode-text').textContent} of space ${spaceName(Number($('mode-space').value))}, not the live part`,
  validation: () => `validation (offline): ${$('validation-kind').selectedOptions[0].text} contact errors of space ${spaceName(Number($('validation-space').value))}`,
  stiffness: () => (showingDifference() ? `stiffness (offline): design B (${comparison.file.split('/').pop()}) against this basis, B − A in % of A`
    : info.felt_stiffness_map ? 'stiffness (offline): the felt-stiffness map, each vertex from its region\'s space'
    : 'stiffness (offline): this basis has no felt-stiffness map'),
};
function showStatus() { $('status').textContent = statusOf[state.mode](); }
function setLiveStatus(text) { live.status = text; showStatus(); }
const spaceName = (s) => `${s} '${info.spaces[s].name}'`;

// A legend: what the colours mean, `colour` mapping [0, 1] to a THREE.Color; the end labels get
// the ids ID-low and ID-high.
function showLegend(id, title, colour, low, high) {
  const stops = Array.from({ length: 9 }, (_, i) => `#${colour(i / 8).getHexString()}`).join(', ');
  $(id).innerHTML = `<div class="row"><span>${title}</span></div>
    <div class="legend-bar" style="background: linear-gradient(to right, ${stops})"></div>
    <div class="row num"><span id="${id}-low">${low}</span><span id="${id}-high">${high}</span></div>`;
}
showLegend('modes-legend', '|φ| (mode shape magnitude, relative to its largest)', turbo, '0', '1');
showLegend('validation-legend', 'contact error (relative, log scale)', (x) => errorColor(10 ** (12 * x - 12)), '1e-12', '1');

// ------------------------------------------------------------------------------------- the socket
const socket = new WebSocket(socketUrl());
socket.binaryType = 'arraybuffer';
socket.onopen = () => setLiveStatus(state.watchOnly ? `watching modal-rt ${session.driver} (watch-only)` : 'live');
socket.onclose = () => setLiveStatus('disconnected (no session): offline tabs only');
socket.onmessage = (event) => {
  if (typeof event.data === 'string') { if (event.data.startsWith('error')) setLiveStatus(event.data); return; }
  const f = parseFrame(event.data);
  if (!f) return;
  trackPresses(f);
  latest = f; freshFrame = true; ++received; ++state.frames; state.bytesPerFrame = f.bytes;
};

// The displacement along the inward surface normal (the direction the mouse presses).
function alongNormal(u, v) {
  return -(u[0] * basis.normals[3 * v] + u[1] * basis.normals[3 * v + 1] + u[2] * basis.normals[3 * v + 2]);
}

// A new press (a HIP comes into contact, or moves to another vertex) starts a new force-displacement
// curve and a new colour scale; a release keeps both, so the last press can be inspected until the
// next one starts.
function trackPresses(f) {
  let newPress = false;
  f.hips.forEach((hip, h) => {
    const view = hips[h];
    if (hip.inContact !== 1) { view.vertex = null; view.inContact = false; return; }
    // The kernel's output position: the felt point (a proxy's on the deformed surface).
    hip.position = restPosition(hip.vertex).add(new THREE.Vector3(...hip.felt)).toArray();
    if (!view.inContact) view.pathPoints = 0; // a new contact starts a new path
    view.inContact = true;
    if (view.pathPoints < PATH_POINTS) {
      view.path.geometry.attributes.position.array.set(hip.position, 3 * view.pathPoints++);
      view.path.geometry.attributes.position.needsUpdate = true;
      view.path.geometry.setDrawRange(0, view.pathPoints);
    }
    if (state.sliding) { // a slide is one press: its curve runs on over the vertices it passes
      if (view.vertex === null) { view.history = []; newPress = true; }
      view.vertex = hip.vertex;
    } else if (view.vertex !== hip.vertex) { view.history = []; view.vertex = hip.vertex; newPress = true; }
    hip.js = vertexDisplacement(f, hip.vertex);
    view.history.push([Math.max(0, alongNormal(hip.felt, hip.vertex)), Math.hypot(...hip.force)]);
    view.validityForce = hip.validityForce; // the plot's validity line: the press's, kept after the release
    if (view.history.length > 2000) view.history.shift();
  });
  if (newPress) live.scaleMax = SCALE_FLOOR;
  for (const hip of f.hips) if (hip.inContact === 1) live.scaleMax = Math.max(live.scaleMax, Math.hypot(...hip.js));
}

// ------------------------------------------------------------------------------------- the mouse
const raycaster = new THREE.Raycaster();
let drag = null;
function send(text) { if (socket.readyState === WebSocket.OPEN) socket.send(text); }
// The display vertex a ray's hit stands for: the hit triangle's corner nearest to the hit point.
function nearestCorner(hit) {
  let best = hit.face.a, bestD = Infinity;
  for (const v of [hit.face.a, hit.face.b, hit.face.c]) {
    const d = restPosition(v).distanceToSquared(hit.point);
    if (d < bestD) { bestD = d; best = v; }
  }
  return best;
}
function pointerNdc(event) {
  const rect = renderer.domElement.getBoundingClientRect();
  return new THREE.Vector2(((event.clientX - rect.left) / rect.width) * 2 - 1, -((event.clientY - rect.top) / rect.height) * 2 + 1);
}
renderer.domElement.addEventListener('pointerdown', (event) => {
  if (event.button !== 0 || state.mode !== 'live' || state.watchOnly) return;
  raycaster.setFromCamera(pointerNdc(event), camera);
  const hit = raycaster.intersectObject(mesh)[0];
  if (!hit) return; // the background: OrbitControls turns the view
  const best = nearestCorner(hit); // the snap
  const hip = event.shiftKey ? 1 : 0;
  const pixel = 2 * hit.distance * Math.tan(THREE.MathUtils.degToRad(camera.fov / 2)) / renderer.domElement.clientHeight;
  drag = { hip, vertex: best, x: event.clientX, y: event.clientY, pixel, force: 0 };
  controls.enabled = false;
  renderer.domElement.setPointerCapture(event.pointerId);
  if (state.sliding) { slideTo(hit, hip); return; }
  send(`press ${hip} ${best} 0`);
  state.pressed = { hip, vertex: best, force: 0, pixelMetres: pixel };
});
// Sliding contacts: the HIP goes under the point of the part under the pointer (at rest: the mesh the
// ray meets is the rest one), the nearest vertex's normal pressing, with the slide force.
function slideTo(hit, hip) {
  const best = nearestCorner(hit);
  const p = hit.point;
  send(`slide ${hip} ${best} ${p.x} ${p.y} ${p.z} ${slideForceN}`);
  state.pressed = { hip, vertex: best, force: slideForceN, point: p.toArray() };
}
renderer.domElement.addEventListener('pointermove', (event) => {
  if (!drag) return;
  if (state.sliding) {
    raycaster.setFromCamera(pointerNdc(event), camera);
    const hit = raycaster.intersectObject(mesh)[0];
    if (hit) slideTo(hit, drag.hip); // off the part: the HIP stays where it was
    return;
  }
  const travel = Math.hypot(event.clientX - drag.x, event.clientY - drag.y) * drag.pixel; // [m]
  drag.force = springNPerM * travel;
  state.pressed = { hip: drag.hip, vertex: drag.vertex, force: drag.force, travel, pixelMetres: drag.pixel };
  send(`press ${drag.hip} ${drag.vertex} ${drag.force}`);
});
renderer.domElement.addEventListener('pointerup', () => {
  if (!drag) return;
  if (!$('hold').checked) send(`release ${drag.hip}`);
  drag = null; controls.enabled = true;
});
$('release-all').onclick = () => { send('release 0'); send('release 1'); };

// ------------------------------------------------------------------------------------- panels
const fmt = (x, digits = 4) => (Number.isFinite(x) ? x.toPrecision(digits) : '–');
// A length in mm, 4 significant digits. Below ZERO_FRACTION of the colour scale's top a value is
// rounding noise (a decayed mode leaves 1e-93 m) and is printed as 0.
const ZERO_FRACTION = 1e-6;
function formatMm(metres, scale) {
  if (!Number.isFinite(metres)) return '–';
  return Math.abs(metres) < ZERO_FRACTION * scale ? '0 mm' : `${(metres * 1000).toPrecision(4)} mm`;
}
const restPosition = (v) => new THREE.Vector3(basis.vertices[3 * v], basis.vertices[3 * v + 1], basis.vertices[3 * v + 2]);
const restMm = (v) => restPosition(v).multiplyScalar(1000).toArray().map((x) => x.toFixed(1));
// Where a vertex is: its rest position and its region (the VOI it lies in, or none).
function whereText(v) {
  const region = basis.regions[v];
  const voi = region > 0 && region < info.spaces.length ? `VOI '${info.spaces[region].name}'` : 'outside every VOI (global)';
  return { at: `(${restMm(v).join(', ')}) mm`, voi };
}

function hipPanel(h, hip, space) {
  const F = Math.hypot(...hip.force), v = hip.vertex;
  const along = alongNormal(hip.felt, v);
  const felt = along > 0 ? F / along / 1000 : NaN;
  const where = whereText(v);
  return `<div style="color:#${hipColors[h].toString(16)}"><b>HIP ${h}</b> vertex ${v}</div>
    <div class="row"><span>at rest</span><span class="num" id="hip${h}-at">${where.at}</span></div>
    <div class="row"><span>region</span><span id="hip${h}-region">${escaped(where.voi)}; kernel's space ${escaped(spaceName(space))}</span></div>
    <div class="row"><span>force</span><span class="num" id="hip${h}-force" data-value="${F}">${F.toFixed(4)} N</span></div>
    <div class="row"><span>|u| (magnitude)</span><span class="num" id="hip${h}-u" data-value="${hip.js.join(',')}">${formatMm(Math.hypot(...hip.js), live.scaleMax)}</span></div>
    <div class="row"><span>u·n (along the surface normal)</span><span class="num" id="hip${h}-un">${formatMm(along, live.scaleMax)}</span></div>
    <div class="row"><span>stiffness at the contact (live) F/(u·n)</span><span class="num">${fmt(felt)} N/mm</span></div>
    <div class="row"><span>static stiffness</span><span class="num">${fmt(hip.staticStiffness / 1000)} N/mm ${hip.fullFe ? '(full FE)' : '(modal only: not a candidate)'}</span></div>${validityRow(h, hip, F)}${state.sliding ? proxyRows(h, hip) : ''}`;
}

// The contact's validity force at the kernel's level, and whether the force is beyond it (the kernel's flag).
function validityRow(h, hip, F) {
  if (!info.validity_map) return '';
  const beyond = (hip.flags & BEYOND_VALIDITY) !== 0;
  const text = !(hip.validityForce > 0) ? 'no value here' : hip.validityForce >= 1e29 ? 'not reached'
    : `${fmt(hip.validityForce)} N: ${beyond ? 'BEYOND (linear stiffness off by more than ' + validityLevel + ' %)' : `within (${F.toFixed(3)} N)`}`;
  return `<div class="row"><span>validity force F${validityLevel}</span><span class="num" id="hip${h}-validity" data-value="${hip.validityForce}" data-beyond="${beyond ? 1 : 0}"${beyond ? ` style="color:${beyondText}"` : ''}>${text}</span></div>`;
}

// A sliding contact: whether its proxy slides, the force across the normal (friction) and along it.
function proxyRows(h, hip) {
  const v = hip.vertex, n = [0, 1, 2].map((d) => basis.normals[3 * v + d]);
  const along = hip.force.reduce((sum, f, d) => sum + f * n[d], 0);
  const across = Math.hypot(...hip.force.map((f, d) => f - along * n[d]));
  return `<div class="row"><span>proxy</span><span id="hip${h}-proxy">${(hip.flags & 128) ? 'sliding' : 'stuck'}, path ${hips[h].pathPoints} points</span></div>
    <div class="row"><span>friction |F_t| / normal F_n</span><span class="num">${across.toFixed(4)} N / ${along.toFixed(4)} N</span></div>`;
}

function drawPlot(pressing) {
  const canvas = $('plot'), g = canvas.getContext('2d');
  g.clearRect(0, 0, canvas.width, canvas.height);
  let maxU = 1e-6, maxF = 1e-3;
  for (const hip of hips) for (const [u, f] of hip.history) { maxU = Math.max(maxU, u); maxF = Math.max(maxF, f); }
  // A press's validity force as a dashed line, when within five times the largest force shown (the scale grows to it).
  const lines = hips.map((hip) => (hip.history.length && hip.validityForce > 0 && hip.validityForce <= 5 * maxF ? hip.validityForce : null));
  for (const line of lines) if (line !== null) maxF = Math.max(maxF, 1.05 * line);
  g.strokeStyle = '#555'; g.strokeRect(40, 10, canvas.width - 50, canvas.height - 40);
  g.fillStyle = '#aaa'; g.font = '20px sans-serif';
  g.fillText(`u·n [mm], along the surface normal (max ${(maxU * 1000).toPrecision(3)})`, 50, canvas.height - 5);
  g.save(); g.translate(25, canvas.height - 40); g.rotate(-Math.PI / 2); g.fillText(`F [N] (max ${maxF.toPrecision(3)})`, 0, 0); g.restore();
  if (!pressing && hips.some((hip) => hip.history.length)) g.fillText('last press (released)', 50, 34);
  hips.forEach((hip, h) => {
    g.strokeStyle = '#' + hipColors[h].toString(16); g.beginPath();
    hip.history.forEach(([u, f], i) => {
      const x = 40 + (u / maxU) * (canvas.width - 50), y = canvas.height - 30 - (f / maxF) * (canvas.height - 40);
      if (i) g.lineTo(x, y); else g.moveTo(x, y);
    });
    g.stroke();
    if (lines[h] === null) return;
    const y = canvas.height - 30 - (lines[h] / maxF) * (canvas.height - 40);
    g.setLineDash([10, 8]); g.beginPath(); g.moveTo(40, y); g.lineTo(canvas.width - 10, y); g.stroke(); g.setLineDash([]);
    g.fillText(`F${validityLevel} validity ${lines[h].toPrecision(3)} N`, canvas.width - 260, y - 6);
  });
  state.plotPoints = hips.map((hip) => hip.history.length);
  state.plotValidity = lines;
}

// Live amplification: automatic (the largest |u| drawn as 6 % of the part's size, at least ×1) until
// the slider is moved; the slider is in decades, 10^x.
$('exaggeration').addEventListener('input', () => { live.autoExaggeration = false; });
function liveExaggeration() {
  if (!live.autoExaggeration) return 10 ** Number($('exaggeration').value);
  const e = Math.max(1, (0.06 * size) / live.scaleMax);
  $('exaggeration').value = Math.log10(e);
  return e;
}

// What every tab sets before drawing: the space, q, the contacts, the amplification and the colour.
function applyModal(spaceIndex, q, contacts, { exaggeration, scaleMax, plain, stiffness = 0, difference = 0 }) {
  uniforms.phi.value = textures[spaceIndex];
  uniforms.r.value = basis.spaces[spaceIndex].r;
  for (let i = 0; i < maxModes; ++i) uniforms.q.value[i >> 2].setComponent(i & 3, i < q.length ? q[i] : 0);
  for (let k = 0; k < 2; ++k) {
    const c = contacts[k];
    uniforms.contactOn.value[k] = c ? 1 : 0;
    if (!c) continue;
    uniforms.contactVertex.value[k] = c.vertex;
    uniforms.contactPos.value[k].copy(restPosition(c.vertex));
    uniforms.contactC.value[k].set(...c.c);
  }
  uniforms.exaggeration.value = exaggeration; uniforms.scaleMax.value = scaleMax; uniforms.plain.value = plain;
  uniforms.stiffnessOn.value = stiffness; uniforms.differenceOn.value = difference;
  voiBoxes.forEach((box, i) => { if (box) box.material.color.set(i === spaceIndex ? 0xffd34f : 0x667788); });
}

// The Live tab, from the latest frame (or the part at rest before the first one). `fresh`: a new
// frame, counted in the frame-age figures.
function drawLive(f, fresh) {
  const e = liveExaggeration();
  $('exaggeration-value').textContent = `×${e.toPrecision(3)}`;
  const top = formatMm(live.scaleMax, 0);
  if ($('live-legend-high')?.textContent !== top) showLegend('live-legend', '|u| (displacement magnitude)', turbo, '0 mm', top);
  applyModal(f?.space ?? 0, f?.q ?? [], f?.contacts ?? [], { exaggeration: e, scaleMax: live.scaleMax, plain: 0 });
  if (!f) return;
  $('space').textContent = `${spaceName(f.space)} (r = ${basis.spaces[f.space].r})`;
  state.space = f.space; state.tick = f.tick; state.hapticTick = f.stats[0];
  if (fresh) { state.ageMs.push(Date.now() - f.tickWallMs); if (state.ageMs.length > 600) state.ageMs.shift(); }
  let html = '';
  state.hips = f.hips.map((hip, h) => {
    const shown = showHip(hip, h, e, f.stats[0]);
    if (shown.inContact) html += hipPanel(h, hip, f.space);
    return shown;
  });
  $('hips').innerHTML = html || `<small>no contact${state.watchOnly ? '' : ': click the part'}</small>`;
  showTicks(f.stats);
  drawPlot(state.hips.some((h) => h.inContact));
}

// One HIP in the scene: a sphere where it is felt (amplified as the part), the force arrow, a label.
function showHip(hip, h, e, tick) {
  const view = hips[h];
  const show = hip.inContact === 1;
  view.sphere.visible = view.arrow.visible = show;
  view.label.style.display = show ? 'block' : 'none';
  if (!show) return { inContact: 0 };
  const F = Math.hypot(...hip.force);
  const beyond = (hip.flags & BEYOND_VALIDITY) !== 0, color = beyond ? beyondColor : hipColors[h];
  view.sphere.material.color.setHex(color); view.arrow.setColor(color);
  view.label.style.color = `#${color.toString(16).padStart(6, '0')}`;
  // At the felt point; a proxy's offset from its vertex is not amplified, the part's displacement is.
  const at = state.sliding ? new THREE.Vector3(...hip.position).add(new THREE.Vector3(...hip.js).multiplyScalar(e - 1))
    : restPosition(hip.vertex).add(new THREE.Vector3(...hip.js).multiplyScalar(e));
  view.sphere.position.copy(at);
  if (F > 0) {
    const dir = new THREE.Vector3(...hip.force).normalize();
    view.arrow.position.copy(at.clone().sub(dir.clone().multiplyScalar(size * 0.12)));
    view.arrow.setDirection(dir); view.arrow.setLength(size * 0.12, size * 0.03, size * 0.015);
  }
  const p = at.clone().project(camera);
  view.label.style.left = `${(p.x * 0.5 + 0.5) * container.clientWidth + 8}px`;
  view.label.style.top = `${(-p.y * 0.5 + 0.5) * container.clientHeight - 24}px`;
  view.label.textContent = `${F.toFixed(3)} N${beyond ? ` beyond F${validityLevel}` : ''}`;
  return { inContact: 1, vertex: hip.vertex, tick, force: hip.force, forceN: F, displacement: hip.js, kernelDisplacement: hip.kernelDisplacement, felt: hip.felt,
    position: hip.position, flags: hip.flags, sliding: (hip.flags & 128) !== 0, pathPoints: view.pathPoints, staticStiffness: hip.staticStiffness,
    beyond, validityForce: hip.validityForce, sphereColor: view.sphere.material.color.getHex() };
}

// The haptic loop's figures: each over the server's last closed one-second window.
function showTicks(s) {
  const us = (x) => (Number.isFinite(x) ? x.toFixed(1) : '–');
  $('ticks').innerHTML = `ticks ${s[0]} (rejected ${s[1]}), ${s[7].toFixed(0)} Hz<br>over the last second:<br>`
    + `tick p50 ${us(s[2])} µs, p99 ${us(s[3])} µs, max ${us(s[4])} µs<br>wake-up lateness p99 ${us(s[5])} µs, max ${us(s[6])} µs`;
}

// The Modes tab: one mode animated at 1 Hz. The colour is |φ| relative to the mode's largest (it
// does not pulse); the amplification (×1: the crest at 5 % of the part's size) moves the vertices.
function drawModes(now) {
  const s = Number($('mode-space').value), i = Number($('mode-index').value);
  const space = basis.spaces[s];
  let maxPhi = 0;
  for (let v = 0; v < basis.nv; ++v) {
    const t = (v * space.r + i) * 3;
    maxPhi = Math.max(maxPhi, Math.hypot(space.phi32[t], space.phi32[t + 1], space.phi32[t + 2]));
  }
  const q = new Array(space.r).fill(0);
  q[i] = maxPhi > 0 ? 1 / maxPhi : 0; // the largest |u| is 1 (m): the colour scale's top
  const amplification = 10 ** Number($('mode-amplification').value);
  $('mode-amplification-value').textContent = `×${amplification.toPrecision(3)}`;
  $('mode-text').textContent = `mode ${i + 1}: ${info.spaces[s].frequencies_hz[i].toFixed(2)} Hz`;
  const exaggeration = 0.05 * size * amplification * Math.sin(2 * Math.PI * now / 1000);
  applyModal(s, q, [], { exaggeration, scaleMax: 1, plain: 0 });
  showStatus();
}

// The Validation tab: the part at rest in grey, the candidates as points coloured by the largest
// error of the chosen kind over their cases, and the cases in a table of that same error.
function validationErrors(s, kind) {
  const rows = report?.spaces?.[s]?.validation ?? [];
  const errorOf = (row) => (kind === 'modal' ? row.contact_rel_error_modal : row.contact_rel_error_corrected);
  // report.json's rows by vertex and direction ("x"), the kernel's self-check by vertex and index (0)
  const fromReport = new Map(rows.map((row) => [`${row.vertex} ${row.direction}`, errorOf(row)]));
  const cases = info.spaces[s].validation.map((c) => {
    const error = rows.length ? fromReport.get(`${c.vertex} ${'xyz'[c.direction]}`) : (kind === 'corrected' ? c.kernel_rel_error : undefined);
    return { vertex: c.vertex, direction: 'xyz'[c.direction], error, kernel: c.kernel_rel_error };
  });
  return { cases, fromReport: rows.length > 0 };
}
function showValidation() {
  const s = Number($('validation-space').value), kind = $('validation-kind').value;
  const { cases, fromReport } = validationErrors(s, kind);
  const byVertex = new Map();
  for (const c of cases) if (c.error !== undefined) byVertex.set(c.vertex, Math.max(byVertex.get(c.vertex) ?? 0, c.error));
  const positions = [], colors = [];
  for (const v of info.spaces[s].candidates) {
    positions.push(...restPosition(v).toArray());
    const e = byVertex.get(v);
    const c = e === undefined ? new THREE.Color(0x999999) : errorColor(e);
    colors.push(c.r, c.g, c.b);
  }
  validationPoints.geometry.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
  validationPoints.geometry.setAttribute('color', new THREE.Float32BufferAttribute(colors, 3));
  const kindName = $('validation-kind').selectedOptions[0].text;
  const swatch = (e) => (e === undefined ? '' : `<span style="color:#${errorColor(e).getHexString()}">●</span> `);
  let table = `<table id="validation-cases"><tr><th>vertex</th><th>dir</th><th>${kindName} error</th><th>kernel self-check</th></tr>`;
  for (const c of cases) table += `<tr><td>${c.vertex}</td><td>${c.direction}</td><td data-value="${c.error ?? ''}">${swatch(c.error)}${fmt(c.error, 3)}</td><td>${fmt(c.kernel, 3)}</td></tr>`;
  const note = fromReport ? '' : `<small>no report.json beside the basis: ${kind === 'modal' ? 'no modal-only errors; ' : ''}the corrected error is the kernel's self-check</small>`;
  $('validation-table').innerHTML = `${table}</table>${note}`;
  applyModal(s, [], [], { exaggeration: 1, scaleMax: 1, plain: 1 });
  showStatus();
}

// The Stiffness tab: the part at rest coloured by the scene's felt-stiffness map (each vertex from its
// region's space; grey where it has none), and the value at the vertex under the pointer. Log scale
// from the map's smallest value to its 95th percentile, stiffer drawn as the top colour: vertices on a
// clamp are almost rigid (up to 5e7 N/mm on the default scene, against 4.5 to 950 N/mm elsewhere) and
// would leave the rest of the part one colour.
const STIFFNESS_TOP_PERCENTILE = 0.95;
const stiffnessRange = (() => {
  const values = basis.stiffness.filter((k) => k > 0).sort();
  const n = values.length;
  return { low: values[0], high: values[Math.max(0, Math.ceil(STIFFNESS_TOP_PERCENTILE * n) - 1)], max: values[n - 1], computed: n };
})();
const nPerMm = (k) => `${k.toPrecision(4)} N/mm`;
// With --compare: the difference map instead, B − A in % of A, a diverging scale symmetric about 0 up
// to the 95th percentile of |%| (at least twice the noise floor), the noise floor drawn as no difference.
const showingDifference = () => comparison !== null && $('stiffness-show').value === 'difference';
const differenceScale = (() => {
  if (!comparison) return 0;
  const magnitudes = comparison.percent.filter((p) => p !== null).map(Math.abs).sort((a, b) => a - b);
  const top = magnitudes.length ? magnitudes[Math.max(0, Math.ceil(STIFFNESS_TOP_PERCENTILE * magnitudes.length) - 1)] : 0;
  return Math.max(top, 2 * comparison.noise_floor_percent, 1e-9);
})();
const signedPercent = (p) => `${p >= 0 ? '+' : ''}${p.toFixed(3)} %`;
function showDifference() {
  const c = comparison, range = differenceScale;
  showLegend('stiffness-legend', `B − A in % of A (white: within the noise floor, ${c.noise_floor_percent} %; grey: not compared)`,
    (x) => diverging(2 * x - 1), `−${range.toPrecision(3)} % (B softer)`, `+${range.toPrecision(3)} % (B stiffer)`);
  $('stiffness-range').textContent = `${c.rule}, match ≤ ${formatMm(c.match_distance_max_m, size)}; ratio B/A ${c.ratio.min.toFixed(4)} / ${c.ratio.median.toFixed(4)} / ${c.ratio.max.toFixed(4)}; ${c.beyond_noise} of ${c.compared} beyond the floor`;
  uniforms.differenceRange.value = range;
  uniforms.noiseFloor.value = c.noise_floor_percent;
  applyModal(0, [], [], { exaggeration: 1, scaleMax: 1, plain: 0, difference: 1 });
  showStatus();
}
function showStiffness() {
  if (showingDifference()) return showDifference();
  const { low, high, max, computed } = stiffnessRange;
  if (computed > 0) {
    showLegend('stiffness-legend', 'felt stiffness, pressing straight in (log scale; grey: not computed)',
      (x) => turbo(x), nPerMm(low), `${high < max ? '≥ ' : ''}${nPerMm(high)}`);
    $('stiffness-range').textContent = `${computed} of ${basis.nv} vertices, ${nPerMm(low)} – ${nPerMm(max)}`;
  } else {
    $('stiffness-legend').innerHTML = '<small>this basis has no felt-stiffness map (FELT_STIFFNESS, .mrt 1.1): the part is grey</small>';
    $('stiffness-range').textContent = '–';
  }
  uniforms.stiffnessLogLow.value = Math.log(computed > 0 ? low : 1);
  uniforms.stiffnessLogHigh.value = Math.log(computed > 0 ? high : 10);
  applyModal(0, [], [], { exaggeration: 1, scaleMax: 1, plain: 0, stiffness: 1 });
  showStatus();
}
const stiffnessLabel = document.createElement('div');
stiffnessLabel.className = 'label'; stiffnessLabel.style.display = 'none';
$('labels').appendChild(stiffnessLabel);
renderer.domElement.addEventListener('pointermove', (event) => {
  if (state.mode !== 'stiffness') return;
  raycaster.setFromCamera(pointerNdc(event), camera);
  const hit = raycaster.intersectObject(mesh)[0];
  if (!hit) { stiffnessLabel.style.display = 'none'; return; }
  const v = nearestCorner(hit), k = basis.stiffness[v];
  let text = k > 0 ? nPerMm(k) : 'not computed';
  if (showingDifference()) {
    const p = comparison.percent[v], b = comparison.b_n_per_mm[v];
    text = p === null ? `A ${text}, B ${b ? nPerMm(b) : 'none'}: not compared`
      : `A ${text}, B ${nPerMm(b)}: ${signedPercent(p)}${Math.abs(p) <= comparison.noise_floor_percent ? ' (within the noise floor)' : ''}`;
  }
  $('stiffness-vertex').textContent = `${v} (${whereText(v).voi})`;
  $('stiffness-vertex').dataset.value = v;
  $('stiffness-value').textContent = text;
  $('stiffness-value').dataset.value = k;
  const rect = renderer.domElement.getBoundingClientRect();
  stiffnessLabel.textContent = `vertex ${v}: ${text}`;
  stiffnessLabel.style.left = `${event.clientX - rect.left + 12}px`;
  stiffnessLabel.style.top = `${event.clientY - rect.top - 24}px`;
  stiffnessLabel.style.display = 'block';
});

function reportTables() {
  let html = '<table><tr><th>space</th><th>r</th><th>f [Hz]</th><th>cand.</th><th>cross</th></tr>';
  info.spaces.forEach((s) => {
    html += `<tr><td>${escaped(s.name)}</td><td>${s.modes}</td><td>${s.frequencies_hz[0].toFixed(1)}–${s.frequencies_hz[s.modes - 1].toFixed(1)}</td><td>${s.candidates.length}</td><td>${s.cross ? 'yes' : 'no'}</td></tr>`;
  });
  html += '</table>';
  if (report) {
    html += '<table><tr><th>space</th><th>DoFs</th><th>max err. modal</th><th>max err. corr.</th></tr>';
    for (const s of report.spaces ?? []) {
      const v = s.validation ?? [];
      const m = Math.max(0, ...v.map((x) => x.contact_rel_error_modal)), c = Math.max(0, ...v.map((x) => x.contact_rel_error_corrected));
      html += `<tr><td>${escaped(s.name)}</td><td>${escaped(s.n_dofs)}</td><td>${fmt(m, 3)}</td><td>${fmt(c, 3)}</td></tr>`;
    }
    html += '</table>';
    if (report.timings_s) html += '<table>' + Object.entries(report.timings_s).map(([k, t]) => `<tr><td>${escaped(k)}</td><td>${Number(t).toFixed(2)} s</td></tr>`).join('') + '</table>';
  } else html += '<small>no report.json beside the basis</small><br>';
  html += `<small>basis: ${info.vertices} vertices, ${info.triangles} triangles, ${(state.basisBytes / 1e6).toFixed(2)} MB sent once</small>`;
  $('report').innerHTML = html;
}

// Tabs: a switch shows the tab's panel, hint and status; Live redraws from its own state at once.
const TABS = ['live', 'modes', 'validation', 'stiffness'];
function selectTab(name) {
  state.mode = name;
  for (const other of TABS) {
    $(`tab-${other}`).classList.toggle('on', other === name);
    $(`${other}-panel`).style.display = other === name ? '' : 'none';
  }
  validationPoints.visible = name === 'validation';
  hips.forEach((h) => { h.sphere.visible = h.arrow.visible = false; h.label.style.display = 'none'; });
  $('hint').textContent = hints[name];
  if (name !== 'stiffness') stiffnessLabel.style.display = 'none';
  if (name === 'validation') showValidation();
  if (name === 'stiffness') showStiffness();
  if (name === 'live') drawLive(latest, false);
  showStatus();
}
for (const name of TABS) $(`tab-${name}`).onclick = () => selectTab(name);
for (const id of ['mode-space', 'validation-space'])
  info.spaces.forEach((s, i) => $(id).add(new Option(`${i} ${s.name}`, i)));
$('mode-space').onchange = () => { $('mode-index').max = info.spaces[Number($('mode-space').value)].modes - 1; };
$('mode-space').onchange();
$('validation-space').onchange = $('validation-kind').onchange = showValidation;
if (comparison) {
  $('stiffness-compare').style.display = '';
  $('stiffness-show').options[1].text = `design B ${comparison.file.split('/').pop()} − this basis (%)`;
  $('stiffness-show').onchange = () => { showStiffness(); $('hint').textContent = hints.stiffness; };
}
reportTables();
selectTab('live');

// ------------------------------------------------------------------------------------- the loop
function render(now) {
  requestAnimationFrame(render);
  if (state.mode === 'live' && freshFrame) { drawLive(latest, true); freshFrame = false; ++rendered; ++state.renderedFrames; }
  else if (state.mode === 'modes') drawModes(now);
  controls.update();
  renderer.render(scene, camera);
  if (now - lastSecond >= 1000) {
    state.fps = rendered * 1000 / (now - lastSecond); state.receivedFps = received * 1000 / (now - lastSecond);
    rendered = 0; received = 0; lastSecond = now;
    const sorted = [...state.ageMs].sort((a, b) => a - b);
    state.ageP50 = sorted[Math.floor(sorted.length * 0.5)]; state.ageP95 = sorted[Math.floor(sorted.length * 0.95)];
    $('frames').innerHTML = `${state.fps.toFixed(1)} frames/s drawn (${state.receivedFps.toFixed(1)} received), ${state.bytesPerFrame} bytes/frame<br>frame age tick → screen p50 ${fmt(state.ageP50, 3)} ms, p95 ${fmt(state.ageP95, 3)} ms`;
  }
}
// For tests and benchmarks: the screen position of a display vertex at rest, the canvas, and the
// formatters of lengths and of a vertex's rest position.
window.viewDebug = {
  project(v) {
    const p = restPosition(v).project(camera);
    const rect = renderer.domElement.getBoundingClientRect();
    return { x: rect.left + (p.x * 0.5 + 0.5) * rect.width, y: rect.top + (-p.y * 0.5 + 0.5) * rect.height };
  },
  canvas: renderer.domElement,
  // HIP h's drawn path: how many points, the first and the last [m].
  path(h) {
    const a = hips[h].path.geometry.attributes.position.array, n = hips[h].pathPoints;
    return { points: n, first: n ? Array.from(a.slice(0, 3)) : null, last: n ? Array.from(a.slice(3 * n - 3, 3 * n)) : null };
  },
  formatMm,
  restMm,
};
state.ready = true;
requestAnimationFrame(render);
