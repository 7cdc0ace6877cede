/* The four study faces as projected "robot masks": flat, matte colours painted into the
   canonical mesh's UV layout (so brows, lids and lips move with the morph targets), a shell
   in the hair colour, never photo-real. Colours come from the 2D characters (faces.js,
   window.RobotFaces) so a persona looks alike in 2D and 3D; the gender and age cues are
   those of the study's faces (face-1 Ada, young woman; face-2 Bram, man; face-3 Cleo,
   young woman; face-4 Dex, older man). */

// Per face: hair cover of the shell (how low at the back, a fringe on the forehead),
// brow thickness, lash line, lines of age, stubble.
export const LOOKS = {
  "face-1": { hairBack: -6.5, hairFront: 6.9, brow: 0.9, liner: 3.2, shadow: 0.18, lines: 0, stubble: 0, sheen: 0.05 },
  "face-2": { hairBack: 1.5, hairFront: 7.2, brow: 1.5, liner: 1.6, shadow: 0, lines: 0.15, stubble: 0.35, sheen: 0.0 },
  "face-3": { hairBack: -2.5, hairFront: 7.4, brow: 0.75, liner: 3.6, shadow: 0.25, lines: 0, stubble: 0, sheen: 0.08 },
  "face-4": { hairBack: 2.5, hairFront: 6.2, brow: 1.35, liner: 1.4, shadow: 0, lines: 0.6, stubble: 0, sheen: 0.0, moustache: true },
};

const SIZE = 1024;
const BROW_UPPER = { L: [300, 293, 334, 296, 336], R: [70, 63, 105, 66, 107] };
const BROW_LOWER = { L: [276, 283, 282, 295, 285], R: [46, 53, 52, 65, 55] };
const LIP_OUTER = [61, 185, 40, 39, 37, 0, 267, 269, 270, 409, 291, 375, 321, 405, 314, 17, 84, 181, 91, 146];
const UPPER_LID = { L: [263, 466, 388, 387, 386, 385, 384, 398, 362], R: [33, 246, 161, 160, 159, 158, 157, 173, 133] };
const LOWER_LID = { L: [263, 249, 390, 373, 374, 380, 381, 382, 362], R: [33, 7, 163, 144, 145, 153, 154, 155, 133] };
const CHEEK = { L: 425, R: 205 };
const NOSTRIL = { L: 327, R: 98 };
const JAW_LINE = [234, 93, 132, 58, 172, 136, 150, 149, 176, 148, 152, 377, 400, 378, 379, 365, 397, 288, 361, 323, 454];
const FOLD = { L: [358, 423, 426, 436, 432], R: [129, 203, 206, 216, 212] };
const FOREHEAD_LINES = [[[109, 10, 338]], [[67, 109, 10, 338, 297]]];

