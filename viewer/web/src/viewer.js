// The hpr viewer page: the robot posed by the estimate (ROBOT_STATE) and, translucent, by the
// simulator's truth (SIM_TRUTH base pose), the push, CoM, CoP, soles and support polygon, the CAM
// vectors, a time plot and a status line. Live over the Foxglove WebSocket protocol, or a recorded
// run frame by frame from the viewer's /api/log and /api/frame/<i>.
//
// World frame: z up, as the robot's (three.js's default up is y; every object here lives in z-up).
//
// window.hpr is the page's programmatic side (tests and the video renderer drive it):
//   await hpr.ready; await hpr.seek(t); hpr.jointAngles(); hpr.renderNow(); hpr.info; hpr.mode.
import * as THREE from 'three';
import URDFLoader from 'urdf-loader';
import { STLLoader } from 'three/examples/jsm/loaders/STLLoader.js';
import { ColladaLoader } from 'three/examples/jsm/loaders/ColladaLoader.js';
import { OBJLoader } from 'three/examples/jsm/loaders/OBJLoader.js';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { TimePlot } from './plot.js';
import { FoxgloveClient } from './foxglove.js';

THREE.Object3D.DEFAULT_UP.set(0, 0, 1);

const params = new URLSearchParams(location.search);
const renderMode = params.has('render');  // video frames: no controls, fixed size, a label
if (renderMode) document.body.classList.add('render');

const COLORS = { ref: 0xe0662b, cmd: 0x2b7be0, meas: 0x2bb04a, push: 0xd62728, com: 0xf2c12e, cop: 0x8e44ad, sole: 0x555f6b, support: 0x1f77b4, capture: 0x00a6a6, step: 0x00a6a6 };
const CAM_SCALE = 0.25;    // [m per N m s]
const PUSH_SCALE = 1 / 150; // [m per N]
const PHASES = ['idle', 'generate', 'reduce', 'recover'];
const SUPPORT = ['double', 'left', 'right'];
const STAGES = ['init', 'hold', 'shift', 'lift', 'lower', 'shift back', 'step unload', 'step swing', 'step settle', 'step recover'];  // BALANCE_PLAN.stage
const STATES = ['starting', 'ok', 'degraded', 'FAULT', 'stopping'];

// ---------------------------------------------------------------------------------------------
// Scene
// ---------------------------------------------------------------------------------------------
const container = document.getElementById('view');
/// Whether WebGL runs on the CPU (SwiftShader, llvmpipe): then the live view skips antialiasing,
/// which halves its frame time there. Videos keep it.
function softwareGL() {
  const gl = document.createElement('canvas').getContext('webgl2');
  const ext = gl?.getExtension('WEBGL_debug_renderer_info');
  const name = ext ? gl.getParameter(ext.UNMASKED_RENDERER_WEBGL) : '';
  gl?.getExtension('WEBGL_lose_context')?.loseContext();
  return /SwiftShader|llvmpipe|softpipe|Software/i.test(name);
}
const software = softwareGL();
const renderer = new THREE.WebGLRenderer({ antialias: renderMode || !software, preserveDrawingBuffer: renderMode });
renderer.setPixelRatio(renderMode || software ? 1 : Math.min(window.devicePixelRatio, 2));
renderer.setSize(window.innerWidth, window.innerHeight);
container.appendChild(renderer.domElement);

const scene = new THREE.Scene();
scene.background = new THREE.Color(0xeef1f4);
const camera = new THREE.PerspectiveCamera(40, window.innerWidth / window.innerHeight, 0.02, 100);
camera.position.set(-1.7, -2.7, 1.3);
const controls = renderMode ? null : new OrbitControls(camera, renderer.domElement);
const target = new THREE.Vector3(0, 0, 0.8);
const viewOffset = new THREE.Vector3(-1.7, -2.7, 0.5);  // from the side and behind: the push and the CAM about y both in view
let renderPan = 0;  // [m] along the screen's right
camera.lookAt(target);
if (controls) { controls.target.copy(target); controls.update(); }

scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8f96, 2.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(2, -3, 5);
scene.add(sun);
const grid = new THREE.GridHelper(10, 40, 0x9aa3ad, 0xc9cfd6);
grid.rotation.x = Math.PI / 2;
scene.add(grid);

