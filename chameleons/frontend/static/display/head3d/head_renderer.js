/* The 3D robot head on a WebGL canvas: the canonical-mesh head (head_mesh.js) with the
   study face's look (looks.js), eyeballs, teeth and tongue, on a fixed neck that turns the
   head by yaw/pitch/roll within Furhat-like limits; matte, lit from the front.

   Same contract as the 2D FaceRenderer: draw(state, face) paints state.bs (52 ARKit
   values in the page's order), state.head ([yaw, pitch, roll] degrees: yaw > 0 turns the
   face to the viewer's right, pitch > 0 tilts it down, roll > 0 counter-clockwise) and
   state.eyes (Live Link eye angles), and returns screen geometry for tests and telemetry. */

import * as THREE from "three";
import { buildHead, loadCanonicalMesh } from "./head_mesh.js";
import { LOOKS, hex, paintEye, paintFace, shellColours } from "./looks.js";
import { JAW_PIVOT, NECK_LIMITS } from "./morph_table.js";
import { createStage, projector, renderStills } from "./stage.js";

const NECK_PIVOT = [0, -3.2, -3.4];  // cm, mesh frame: where the neck turns the head
const TONGUE_REACH = 2.5;  // cm the tongue comes out at tongueOut = 1
const DEG = Math.PI / 180;
const clamp = (v, lo, hi) => Math.min(hi, Math.max(lo, v));

export async function createCanonicalHead(canvas, options) {
  const mesh = await loadCanonicalMesh(options.meshUrl);
  return new CanonicalHead(canvas, mesh, options);
}

class CanonicalHead {
  constructor(canvas, mesh, { names, faces }) {
    this.kind = "3d";
    this.names = names;
    this.faces = faces;
    this.stage = createStage(canvas);
    const { geometry, info } = buildHead(mesh, names);
    this.info = info;
    this.uvs = mesh.uvs;
    this.faceTexture = new THREE.CanvasTexture(document.createElement("canvas"));
    this.faceTexture.flipY = false;
    this.faceTexture.colorSpace = THREE.SRGBColorSpace;
    this.faceTexture.anisotropy = 4;
    const faceMaterial = new THREE.MeshLambertMaterial({ map: this.faceTexture });
    const shellMaterial = new THREE.MeshLambertMaterial({ vertexColors: true });
    this.head = new THREE.Mesh(geometry, [faceMaterial, shellMaterial]);
    this.head.morphTargetInfluences = new Array(names.length).fill(0);
    this.head.position.set(-NECK_PIVOT[0], -NECK_PIVOT[1], -NECK_PIVOT[2]);
    this.pivot = new THREE.Group();
    this.pivot.position.set(...NECK_PIVOT);
    this.pivot.rotation.order = "ZXY";
    this.pivot.add(this.head);
    this.stage.scene.add(this.pivot);
    this.buildEyes();
    this.buildMouth();
    this.buildBody();
    this.face = null;
    this.rig = { eyeL: [0, 0], eyeR: [0, 0], tongue: 0, jawOpen: 0, jawShift: [0, 0, 0] };
  }

  buildEyes() {
    this.eyeTexture = new THREE.CanvasTexture(document.createElement("canvas"));
    this.eyeTexture.colorSpace = THREE.SRGBColorSpace;
    const material = new THREE.MeshLambertMaterial({ map: this.eyeTexture });
    // A dark socket behind each eye (only its far, inner side is drawn, as for the mouth):
    // what a glance past the eyeball, at an angle, sees through the lids' opening.
    const socket = new THREE.MeshBasicMaterial({ color: 0x3a2a2a, side: THREE.BackSide });
    this.eyes = {};
    for (const side of ["L", "R"]) {
      const { centre, radius } = this.info.eyes[side];
      const hollow = new THREE.Mesh(new THREE.SphereGeometry(radius * 1.5, 16, 12), socket);
      hollow.position.set(...centre);
      this.head.add(hollow);
      const ball = new THREE.Mesh(new THREE.SphereGeometry(radius, 24, 16), material);
      ball.position.set(...centre);
      ball.rotation.order = "YXZ";
      this.head.add(ball);
      this.eyes[side] = ball;
    }
  }

