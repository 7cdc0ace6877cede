/* Which face the robot display paints: the 2D cartoon (face_renderer.js) on the 2D canvas,
   or the 3D head (head3d/, three.js, loaded only when first chosen) on the WebGL canvas.

   The choice comes from the study's condition (set_face carries "renderer"), else the
   display link's ?renderer=2d|3d, else the booth's default (both resolved by the server
   into data-renderer). Without WebGL, or when the 3D head fails to load, the page keeps
   the 2D face and shows a short note saying why; telemetry reports what is painted. */
"use strict";

class RobotScreen {
  constructor(canvas2d, canvas3d, ctx, noteBox, warn) {
    Object.assign(this, { canvas2d, canvas3d, ctx, noteBox, warn });
    this.kind = "2d";
    this.wanted = "2d";
    this.source = canvas3d.dataset.rendererSource || "default";
    this.fallback = null;  // why a wanted 3D head is not shown
    this.missing = null;  // ARKit names a lab's own head lacks
    this.head = null;
    this.loading = null;
    this.ready = false;
    this.size = [1, 1, 1];
    this.own = [canvas3d.dataset.renderer || "2d", this.source];  // the link's or booth's
    this.choose(...this.own);
  }

  /** A set_face from the worker: the condition's renderer, or back to the page's own. */
  follow(renderer) {
    if (renderer) this.choose(renderer, "study");
    else this.choose(...this.own);
  }

  /** Switch to "2d" or "3d" (loading the 3D head the first time). */
  choose(kind, source) {
    if (kind !== "2d" && kind !== "3d") return;
    this.wanted = kind;
    this.source = source;
    if (kind === "2d") { this.show("2d"); this.ready = true; return; }
    if (this.head) { this.show("3d"); return; }
    if (this.loading || this.fallback) return;
    this.ready = false;
    const data = this.canvas3d.dataset;
    this.loading = import(data.module)
      .then((module) => {
        if (!module.webglAvailable()) throw new Error("this browser has no WebGL");
        return module.createHead(this.canvas3d, {
          names: FaceRenderer.NAMES, faces: RobotFaces, meshUrl: data.meshUrl,
          headUrl: data.headUrl || null,
        });
      })
      .then((head) => {
        this.head = head;
        this.missing = head.missing || null;
        if (this.missing && this.missing.length) {
          console.warn("[display] the lab's head lacks", this.missing.length, "ARKit shapes:", this.missing.join(", "));
        }
        this.head.resize(this.size[0], this.size[1]);
        if (this.wanted === "3d") this.show("3d");
        this.ready = true;
      })
      .catch((err) => {
        this.fallback = "3D head unavailable (" + (err && err.message ? err.message : err) + "): showing the 2D face";
        this.warn(this.fallback);
        this.noteBox.textContent = this.fallback;
        this.noteBox.hidden = false;
        this.show("2d");
        this.ready = true;
      })
      .finally(() => { this.loading = null; });
  }

  show(kind) {
    this.kind = kind;
    this.canvas2d.hidden = kind !== "2d";
    this.canvas3d.hidden = kind !== "3d";
  }

  resize(width, height, dpr) {
    this.size = [width, height, dpr];
    this.canvas2d.width = Math.round(width * dpr);
    this.canvas2d.height = Math.round(height * dpr);
    if (this.head) this.head.resize(width, height);
  }

  /** Paint one frame; returns the painted face's screen geometry. */
  draw(state, face) {
    if (this.kind === "3d" && this.head) return this.head.draw(state, face);
    return FaceRenderer.draw(this.ctx, this.canvas2d.width, this.canvas2d.height, state, RobotFaces[face]);
  }
}
