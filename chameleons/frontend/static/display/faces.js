/* The study's four robot characters. Each is a style the renderer draws from the same
   52 ARKit blendshapes; they differ in head shape, colours, eyes, brows, hair and extras.
   Units: the head's half-width is 1; y points up. */
"use strict";

window.RobotFaces = Object.freeze({
  "face-1": {
    name: "Ada",
    background: "#17202a",
    head: { rx: 0.95, ry: 1.22, n: 2.1, chin: 0.22 },
    skin: "#f1c7a1", skinShade: "#d9a57f", lips: "#c2474f", mouthInside: "#4a1820",
    eyes: { style: "almond", y: 0.18, spacing: 0.37, rw: 0.2, rh: 0.11, iris: "#3f7fbf",
            irisSize: 0.8, lashes: true, lid: "#e3b08d" },
    brows: { color: "#5a3722", width: 0.045, arch: 0.07, y: 0.43, inner: 0.14, outer: 0.55,
             filled: false },
    nose: { style: "button", size: 0.1 },
    hair: { style: "bob", color: "#6b3b22" },
    blush: 0.28, shirt: "#2f6f8f", extras: ["earrings"],
  },
  "face-2": {
    name: "Bram",
    background: "#1d1a16",
    head: { rx: 1.0, ry: 1.15, n: 3.2, chin: 0.08 },
    skin: "#8d5a3b", skinShade: "#6e4329", lips: "#6b3a2c", mouthInside: "#2a0f0c",
    eyes: { style: "round", y: 0.16, spacing: 0.38, rw: 0.17, rh: 0.13, iris: "#4b2a12",
            irisSize: 0.78, lashes: false, lid: "#7a4c30" },
    brows: { color: "#1b1410", width: 0.085, arch: 0.0, y: 0.42, inner: 0.13, outer: 0.56,
             filled: true },
    nose: { style: "wide", size: 0.14 },
    hair: { style: "crop", color: "#161210" },
    blush: 0.0, shirt: "#8a6d2f", extras: ["stubble"],
  },
  "face-3": {
    name: "Cleo",
    background: "#141a24",
    head: { rx: 0.86, ry: 1.24, n: 2.0, chin: 0.3 },
    skin: "#dfe3f1", skinShade: "#b9c0d8", lips: "#d0658f", mouthInside: "#3b1430",
    eyes: { style: "big", y: 0.2, spacing: 0.35, rw: 0.22, rh: 0.16, iris: "#2f9a62",
            irisSize: 0.85, lashes: true, lid: "#c8cde3" },
    brows: { color: "#7d4fa6", width: 0.03, arch: 0.1, y: 0.44, inner: 0.15, outer: 0.52,
             filled: false },
    nose: { style: "line", size: 0.1 },
    hair: { style: "bun", color: "#7d4fa6" },
    blush: 0.38, shirt: "#c9496a", extras: [],
  },
  "face-4": {
    name: "Dex",
    background: "#1a1d1a",
    head: { rx: 1.06, ry: 1.08, n: 2.4, chin: 0.12 },
    skin: "#e0b48a", skinShade: "#c3946b", lips: "#a45d4f", mouthInside: "#3a1712",
    eyes: { style: "small", y: 0.16, spacing: 0.4, rw: 0.15, rh: 0.09, iris: "#5b6b76",
            irisSize: 0.85, lashes: false, lid: "#cfa178" },
    brows: { color: "#9a9a9a", width: 0.07, arch: 0.03, y: 0.4, inner: 0.14, outer: 0.58,
             filled: true },
    nose: { style: "long", size: 0.14 },
    hair: { style: "fringe", color: "#a8a8a8" },
    blush: 0.12, shirt: "#3d5a40", extras: ["glasses", "moustache"],
  },
});
