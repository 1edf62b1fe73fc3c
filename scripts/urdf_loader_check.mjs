// Reads the robot's URDF with urdf-loader (the three.js URDF loader web viewers use) and three.js's ColladaLoader,
// headless in Node, and compares its forward kinematics with poses MuJoCo computed.
//
//   npm install urdf-loader three jsdom            (in a folder DIR; copy this script there: ES modules
//                                                    resolve packages from where the script is)
//   humanoid describe --urdf -o robot.urdf
//   python scripts/urdf_poses.py poses.json
//   node DIR/urdf_loader_check.mjs robot.urdf poses.json
import fs from "node:fs";
import { JSDOM } from "jsdom";

const { window } = new JSDOM("");
Object.assign(globalThis, { DOMParser: window.DOMParser, Document: window.Document, Element: window.Element });
const THREE = await import("three");
const { default: URDFLoader } = await import("urdf-loader");
const { ColladaLoader } = await import("three/examples/jsm/loaders/ColladaLoader.js");

const [urdfPath, posesPath] = process.argv.slice(2);
let meshes = 0;
let triangles = 0;
const notEmbedded = [];
const loader = new URDFLoader();
loader.loadMeshCb = (path, manager, material, done) => {
  const match = /^data:([^;,]+);base64,(.*)$/s.exec(path);
  if (!match) {
    notEmbedded.push(path.slice(0, 60));
    done(null, new Error("not embedded"));
    return;
  }
  const dae = new ColladaLoader().parse(Buffer.from(match[2], "base64").toString("utf8"), "");
  dae.scene.rotation.set(0, 0, 0); // Z-up as declared: as Foxglove and RViz read it (three.js would turn it Y-up)
  dae.scene.traverse((o) => {
    if (o.isMesh) {
      meshes += 1;
      const g = o.geometry;
      triangles += (g.index ? g.index.count : g.attributes.position.count) / 3;
    }
  });
  done(dae.scene);
};
const robot = loader.parse(fs.readFileSync(urdfPath, "utf8"));
const poses = JSON.parse(fs.readFileSync(posesPath, "utf8"));
let worst = 0;
for (const pose of poses) {
  robot.setJointValues(pose.joints);
  robot.updateMatrixWorld(true);
  const base = new THREE.Matrix4().copy(robot.links[pose.base].matrixWorld).invert();
  for (const [name, expected] of Object.entries(pose.links)) {
    const got = new THREE.Matrix4().multiplyMatrices(base, robot.links[name].matrixWorld);
    const e = new THREE.Matrix4().fromArray(expected).transpose(); // expected is row-major
    got.elements.forEach((v, i) => { worst = Math.max(worst, Math.abs(v - e.elements[i])); });
  }
}
const result = {
  links: Object.keys(robot.links).length,
  joints: Object.keys(robot.joints).length,
  meshes,
  triangles,
  notEmbedded: notEmbedded.length,
  poses: poses.length,
  worstDifference: worst,
};
console.log(JSON.stringify(result));
process.exit(notEmbedded.length === 0 && worst < 1e-6 ? 0 : 1);
