/* Lip-sync curves: the project's CSV (a "time" column in seconds, then canonical ARKit
   blendshape columns), sampled by linear interpolation on the audio's clock. */
"use strict";

window.LipSync = (function () {
  /** Parse CSV text into {times: Float64Array, channels: [{index, values: Float32Array}]}. */
  function parse(text, index) {
    const lines = text.split(/\r?\n/).filter((l) => l.trim() !== "");
    if (lines.length < 2) throw new Error("lip-sync file has no rows");
    const header = lines[0].split(",").map((h) => h.trim());
    const timeCol = header.indexOf("time");
    if (timeCol < 0) throw new Error("lip-sync file has no time column");
    const cols = header.map((name, col) => ({ name, col, index: index[name] }))
      .filter((c) => c.col !== timeCol && c.index !== undefined);
    const n = lines.length - 1;
    const times = new Float64Array(n);
    const channels = cols.map((c) => ({ index: c.index, col: c.col, values: new Float32Array(n) }));
    for (let r = 0; r < n; r++) {
      const cells = lines[r + 1].split(",");
      times[r] = parseFloat(cells[timeCol]);
      for (const c of channels) c.values[r] = parseFloat(cells[c.col]) || 0;
    }
    return { times, channels, duration: times[n - 1] };
  }

  /** Write the curves' values at time t (seconds) into bs; returns false past the end. */
  function apply(curves, t, bs) {
    const times = curves.times, n = times.length;
    let lo = 0, hi = n - 1;
    if (t <= times[0]) hi = 0;
    else if (t >= times[n - 1]) lo = n - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (times[mid] <= t) lo = mid; else hi = mid;
    }
    const span = times[hi] - times[lo];
    const w = span > 0 ? (t - times[lo]) / span : 0;
    for (const c of curves.channels) {
      bs[c.index] = c.values[lo] + (c.values[hi] - c.values[lo]) * Math.min(1, Math.max(0, w));
    }
    return t <= curves.duration;
  }

  return Object.freeze({ parse, apply });
})();