/// An arrow of solid geometry (a shaft and a cone along +y, scaled to length), drawn over the body
/// when `onTop` (vectors at the CoM sit inside the trunk).
class FatArrow extends THREE.Group {
  constructor(color, radius, onTop) {
    super();
    const mat = new THREE.MeshBasicMaterial({ color, depthTest: !onTop, transparent: onTop, opacity: onTop ? 0.92 : 1 });
    this.shaft = new THREE.Mesh(new THREE.CylinderGeometry(radius, radius, 1, 12), mat);
    this.head = new THREE.Mesh(new THREE.ConeGeometry(radius * 2.6, 1, 16), mat);
    this.shaft.renderOrder = this.head.renderOrder = onTop ? 5 : 1;
    this.add(this.shaft, this.head);
    this.visible = false;
  }
  /// From `origin` along `dir` (unit) for `length` [m].
  set(origin, dir, length) {
    const headLength = Math.min(0.3 * length, 0.09);
    this.position.copy(origin);
    this.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), dir);
    this.shaft.scale.set(1, Math.max(length - headLength, 1e-4), 1);
    this.shaft.position.set(0, (length - headLength) / 2, 0);
    this.head.scale.set(1, headLength, 1);
    this.head.position.set(0, length - headLength / 2, 0);
    this.visible = true;
  }
}
function arrow(color, radius = 0.008, onTop = true) {
  const a = new FatArrow(color, radius, onTop);
  scene.add(a);
  return a;
}
function setArrow(a, origin, vec, scale, minLength = 0.0) {
  const v = new THREE.Vector3(vec[0] ?? 0, vec[1] ?? 0, vec[2] ?? 0).multiplyScalar(scale);
  const len = v.length();
  if (!(len > 1e-3) || !Number.isFinite(len)) { a.visible = false; return; }
  a.set(origin, v.clone().normalize(), Math.max(len, minLength));
}
const camArrows = { ref: arrow(COLORS.ref), cmd: arrow(COLORS.cmd), meas: arrow(COLORS.meas) };
const pushArrow = arrow(COLORS.push, 0.014, false);
pushArrow.name = 'push';

function marker(color, radius, flat = false) {
  const geo = flat ? new THREE.CircleGeometry(radius, 32) : new THREE.SphereGeometry(radius, 20, 14);
  const m = new THREE.Mesh(geo, new THREE.MeshBasicMaterial({ color, depthTest: false }));
  m.renderOrder = flat ? 2 : 6;
  m.visible = false;
  scene.add(m);
  return m;
}
const comMarker = marker(COLORS.com, 0.035);
const comGround = marker(COLORS.com, 0.025, true);
const copMarker = marker(COLORS.cop, 0.02, true);
const copCmdMarker = new THREE.Mesh(new THREE.RingGeometry(0.022, 0.03, 32), new THREE.MeshBasicMaterial({ color: COLORS.cop }));
copCmdMarker.visible = false;
scene.add(copCmdMarker);
const comLine = new THREE.Line(new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3()]),
  new THREE.LineDashedMaterial({ color: COLORS.com, dashSize: 0.03, gapSize: 0.02 }));
comLine.visible = false;
scene.add(comLine);

const soleLines = [0, 1].map(() => {
  const l = new THREE.LineLoop(new THREE.BufferGeometry().setFromPoints([0, 1, 2, 3].map(() => new THREE.Vector3())),
    new THREE.LineBasicMaterial({ color: COLORS.sole }));
  l.visible = false;
  scene.add(l);
  return l;
});
// The stepping strategy (BALANCE_PLAN; WHOLEBODY_COMMAND carries it too): the capture point it watches (a diamond on the
// ground, red once a step is due) and the landing of the step under way (the sole's outline,
// filled translucent).
// Both are drawn in the transparent pass, after the support polygon, so that its tint stays off them.
const captureMarker = new THREE.Mesh(new THREE.CircleGeometry(0.04, 4), new THREE.MeshBasicMaterial({ color: COLORS.capture, depthTest: false, transparent: true }));
captureMarker.renderOrder = 4;
captureMarker.visible = false;
scene.add(captureMarker);
const stepOutline = new THREE.Group();
stepOutline.add(new THREE.Mesh(new THREE.PlaneGeometry(1, 1), new THREE.MeshBasicMaterial({ color: COLORS.step, transparent: true, opacity: 0.7, depthWrite: false, side: THREE.DoubleSide })));
stepOutline.add(new THREE.LineLoop(new THREE.BufferGeometry().setFromPoints([[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]].map(([x, y]) => new THREE.Vector3(x, y, 0))),
  new THREE.LineBasicMaterial({ color: COLORS.step })));
