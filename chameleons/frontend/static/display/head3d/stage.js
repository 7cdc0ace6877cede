/* The stage both 3D heads stand on: WebGL renderer, camera and the lights of a
   back-projected mask (a soft, even light from the front, a little from above; matte
   materials; no shadows, no specular highlights). Units: cm. */

import * as THREE from "three";

const FOV = 24;  // degrees, vertical: a portrait lens, little perspective distortion
const LOOK_AT = new THREE.Vector3(0, -3, 0);
const VIEW_HEIGHT = 36;  // cm of the scene the canvas shows at the head's depth

/** Throws when the browser has no WebGL (the page then falls back to the 2D face). */
export function createStage(canvas) {
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, alpha: false, powerPreference: "high-performance" });
  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(FOV, 1, 10, 400);
  camera.position.set(0, -1, VIEW_HEIGHT / 2 / Math.tan((FOV / 2) * (Math.PI / 180)));
  camera.lookAt(LOOK_AT);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x5a5a66, 1.6));
  const key = new THREE.DirectionalLight(0xffffff, 1.7);
  key.position.set(0, 0.35, 1);  // from the projector's side: the front, slightly above
  scene.add(key);
  const stage = {
    renderer, scene, camera, width: 1, height: 1,
    resize(width, height, pixelRatio) {
      stage.width = Math.max(1, Math.round(width));
      stage.height = Math.max(1, Math.round(height));
      renderer.setPixelRatio(pixelRatio || Math.min(window.devicePixelRatio || 1, 2));
      renderer.setSize(stage.width, stage.height, false);
      camera.aspect = stage.width / stage.height;
      // Keep the whole head in view on a tall (portrait) screen too.
      const visible = VIEW_HEIGHT * Math.max(1, 0.75 / camera.aspect);
      camera.fov = (2 * Math.atan(visible / 2 / camera.position.z) * 180) / Math.PI;
      camera.updateProjectionMatrix();
    },
    setBackground(colour) { scene.background = new THREE.Color(colour); },
    render() { renderer.render(scene, camera); },
    /** Screen pixels per cm at depth z (mesh frame, camera on the z axis). */
    pxPerCm(z) {
      const distance = camera.position.z - z;
      return stage.height / (2 * distance * Math.tan((camera.fov / 2) * (Math.PI / 180)));
    },
  };
  stage.resize(canvas.clientWidth || 640, canvas.clientHeight || 480);
  return stage;
}

/** world position -> [x, y] in CSS pixels of the stage's canvas. */
export function projector(stage) {
  stage.camera.updateMatrixWorld();
  return (p) => {
    const v = p.clone().project(stage.camera);
    return [(v.x + 1) / 2 * stage.width, (1 - v.y) / 2 * stage.height];
  };
}

/** Test hook of both heads: paint each request ({bs: {name: value}, head, eyes}) at
    width x height and return PNG data URLs (read right after each render, before the
    frame is presented, so no preserveDrawingBuffer is needed). */
export function renderStills(painter, requests, width, height, face) {
  const stage = painter.stage, saved = [stage.width, stage.height];
  stage.resize(width, height, 1);
  const out = requests.map((r) => {
    const bs = new Float32Array(painter.names.length);
    for (const [name, v] of Object.entries(r.bs || {})) bs[painter.names.indexOf(name)] = v;
    painter.draw({ bs, head: r.head || [0, 0, 0], eyes: r.eyes || null }, face);
    return stage.renderer.domElement.toDataURL("image/png");
  });
  stage.resize(saved[0], saved[1]);
  return out;
}
