/* The robot head's geometry: MediaPipe's canonical face mesh (the vendored
   canonical_face_mesh.json), opened at the eyes and the mouth, its mouth closed at rest,
   closed at the back by a shell, and the 52 ARKit morph targets authored from
   morph_table.js (Gaussian-falloff displacements and a jaw rotation; relative targets). */

import * as THREE from "three";
import { JAW_PIVOT, LANDMARKS, MIRRORED, SHAPES } from "./morph_table.js";

// Eye contours (outer corner, upper lid, inner corner, lower lid) and the lips' inner line
// as upper/lower pairs, corner to corner; the triangles spanning them are removed.
const EYE_L = [263, 466, 388, 387, 386, 385, 384, 398, 362, 382, 381, 380, 374, 373, 390, 249];
const EYE_R = [33, 246, 161, 160, 159, 158, 157, 173, 133, 155, 154, 153, 145, 144, 163, 7];
const INNER_LIPS = [[13, 14], [312, 317], [311, 402], [310, 318], [415, 324],
  [82, 87], [81, 178], [80, 88], [191, 95]];
const MOUTH_CORNERS = [308, 78];
const ALL_CORNERS = new Set([308, 78, 291, 61]);  // half on the jaw, half on the upper lip
const SHELL_RINGS = 10;
const SHELL_CENTRE = [0, 1.2, -3.2];
const SHELL_RADII = { x: 7.9, up: 10.2, down: 8.6, back: 9.4 };

const smoothstep = (a, b, x) => {
  const t = Math.min(1, Math.max(0, (x - a) / (b - a)));
  return t * t * (3 - 2 * t);
};

/** The canonical mesh (positions in cm, uvs, triangles) from the vendored JSON. */
export async function loadCanonicalMesh(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`canonical face mesh: HTTP ${response.status}`);
  return response.json();
}

/** Build the head: {geometry, info} (info: landmarks, eyes, jaw, rigs, morph deltas). */
export function buildHead(mesh, names) {
  const base = mesh.positions.map((p) => p.slice());
  const mirror = mirrorMap(base);
  closeMouth(base);
  const faceTriangles = mesh.triangles.filter((t) => !spans(t, EYE_L) && !spans(t, EYE_R)
    && !spans(t, INNER_LIPS.flat()));
  const shell = buildShell(base, faceTriangles);
  const positions = base.concat(shell.positions);
  const uvs = mesh.uvs.concat(shell.uvs);
  const regions = computeRegions(positions, base.length);
  const jawWeights = positions.map((p, i) => jawWeight(p, i, regions));

  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute("position", new THREE.Float32BufferAttribute(positions.flat(), 3));
  geometry.setAttribute("uv", new THREE.Float32BufferAttribute(uvs.flat(), 2));
  geometry.setAttribute("color", new THREE.Float32BufferAttribute(new Float32Array(positions.length * 3).fill(1), 3));
  geometry.setIndex(faceTriangles.flat().concat(shell.triangles.flat()));
  geometry.addGroup(0, faceTriangles.length * 3, 0);
  geometry.addGroup(faceTriangles.length * 3, shell.triangles.length * 3, 1);
  geometry.computeVertexNormals();

  const ctx = { base: positions, mirror, regions, jawWeights };
  const deltas = [], rigs = {}, jaws = {};
  for (const name of names) {
    const ops = shapeOps(name, mirror);
    const disp = new Float32Array(positions.length * 3);
    for (const op of ops) applyOp(op, ctx, disp);
    deltas.push(disp);
    rigs[name] = ops.filter((op) => op.rig).map((op) => op.rig);
    jaws[name] = ops.filter((op) => op.jaw).map((op) => op.jaw);
  }
  geometry.morphTargetsRelative = true;
  geometry.morphAttributes.position = deltas.map((d) => new THREE.BufferAttribute(d, 3));
  geometry.morphAttributes.normal = deltas.map((d) => morphNormals(geometry, d));
  return {
    geometry,
    info: {
      base: positions, deltas, rigs, jaws, shellStart: base.length,
      eyes: { L: eyeSocket(base, EYE_L), R: eyeSocket(base, EYE_R) },
      mouthCentre: midpoint(base[13], base[14]),
    },
  };
}

// ---- the shape table -----------------------------------------------------------------

/** The operations of one shape, with *Right shapes mirrored from their *Left twin. */
export function shapeOps(name, mirror) {
  const source = MIRRORED[name];
  const ops = (SHAPES[source || name] || []).flatMap((entry) => {
    const op = resolve(entry);
    return entry.both ? [op, mirrorOp(op, mirror)] : [op];
  });
  return source ? ops.map((op) => mirrorOp(op, mirror)) : ops;
}