stepOutline.traverse((o) => { o.renderOrder = 3; });
stepOutline.visible = false;
scene.add(stepOutline);

const supportMesh = new THREE.Mesh(new THREE.BufferGeometry(), new THREE.MeshBasicMaterial({ color: COLORS.support, transparent: true, opacity: 0.18, depthWrite: false, side: THREE.DoubleSide }));
supportMesh.visible = false;
scene.add(supportMesh);

// ---------------------------------------------------------------------------------------------
// Robot
// ---------------------------------------------------------------------------------------------
function loadMesh(path, manager, material, done) {
  const ext = path.split('.').pop().toLowerCase();
  const fail = (err) => done(null, err);
  if (ext === 'stl') {
    new STLLoader(manager).load(path, (geo) => done(new THREE.Mesh(geo, material)), undefined, fail);
  } else if (ext === 'dae') {
    new ColladaLoader(manager).load(path, (dae) => done(dae.scene), undefined, fail);
  } else if (ext === 'obj') {
    new OBJLoader(manager).load(path, (obj) => {
      obj.traverse((c) => { if (c.isMesh) c.material = material; });
      done(obj);
    }, undefined, fail);
  } else {
    fail(new Error(`unsupported mesh format: ${path}`));
  }
}

async function loadRobot() {
  const manager = new THREE.LoadingManager();
  const loader = new URDFLoader(manager);
  loader.loadMeshCb = loadMesh;
  const text = await (await fetch('/robot/robot.urdf')).text();
  const robot = loader.parse(text);
  await new Promise((resolve) => {
    manager.onLoad = resolve;
    // A robot without meshes triggers no load at all.
    setTimeout(() => { if (!manager.itemsLoading) resolve(); }, 0);
  });
  for (const j of Object.values(robot.joints)) j.ignoreLimits = true;  // show what the robot reports
  return robot;
}

function makeGhost(robot) {
  const ghost = robot.clone();
  ghost.traverse((o) => {
    if (o.isMesh) {
      o.material = o.material.clone();
      o.material.transparent = true;
      o.material.opacity = 0.28;
      o.material.depthWrite = false;
      o.material.color.lerp(new THREE.Color(0x7fb2ff), 0.5);
    }
  });
  for (const j of Object.values(ghost.joints)) j.ignoreLimits = true;
  return ghost;
}

// ---------------------------------------------------------------------------------------------
// State and drawing
// ---------------------------------------------------------------------------------------------
const state = { channels: {}, health: {}, t: 0, rate: 0 };
let info = null, robot = null, ghost = null, baseFromRoot = null;
const plot = new TimePlot(document.getElementById('plot-canvas'));
const statusEl = document.getElementById('status');
const labelEl = document.getElementById('label');
const truthBox = document.getElementById('show-truth');
const plotAxis = document.getElementById('plot-axis');
plotAxis.addEventListener('change', () => { plot.axis = Number(plotAxis.value); plot.draw(); });

const unknownJoints = new Set();  // ROBOT_STATE joints this robot does not have (another robot's traffic)
function setJoints(r, msg) {
  if (!msg || !msg.joint_name) return;
  for (let i = 0; i < msg.joint_name.length; ++i) {
    const j = r.joints[msg.joint_name[i]];
    if (!j) unknownJoints.add(msg.joint_name[i]);
    else if (msg.q[i] !== null) j.setJointValue(msg.q[i]);
  }
}