  buildMouth() {
    const [mx, my, mz] = this.info.mouthCentre;
    const cavity = new THREE.Mesh(new THREE.SphereGeometry(2.2, 20, 14),
      new THREE.MeshBasicMaterial({ color: 0x2a0d12, side: THREE.BackSide }));
    cavity.scale.set(1.15, 1.0, 0.85);
    cavity.position.set(mx, my - 0.4, mz - 2.7);
    this.head.add(cavity);
    const teeth = new THREE.MeshLambertMaterial({ color: 0xe9e4da });
    const arc = (y) => {
      const strip = new THREE.Mesh(new THREE.CylinderGeometry(2.0, 2.0, 0.5, 20, 1, true, -0.95, 1.9), teeth);
      strip.position.set(mx, y, mz - 2.25);
      return strip;
    };
    this.head.add(arc(my + 0.32));
    this.jaw = new THREE.Group();
    this.jaw.position.set(...JAW_PIVOT);
    const lower = arc(my - 0.38);
    lower.position.sub(this.jaw.position);
    this.jaw.add(lower);
    this.tongue = new THREE.Mesh(new THREE.SphereGeometry(1, 18, 12),
      new THREE.MeshLambertMaterial({ color: 0xb8505a }));
    this.tongue.scale.set(1.1, 0.42, 1.5);
    this.tongueRest = new THREE.Vector3(mx, my - 0.45, mz - 2.2).sub(this.jaw.position);
    this.tongue.position.copy(this.tongueRest);
    this.jaw.add(this.tongue);
    this.head.add(this.jaw);
  }

  buildBody() {
    this.neckMaterial = new THREE.MeshLambertMaterial({ color: 0xcccccc });
    const neck = new THREE.Mesh(new THREE.CylinderGeometry(5.0, 5.8, 12, 24), this.neckMaterial);
    neck.position.set(0, -12, -3.8);
    this.bodyMaterial = new THREE.MeshLambertMaterial({ color: 0x446688 });
    const body = new THREE.Mesh(new THREE.SphereGeometry(1, 32, 16), this.bodyMaterial);
    body.scale.set(19, 7.5, 10);
    body.position.set(0, -21.5, -4.8);
    this.stage.scene.add(neck, body);
  }

  setFace(faceId) {
    if (faceId === this.face || !this.faces[faceId]) return;
    this.face = faceId;
    const style = this.faces[faceId], look = LOOKS[faceId] || LOOKS["face-1"];
    paintFace(this.faceTexture.image, this.uvs, style, look);
    this.faceTexture.needsUpdate = true;
    paintEye(this.eyeTexture.image, style.eyes.iris);
    this.eyeTexture.needsUpdate = true;
    const colours = this.head.geometry.getAttribute("color");
    shellColours(this.info.base, this.info.shellStart, style, look, colours.array);
    colours.needsUpdate = true;
    this.neckMaterial.color.setRGB(...hex(style.skinShade));
    this.bodyMaterial.color.setRGB(...hex(style.shirt));
    this.stage.setBackground(style.background);
  }