function resolve(entry) {
  const op = {};
  for (const [kind, body] of Object.entries(entry)) {
    if (kind === "both") continue;
    op.kind = kind;
    op.body = { ...body };
    for (const key of ["at", "from", "to"]) {
      if (typeof body[key] === "string") op.body[key] = LANDMARKS[body[key]].slice();
    }
    if (kind === "rig") op.rig = { ...body };
    if (kind === "jaw") op.jaw = { open: body.open || 0, shift: body.shift || [0, 0, 0] };
  }
  return op;
}

function mirrorOp(op, mirror) {
  const body = { ...op.body };
  for (const key of ["at", "from", "to"]) if (Array.isArray(body[key])) body[key] = body[key].map((i) => mirror[i]);
  if (body.move) body.move = [-body.move[0], body.move[1], body.move[2]];
  if (body.region) body.region = body.region.replace(/L$/, "R");
  const out = { kind: op.kind, body };
  if (op.rig) {
    out.rig = {};
    for (const [k, v] of Object.entries(op.rig)) {
      if (k === "eyeL") out.rig.eyeR = [-v[0], v[1]];
      else if (k === "eyeR") out.rig.eyeL = [-v[0], v[1]];
      else out.rig[k] = v;
    }
  }
  if (op.jaw) out.jaw = { open: op.jaw.open, shift: [-op.jaw.shift[0], op.jaw.shift[1], op.jaw.shift[2]] };
  return out;
}

function applyOp(op, ctx, disp) {
  const b = op.body, P = ctx.base;
  if (op.kind === "move") {
    spread(ctx, disp, b, b.at.map((i) => [P[i], b.move]));
  } else if (op.kind === "toward") {
    spread(ctx, disp, b, b.from.map((i, k) => [P[i], scaled(sub(P[b.to[k]], P[i]), b.amount)]));
  } else if (op.kind === "pull") {
    const target = P[b.to[0]];
    spread(ctx, disp, b, b.at.map((i) => [P[i], scaled(sub(target, P[i]), b.amount)]));
  } else if (op.kind === "jaw") {
    const turn = new THREE.Matrix4().makeRotationX((op.jaw.open * Math.PI) / 180);
    const v = new THREE.Vector3();
    P.forEach((p, i) => {
      const w = ctx.jawWeights[i];
      if (w <= 0) return;
      v.set(p[0] - JAW_PIVOT[0], p[1] - JAW_PIVOT[1], p[2] - JAW_PIVOT[2]).applyMatrix4(turn);
      const d = [v.x + JAW_PIVOT[0] - p[0] + op.jaw.shift[0], v.y + JAW_PIVOT[1] - p[1] + op.jaw.shift[1],
        v.z + JAW_PIVOT[2] - p[2] + op.jaw.shift[2]];
      for (let k = 0; k < 3; k++) disp[3 * i + k] += w * d[k];
    });
  }
}

/** Gaussian-weighted spread of anchor moves [[position, move], ...] over the vertices. */
function spread(ctx, disp, body, anchors) {
  const r2 = body.radius * body.radius;
  const region = body.region ? ctx.regions[body.region] : null;
  ctx.base.forEach((p, i) => {
    if (region && !region[i]) return;
    let best = 0, sum = 0;
    const acc = [0, 0, 0];
    for (const [a, move] of anchors) {
      const d2 = (p[0] - a[0]) ** 2 + (p[1] - a[1]) ** 2 + (p[2] - a[2]) ** 2;
      if (d2 > 9 * r2) continue;
      const g = Math.exp(-d2 / r2);
      best = Math.max(best, g);
      sum += g;
      for (let k = 0; k < 3; k++) acc[k] += g * move[k];
    }
    if (sum <= 0) return;
    for (let k = 0; k < 3; k++) disp[3 * i + k] += (best * acc[k]) / sum;
  });
}

// ---- mesh preparation ----------------------------------------------------------------

function mirrorMap(P) {
  return P.map((p) => {
    let best = 0, dist = Infinity;
    P.forEach((q, j) => {
      const d = (q[0] + p[0]) ** 2 + (q[1] - p[1]) ** 2 + (q[2] - p[2]) ** 2;
      if (d < dist) { dist = d; best = j; }
    });
    return best;
  });
}

/** The canonical face's lips are parted by ~5 mm: close them at rest (each inner pair
    meets at its midpoint; the lips around follow with a short falloff). */