/// Places the URDF root so that the base link has the pose (p, quat wxyz).
function placeBase(r, p, q) {
  if (!p || !q || p.some((x) => x === null) || q.some((x) => x === null)) return false;
  const T_WB = new THREE.Matrix4().compose(new THREE.Vector3(p[0], p[1], p[2]),
    new THREE.Quaternion(q[1], q[2], q[3], q[0]).normalize(), new THREE.Vector3(1, 1, 1));
  // root pose = T_WB * T_BRoot, with T_BRoot from the current joint angles (identity when the base is the root).
  r.position.set(0, 0, 0); r.quaternion.identity(); r.updateMatrixWorld(true);
  const T_RootB = r.links[info.base_link].matrixWorld.clone();
  const T_WRoot = T_WB.multiply(T_RootB.invert());
  T_WRoot.decompose(r.position, r.quaternion, r.scale);
  r.updateMatrixWorld(true);
  return true;
}

function applyHeld(r) {
  for (const [name, q] of Object.entries(info.held)) r.joints[name]?.setJointValue(q);
  for (const [name, q] of Object.entries(info.locked)) r.joints[name]?.setJointValue(q);
}

const _v = new THREE.Vector3();
function solePose(r, foot) {
  const link = r.links[foot.link];
  const s = foot.sole;
  const T_LS = new THREE.Matrix4().compose(new THREE.Vector3(...s.xyz),
    new THREE.Quaternion(s.quat_wxyz[1], s.quat_wxyz[2], s.quat_wxyz[3], s.quat_wxyz[0]), new THREE.Vector3(1, 1, 1));
  return link.matrixWorld.clone().multiply(T_LS);
}

function cross2(o, a, b) { return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x); }
function hull2(points) {
  const p = points.slice().sort((a, b) => a.x - b.x || a.y - b.y);
  if (p.length < 3) return p;
  const lower = [], upper = [];
  for (const q of p) { while (lower.length >= 2 && cross2(lower[lower.length - 2], lower[lower.length - 1], q) <= 0) lower.pop(); lower.push(q); }
  for (const q of p.reverse()) { while (upper.length >= 2 && cross2(upper[upper.length - 2], upper[upper.length - 1], q) <= 0) upper.pop(); upper.push(q); }
  return lower.slice(0, -1).concat(upper.slice(0, -1));
}

function vstanceToWorld(b, xy) {
  const c = Math.cos(b.yaw_WV), s = Math.sin(b.yaw_WV);
  return new THREE.Vector3(b.p_WV[0] + c * xy[0] - s * xy[1], b.p_WV[1] + s * xy[0] + c * xy[1], 0.002);
}

