/* The 52 ARKit blendshapes of the 3D robot head, as data.

   Each shape is a list of operations on MediaPipe's canonical face mesh (468 landmarks, in
   cm: x towards the face's own LEFT, which the viewer sees on the right; y up; z out of the
   face). ARKit's "Left" is the face's own left (Apple, ARFaceAnchor.BlendShapeLocation and
   lookAtPoint: "looking to the left ... positive x"), so every *Left shape below moves
   landmarks with x > 0, and its *Right twin is made by mirroring it (x -> -x, landmark ->
   its mirror landmark): left and right cannot disagree.

   Operations (a shape's displacement at value 1.0; head_mesh.js turns them into
   morph targets with morphTargetsRelative = true):
   - move:   {at, move: [dx, dy, dz], radius}: the landmarks move by `move`; every vertex
             follows with the Gaussian falloff exp(-(d / radius)^2) of its distance d to
             the nearest of them.
   - toward: {from, to, amount, radius}: each `from` landmark moves `amount` of the way to
             its partner in `to` (an eyelid closing onto the other); vertices in between
             follow the Gaussian-weighted mean of those moves.
   - pull:   {at, to, amount, radius}: the landmarks move `amount` of the way towards the
             point `to` (a landmark), e.g. lips puckering towards the mouth's centre.
   - jaw:    {open: degrees} rotates the jaw region about the jaw pivot (below the ears);
             {shift: [dx, dy, dz]} translates it. The jaw region is computed from the mesh
             (below the lips' parting line, fading towards the ears).
   `region` limits an operation to one side of a parting line: the eyelids (upperEye /
   lowerEye, split by the line through the eye's corners) and the lips (upperLip /
   lowerLip, split by the mouth's inner line).
   `rig` drives the parts that are not face skin: the eyeballs (yaw/pitch in degrees;
   yaw > 0 turns the pupil towards the face's left) and the tongue. */

export const LANDMARKS = {
  // Left eye (the face's own left; x > 0). Lids listed outer corner to inner corner.
  upperLidL: [466, 388, 387, 386, 385, 384, 398],
  lowerLidL: [249, 390, 373, 374, 380, 381, 382],
  underEyeL: [253, 450, 449, 348, 451],
  browL: [300, 293, 334, 296, 336, 276, 283, 282, 295, 285],
  browInnerL: [336, 296, 285, 295],
  browOuterL: [300, 293, 276, 283],
  cheekL: [425, 280, 427, 411],
  cheekUpperL: [347, 330, 348, 449],
  noseSideL: [412, 343, 437, 277],
  alarL: [327, 294, 358, 331],
  mouthCornerL: [291, 308],
  dimpleL: [287, 432],
  upperLipL: [267, 269, 270, 409, 312, 311, 310, 415],
  lowerLipL: [314, 405, 321, 375, 317, 402, 318, 324],
  // The middle (x = 0) and both sides.
  upperLipMid: [0, 13],
  lowerLipMid: [17, 14],
  upperLip: [0, 13, 267, 269, 270, 409, 312, 311, 310, 415, 37, 39, 40, 185, 82, 81, 80, 191],
  lowerLip: [17, 14, 314, 405, 321, 375, 317, 402, 318, 324, 84, 181, 91, 146, 87, 178, 88, 95],
  lips: [0, 13, 267, 269, 270, 409, 312, 311, 310, 415, 37, 39, 40, 185, 82, 81, 80, 191,
    17, 14, 314, 405, 321, 375, 317, 402, 318, 324, 84, 181, 91, 146, 87, 178, 88, 95, 291, 61],
  mouthCorners: [291, 308, 61, 78],
  mouthCentre: [13],
  chin: [18, 200, 199, 313, 83],
  innerBrows: [336, 296, 285, 295, 107, 66, 55, 65],
};

const DEG = 1;  // angles are written in degrees