/** The face texture (a canvas in UV space; u right, v down, as MediaPipe's uvs are). */
export function paintFace(canvas, uvs, style, look) {
  canvas.width = SIZE;
  canvas.height = SIZE;
  const g = canvas.getContext("2d");
  const at = (i) => [uvs[i][0] * SIZE, uvs[i][1] * SIZE];
  const path = (ids, close) => {
    g.beginPath();
    ids.forEach((i, k) => (k ? g.lineTo(...at(i)) : g.moveTo(...at(i))));
    if (close) g.closePath();
  };
  g.fillStyle = style.skin;
  g.fillRect(0, 0, SIZE, SIZE);
  // A soft top light baked in: the mask's projector is brighter at the centre.
  const glow = g.createRadialGradient(SIZE / 2, SIZE * 0.42, SIZE * 0.1, SIZE / 2, SIZE * 0.5, SIZE * 0.62);
  glow.addColorStop(0, "rgba(255,255,255,0.10)");
  glow.addColorStop(1, "rgba(0,0,0,0.10)");
  g.fillStyle = glow;
  g.fillRect(0, 0, SIZE, SIZE);
  for (const side of ["L", "R"]) {
    const [cx, cy] = at(CHEEK[side]);
    const blush = g.createRadialGradient(cx, cy, 0, cx, cy, SIZE * 0.09);
    blush.addColorStop(0, `rgba(225,105,105,${0.15 + style.blush * 0.5})`);
    blush.addColorStop(1, "rgba(225,105,105,0)");
    g.fillStyle = blush;
    g.fillRect(cx - SIZE * 0.1, cy - SIZE * 0.1, SIZE * 0.2, SIZE * 0.2);
  }
  if (look.stubble) {
    path(JAW_LINE.concat([287, 273, 335, 406, 313, 18, 83, 182, 43, 57]), true);
    g.fillStyle = `rgba(40,28,22,${look.stubble})`;
    g.fill();
    feather(g, style.skin, [26, 14], 0.35);  // a soft edge (no canvas filter: see feather)
  }
  for (const side of ["L", "R"]) {
    if (look.shadow) {  // lid colour: a soft band just above the lash line
      path(UPPER_LID[side], false);
      feather(g, `rgba(90,60,110,${look.shadow * 0.6})`, [18, 12, 6]);
    }
    path(BROW_UPPER[side].concat(BROW_LOWER[side].slice().reverse()), true);  // brows
    g.fillStyle = style.brows.color;
    g.fill();
    g.lineWidth = 6 * look.brow;
    g.strokeStyle = style.brows.color;
    g.lineJoin = "round";
    g.stroke();
    path(UPPER_LID[side], false);  // lash line
    g.lineWidth = look.liner * 2;
    g.strokeStyle = "#2a1a14";
    g.stroke();
    path(LOWER_LID[side], false);
    g.lineWidth = 2;
    g.strokeStyle = "rgba(60,35,30,0.45)";
    g.stroke();
    const [nx, ny] = at(NOSTRIL[side]);  // nostrils
    g.fillStyle = "rgba(50,25,20,0.55)";
    g.beginPath();
    g.ellipse(nx + (side === "L" ? -6 : 6), ny + 4, 9, 5, 0, 0, 2 * Math.PI);
    g.fill();
    if (look.lines) {  // nasolabial folds
      path(FOLD[side], false);
      g.lineWidth = 3;
      g.strokeStyle = `rgba(80,45,35,${look.lines * 0.6})`;
      g.stroke();
    }
  }
  if (look.lines) {
    for (const [ids] of FOREHEAD_LINES) {
      for (const dy of [SIZE * 0.035, SIZE * 0.06]) {
        g.beginPath();
        ids.forEach((i, k) => { const [x, y] = at(i); (k ? g.lineTo : g.moveTo).call(g, x, y + dy); });
        g.lineWidth = 3;
        g.strokeStyle = `rgba(80,45,35,${look.lines * 0.4})`;
        g.stroke();
      }
    }
  }
  path(LIP_OUTER, true);  // lips
  g.fillStyle = style.lips;
  g.fill();
  g.lineWidth = 2;
  g.strokeStyle = "rgba(60,20,20,0.35)";
  g.stroke();
  if (look.moustache) {
    path([61, 186, 92, 165, 167, 164, 393, 391, 322, 410, 291, 409, 270, 269, 267, 0, 37, 39, 40, 185], true);
    g.fillStyle = style.hair.color;
    g.fill();
  }
  // The hairline: the top of the mask in the hair colour.
  const [, top] = at(10);
  const line = SIZE * (0.107 + (8.26 - look.hairFront) * 0.04);
  const hair = g.createLinearGradient(0, top, 0, line + 18);
  hair.addColorStop(0, style.hair.color);
  hair.addColorStop(Math.max(0, (line - top) / (line + 18 - top)), style.hair.color);
  hair.addColorStop(1, "rgba(0,0,0,0)");
  g.fillStyle = hair;
  g.fillRect(0, 0, SIZE, line + 18);
  return canvas;
}

/** Per-vertex colours of the shell behind the mask: hair on the top and back, down to
    `hairBack` (cm) at the back; skin below, at the sides near the face. */
export function shellColours(positions, start, style, look, out) {
  const skin = hex(style.skinShade), hair = hex(style.hair.color);
  for (let i = 0; i < positions.length; i++) {
    const [x, y, z] = positions[i];
    // Hair down to hairBack at the back, rising towards the face; the face's own vertices
    // (shared with the shell along its edge) take the same rule, so the edge has no seam.
    const edge = look.hairBack + Math.max(0, z + 3) * (look.hairBack < 0 ? 0.9 : 0.5) + Math.abs(x) * 0.05;
    const w = i >= start || y > 4 ? smooth(edge - 0.6, edge + 0.6, y) : 0;
    for (let k = 0; k < 3; k++) out[3 * i + k] = skin[k] * (1 - w) + hair[k] * w;
  }
}

/** Strokes the current path several times, widest first, for a soft edge. (A canvas
    filter such as blur() stalled Chromium's software WebGL texture upload for seconds.) */
function feather(g, colour, widths, alpha = 1) {
  g.save();
  g.globalAlpha = alpha;
  g.strokeStyle = colour;
  g.lineJoin = "round";
  for (const width of widths) {
    g.lineWidth = width;
    g.stroke();
  }
  g.restore();
}

function smooth(a, b, x) {
  const t = Math.min(1, Math.max(0, (x - a) / (b - a)));
  return t * t * (3 - 2 * t);
}

/** "#rrggbb" -> linear [r, g, b] (vertex colours are linear in three.js). */
export function hex(colour) {
  const n = parseInt(colour.slice(1), 16);
  return [(n >> 16) & 255, (n >> 8) & 255, n & 255].map((c) => (c / 255) ** 2.2);
}

/** An eyeball texture: white, the iris colour, a dark pupil; the pupil at u = 0.25 (three's
    SphereGeometry faces +z there). */
export function paintEye(canvas, iris) {
  canvas.width = 256;
  canvas.height = 128;
  const g = canvas.getContext("2d");
  g.fillStyle = "#f2efe9";
  g.fillRect(0, 0, 256, 128);
  const cx = 64, cy = 64;
  g.fillStyle = iris;
  g.beginPath(); g.ellipse(cx, cy, 22, 22, 0, 0, 2 * Math.PI); g.fill();
  g.strokeStyle = "rgba(0,0,0,0.45)";
  g.lineWidth = 3;
  g.stroke();
  g.fillStyle = "#0d0d10";
  g.beginPath(); g.ellipse(cx, cy, 9, 9, 0, 0, 2 * Math.PI); g.fill();
  return canvas;
}