  /** Morph influences and rig (eyes, jaw parts, tongue) from 52 values and eye angles. */
  pose(bs, eyes) {
    const infl = this.head.morphTargetInfluences, rig = this.rig;
    rig.eyeL = [0, 0]; rig.eyeR = [0, 0]; rig.tongue = 0; rig.jawOpen = 0; rig.jawShift = [0, 0, 0];
    for (let i = 0; i < this.names.length; i++) {
      const v = clamp(bs[i] || 0, 0, 1);
      infl[i] = v;
      if (v === 0) continue;
      for (const r of this.info.rigs[this.names[i]]) {
        for (const side of ["L", "R"]) {
          const e = r["eye" + side];
          if (e) { rig["eye" + side][0] += v * e[0]; rig["eye" + side][1] += v * e[1]; }
        }
        if (r.tongue) rig.tongue += v * r.tongue;
      }
      for (const j of this.info.jaws[this.names[i]]) {
        rig.jawOpen += v * j.open;
        for (let k = 0; k < 3; k++) rig.jawShift[k] += v * j.shift[k];
      }
    }
    const e = eyes || [0, 0, 0, 0, 0, 0];  // Live Link: yaw > 0 to the viewer's right, pitch > 0 down
    for (const [side, yaw, pitch] of [["L", e[0], e[1]], ["R", e[3], e[4]]]) {
      const ball = this.eyes[side], [ry, rp] = rig["eye" + side];
      ball.rotation.y = clamp(ry + yaw, -35, 35) * DEG;
      ball.rotation.x = -clamp(rp - pitch, -30, 30) * DEG;
    }
    this.jaw.rotation.x = rig.jawOpen * DEG;
    this.jaw.position.set(JAW_PIVOT[0] + rig.jawShift[0], JAW_PIVOT[1] + rig.jawShift[1], JAW_PIVOT[2] + rig.jawShift[2]);
    this.tongue.position.copy(this.tongueRest);
    this.tongue.position.z += clamp(rig.tongue, 0, 1) * TONGUE_REACH;
    this.tongue.position.y += clamp(rig.tongue, 0, 1) * 0.1;
  }

  orient(head) {
    const [yaw, pitch, roll] = head || [0, 0, 0];
    this.pivot.rotation.set(clamp(pitch, -NECK_LIMITS.pitch, NECK_LIMITS.pitch) * DEG,
      clamp(yaw, -NECK_LIMITS.yaw, NECK_LIMITS.yaw) * DEG, clamp(roll, -NECK_LIMITS.roll, NECK_LIMITS.roll) * DEG);
  }

  draw(state, faceId) {
    this.setFace(faceId);
    this.pose(state.bs, state.eyes);
    this.orient(state.head);
    this.stage.render();
    return this.geometry();
  }

  /** A landmark's position with the current morphs, in world space. */
  landmark(i) {
    const { base, deltas } = this.info, infl = this.head.morphTargetInfluences;
    const p = new THREE.Vector3(...base[i]);
    for (let k = 0; k < deltas.length; k++) {
      if (infl[k]) p.add(new THREE.Vector3(deltas[k][3 * i], deltas[k][3 * i + 1], deltas[k][3 * i + 2]).multiplyScalar(infl[k]));
    }
    this.head.updateWorldMatrix(true, false);
    return p.applyMatrix4(this.head.matrixWorld);
  }

  geometry() {
    const project = projector(this.stage);
    const [top, bottom, right, left, nose] = [13, 14, 61, 291, 1].map((i) => project(this.landmark(i)));
    return {
      renderer: "3d", mouthOpenPx: Math.hypot(top[0] - bottom[0], top[1] - bottom[1]),
      mouthWidthPx: Math.hypot(left[0] - right[0], left[1] - right[1]),
      noseX: nose[0], noseY: nose[1], centerX: this.stage.width / 2, centerY: this.stage.height / 2,
      scale: this.stage.pxPerCm(NECK_PIVOT[2]) * 7.7,
    };
  }

  /** Named landmarks' screen points (px) on the resting face, at width x height (default:
      the canvas), for tests that check where pixels change. */
  screenPoints(ids, width, height) {
    const saved = [this.stage.width, this.stage.height];
    if (width) this.stage.resize(width, height, 1);
    this.pose(new Float32Array(this.names.length), null);
    this.orient([0, 0, 0]);
    const project = projector(this.stage);
    const out = Object.fromEntries(Object.entries(ids).map(([name, i]) => [name, project(this.landmark(i))]));
    if (width) this.stage.resize(saved[0], saved[1]);
    return out;
  }

  /** Test hook: PNG data URLs of each request ({bs, head, eyes}) at width x height. */
  stills(requests, width, height, faceId) {
    return renderStills(this, requests, width, height, faceId || this.face);
  }

  resize(width, height) { this.stage.resize(width, height); }
}