export const SHAPES = {
  // ---- eyes (eyeLook* turn the eyeball; the lids follow a little, as ARKit's do) -------
  eyeBlinkLeft: [
    { toward: { from: "upperLidL", to: "lowerLidL", amount: 1.0, radius: 0.55, region: "upperEyeL" } },
    { move: { at: "upperLidL", move: [0, 0, 0.1], radius: 0.4, region: "upperEyeL" } },
    { move: { at: "lowerLidL", move: [0, 0.07, 0], radius: 0.35, region: "lowerEyeL" } },
  ],
  eyeLookDownLeft: [
    { move: { at: "upperLidL", move: [0, -0.2, 0], radius: 0.6, region: "upperEyeL" } },
    { rig: { eyeL: [0, -24 * DEG] } },
  ],
  eyeLookInLeft: [{ rig: { eyeL: [-26 * DEG, 0] } }],
  eyeLookOutLeft: [{ rig: { eyeL: [26 * DEG, 0] } }],
  eyeLookUpLeft: [
    { move: { at: "upperLidL", move: [0, 0.15, 0], radius: 0.6, region: "upperEyeL" } },
    { rig: { eyeL: [0, 20 * DEG] } },
  ],
  eyeSquintLeft: [
    { move: { at: "lowerLidL", move: [0, 0.22, 0.05], radius: 0.55, region: "lowerEyeL" } },
    { move: { at: "upperLidL", move: [0, -0.1, 0], radius: 0.5, region: "upperEyeL" } },
    { move: { at: "underEyeL", move: [0, 0.12, 0], radius: 0.6 } },
  ],
  eyeWideLeft: [
    { move: { at: "upperLidL", move: [0, 0.3, 0.05], radius: 0.6, region: "upperEyeL" } },
    { move: { at: "lowerLidL", move: [0, -0.06, 0], radius: 0.4, region: "lowerEyeL" } },
  ],
  // ---- jaw --------------------------------------------------------------------------------
  jawForward: [{ jaw: { shift: [0, 0, 0.6] } }],
  jawLeft: [{ jaw: { shift: [0.75, 0, 0] } }],
  jawOpen: [{ jaw: { open: 24 * DEG } }],
  // ---- mouth --------------------------------------------------------------------------------
  mouthClose: [  // the lips meet whatever the jaw does: alone, they press together
    { move: { at: "upperLip", move: [0, -0.18, 0.05], radius: 0.45, region: "upperLip" } },
    { move: { at: "lowerLip", move: [0, 0.3, 0.08], radius: 0.5, region: "lowerLip" } },
  ],
  mouthFunnel: [
    { move: { at: "upperLip", move: [0, 0.3, 0.45], radius: 0.55, region: "upperLip" } },
    { move: { at: "lowerLip", move: [0, -0.4, 0.45], radius: 0.55, region: "lowerLip" } },
    { pull: { at: "mouthCorners", to: "mouthCentre", amount: 0.3, radius: 0.7 } },
  ],
  mouthPucker: [
    { pull: { at: "mouthCorners", to: "mouthCentre", amount: 0.42, radius: 0.8 } },
    { move: { at: "lips", move: [0, 0, 0.5], radius: 0.5 } },
  ],
  mouthLeft: [{ move: { at: "lips", move: [0.7, 0, 0], radius: 0.75 } }],
  mouthSmileLeft: [
    { move: { at: "mouthCornerL", move: [0.55, 0.85, -0.35], radius: 1.2 } },
    { move: { at: "cheekL", move: [0.08, 0.3, 0.12], radius: 1.1 } },
  ],
  mouthFrownLeft: [{ move: { at: "mouthCornerL", move: [0.05, -0.5, 0], radius: 1.0 } }],
  mouthDimpleLeft: [{ move: { at: "mouthCornerL", move: [0.3, 0, -0.4], radius: 0.8 } },
    { move: { at: "dimpleL", move: [0, 0, -0.25], radius: 0.5 } }],
  mouthStretchLeft: [{ move: { at: "mouthCornerL", move: [0.55, -0.3, -0.15], radius: 1.0 } }],
  mouthRollLower: [{ move: { at: "lowerLip", move: [0, 0.22, -0.35], radius: 0.4, region: "lowerLip" } }],
  mouthRollUpper: [{ move: { at: "upperLip", move: [0, -0.2, -0.3], radius: 0.4, region: "upperLip" } }],
  mouthShrugLower: [
    { move: { at: "lowerLip", move: [0, 0.25, 0.2], radius: 0.6, region: "lowerLip" } },
    { move: { at: "chin", move: [0, 0.25, 0.15], radius: 0.9 } },
  ],
  mouthShrugUpper: [{ move: { at: "upperLip", move: [0, 0.22, 0.22], radius: 0.6, region: "upperLip" } }],
  mouthPressLeft: [
    { move: { at: "lowerLipL", move: [0, 0.16, -0.12], radius: 0.5, region: "lowerLip" } },
    { move: { at: "mouthCornerL", move: [0.1, 0, -0.05], radius: 0.5 } },
  ],
  mouthLowerDownLeft: [{ move: { at: "lowerLipL", move: [0, -0.5, 0.05], radius: 0.55, region: "lowerLip" } }],
  mouthUpperUpLeft: [{ move: { at: "upperLipL", move: [0, 0.42, 0.05], radius: 0.55, region: "upperLip" } }],
  // ---- brows, cheeks, nose ----------------------------------------------------------------
  browDownLeft: [{ move: { at: "browL", move: [-0.12, -0.45, 0.05], radius: 0.8 } }],
  browInnerUp: [{ move: { at: "innerBrows", move: [0, 0.55, 0], radius: 0.75 } }],
  browOuterUpLeft: [{ move: { at: "browOuterL", move: [0, 0.55, 0], radius: 0.8 } }],
  cheekPuff: [
    { move: { at: "cheekL", move: [0.6, -0.1, 0.5], radius: 1.5 }, both: true },
    { move: { at: "lips", move: [0, 0, 0.12], radius: 0.5 } },
  ],
  cheekSquintLeft: [
    { move: { at: "cheekUpperL", move: [0, 0.3, 0.08], radius: 0.9 } },
    { move: { at: "lowerLidL", move: [0, 0.08, 0], radius: 0.35, region: "lowerEyeL" } },
  ],
  noseSneerLeft: [
    { move: { at: "noseSideL", move: [0, 0.28, 0.06], radius: 0.6 } },
    { move: { at: "alarL", move: [0.06, 0.32, 0], radius: 0.45 } },
  ],
  tongueOut: [
    { jaw: { open: 7 * DEG } },
    { move: { at: "lowerLip", move: [0, -0.15, 0.05], radius: 0.45, region: "lowerLip" } },
    { rig: { tongue: 1 } },
  ],
};

