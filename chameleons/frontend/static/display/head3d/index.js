/* Entry point of the 3D robot head, loaded on demand by display.js (dynamic import, so the
   2D face never downloads three.js). createHead() resolves to a painter with the 2D
   renderer's contract (draw(state, face) -> geometry) or rejects (no WebGL, a head file
   that does not load), and the page falls back to the 2D face. */

export async function createHead(canvas, options) {
  if (options.headUrl) {
    const { createCustomHead } = await import("./custom_head.js");
    return createCustomHead(canvas, options);
  }
  const { createCanonicalHead } = await import("./head_renderer.js");
  return createCanonicalHead(canvas, options);
}

/** Whether this browser can give the page a WebGL 2 context at all. */
export function webglAvailable() {
  try {
    return Boolean(document.createElement("canvas").getContext("webgl2"));
  } catch {
    return false;
  }
}