function draw() {
  const ch = state.channels;
  const rs = ch.ROBOT_STATE, truth = ch.SIM_TRUTH, bal = ch.BALANCE_STATUS, cam = ch.CAM_REFERENCE, wb = ch.WHOLEBODY_COMMAND;
  if (!robot) return;
  if (rs) {
    setJoints(robot, rs);
    robot.visible = placeBase(robot, rs.p_WB, rs.quat_WB);
  } else if (truth) {
    robot.visible = placeBase(robot, truth.p_WB, truth.quat_WB);
  }
  ghost.visible = !!(truth && rs && truthBox.checked);
  if (ghost.visible) {
    setJoints(ghost, rs);
    ghost.visible = placeBase(ghost, truth.p_WB, truth.quat_WB);
  }
  // CoM and its ground projection.
  const com = rs?.p_WCom ?? truth?.p_WCom;
  if (com && com.every((x) => x !== null)) {
    comMarker.visible = comGround.visible = comLine.visible = true;
    comMarker.position.set(com[0], com[1], com[2]);
    comGround.position.set(com[0], com[1], 0.003);
    comLine.geometry.setFromPoints([comMarker.position, comGround.position]);
    comLine.computeLineDistances();
    if (!framed) frameRobot(com);
    if (!controls) { target.set(com[0], com[1], 0.8 * com[2]); }
  }
  // CAM vectors from the CoM.
  const origin = comMarker.position;
  setArrow(camArrows.ref, origin, cam?.l_ref_W ?? [0, 0, 0], CAM_SCALE);
  setArrow(camArrows.cmd, origin, wb?.l_cmd_W ?? [0, 0, 0], CAM_SCALE);
  setArrow(camArrows.meas, origin, rs?.l_WCom ?? [0, 0, 0], CAM_SCALE);
  // Push: an arrow ending at its point of application (the simulator's truth).
  pushArrow.visible = false;
  if (truth && truth.push_active && truth.push_point_W.every((x) => x !== null)) {
    const f = truth.push_force_W;
    const p = new THREE.Vector3(...truth.push_point_W);
    const v = new THREE.Vector3(f[0], f[1], f[2]).multiplyScalar(PUSH_SCALE);
    const len = Math.max(v.length(), 0.12);
    const dir = v.clone().normalize();
    setArrow(pushArrow, p.clone().sub(dir.clone().multiplyScalar(len)), dir.toArray(), len, 0.12);
  }
  // Soles and the support polygon (soles in contact by the estimator's force sensing).
  const corners = [];
  info.feet.forEach((foot, k) => {
    const T = solePose(robot, foot);
    const pts = [[1, 1], [-1, 1], [-1, -1], [1, -1]].map(([a, b]) =>
      new THREE.Vector3(a * foot.length / 2, b * foot.width / 2, 0.0).applyMatrix4(T));
    soleLines[k].geometry.setFromPoints(pts);
    soleLines[k].visible = robot.visible;
    const idx = rs?.foot_name ? rs.foot_name.findIndex((n) => n === foot.side || n === foot.link) : -1;
    const contact = idx >= 0 ? rs.foot_contact[idx] : true;
    if (contact) corners.push(...pts.map((q) => new THREE.Vector2(q.x, q.y)));
  });
  const h = hull2(corners);
  supportMesh.visible = h.length >= 3;
  if (supportMesh.visible) {
    const shape = new THREE.Shape(h);
    supportMesh.geometry.dispose();
    supportMesh.geometry = new THREE.ShapeGeometry(shape);
    supportMesh.position.z = 0.001;
  }
  drawStepping(ch.BALANCE_PLAN ?? wb);
  // CoP: measured (disc) and commanded (ring), from the virtual stance foot frame.
  copMarker.visible = copCmdMarker.visible = !!bal;
  if (bal) {
    copMarker.position.copy(vstanceToWorld(bal, bal.cop_measured_V));
    copCmdMarker.position.copy(vstanceToWorld(bal, bal.cop_V));
  }
  drawStatus();
}

function drawStepping(plan) {
  const on = !!(plan?.stepping && plan.xi_W?.every((x) => x !== null));
  captureMarker.visible = on;
  stepOutline.visible = on && plan.step_foot >= 0 && plan.step_foot < info.feet.length && plan.step_target_W.every((x) => x !== null);
  if (!on) return;
  captureMarker.position.set(plan.xi_W[0], plan.xi_W[1], 0.004);
  captureMarker.material.color.setHex(plan.xi_excess > 0 ? COLORS.push : COLORS.capture);
  if (stepOutline.visible) {
    const foot = info.feet[plan.step_foot];
    stepOutline.position.set(plan.step_target_W[0], plan.step_target_W[1], 0.003);
    stepOutline.rotation.set(0, 0, plan.step_target_W[2]);
    stepOutline.scale.set(foot.length, foot.width, 1);
  }
}

/// Once, at the first CoM: the camera's distance scaled to the robot (the CoM of a 1.3 m G1 stands
/// lower than a 1.8 m TORO's), looking at the CoM.
let framed = false;
function frameRobot(com) {
  framed = true;
  const scale = Math.min(1.5, Math.max(0.4, com[2] / 0.9));
  viewOffset.multiplyScalar(scale);
  renderPan *= scale;
  if (controls) {
    controls.target.set(com[0], com[1], 0.8 * com[2]);
    camera.position.copy(controls.target).add(viewOffset);
    controls.update();
  }
}

function fmt(x, d = 2) { return x === null || x === undefined ? '–' : Number(x).toFixed(d); }

