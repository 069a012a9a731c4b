// report.html's 3-D view: the boxes (with their quadtree footprints), the occupied
// cells and the trajectory of a run, orbit and zoom with the mouse. Bundled with
// three.js by esbuild at build time (tools/report/CMake rules); the page inlines
// the bundle, so nothing is fetched when it is opened.
import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";

const data = JSON.parse(document.getElementById("zonemap-data").textContent);
const host = document.getElementById("view");

const KIND_COLOURS = { obstacle: 0xff5a1a, ground: 0x8c7350 };
const PRIOR_COLOUR = 0x8c5ad9; // a prior map's box no view has confirmed yet

function boxMesh(box, group) {
  const size = [0, 1, 2].map((k) => box.max[k] - box.min[k]);
  const centre = [0, 1, 2].map((k) => (box.max[k] + box.min[k]) / 2);
  const geometry = new THREE.BoxGeometry(...size);
  const colour = box.prior ? PRIOR_COLOUR : (KIND_COLOURS[box.kind] ?? 0xffffff);
  const solid = new THREE.Mesh(
    geometry,
    new THREE.MeshBasicMaterial({ color: colour, transparent: true, opacity: box.kind === "ground" ? 0.12 : 0.3, depthWrite: false }),
  );
  const edges = new THREE.LineSegments(new THREE.EdgesGeometry(geometry), new THREE.LineBasicMaterial({ color: colour }));
  solid.position.set(...centre);
  edges.position.set(...centre);
  solid.userData.featureId = box.id;
  group.add(solid, edges);
}

// The footprint's full squares, outlined at the box's bottom.
function footprint(box, group) {
  if (!box.rects || box.rects.length === 0) return;
  const points = [];
  const z = box.min[2];
  for (const [x0, y0, x1, y1] of box.rects) {
    const c = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
    for (let k = 0; k < 4; ++k) points.push(...c[k], z, ...c[(k + 1) % 4], z);
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", new THREE.Float32BufferAttribute(points, 3));
  group.add(new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: 0xffffff, transparent: true, opacity: 0.7 })));
}

function occupiedCloud(flat, up) {
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", new THREE.Float32BufferAttribute(flat, 3));
  let lo = Infinity;
  let hi = -Infinity;
  for (let i = 2; i < flat.length; i += 3) {
    lo = Math.min(lo, up * flat[i]);
    hi = Math.max(hi, up * flat[i]);
  }
  const colours = new Float32Array(flat.length);
  const c = new THREE.Color();
  for (let i = 0; i < flat.length; i += 3) {
    const t = hi > lo ? (up * flat[i + 2] - lo) / (hi - lo) : 0;
    c.setHSL(0.66 * (1 - t), 0.9, 0.5);
    colours.set([c.r, c.g, c.b], i);
  }
  g.setAttribute("color", new THREE.BufferAttribute(colours, 3));
  return new THREE.Points(g, new THREE.PointsMaterial({ size: data.cell_size_m * 0.8, vertexColors: true }));
}

function trajectoryLine(flat) {
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", new THREE.Float32BufferAttribute(flat, 3));
  return new THREE.Line(g, new THREE.LineBasicMaterial({ color: 0x3399ff }));
}

const scene = new THREE.Scene();
scene.background = new THREE.Color(0x15181c);
const up = data.world_z_up ? 1 : -1;
const boxes = new THREE.Group();
for (const box of data.boxes) {
  boxMesh(box, boxes);
  footprint(box, boxes);
}
scene.add(boxes);
if (data.occupied.length) scene.add(occupiedCloud(data.occupied, up));
if (data.trajectory.length) scene.add(trajectoryLine(data.trajectory));

const bounds = new THREE.Box3().setFromObject(scene);
if (bounds.isEmpty()) bounds.set(new THREE.Vector3(-10, -10, -10), new THREE.Vector3(10, 10, 10));
const centre = bounds.getCenter(new THREE.Vector3());
const radius = Math.max(bounds.getSize(new THREE.Vector3()).length() / 2, 1);
const grid = new THREE.GridHelper(radius * 2, 20, 0x444444, 0x2a2a2a);
grid.rotation.x = Math.PI / 2; // the helper lies in x-z; the map's ground is x-y
grid.position.set(centre.x, centre.y, up > 0 ? bounds.min.z : bounds.max.z);
scene.add(grid, new THREE.AxesHelper(radius / 5));

const camera = new THREE.PerspectiveCamera(50, host.clientWidth / host.clientHeight, radius / 1000, radius * 20);
camera.up.set(0, 0, up);
camera.position.set(centre.x - radius * 1.2, centre.y - radius * 1.2, centre.z + up * radius * 1.1);
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setSize(host.clientWidth, host.clientHeight);
host.appendChild(renderer.domElement);
const controls = new OrbitControls(camera, renderer.domElement);
controls.target.copy(centre);
controls.update();

function render() {
  renderer.render(scene, camera);
}
controls.addEventListener("change", render);
window.addEventListener("resize", () => {
  camera.aspect = host.clientWidth / host.clientHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(host.clientWidth, host.clientHeight);
  render();
});
render();
document.body.dataset.boxesShown = String(boxes.children.filter((o) => o.userData.featureId !== undefined).length);
document.body.dataset.viewReady = "1";
