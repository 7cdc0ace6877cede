/* Draws a robot face on a 2D canvas from 52 ARKit blendshapes, head pose and eye rotations.

   The face is a rigid plane with depth: each feature has a centre (x, y, z) in head units
   (half-width 1, y up, z towards the viewer) and is drawn in its own local frame through
   ctx.setTransform, after rotating by yaw (about y), pitch (about x) and roll (about z).
   Yaw > 0 turns the face to the viewer's right, pitch > 0 tilts it down, roll > 0 tilts it
   counter-clockwise. "Left" channels belong to the robot's own left (the viewer's right).
   draw() returns screen-space geometry (mouth opening, nose position) for tests/telemetry. */
"use strict";

(function () {
  const NAMES = [
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft",
    "eyeSquintLeft", "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight",
    "eyeLookOutRight", "eyeLookUpRight", "eyeSquintRight", "eyeWideRight", "jawForward",
    "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel", "mouthPucker", "mouthLeft",
    "mouthRight", "mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft", "mouthFrownRight",
    "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft", "mouthStretchRight",
    "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper", "mouthPressLeft",
    "mouthPressRight", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft",
    "browOuterUpRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft",
    "noseSneerRight", "tongueOut",
  ];
  const I = Object.fromEntries(NAMES.map((n, i) => [n, i]));
  const DEG = Math.PI / 180;
  const clamp = (v, lo, hi) => Math.min(hi, Math.max(lo, v));

  /** Reads channels by name; sided(name) gives [left, right] for "<name>Left/Right". */
  function channels(bs) {
    const get = (name) => clamp(bs[I[name]] || 0, 0, 1);
    return { get, sided: (name) => [get(name + "Left"), get(name + "Right")] };
  }

  /** Rotation matrix R = Rz(roll) Rx(pitch) Ry(yaw), rows as arrays. Pitch > 0 tilts down. */
  function rotation(yawDeg, pitchDeg, rollDeg) {
    const [y, p, r] = [yawDeg * DEG, pitchDeg * DEG, rollDeg * DEG];
    const cy = Math.cos(y), sy = Math.sin(y), cp = Math.cos(p), sp = Math.sin(p);
    const cr = Math.cos(r), sr = Math.sin(r);
    const ry = [[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]];
    const rx = [[1, 0, 0], [0, cp, -sp], [0, sp, cp]];
    const rz = [[cr, -sr, 0], [sr, cr, 0], [0, 0, 1]];
    return mul(rz, mul(rx, ry));
  }

  function mul(a, b) {
    return a.map((row) => [0, 1, 2].map((j) => row[0] * b[0][j] + row[1] * b[1][j] + row[2] * b[2][j]));
  }

  class Frame {
    constructor(ctx, cx, cy, scale, rot) {
      Object.assign(this, { ctx, cx, cy, scale, rot });
    }
    /** Screen point of a face-space point. */
    project(x, y, z) {
      const R = this.rot, S = this.scale;
      return [this.cx + S * (R[0][0] * x + R[0][1] * y + R[0][2] * z),
              this.cy - S * (R[1][0] * x + R[1][1] * y + R[1][2] * z)];
    }
    /** Draw in a feature's local frame (origin at x0, y0, z0; y up). */
    at(x0, y0, z0) {
      const R = this.rot, S = this.scale;
      const [e, f] = this.project(x0, y0, z0);
      this.ctx.setTransform(S * R[0][0], -S * R[1][0], S * R[0][1], -S * R[1][1], e, f);
    }
    /** The silhouette frame: rolls and shifts with the head but does not foreshorten. */
    flat(shiftX, shiftY) {
      const R = this.rot, S = this.scale;
      const c = Math.cos(Math.atan2(R[1][0], R[0][0])), s = Math.sin(Math.atan2(R[1][0], R[0][0]));
      this.ctx.setTransform(S * c, -S * s, -S * s, -S * c, this.cx + S * shiftX, this.cy - S * shiftY);
    }
  }

  function ellipse(ctx, x, y, rx, ry, fill) {
    ctx.beginPath();
    ctx.ellipse(x, y, Math.max(rx, 1e-4), Math.max(ry, 1e-4), 0, 0, 2 * Math.PI);
    ctx.fillStyle = fill;
    ctx.fill();
  }

  /** Head outline points: superellipse, tapered chin, jaw drop and puffed cheeks. */
  function headOutline(head, jawOpen, puff) {
    const pts = [];
    for (let k = 0; k < 72; k++) {
      const t = (k / 72) * 2 * Math.PI, c = Math.cos(t), s = Math.sin(t);
      let x = head.rx * Math.sign(c) * Math.abs(c) ** (2 / head.n);
      let y = head.ry * Math.sign(s) * Math.abs(s) ** (2 / head.n);
      if (y < 0) {
        const depth = -y / head.ry;
        x *= 1 - head.chin * depth * depth + puff * 0.08 * Math.sin(Math.PI * clamp(depth * 1.4, 0, 1));
        y -= jawOpen * 0.17 * clamp((depth - 0.25) / 0.75, 0, 1);
      }
      pts.push([x, y]);
    }
    return pts;
  }

  function pathOf(ctx, pts) {
    ctx.beginPath();
    pts.forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
    ctx.closePath();
  }

  function drawBody(fr, st, shiftX) {
    const ctx = fr.ctx, h = st.head;
    fr.ctx.setTransform(fr.scale, 0, 0, -fr.scale, fr.cx, fr.cy);
    ellipse(ctx, 0, -h.ry - 1.05, 1.75, 0.75, st.shirt);
    ctx.fillStyle = st.skinShade;  // the neck stays put; the head turns on top of it
    ctx.fillRect(-0.3 + shiftX * 0.5, -h.ry - 0.75, 0.6, 0.9);
  }

  function drawHairBack(ctx, st) {
    const h = st.head, hair = st.hair;
    if (hair.style === "bob") {
      ctx.beginPath();
      ctx.ellipse(0, 0.08, h.rx * 1.16, h.ry * 1.08, 0, Math.PI * 1.08, Math.PI * 1.92, true);
      ctx.lineTo(h.rx * 1.1, -0.55);
      ctx.lineTo(-h.rx * 1.1, -0.55);
      ctx.closePath();
      ctx.fillStyle = hair.color;
      ctx.fill();
    } else if (hair.style === "bun") {
      ellipse(ctx, 0, h.ry + 0.1, 0.3, 0.26, hair.color);
    }
  }

  function drawHairFront(ctx, st) {
    const h = st.head, hair = st.hair;
    ctx.fillStyle = hair.color;
    ctx.beginPath();
    if (hair.style === "bob") {
      ctx.ellipse(0, 0.05, h.rx * 1.06, h.ry * 1.03, 0, 0.08 * Math.PI, 0.92 * Math.PI);
      ctx.quadraticCurveTo(-0.5, 0.55, -0.1, 0.72);
      ctx.quadraticCurveTo(0.5, 0.6, h.rx * 1.0, 0.3);
    } else if (hair.style === "crop") {
      ctx.ellipse(0, 0.0, h.rx * 1.03, h.ry * 1.05, 0, 0.12 * Math.PI, 0.88 * Math.PI);
      ctx.lineTo(-h.rx * 0.8, 0.66);
      ctx.lineTo(h.rx * 0.8, 0.66);
    } else if (hair.style === "bun") {
      ctx.ellipse(0, 0.02, h.rx * 1.02, h.ry * 1.02, 0, 0.15 * Math.PI, 0.85 * Math.PI);
      ctx.quadraticCurveTo(0, 0.68, h.rx * 0.9, 0.62);
    } else if (hair.style === "fringe") {
      ctx.ellipse(0, 0.0, h.rx * 1.02, h.ry * 1.02, 0, 0.2 * Math.PI, 0.8 * Math.PI);
      for (let k = 0; k <= 6; k++) ctx.lineTo(-h.rx * 0.8 + (k * h.rx * 1.6) / 6, k % 2 ? 0.62 : 0.74);
    }
    ctx.closePath();
    ctx.fill();
  }

  function drawHead(fr, st, ch, shiftX) {
    const ctx = fr.ctx, h = st.head;
    fr.flat(shiftX, 0);
    drawHairBack(ctx, st);
    for (const side of [-1, 1]) ellipse(ctx, side * h.rx * 0.98, 0.05, 0.14, 0.22, st.skinShade);
    const outline = headOutline(h, ch.get("jawOpen"), ch.get("cheekPuff"));
    pathOf(ctx, outline);
    const grad = ctx.createRadialGradient(-0.25, 0.35, 0.1, 0, 0, h.ry * 1.3);
    grad.addColorStop(0, st.skin);
    grad.addColorStop(1, st.skinShade);
    ctx.fillStyle = grad;
    ctx.fill();
    if (st.extras.includes("stubble")) {
      ctx.save();
      ctx.clip();
      ellipse(ctx, 0, -h.ry * 0.78 - ch.get("jawOpen") * 0.12, h.rx * 0.78, h.ry * 0.42, "rgba(40,25,18,0.35)");
      ctx.restore();
    }
    drawHairFront(ctx, st);
    if (st.extras.includes("earrings")) {
      for (const side of [-1, 1]) ellipse(ctx, side * h.rx * 0.99, -0.2, 0.05, 0.05, "#e8c547");
    }
  }

  /** One eye in its local frame; side +1 is the robot's left (viewer's right). */
  function drawEye(fr, st, ch, side, gaze) {
    const ctx = fr.ctx, e = st.eyes;
    const sfx = side > 0 ? "Left" : "Right";
    const blink = ch.get("eyeBlink" + sfx), wide = ch.get("eyeWide" + sfx);
    const squint = ch.get("eyeSquint" + sfx), cheek = ch.get("cheekSquint" + sfx);
    const upper = clamp(1 - blink * 1.05 + wide * 0.35 - squint * 0.15, 0, 1.35) * e.rh;
    const lower = clamp(1 - squint * 0.45 - cheek * 0.35 - blink * 0.3 + wide * 0.1, 0.05, 1.1) * e.rh;
    fr.at(side * e.spacing, e.y, 0.74);
    const almond = (top, bottom) => {
      ctx.beginPath();
      ctx.moveTo(-e.rw, 0);
      ctx.quadraticCurveTo(0, 2 * top, e.rw, 0);
      ctx.quadraticCurveTo(0, -2 * bottom, -e.rw, 0);
      ctx.closePath();
    };
    ctx.lineWidth = 0.022;
    ctx.strokeStyle = "#2b1d16";
    if (upper < 0.12 * e.rh) {  // closed: just the lid line
      ctx.beginPath();
      ctx.moveTo(-e.rw, 0);
      ctx.quadraticCurveTo(0, -0.35 * e.rh, e.rw, 0);
      ctx.stroke();
      return;
    }
    ctx.save();
    almond(upper, lower);
    ctx.fillStyle = "#fbfbf8";
    ctx.fill();
    ctx.clip();
    const r = e.rh * e.irisSize;
    const ix = gaze[0] * e.rw * 0.5, iy = gaze[1] * e.rh * 0.45;
    ellipse(ctx, ix, iy, r, r, e.iris);
    ellipse(ctx, ix, iy, r * 0.45, r * 0.45, "#0c0c0e");
    ellipse(ctx, ix + r * 0.3, iy + r * 0.35, r * 0.18, r * 0.18, "rgba(255,255,255,0.85)");
    ctx.restore();
    almond(upper, lower);
    ctx.stroke();
    if (e.lashes) {  // a few lashes near the outer corner, on the upper lid curve
      ctx.beginPath();
      for (const u of [0.7, 0.82, 0.94]) {
        const t = side > 0 ? u : 1 - u;
        const x = e.rw * (2 * t - 1), y = 4 * t * (1 - t) * upper;
        ctx.moveTo(x, y);
        ctx.lineTo(x + side * 0.045, y + 0.045);
      }
      ctx.stroke();
    }
  }

  function drawBrow(fr, st, ch, side) {
    const ctx = fr.ctx, b = st.brows;
    const sfx = side > 0 ? "Left" : "Right";
    const down = ch.get("browDown" + sfx), innerUp = ch.get("browInnerUp");
    const outerUp = ch.get("browOuterUp" + sfx);
    fr.at(0, b.y, 0.72);
    const inner = [side * b.inner, innerUp * 0.13 - down * 0.09];
    const outer = [side * b.outer, -0.03 + outerUp * 0.12 - down * 0.03];
    const mid = [(inner[0] + outer[0]) / 2, Math.max(inner[1], outer[1]) + b.arch + innerUp * 0.02];
    ctx.lineCap = "round";
    ctx.strokeStyle = b.color;
    ctx.lineWidth = b.width;
    ctx.beginPath();
    ctx.moveTo(inner[0], inner[1]);
    ctx.quadraticCurveTo(2 * mid[0] - (inner[0] + outer[0]) / 2, 2 * mid[1] - (inner[1] + outer[1]) / 2, outer[0], outer[1]);
    ctx.stroke();
    if (b.filled) {  // thick brows: a second, offset stroke
      ctx.lineWidth = b.width * 0.7;
      ctx.beginPath();
      ctx.moveTo(inner[0], inner[1] + b.width * 0.35);
      ctx.quadraticCurveTo(mid[0], mid[1] + b.width * 0.4, outer[0] - side * 0.05, outer[1] + b.width * 0.2);
      ctx.stroke();
    }
  }

  function drawCheeks(fr, st, ch) {
    const puff = ch.get("cheekPuff");
    for (const side of [-1, 1]) {
      const squint = ch.get(side > 0 ? "cheekSquintLeft" : "cheekSquintRight");
      fr.at(side * (0.55 + puff * 0.06), -0.22 + squint * 0.06, 0.6);
      const alpha = clamp(st.blush + squint * 0.25 + puff * 0.2, 0, 0.7);
      if (alpha > 0.01) ellipse(fr.ctx, 0, 0, 0.17 + puff * 0.06, 0.1 + puff * 0.03, `rgba(230,110,110,${alpha})`);
    }
  }

  function drawNose(fr, st, ch) {
    const ctx = fr.ctx, n = st.nose, s = n.size;
    const [sneerL, sneerR] = ch.sided("noseSneer");
    fr.at(0, -0.1, 0.95);
    ctx.strokeStyle = st.skinShade;
    ctx.fillStyle = st.skinShade;
    ctx.lineWidth = 0.025;
    ctx.lineCap = "round";
    if (n.style === "line" || n.style === "long") {
      const top = n.style === "long" ? 0.28 : 0.16;
      ctx.beginPath();
      ctx.moveTo(0.02, top);
      ctx.quadraticCurveTo(0.05, -0.02, -0.05, -0.04);
      ctx.stroke();
    } else {
      ellipse(ctx, 0, 0, s * (n.style === "wide" ? 0.9 : 0.6), s * 0.45, "rgba(0,0,0,0.12)");
    }
    for (const [side, sneer] of [[1, sneerL], [-1, sneerR]]) {
      ellipse(ctx, side * s * 0.45, -0.03 + sneer * 0.04, s * 0.17, s * 0.11, "rgba(40,20,15,0.55)");
      if (sneer > 0.05) {  // wrinkles above the nose
        ctx.strokeStyle = `rgba(60,30,20,${sneer * 0.6})`;
        ctx.beginPath();
        ctx.moveTo(side * 0.05, 0.14);
        ctx.lineTo(side * 0.13, 0.09);
        ctx.stroke();
      }
    }
  }

  /** Mouth shape numbers (face units, relative to the mouth centre) from the channels. */
  function mouthShape(ch) {
    const g = ch.get;
    const [smL, smR] = ch.sided("mouthSmile"), [frL, frR] = ch.sided("mouthFrown");
    const [stL, stR] = ch.sided("mouthStretch"), [prL, prR] = ch.sided("mouthPress");
    const [dmL, dmR] = ch.sided("mouthDimple"), [ldL, ldR] = ch.sided("mouthLowerDown");
    const [uuL, uuR] = ch.sided("mouthUpperUp");
    const pucker = g("mouthPucker"), funnel = g("mouthFunnel"), press = (prL + prR) / 2;
    const widthFor = (smile, stretch, dimple) =>
      0.3 * (1 + 0.32 * stretch + 0.16 * smile + 0.08 * dimple - 0.42 * pucker - 0.3 * funnel);
    const open = Math.max(0, g("jawOpen") * 0.3 + (ldL + ldR) * 0.035 + (uuL + uuR) * 0.02
      + funnel * 0.07 - g("mouthClose") * 0.3 - press * 0.03);
    return {
      shiftX: (g("mouthLeft") - g("mouthRight")) * 0.12 + (g("jawLeft") - g("jawRight")) * 0.05,
      left: [widthFor(smL, stL, dmL), smL * 0.11 - frL * 0.1 + dmL * 0.015],
      right: [-widthFor(smR, stR, dmR), smR * 0.11 - frR * 0.1 + dmR * 0.015],
      upperUp: (uuL + uuR) * 0.02 + g("mouthShrugUpper") * 0.015,
      open,
      lowerShift: g("mouthShrugLower") * 0.03 - g("jawOpen") * 0.04,
      upperThick: 0.045 * (1 - g("mouthRollUpper") * 0.75 - press * 0.4) * (1 + pucker * 0.6),
      lowerThick: 0.06 * (1 - g("mouthRollLower") * 0.75 - press * 0.4) * (1 + pucker * 0.6),
      round: clamp(Math.max(funnel, pucker * 0.7), 0, 1),
      forward: (pucker + funnel) * 0.06 + g("jawForward") * 0.04,
      tongue: g("tongueOut"),
    };
  }

  /** A cubic lip line from corner to corner whose middle passes through midY. */
  function lipCurve(ctx, from, to, midY, round, start) {
    const k = 0.5 + 0.4 * round;
    const c = (midY - (from[1] + to[1]) / 8) * (8 / 6);
    if (start) ctx.moveTo(from[0], from[1]);
    ctx.bezierCurveTo(from[0] * k, c, to[0] * k, c, to[0], to[1]);
  }

  function drawMouth(fr, st, ch) {
    const ctx = fr.ctx, m = mouthShape(ch);
    const cy = -0.5 - ch.get("jawOpen") * 0.05;
    fr.at(m.shiftX, cy, 0.8 + m.forward);
    const L = m.left, R = m.right;
    const innerTop = 0.01 + m.upperUp, innerBottom = innerTop - m.open + m.lowerShift * 0.3;
    const outerTop = innerTop + m.upperThick, outerBottom = innerBottom - m.lowerThick;
    ctx.beginPath();  // lips
    lipCurve(ctx, L, R, outerTop, m.round, true);
    lipCurve(ctx, R, L, outerBottom, m.round, false);
    ctx.closePath();
    ctx.fillStyle = st.lips;
    ctx.fill();
    if (m.open > 0.004) {
      ctx.save();
      ctx.beginPath();
      lipCurve(ctx, L, R, innerTop, m.round, true);
      lipCurve(ctx, R, L, innerBottom, m.round, false);
      ctx.closePath();
      ctx.fillStyle = st.mouthInside;
      ctx.fill();
      ctx.clip();
      ctx.fillStyle = "#f4f1ea";
      ctx.fillRect(-0.3, innerTop - 0.045, 0.6, 0.045);
      ellipse(ctx, 0, innerBottom - 0.01 + m.tongue * 0.06, 0.15, 0.06 + m.tongue * 0.05, "#c0505a");
      ctx.restore();
    } else {
      ctx.strokeStyle = st.mouthInside;
      ctx.lineWidth = 0.012;
      ctx.beginPath();
      lipCurve(ctx, L, R, innerTop, m.round, true);
      ctx.stroke();
    }
    return { top: fr.project(m.shiftX, cy + innerTop, 0.8), bottom: fr.project(m.shiftX, cy + innerBottom, 0.8),
             left: fr.project(m.shiftX + L[0], cy + L[1], 0.8), right: fr.project(m.shiftX + R[0], cy + R[1], 0.8) };
  }

  function drawGlasses(fr, st) {
    const ctx = fr.ctx, e = st.eyes;
    ctx.strokeStyle = "#2a2a2a";
    ctx.lineWidth = 0.03;
    for (const side of [-1, 1]) {
      fr.at(side * e.spacing, e.y, 0.8);
      ctx.beginPath();
      ctx.ellipse(0, 0, e.rw * 1.45, e.rh * 2.0, 0, 0, 2 * Math.PI);
      ctx.stroke();
    }
    fr.at(0, e.y, 0.82);
    ctx.beginPath();
    ctx.moveTo(-e.spacing + e.rw * 1.45, 0.02);
    ctx.quadraticCurveTo(0, 0.07, e.spacing - e.rw * 1.45, 0.02);
    ctx.stroke();
  }

  function drawMoustache(fr, st, ch) {
    const ctx = fr.ctx;
    fr.at((ch.get("mouthLeft") - ch.get("mouthRight")) * 0.1, -0.36, 0.85);
    ctx.fillStyle = st.hair.color;
    ctx.beginPath();
    ctx.moveTo(-0.3, -0.05 + ch.get("mouthSmileRight") * 0.05);
    ctx.quadraticCurveTo(0, 0.12, 0.3, -0.05 + ch.get("mouthSmileLeft") * 0.05);
    ctx.quadraticCurveTo(0, 0.02, -0.3, -0.05 + ch.get("mouthSmileRight") * 0.05);
    ctx.fill();
  }

  /** Gaze per eye in [-1, 1] (x to the viewer's right, y up) from channels and eye angles. */
  function gazeOf(ch, eyes) {
    const [downL, downR] = ch.sided("eyeLookDown"), [upL, upR] = ch.sided("eyeLookUp");
    const [inL, inR] = ch.sided("eyeLookIn"), [outL, outR] = ch.sided("eyeLookOut");
    const e = eyes || [0, 0, 0, 0, 0, 0];
    return {
      left: [clamp(outL - inL + e[0] / 30, -1, 1), clamp(upL - downL - e[1] / 30, -1, 1)],
      right: [clamp(inR - outR + e[3] / 30, -1, 1), clamp(upR - downR - e[4] / 30, -1, 1)],
    };
  }

  /** Paint one face; returns screen geometry of what was drawn. */
  function draw(ctx, width, height, state, style) {
    const ch = channels(state.bs);
    const [yaw, pitch, roll] = state.head;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = style.background;
    ctx.fillRect(0, 0, width, height);
    const scale = Math.min(width / 3.2, height / 3.7);
    const fr = new Frame(ctx, width / 2, height * 0.5, scale, rotation(yaw, pitch, roll));
    const shiftX = Math.sin(yaw * DEG) * 0.08;
    drawBody(fr, style, shiftX);
    drawHead(fr, style, ch, shiftX);
    drawCheeks(fr, style, ch);
    const gaze = gazeOf(ch, state.eyes);
    drawEye(fr, style, ch, 1, gaze.left);
    drawEye(fr, style, ch, -1, gaze.right);
    drawBrow(fr, style, ch, 1);
    drawBrow(fr, style, ch, -1);
    drawNose(fr, style, ch);
    if (style.extras.includes("moustache")) drawMoustache(fr, style, ch);
    const mouth = drawMouth(fr, style, ch);
    if (style.extras.includes("glasses")) drawGlasses(fr, style);
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    const nose = fr.project(0, -0.1, 0.95);
    return {
      mouthOpenPx: Math.hypot(mouth.top[0] - mouth.bottom[0], mouth.top[1] - mouth.bottom[1]),
      mouthWidthPx: Math.hypot(mouth.left[0] - mouth.right[0], mouth.left[1] - mouth.right[1]),
      noseX: nose[0], noseY: nose[1], centerX: fr.cx, centerY: fr.cy, scale,
    };
  }

  window.FaceRenderer = Object.freeze({ NAMES, INDEX: I, draw });
})();
