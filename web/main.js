// The built-in motion model (motion-web, Rust compiled to WebAssembly) driving one character live
// at the display's frame rate, drawn with three.js as a skinned glTF humanoid (the CC0 mannequin,
// its own skeleton driven through motion-core's rig target), the joints as a stick figure on
// demand. State for tests: window.motionStatus.
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import init, { WebCharacter } from "./pkg/motion_web.js";

const status = { ready: false, poses: 0, finite: true, action: null, source: null, error: null, skinned: false };
window.motionStatus = status;
const $ = (id) => document.getElementById(id);

function fail(e) {
  status.error = String(e && e.message ? e.message : e);
  $("error").textContent = status.error;
}

// --- scene: ground grid, lights, a skeleton of instanced bones and joints -----------------------
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setSize(window.innerWidth, window.innerHeight);
document.body.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1d2127);
scene.add(new THREE.HemisphereLight(0xffffff, 0x303030, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(3, 6, 4);
scene.add(sun);
const ground = new THREE.Mesh(
  new THREE.PlaneGeometry(200, 200).rotateX(-Math.PI / 2),
  new THREE.MeshStandardMaterial({ color: 0x2b313a, roughness: 1 }),
);
scene.add(ground);
const grid = new THREE.GridHelper(200, 200, 0x6c7684, 0x48515d);
grid.position.y = 0.001;
scene.add(grid);
const camera = new THREE.PerspectiveCamera(45, window.innerWidth / window.innerHeight, 0.05, 200);
window.addEventListener("resize", () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
});

let character = null;
let parents = [];
let bones = null; // InstancedMesh: one cylinder per (joint, parent)
let joints = null; // InstancedMesh: one sphere per joint
const seedSource = { bvh: null, name: null };
let lift = 0; // the model's root starts at the origin: raise the figure so its first pose stands on the floor

// --- the skinned character: every node of the glTF scene in parents-first order (node 0 the scene
// itself, the character's world), handed to the wasm character as a rig; each frame the local
// rotations (and the hips' translation) it returns go straight into the nodes ----------------------
let mannequin = null; // { root, nodes, hips }
// The character drawn: ?character=URL in the address (any glTF humanoid the built-in name maps
// know), a .glb chosen on the page, or the committed CC0 mannequin.
const CHARACTER = new URLSearchParams(location.search).get("character") ?? "./pkg/mannequin.glb";
function useCharacter(gltf) {
  if (mannequin) scene.remove(mannequin.root);
  // The rig: the bones of the largest skin and every node above them (meshes are not joints).
  let bones = [];
  gltf.scene.traverse((o) => {
    if (o.isSkinnedMesh && o.skeleton.bones.length > bones.length) bones = o.skeleton.bones;
    o.frustumCulled = false; // the hips walk away from the bind-pose bounds
  });
  if (bones.length === 0) throw new Error("the glTF file has no skinned mesh: nothing to drive");
  const keep = new Set([gltf.scene]);
  for (let b of bones) {
    for (; b && !keep.has(b); b = b.parent) keep.add(b);
  }
  const nodes = [];
  gltf.scene.traverse((o) => keep.has(o) && nodes.push(o));
  mannequin = { root: gltf.scene, nodes, hips: -1 };
  scene.add(gltf.scene);
  status.character = nodes.length - 1;
}
async function loadMannequin(url = CHARACTER) {
  useCharacter(await new GLTFLoader().loadAsync(url));
}

function attachRig() {
  if (!mannequin || !character) return;
  const { nodes } = mannequin;
  const names = nodes.map((o, j) => (j === 0 ? "__scene" : o.name || `node${j}`));
  const parents = nodes.map((o, j) => (j === 0 ? -1 : nodes.indexOf(o.parent)));
  const rest = new Float32Array(7 * nodes.length);
  nodes.forEach((o, j) => {
    if (j === 0) return rest.set([0, 0, 0, 1, 0, 0, 0], 0);
    if (!o.userData.rest) o.userData.rest = { q: o.quaternion.clone(), p: o.position.clone() };
    const { q, p } = o.userData.rest;
    rest.set([q.x, q.y, q.z, q.w, p.x, p.y, p.z], 7 * j);
  });
  mannequin.hips = character.attach_rig(names, Int32Array.from(parents), rest);
  status.skinned = true;
}

function poseMannequin() {
  if (!mannequin || mannequin.hips < 0) return;
  const pose = character.rig_pose();
  const { nodes, hips } = mannequin;
  for (let j = 1; j < nodes.length; j++) nodes[j].quaternion.fromArray(pose, 4 * j);
  nodes[hips].position.fromArray(pose, 4 * nodes.length);
}

function showSticks(on) {
  if (bones) bones.visible = joints.visible = on;
  if (mannequin) mannequin.root.visible = !on || !status.skinned;
}

function buildSkeleton(count) {
  if (bones) scene.remove(bones, joints);
  bones = new THREE.InstancedMesh(
    new THREE.CylinderGeometry(1, 1, 1, 8),
    new THREE.MeshStandardMaterial({ color: 0xffb347, roughness: 0.6 }),
    count,
  );
  joints = new THREE.InstancedMesh(
    new THREE.SphereGeometry(0.028, 12, 8),
    new THREE.MeshStandardMaterial({ color: 0x7fc8ff, roughness: 0.4 }),
    count,
  );
  scene.add(bones, joints);
}

const up = new THREE.Vector3(0, 1, 0);
const a = new THREE.Vector3(), b = new THREE.Vector3(), d = new THREE.Vector3();
const q = new THREE.Quaternion(), s = new THREE.Vector3(), m = new THREE.Matrix4();
const zero = new THREE.Matrix4().makeScale(0, 0, 0);

function draw(xyz) {
  for (let j = 0; j < parents.length; j++) {
    a.fromArray(xyz, 3 * j);
    a.y += lift;
    m.compose(a, q.identity(), s.set(1, 1, 1));
    joints.setMatrixAt(j, m);
    const p = parents[j];
    if (p < 0) { bones.setMatrixAt(j, zero); continue; }
    b.fromArray(xyz, 3 * p);
    b.y += lift;
    d.subVectors(a, b);
    const len = d.length();
    if (len < 1e-6) { bones.setMatrixAt(j, zero); continue; }
    q.setFromUnitVectors(up, d.divideScalar(len));
    m.compose(b.add(a).multiplyScalar(0.5), q, s.set(0.018, len, 0.018));
    bones.setMatrixAt(j, m);
  }
  bones.instanceMatrix.needsUpdate = true;
  joints.instanceMatrix.needsUpdate = true;
  // Follow the character from the side, looking at its hips.
  const root = a.fromArray(xyz, 0);
  camera.position.set(root.x + 3.2, 1.7, root.z + 3.2);
  camera.lookAt(root.x, root.y + lift, root.z);
}

function start() {
  const action = $("action").value;
  // ?seed=N in the address makes a run repeatable.
  const fixed = new URLSearchParams(location.search).get("seed");
  const seed = BigInt(fixed ?? Math.floor(Math.random() * 2 ** 32));
  const source = $("source").value;
  try {
    character?.free();
    if (source === "matching") {
      // The shipped motion-matching database plays on its own (CMU) rig; it has no actions.
      character = seedSource.bvh
        ? WebCharacter.from_bvh_matching(seedSource.bvh, seedSource.name)
        : WebCharacter.walk_matching();
    } else {
      character = seedSource.bvh
        ? WebCharacter.from_bvh(seedSource.bvh, seedSource.name, action, seed)
        : WebCharacter.walk(action, seed);
    }
    $("action").disabled = source === "matching";
    parents = Array.from(character.parents());
    lift = character.floor_offset() + 0.02;
    buildSkeleton(parents.length);
    status.skinned = false;
    attachRig();
    showSticks($("sticks").checked);
    status.action = source === "matching" ? "motion matching" : action;
    status.source = source;
    $("error").textContent = "";
  } catch (e) {
    fail(e);
  }
}

// --- steering: arrow keys or WASD (or a gamepad's left stick) set a goal velocity on the floor ---
// m/s: about the shipped model's own walking pace (the warp scales its stride ±30 %); the
// database walks at a person's pace.
const SPEED = { model: 0.5, matching: 1.2 };
const held = new Set();
window.addEventListener("keydown", (e) => held.add(e.key.toLowerCase()));
window.addEventListener("keyup", (e) => held.delete(e.key.toLowerCase()));
let steering = false;
function steer() {
  let x = 0, z = 0;
  if (held.has("arrowup") || held.has("w")) z += 1;
  if (held.has("arrowdown") || held.has("s")) z -= 1;
  if (held.has("arrowleft") || held.has("a")) x += 1;
  if (held.has("arrowright") || held.has("d")) x -= 1;
  const pad = navigator.getGamepads ? [...navigator.getGamepads()].find((g) => g) : null;
  if (pad && Math.hypot(pad.axes[0], pad.axes[1]) > 0.2) {
    x = -pad.axes[0];
    z = -pad.axes[1];
  }
  const length = Math.hypot(x, z);
  if (length > 0) {
    // yaw about +y: 0 faces +z, pi/2 faces +x
    const speed = SPEED[status.source] ?? SPEED.model;
    character.set_goal((speed * x) / length, (speed * z) / length, Math.atan2(x, z));
    steering = true;
  } else if (steering) {
    character.clear_goal();
    steering = false;
  }
}

// --- the loop: one pose per displayed frame, at the display's rate ------------------------------
let last = null;
let fps = 0;
let stepMs = 0;
function frame(now) {
  requestAnimationFrame(frame);
  if (!character) return;
  const dt = last === null ? 0 : Math.min((now - last) / 1000, 0.1); // a hidden tab resumes calmly
  last = now;
  if (dt > 0) fps = 0.95 * fps + 0.05 / dt;
  try {
    steer();
    const t0 = performance.now();
    character.advance(dt);
    stepMs = 0.95 * stepMs + 0.05 * (performance.now() - t0);
    const xyz = character.positions();
    if (!xyz.every(Number.isFinite)) status.finite = false;
    draw(xyz);
    poseMannequin();
    status.poses += 1;
  } catch (e) {
    fail(e);
    character = null;
  }
  renderer.render(scene, camera);
  $("stats").textContent =
    `${status.action} · ${status.poses} poses · ${fps.toFixed(0)} fps · advance ${stepMs.toFixed(2)} ms`;
}

// Time `n` model steps of a fresh character (µs per step), for the tests and the README numbers.
window.motionDebug = () => ({
  camera: camera.position.toArray(), lift, joints: parents.length, root: Array.from(character.positions().slice(0, 3)),
  // world positions of a few of the mannequin's bones (metres)
  bones: mannequin ? Object.fromEntries(["pelvis", "hand_l", "foot_l", "foot_r", "ball_l", "ball_r", "head"].map((n) => {
    const o = mannequin.root.getObjectByName(n);
    return [n, o ? o.getWorldPosition(new THREE.Vector3()).toArray() : null];
  })) : null,
});
// Pixels the skinned mesh covers in the current view: the frame drawn with and without it.
window.motionMeshPixels = () => {
  const gl = renderer.getContext();
  const [w, h] = [gl.drawingBufferWidth, gl.drawingBufferHeight];
  const read = () => {
    renderer.render(scene, camera);
    const px = new Uint8Array(4 * w * h);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    return px;
  };
  const sticks = bones?.visible;
  showSticks(false);
  const withMesh = read();
  mannequin.root.visible = false;
  const without = read();
  showSticks(sticks);
  renderer.render(scene, camera);
  let n = 0;
  for (let i = 0; i < withMesh.length; i += 4) {
    if (Math.abs(withMesh[i] - without[i]) + Math.abs(withMesh[i + 1] - without[i + 1]) + Math.abs(withMesh[i + 2] - without[i + 2]) > 30) n++;
  }
  return n;
};
window.motionBench = (n) => {
  const c = WebCharacter.walk("walking", 7n);
  c.step_model(10); // warm up
  const t0 = performance.now();
  c.step_model(n);
  const us = ((performance.now() - t0) * 1000) / n;
  c.free();
  return us;
};

try {
  await Promise.all([init(), loadMannequin()]);
  for (const name of WebCharacter.actions()) {
    const option = document.createElement("option");
    option.value = option.textContent = name;
    $("action").appendChild(option);
  }
  $("action").value = "walking";
  $("action").addEventListener("change", () => {
    try {
      character?.set_action($("action").value);
      status.action = $("action").value;
    } catch (e) {
      fail(e);
    }
  });
  $("restart").addEventListener("click", start);
  $("sticks").addEventListener("change", () => showSticks($("sticks").checked));
  $("source").addEventListener("change", start);
  $("glb").addEventListener("change", async (event) => {
    const file = event.target.files[0];
    if (!file) return;
    try {
      useCharacter(await new GLTFLoader().parseAsync(await file.arrayBuffer(), ""));
      status.skinned = false;
      attachRig();
      showSticks($("sticks").checked);
      $("error").textContent = "";
    } catch (e) {
      fail(new Error(`${file.name}: ${e.message ?? e}`));
    }
  });
  $("bvh").addEventListener("change", async (event) => {
    const file = event.target.files[0];
    if (!file) return;
    seedSource.bvh = await file.text();
    seedSource.name = file.name;
    start();
  });
  start();
  status.ready = true;
  requestAnimationFrame(frame);
} catch (e) {
  fail(e);
}