function closeMouth(P) {
  const moves = [];
  for (const [up, lo] of INNER_LIPS) {
    const mid = midpoint(P[up], P[lo]);
    moves.push([up, sub(mid, P[up])], [lo, sub(mid, P[lo])]);
  }
  const upper = new Set(INNER_LIPS.map((p) => p[0])), lower = new Set(INNER_LIPS.map((p) => p[1]));
  const original = P.map((p) => p.slice());
  const side = (i) => (upper.has(i) ? 1 : lower.has(i) ? -1 : 0);
  original.forEach((p, i) => {
    let best = null, bestD = Infinity;
    for (const [j, m] of moves) {
      if (side(i) !== 0 && side(i) !== side(j)) continue;
      if (side(i) === 0 && Math.sign(p[1] - mouthLineY(original, p[0])) !== side(j)) continue;
      const d = Math.hypot(p[0] - original[j][0], p[1] - original[j][1], p[2] - original[j][2]);
      if (d < bestD) { bestD = d; best = m; }
    }
    if (!best || bestD > 1.2) return;
    const w = Math.exp(-((bestD / 0.35) ** 2));
    for (let k = 0; k < 3; k++) P[i][k] += w * best[k];
  });
}

function mouthLineY(P, x) {
  const pts = INNER_LIPS.map(([u, l]) => [P[u][0], (P[u][1] + P[l][1]) / 2]).sort((a, b) => a[0] - b[0]);
  if (x <= pts[0][0]) return pts[0][1];
  for (let k = 1; k < pts.length; k++) {
    if (x <= pts[k][0]) {
      const t = (x - pts[k - 1][0]) / (pts[k][0] - pts[k - 1][0]);
      return pts[k - 1][1] + t * (pts[k][1] - pts[k - 1][1]);
    }
  }
  return pts[pts.length - 1][1];
}

function spans(triangle, ring) {
  return triangle.every((v) => ring.includes(v));
}

/** Which side of the eyelids' and lips' parting lines each vertex is on. */
function computeRegions(P, faceCount) {
  const regions = {};
  for (const [side, ring] of [["L", EYE_L], ["R", EYE_R]]) {
    const outer = P[ring[0]], inner = P[ring[8]];
    const cx = (outer[0] + inner[0]) / 2;
    const lineY = (x) => outer[1] + ((x - outer[0]) / (inner[0] - outer[0])) * (inner[1] - outer[1]);
    const near = (p) => Math.abs(p[0] - cx) < 2.4 && p[2] > 1;
    regions["upperEye" + side] = P.map((p, i) => i < faceCount && near(p) && p[1] >= lineY(p[0]) - 1e-6);
    regions["lowerEye" + side] = P.map((p, i) => i < faceCount && near(p) && p[1] < lineY(p[0]) - 1e-6);
  }
  const upper = new Set(INNER_LIPS.map((p) => p[0])), lower = new Set(INNER_LIPS.map((p) => p[1]));
  const lipSide = (p, i) => (upper.has(i) ? 1 : lower.has(i) ? -1 : Math.sign(p[1] - mouthLineY(P, p[0])));
  regions.upperLip = P.map((p, i) => i < faceCount && lipSide(p, i) > 0);
  regions.lowerLip = P.map((p, i) => i < faceCount && lipSide(p, i) < 0);
  regions.lipSide = P.map(lipSide);
  regions.cornerY = (P[MOUTH_CORNERS[0]][1] + P[MOUTH_CORNERS[1]][1]) / 2;
  return regions;
}

/** How much a vertex moves with the jaw: the lower lip and everything below the mouth's
    corners, fading out above them and behind the jaw pivot. */
function jawWeight(p, i, regions) {
  if (ALL_CORNERS.has(i)) return 0.45;
  if (regions.lipSide[i] > 0 && Math.abs(p[0]) < 2.6 && p[1] > regions.cornerY - 0.6) return 0;
  let w = regions.lowerLip[i] && Math.abs(p[0]) < 2.6 ? 1 : smoothstep(regions.cornerY + 0.2, regions.cornerY - 1.4, p[1]);
  w *= smoothstep(JAW_PIVOT[2] - 1.5, JAW_PIVOT[2] + 2.5, p[2]);
  return w;
}

/** The back of the head: rings from the face's outer edge round to the back, each vertex on
    a path from its edge vertex to that vertex's mirror image behind the head. */