function drawStatus() {
  const ch = state.channels, rs = ch.ROBOT_STATE, truth = ch.SIM_TRUTH, bal = ch.BALANCE_STATUS, cam = ch.CAM_REFERENCE;
  const t = truth?.sim_time ?? (rs ? rs.utime * 1e-6 : state.t);
  const parts = [`t ${fmt(t, 3)} s`, `tick ${rs?.tick ?? '–'}`];
  if (mode === 'live') parts.push(`${fmt(state.rate, 0)} Hz`);
  parts.push(`support ${bal ? SUPPORT[bal.support] ?? bal.support : '–'}`);
  if (cam) parts.push(`phase x ${PHASES[cam.phase[0]]}, y ${PHASES[cam.phase[1]]}, z ${PHASES[cam.phase[2]]}`);
  if (truth?.push_active) parts.push(`push ${fmt(Math.hypot(...truth.push_force_W), 0)} N`);
  const plan = ch.BALANCE_PLAN;
  if (plan) {
    const f = Math.hypot(plan.f_ext_W[0] ?? 0, plan.f_ext_W[1] ?? 0);
    parts.push(`plan ${STAGES[plan.stage] ?? plan.stage}${f >= 1 ? `, resisting ${fmt(f, 0)} N` : ''}`);
  }
  const wb = plan ?? ch.WHOLEBODY_COMMAND;
  if (wb?.stepping) {
    parts.push(wb.follow_steps ? `steps ${wb.steps_taken} (${wb.follow_steps} closing up)` : `steps ${wb.steps_taken}`);
    if (wb.step_foot >= 0) parts.push(`${info.feet[wb.step_foot]?.side ?? wb.step_foot} foot lands in ${fmt(wb.step_time_left, 2)} s`);
  }
  if (truth?.fallen) parts.push('FALLEN');
  if (unknownJoints.size) parts.push(`${unknownJoints.size} ROBOT_STATE joints unknown to ${info.name}: another robot? (tools/view --robot)`);
  let line2 = '';
  const nodes = Object.values(state.health).sort((a, b) => a.node.localeCompare(b.node));
  if (nodes.length) {
    line2 = '\n' + nodes.map((n) => {
      const s = `${n.node} ${STATES[n.state] ?? n.state} ${fmt(n.rate_hz, 0)} Hz`;
      return n.faults.length ? `<span class="fault">${escapeHtml(s + ': ' + n.faults.join('; '))}</span>` : s;
    }).join(' · ');
  }
  statusEl.innerHTML = escapeHtml(parts.join(' · ')) + line2 + ` · ${fmt(fps, 0)} fps`;
  if (labelEl.dataset.text) labelEl.textContent = `${labelEl.dataset.text} · t = ${fmt(t, 2)} s`;
}
function escapeHtml(s) { return String(s).replace(/[&<>]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;' })[c]); }

// ---------------------------------------------------------------------------------------------
// Render loop and frame rate
// ---------------------------------------------------------------------------------------------
let fps = 0, frames = 0, fpsStart = performance.now();
function renderNow() {
  if (!controls) {
    // Render mode: the robot left of centre, the plot panel to its right.
    const right = new THREE.Vector3().crossVectors(viewOffset.clone().negate(), camera.up).normalize();
    const look = target.clone().addScaledVector(right, renderPan);
    camera.position.copy(look).add(viewOffset);
    camera.lookAt(look);
  }
  renderer.render(scene, camera);
}
function onResize() {
  if (renderMode) return;
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
}
window.addEventListener('resize', onResize);

let mode = 'live';
let dirty = false;  // live: new messages since the last drawing
let log = null;  // log mode: summary, frame cache, playback state
function loop(now) {
  ++frames;
  if (now - fpsStart > 1000) { fps = frames * 1000 / (now - fpsStart); frames = 0; fpsStart = now; }
  if (mode === 'log' && log.playing && !renderMode) log.advance(now);
  if (dirty) { dirty = false; draw(); }
  controls?.update();
  renderNow();
  requestAnimationFrame(loop);
}

// ---------------------------------------------------------------------------------------------
// Live: Foxglove WebSocket protocol
// ---------------------------------------------------------------------------------------------
function startLive() {
  let lastTick = null, lastTime = 0;
  const client = new FoxgloveClient(`ws://${location.host}/`);
  client.onMessage = (topic, msg) => {
    if (topic === 'HEALTH') { state.health[msg.node] = msg; return; }
    state.channels[topic] = msg;
    if (topic === 'ROBOT_STATE') {
      const now = performance.now();
      if (lastTick !== null && now > lastTime) state.rate = 0.8 * state.rate + 0.2 * (msg.tick - lastTick) * 1000 / (now - lastTime);
      lastTick = msg.tick; lastTime = now;
      const b = state.channels.BALANCE_STATUS, w = state.channels.WHOLEBODY_COMMAND, c = state.channels.CAM_REFERENCE;
      plot.push(msg.utime * 1e-6, b?.tau_ankle_V, b?.tau_hip_V, c?.l_ref_W, w?.l_cmd_W, msg.l_WCom);
    }
    dirty = true;  // drawn once at the next animation frame, however many messages came
  };
  client.onStatus = (text) => { statusEl.textContent = text; };
  client.connect();
}

// ---------------------------------------------------------------------------------------------
// Log: frames from the viewer, a time slider, play/pause and speed
// ---------------------------------------------------------------------------------------------
class LogPlayer {
  constructor(summary) {
    this.s = summary;
    this.cache = new Map();
    this.index = 0;
    this.t = 0;  // since the start [s]
    this.playing = !renderMode;
    this.speed = 1;
    this.last = null;
    this.pending = new Set();
    this.slider = document.getElementById('time');
    this.slider.max = String(summary.num_frames - 1);
    this.slider.addEventListener('input', () => { this.playing = false; this.updateButton(); this.show(Number(this.slider.value)); });
    this.button = document.getElementById('play');
    this.button.addEventListener('click', () => this.toggle());
    document.getElementById('speed').addEventListener('change', (e) => { this.speed = Number(e.target.value); });
    window.addEventListener('keydown', (e) => { if (e.code === 'Space') { e.preventDefault(); this.toggle(); } });
    document.getElementById('timebar').hidden = false;
    plot.setSeries(summary.series, summary.pushes);
    this.updateButton();
  }
  toggle() {
    this.playing = !this.playing;
    if (this.playing && this.index >= this.s.num_frames - 1) this.t = 0;
    this.last = null;
    this.updateButton();
  }
  updateButton() { this.button.textContent = this.playing ? 'pause' : 'play'; }
  async fetchFrame(i) {
    if (this.cache.has(i)) return this.cache.get(i);
    const f = await (await fetch(`/api/frame/${i}`)).json();
    this.cache.set(i, f);
    if (this.cache.size > 600) this.cache.delete(this.cache.keys().next().value);
    return f;
  }
  /// Keeps the next second of frames in the cache, fetched 60 at a time.
  prefetch(i) {
    const chunk = 60;
    for (let start = i; start < Math.min(i + chunk, this.s.num_frames); ++start) {
      if (this.cache.has(start) || this.pending.has(start)) continue;
      const count = Math.min(chunk, this.s.num_frames - start);
      for (let k = start; k < start + count; ++k) this.pending.add(k);
      fetch(`/api/frames/${start}/${count}`).then((r) => r.json()).then((frames) => {
        for (const f of frames) this.cache.set(f.i, f);
        while (this.cache.size > 900) this.cache.delete(this.cache.keys().next().value);
      }).finally(() => { for (let k = start; k < start + count; ++k) this.pending.delete(k); });
      break;
    }
  }
  apply(f) {
    state.channels = f.channels;
    if (f.channels.HEALTH) state.health[f.channels.HEALTH.node] = f.channels.HEALTH;
    state.t = f.t;
    this.index = f.i;
    this.slider.value = String(f.i);
    document.getElementById('time-text').textContent = `${(f.t - this.s.t0).toFixed(3)} s`;
    plot.cursor = f.t;
    plot.draw();
    draw();
  }
  async show(i) {
    const f = await this.fetchFrame(i);
    this.apply(f);
    return f;
  }
  advance(now) {
    if (this.last !== null) this.t += (now - this.last) * 1e-3 * this.speed;
    this.last = now;
    let i = Math.round(this.t * this.s.fps);
    if (i >= this.s.num_frames - 1) { i = this.s.num_frames - 1; this.playing = false; this.updateButton(); }
    this.prefetch(i);
    if (i === this.index && this.cache.has(i)) return;  // the display outruns the frames: nothing new
    if (this.cache.has(i)) this.apply(this.cache.get(i));
    else if (!this.pending.has(i)) this.fetchFrame(i).then((f) => this.apply(f));
  }
  async seek(t) {
    this.playing = false;
    this.updateButton();
    const i = Math.max(0, Math.min(this.s.num_frames - 1, Math.round((t - this.s.t0) * this.s.fps)));
    this.t = (i / this.s.fps);
    return this.show(i);
  }
}

// ---------------------------------------------------------------------------------------------
// Start
// ---------------------------------------------------------------------------------------------
async function start() {
  const m = await (await fetch('/api/mode')).json();
  mode = m.mode;
  info = await (await fetch('/robot/info.json')).json();
  document.title = `hpr viewer: ${info.name}`;
  robot = await loadRobot();
  ghost = makeGhost(robot);
  applyHeld(robot);
  applyHeld(ghost);
  scene.add(robot);
  scene.add(ghost);
  robot.visible = ghost.visible = false;
  if (params.has('label')) { labelEl.hidden = false; labelEl.dataset.text = params.get('label'); }
  if (renderMode) {
    const pc = document.getElementById('plot-canvas');
    pc.width = 300; pc.height = 150;
    document.querySelector('#plot .plot-head').hidden = true;
    const w = Number(params.get('width') ?? 640), hgt = Number(params.get('height') ?? 480);
    renderer.setSize(w, hgt);
    renderPan = w > hgt * 1.5 ? 0.45 : 0.25;
    camera.aspect = w / hgt;
    camera.updateProjectionMatrix();
  }
  if (mode === 'log') {
    const summary = await (await fetch('/api/log')).json();
    log = new LogPlayer(summary);
    await log.show(0);
  } else {
    startLive();
  }
  if (!renderMode) requestAnimationFrame(loop);
  else renderNow();
}

/// Angle of joint `j` read back from its transform (not from the value it was given): the rotation
/// from its rest orientation, projected on its axis.
function jointAngleFromTransform(j) {
  if (!j.origQuaternion) return 0;
  const rel = j.origQuaternion.clone().invert().multiply(j.quaternion);
  const s = rel.x * j.axis.x + rel.y * j.axis.y + rel.z * j.axis.z;
  return 2 * Math.atan2(s, rel.w);
}

const ready = start();
window.hpr = {
  ready,
  get mode() { return mode; },
  get info() { return info; },
  get state() { return state; },
  get summary() { return log?.s; },
  get fps() { return fps; },
  /// Shows the frame nearest to robot-clock time t [s] (log mode) and renders it.
  async seek(t) { const f = await log.seek(t); renderNow(); return { i: f.i, t: f.t, tick: f.channels.ROBOT_STATE?.tick ?? null }; },
  async showFrame(i) { const f = await log.show(i); renderNow(); return { i: f.i, t: f.t, tick: f.channels.ROBOT_STATE?.tick ?? null }; },
  /// Joint angles of the estimate's robot, read from the scene graph.
  jointAngles() {
    const out = {};
    for (const [name, j] of Object.entries(robot.joints)) if (j.jointType === 'revolute' || j.jointType === 'continuous') out[name] = jointAngleFromTransform(j);
    return out;
  },
  /// Screen rectangle (pixels, origin top left) of the estimate's robot and of the push arrow.
  screenBox(what) {
    const obj = { push: pushArrow, capture: captureMarker, step: stepOutline }[what] ?? robot;
    if (!obj.visible) return null;
    const box = new THREE.Box3().setFromObject(obj);
    const size = renderer.getSize(new THREE.Vector2());
    const r = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
    for (let k = 0; k < 8; ++k) {
      _v.set(k & 1 ? box.max.x : box.min.x, k & 2 ? box.max.y : box.min.y, k & 4 ? box.max.z : box.min.z).project(camera);
      const x = (_v.x + 1) / 2 * size.x, y = (1 - _v.y) / 2 * size.y;
      r.x0 = Math.min(r.x0, x); r.x1 = Math.max(r.x1, x); r.y0 = Math.min(r.y0, y); r.y1 = Math.max(r.y1, y);
    }
    return r;
  },
  pushVisible() { return pushArrow.visible; },
  /// Whether the capture point and the planned step are drawn.
  steppingVisible() { return { capture: captureMarker.visible, step: stepOutline.visible }; },
  /// Camera position relative to the point it looks at (which follows the CoM in render mode).
  setView(offset) { viewOffset.set(...offset); if (controls) { camera.position.copy(controls.target).add(viewOffset); controls.update(); } renderNow(); },
  renderNow,
};