/** The *Right shapes are the *Left ones mirrored (see the header). */
export const MIRRORED = {
  eyeBlinkRight: "eyeBlinkLeft", eyeLookDownRight: "eyeLookDownLeft",
  eyeLookInRight: "eyeLookInLeft", eyeLookOutRight: "eyeLookOutLeft",
  eyeLookUpRight: "eyeLookUpLeft", eyeSquintRight: "eyeSquintLeft",
  eyeWideRight: "eyeWideLeft", jawRight: "jawLeft", mouthRight: "mouthLeft",
  mouthSmileRight: "mouthSmileLeft", mouthFrownRight: "mouthFrownLeft",
  mouthDimpleRight: "mouthDimpleLeft", mouthStretchRight: "mouthStretchLeft",
  mouthPressRight: "mouthPressLeft", mouthLowerDownRight: "mouthLowerDownLeft",
  mouthUpperUpRight: "mouthUpperUpLeft", browDownRight: "browDownLeft",
  browOuterUpRight: "browOuterUpLeft", cheekSquintRight: "cheekSquintLeft",
  noseSneerRight: "noseSneerLeft",
};

/** Where the jaw turns (cm, mesh frame): level with the ear canal, behind the cheek. */
export const JAW_PIVOT = [0, -0.4, -2.8];

/** Furhat-like neck limits (degrees): Furhat's basic neck parameters NECK_PAN, NECK_TILT and
    NECK_ROLL take -50..50 (docs/robot-head.md); a lab that knows its robot's range sets it here. */
export const NECK_LIMITS = { yaw: 50, pitch: 50, roll: 50 };