function buildShell(P, triangles) {
  const loop = outerLoop(triangles);
  const C = SHELL_CENTRE;
  const positions = [], uvs = [], tris = [];
  const ellipsoid = (d) => {
    const ry = d[1] >= 0 ? SHELL_RADII.up : SHELL_RADII.down, rz = d[2] >= 0 ? 8 : SHELL_RADII.back;
    return 1 / Math.sqrt((d[0] / SHELL_RADII.x) ** 2 + (d[1] / ry) ** 2 + (d[2] / rz) ** 2);
  };
  const index = (ring, k) => (ring === 0 ? loop[k] : P.length + (ring - 1) * loop.length + k);
  for (let ring = 1; ring <= SHELL_RINGS; ring++) {
    const t = ring / SHELL_RINGS;
    for (const v of loop) {
      const rel = sub(P[v], C), len = Math.hypot(...rel), d0 = scaled(rel, 1 / len);
      const back = [d0[0], d0[1], -Math.abs(d0[2]) - 0.6];
      const d = normalise(d0.map((x, k) => x * (1 - t) + back[k] * t));
      const r = len + (ellipsoid(d) - len) * smoothstep(0, 0.45, t);
      positions.push([C[0] + r * d[0], C[1] + r * d[1], C[2] + r * d[2]]);
      uvs.push([0.5, 0.02]);
    }
  }
  const n = loop.length;
  for (let ring = 0; ring < SHELL_RINGS; ring++) {
    for (let k = 0; k < n; k++) {
      const a = index(ring, k), b = index(ring, (k + 1) % n), c = index(ring + 1, k), d = index(ring + 1, (k + 1) % n);
      tris.push([a, c, b], [b, c, d]);
    }
  }
  const pole = P.length + positions.length;
  positions.push([C[0], C[1], C[2] - SHELL_RADII.back]);
  uvs.push([0.5, 0.02]);
  for (let k = 0; k < n; k++) tris.push([index(SHELL_RINGS, k), pole, index(SHELL_RINGS, (k + 1) % n)]);
  const all = P.concat(positions);
  return { positions, uvs, triangles: tris.map((tri) => outward(tri, all, C)) };
}

function outward(tri, all, C) {
  const [a, b, c] = tri.map((i) => all[i]);
  const n = cross(sub(b, a), sub(c, a));
  const centre = [(a[0] + b[0] + c[0]) / 3 - C[0], (a[1] + b[1] + c[1]) / 3 - C[1], (a[2] + b[2] + c[2]) / 3 - C[2]];
  return n[0] * centre[0] + n[1] * centre[1] + n[2] * centre[2] >= 0 ? tri : [tri[0], tri[2], tri[1]];
}

/** The face's outer boundary as a vertex loop (the longest boundary loop). */
function outerLoop(triangles) {
  const count = new Map();
  for (const t of triangles) {
    for (const [u, v] of [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]]) {
      const key = u < v ? `${u},${v}` : `${v},${u}`;
      count.set(key, (count.get(key) || 0) + 1);
    }
  }
  const next = new Map();
  for (const [key, c] of count) {
    if (c !== 1) continue;
    const [u, v] = key.split(",").map(Number);
    next.set(u, (next.get(u) || []).concat(v));
    next.set(v, (next.get(v) || []).concat(u));
  }
  const seen = new Set();
  let longest = [];
  for (const start of next.keys()) {
    if (seen.has(start)) continue;
    const loop = [start];
    seen.add(start);
    let prev = -1, cur = start;
    for (;;) {
      const step = next.get(cur).find((v) => v !== prev && !seen.has(v));
      if (step === undefined) break;
      prev = cur; cur = step; seen.add(cur); loop.push(cur);
    }
    if (loop.length > longest.length) longest = loop;
  }
  return longest;
}

function morphNormals(geometry, disp) {
  const moved = new THREE.BufferGeometry();
  const pos = geometry.getAttribute("position").array.slice();
  for (let k = 0; k < pos.length; k++) pos[k] += disp[k];
  moved.setAttribute("position", new THREE.BufferAttribute(pos, 3));
  moved.setIndex(geometry.getIndex());
  moved.computeVertexNormals();
  const n0 = geometry.getAttribute("normal").array, n1 = moved.getAttribute("normal").array;
  const out = new Float32Array(n0.length);
  for (let k = 0; k < n0.length; k++) out[k] = n1[k] - n0[k];
  moved.dispose();
  return new THREE.BufferAttribute(out, 3);
}

/** An eyeball for an eye opening: centred behind the contour, as large as fits inside it. */
function eyeSocket(P, ring) {
  const c = [0, 1, 2].map((k) => ring.reduce((s, v) => s + P[v][k], 0) / ring.length);
  const centre = [c[0], c[1], c[2] - 1.05];
  const radius = 0.97 * Math.min(...ring.map((v) => Math.hypot(...sub(P[v], centre))));
  return { centre, radius };
}

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const scaled = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const midpoint = (a, b) => [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const normalise = (a) => scaled(a, 1 / Math.hypot(...a));
