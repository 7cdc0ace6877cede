/* A lab's own 3D head: a GLB (or VRM, which is GLB) whose blendshapes carry ARKit's names
   ("perfect sync"), rendered on the same stage as the built-in head and driven by the same
   52 values. Names are matched in the spellings found in the wild (camelCase, PascalCase,
   Swift's _L/_R, UPPER_SNAKE, with any "prefix." before them); `missing` lists the ARKit
   shapes no mesh of the file has. The head turns on its head bone when it has one (VRM's
   and most rigs' "head"), else as a whole. */

import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { NECK_LIMITS } from "./morph_table.js";
import { createStage, projector, renderStills } from "./stage.js";

const DEG = Math.PI / 180;
const FACE_HEIGHT = 26;  // cm the head's morphing meshes are scaled to (the built-in's size)
const clamp = (v, lo, hi) => Math.min(hi, Math.max(lo, v));

/** A blendshape name in any common spelling -> the canonical ARKit name, or null. */
export function canonicalName(raw, names) {
  let name = String(raw).split(/[.:|]/).pop().trim();
  if (/^[A-Z0-9_]+$/.test(name) && name.includes("_")) {  // UPPER_SNAKE (Furhat's)
    name = name.toLowerCase().replace(/_([a-z])/g, (m, c) => c.toUpperCase());
  }
  name = name.replace(/_L$/, "Left").replace(/_R$/, "Right");
  name = name.charAt(0).toLowerCase() + name.slice(1);
  const exact = names.find((n) => n.toLowerCase() === name.toLowerCase());
  return exact || null;
}

export async function createCustomHead(canvas, options) {
  const gltf = await new GLTFLoader().loadAsync(options.headUrl);
  return new CustomHead(canvas, gltf, options);
}

class CustomHead {
  constructor(canvas, gltf, { names }) {
    this.kind = "3d";
    this.names = names;
    this.stage = createStage(canvas);
    this.stage.setBackground("#15191e");
    this.model = gltf.scene;
    this.targets = [];  // [mesh, [[arkit index, morph index], ...]]
    const found = new Set();
    this.model.traverse((object) => {
      if (object.isMesh && object.material) {
        for (const m of [].concat(object.material)) {  // matte, like the built-in mask
          if ("roughness" in m) m.roughness = Math.max(m.roughness, 0.85);
          if ("metalness" in m) m.metalness = 0;
        }
      }
      if (!object.isMesh || !object.morphTargetDictionary) return;
      const pairs = [];
      for (const [raw, index] of Object.entries(object.morphTargetDictionary)) {
        const name = canonicalName(raw, names);
        if (name) { pairs.push([names.indexOf(name), index]); found.add(name); }
      }
      if (pairs.length) this.targets.push([object, pairs]);
    });
    this.missing = names.filter((n) => !found.has(n));
    this.fit();
    this.headBone = this.findHeadBone();
    this.rest = (this.headBone || this.pivot).quaternion.clone();
  }

  /** Scale and centre the model so the meshes that morph (the face) fill the frame as the
      built-in head does, turning about a point behind and below the face's centre. */
  fit() {
    const box = new THREE.Box3();
    for (const [mesh] of this.targets) box.expandByObject(mesh);
    if (box.isEmpty()) box.setFromObject(this.model);
    const size = box.getSize(new THREE.Vector3()), centre = box.getCenter(new THREE.Vector3());
    const scale = FACE_HEIGHT / Math.max(size.y, size.x, 1e-6);
    this.pivot = new THREE.Group();
    this.pivot.rotation.order = "ZXY";
    this.model.position.set(-centre.x, -centre.y + size.y * 0.25, -centre.z);
    const holder = new THREE.Group();
    holder.scale.setScalar(scale);
    holder.add(this.model);
    holder.position.set(0, -size.y * 0.25 * scale, 0);
    this.pivot.add(holder);
    this.pivot.position.set(0, 1, 0);
    this.stage.scene.add(this.pivot);
    this.size = size.multiplyScalar(scale);
  }

  findHeadBone() {
    let bone = null;
    this.model.traverse((o) => {
      if (!bone && o.isBone && /(^|[_.:])head$/i.test(o.name)) bone = o;
    });
    return bone;
  }

  setFace() {}

  draw(state) {
    for (const [mesh, pairs] of this.targets) {
      for (const [i, k] of pairs) mesh.morphTargetInfluences[k] = clamp(state.bs[i] || 0, 0, 1);
    }
    const [yaw, pitch, roll] = state.head || [0, 0, 0];
    const turn = new THREE.Quaternion().setFromEuler(new THREE.Euler(
      clamp(pitch, -NECK_LIMITS.pitch, NECK_LIMITS.pitch) * DEG,
      clamp(yaw, -NECK_LIMITS.yaw, NECK_LIMITS.yaw) * DEG,
      clamp(roll, -NECK_LIMITS.roll, NECK_LIMITS.roll) * DEG, "ZXY"));
    (this.headBone || this.pivot).quaternion.copy(this.rest).multiply(turn);
    this.stage.render();
    const project = projector(this.stage);
    const front = project(new THREE.Vector3(0, 0, this.size.z / 2).applyMatrix4(this.pivot.matrixWorld));
    return { renderer: "3d-custom", noseX: front[0], noseY: front[1], centerX: this.stage.width / 2,
             centerY: this.stage.height / 2, scale: this.stage.pxPerCm(0) * this.size.x / 2,
             mouthOpenPx: null, mouthWidthPx: null };
  }

  stills(requests, width, height) {
    return renderStills(this, requests, width, height, null);
  }

  resize(width, height) { this.stage.resize(width, height); }
}
