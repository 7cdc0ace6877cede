/* The robot display: WebSocket client, frame interpolation, audio with lip-sync, telemetry.
   Protocol: chameleons/backend/display/protocol.py. Shows nothing but the face; add
   ?debug=1 to the URL for an overlay with connection and timing figures. The face is the
   2D cartoon (face_renderer.js) or the 3D head (head3d/, see renderer.js), chosen by the
   study's condition, else ?renderer= on the link, else the booth's default. */
"use strict";

(function () {
  const canvas = document.getElementById("face");
  const ctx = canvas.getContext("2d", { alpha: false });
  const robotScreen = new RobotScreen(canvas, document.getElementById("face3d"), ctx,
    document.getElementById("renderer-note"), (text) => note(text));
  const debugBox = document.getElementById("debug");
  const soundHint = document.getElementById("sound-hint");
  const debug = new URLSearchParams(location.search).get("debug") === "1";
  const N = FaceRenderer.NAMES.length;
  const MOUTH_JAW = FaceRenderer.NAMES.map((n, i) => (/^(mouth|jaw)/.test(n) ? i : -1)).filter((i) => i >= 0);

  /** A jitter buffer: samples keep their sender's time ("t", ms), mapped onto this page's
      clock by the smallest transit seen, and are painted a little late (the delay covers
      the frame interval and the network's jitter) so motion is interpolated, never stepped,
      even when frames arrive in bunches. */
  class Track {
    constructor(size) {
      this.size = size;
      this.samples = [];
      this.offset = null;  // page time - sender time, for the quickest frame
      this.interval = 40;  // EWMA of sender intervals, ms
      this.jitter = 2;  // EWMA of lateness beyond the quickest frame, ms
    }
    push(arrival, sent, values) {
      const last = this.samples[this.samples.length - 1];
      const transit = arrival - sent;
      if (last && sent === last.sent) {  // e.g. a face frame carrying the tick's head pose
        last.v = Float32Array.from(values);
        return;
      }
      if (!last || sent < last.sent || Math.abs(transit - this.offset) > 1000) {
        this.samples = [];  // first frame, or the sender restarted: start over
        this.offset = transit;
      } else {
        const dt = sent - last.sent;
        this.interval += 0.1 * (Math.min(dt, 500) - this.interval);
        this.offset = Math.min(this.offset + 0.001 * dt, transit);  // follows clock drift
        this.jitter += 0.05 * (transit - this.offset - this.jitter);
      }
      this.samples.push({ t: arrival, sent, v: Float32Array.from(values), painted: false });
      if (this.samples.length > 64) this.samples.shift();
    }
    get delay() {
      return Math.min(200, Math.max(8, this.interval + 2 * this.jitter + 2));
    }
    /** Interpolate into out at page time now; returns the samples newly shown in full. */
    sample(now, out) {
      const s = this.samples;
      if (!s.length) return [];
      const t = now - this.delay - this.offset;  // in the sender's time
      let k = s.length - 1;
      while (k > 0 && s[k].sent > t) k--;
      const a = s[k], b = s[Math.min(k + 1, s.length - 1)];
      const w = b.sent > a.sent ? Math.min(1, Math.max(0, (t - a.sent) / (b.sent - a.sent))) : 1;
      for (let i = 0; i < this.size; i++) out[i] = a.v[i] + (b.v[i] - a.v[i]) * w;
      const shown = [];
      for (let j = 0; j <= k; j++) {
        if (!s[j].painted && s[j].sent <= t) { s[j].painted = true; shown.push(s[j]); }
      }
      return shown;
    }
    get lastArrival() {
      return this.samples.length ? this.samples[this.samples.length - 1].t : -Infinity;
    }
  }

  const state = { bs: new Float32Array(N), head: new Float32Array(3), eyes: new Float32Array(6) };
  const faceTrack = new Track(N), headTrack = new Track(3), eyeTrack = new Track(6);
  let face = canvas.dataset.initialFace;
  let geometry = null;
  let socket = null, connected = false, backoff = 500;
  const outbox = [];  // speech events wait here while disconnected
  const stats = { painted: 0, framesIn: 0, latencies: [], relay: [], fps: 0, inRate: 0,
                  frameMs: [], intervals: [], dropped: 0, refreshMs: 1000 / 60 };
  let clockOffset = null, bestRtt = Infinity, pingId = 0;
  let playback = null;

  function resize() {
    robotScreen.resize(window.innerWidth, window.innerHeight, window.devicePixelRatio || 1);
  }

  // ---- connection -------------------------------------------------------------------
  function connect() {
    const scheme = location.protocol === "https:" ? "wss:" : "ws:";
    socket = new WebSocket(scheme + "//" + location.host + canvas.dataset.wsPath);
    socket.onopen = () => {
      connected = true;
      backoff = 500;
      while (outbox.length) socket.send(outbox.shift());
      ping();
    };
    socket.onmessage = (event) => {
      try { handle(JSON.parse(event.data), performance.now()); } catch (err) { note("bad message: " + err); }
    };
    socket.onclose = () => {
      connected = false;
      const wait = backoff * (0.8 + 0.4 * Math.random());
      backoff = Math.min(backoff * 2, 5000);
      setTimeout(connect, wait);
    };
  }

  function send(message, important) {
    const text = JSON.stringify(message);
    if (connected && socket.readyState === WebSocket.OPEN) socket.send(text);
    else if (important && outbox.length < 50) outbox.push(text);
  }

  function ping() {
    if (connected) send({ type: "ping", id: ++pingId, t: performance.now() });
  }

  const handlers = {
    hello(m) {
      if (m.blendshapes && m.blendshapes.join() !== FaceRenderer.NAMES.join()) {
        note("the server's blendshape order differs from this page's");
      }
    },
    face(m, now) {
      faceTrack.push(now, m.t, m.bs);
      faceTrack.samples[faceTrack.samples.length - 1].ts = m.ts;
      if (m.head) headTrack.push(now, m.t, m.head);
      if (m.eyes) eyeTrack.push(now, m.t, m.eyes);
      stats.framesIn++;
    },
    head(m, now) {
      headTrack.push(now, m.t, m.head);
      headTrack.samples[headTrack.samples.length - 1].ts = m.ts;
      stats.framesIn++;
    },
    set_face(m) {
      if (RobotFaces[m.face]) face = m.face;
      robotScreen.follow(m.renderer);
    },
    play_audio(m, now) { play(m, now); },
    stop_audio() { if (playback) finish(playback, "stopped"); },
    pong(m, now) {
      const rtt = now - m.t;
      if (rtt <= bestRtt * 1.5) {  // keep the offsets measured over the quickest round trips
        bestRtt = Math.min(bestRtt, rtt);
        clockOffset = m.server_ts - (m.t + now) / 2;
      }
    },
  };

  function handle(message, now) {
    const handler = handlers[message.type];
    if (handler) handler(message, now); else note("unknown message " + message.type);
  }

  // ---- audio and lip-sync -----------------------------------------------------------
  // One audio element for every prompt: Safari lets a page play sound only from an element
  // a user gesture has started once (see unlockAudio), Chromium in a kiosk needs
  // --autoplay-policy=no-user-gesture-required or one click on the page.
  const audio = new Audio();
  audio.preload = "auto";
  const SILENCE = "data:audio/wav;base64,UklGRiQAAABXQVZFZm10IBAAAAABAAEAQB8AAEAfAAABAAgAZGF0YQAAAAA=";
  audio.addEventListener("playing", () => {
    const p = playback;
    if (!p || p.started || p.done) return;
    p.started = true;
    send({ type: "speech", event: "start", play_id: p.id, prompt_id: p.prompt,
           audio_delay_ms: performance.now() - p.received }, true);
  });
  audio.addEventListener("ended", () => { if (playback && playback.started) finish(playback, "ended"); });
  audio.addEventListener("error", () => { if (playback && audio.src === playback.url) finish(playback, "error"); });

  // Sound counts as unlocked once anything played; until then the page shows a small hint
  // (a browser without the autoplay flag needs one click or key press first).
  let audioUnlocked = false;

  function setUnlocked(unlocked) {
    audioUnlocked = unlocked;
    if (soundHint) soundHint.hidden = unlocked;
  }

  function unlockAudio() {
    if (audioUnlocked || playback) return;
    audio.src = SILENCE;
    audio.play().then(() => { if (!playback) audio.pause(); setUnlocked(true); }).catch((err) => {
      if (err && err.name === "NotAllowedError") setUnlocked(false);
    });
  }

  function play(m, now) {
    if (playback) finish(playback, "interrupted");
    const p = { id: m.play_id, prompt: m.prompt_id, url: new URL(m.url, location.href).href,
                curves: null, received: now, started: false, done: false, clock: null };
    playback = p;
    audio.src = p.url;
    const curves = m.lipsync_url
      ? fetch(m.lipsync_url).then((r) => (r.ok ? r.text() : Promise.reject(new Error(r.status))))
          .then((text) => LipSync.parse(text, FaceRenderer.INDEX))
          .catch((err) => { note("lip-sync unavailable: " + err); return null; })
      : Promise.resolve(null);
    curves.then((c) => {
      if (p.done) return undefined;
      p.curves = c;
      return audio.play().then(() => setUnlocked(true));
    }).catch((err) => {
      const blocked = Boolean(err && err.name === "NotAllowedError");
      if (blocked) setUnlocked(false);
      finish(p, blocked ? "autoplay_blocked" : "error");
    });
  }

  function finish(p, reason) {
    if (p.done) return;
    p.done = true;
    if (playback === p) {
      playback = null;
      audio.pause();
    }
    send({ type: "speech", event: "end", play_id: p.id, prompt_id: p.prompt, reason }, true);
  }

  /** The audio clock, extrapolated between the element's coarse currentTime updates. */
  function audioTime(p, now) {
    const t = audio.currentTime;
    if (!p.clock || p.clock.t !== t) p.clock = { t, at: now };
    return audio.paused ? t : p.clock.t + (now - p.clock.at) / 1000;
  }

  // ---- painting ---------------------------------------------------------------------
  function frame(now) {
    let shown = [];
    if (now - Math.max(faceTrack.lastArrival, headTrack.lastArrival) > 3000) {
      relax();
    } else {
      shown = faceTrack.sample(now, state.bs).concat(headTrack.sample(now, state.head));
      eyeTrack.sample(now, state.eyes);
    }
    if (playback && playback.started && playback.curves) {
      for (const i of MOUTH_JAW) state.bs[i] = 0;  // the curves own the mouth while speaking
      LipSync.apply(playback.curves, audioTime(playback, now), state.bs);
    }
    const started = performance.now();
    geometry = robotScreen.draw(state, face);
    const painted = performance.now();
    stats.painted++;
    stats.frameMs.push(painted - started);
    if (stats.lastFrame !== undefined) {  // a frame interval of 2+ refreshes dropped frames
      stats.intervals.push(now - stats.lastFrame);
      const refreshes = Math.round((now - stats.lastFrame) / stats.refreshMs);
      if (refreshes > 1) stats.dropped += refreshes - 1;
    }
    stats.lastFrame = now;
    for (const s of shown) {
      stats.latencies.push(painted - s.t);
      if (clockOffset !== null && s.ts) stats.relay.push(painted + clockOffset - s.ts);
    }
    requestAnimationFrame(frame);
  }

  /** Without frames for a while (worker or network gone), ease back to a neutral face. */
  function relax() {
    for (const v of [state.bs, state.head, state.eyes]) for (let i = 0; i < v.length; i++) v[i] *= 0.97;
  }

  // ---- telemetry --------------------------------------------------------------------
  function percentile(sorted, q) {
    return sorted.length ? sorted[Math.min(sorted.length - 1, Math.floor(q * sorted.length))] : null;
  }

  function report() {
    const lat = stats.latencies.sort((a, b) => a - b), relay = stats.relay.sort((a, b) => a - b);
    const cost = stats.frameMs.sort((a, b) => a - b), gaps = stats.intervals.sort((a, b) => a - b);
    const round = (v) => (v === null ? null : Math.round(v * 10) / 10);
    stats.fps = stats.painted;
    stats.inRate = stats.framesIn;
    const message = {
      type: "telemetry", fps: stats.painted, frames_in: stats.framesIn,
      paint_latency_ms: { p50: round(percentile(lat, 0.5)), p95: round(percentile(lat, 0.95)),
                          max: round(lat.length ? lat[lat.length - 1] : null) },
      interp_delay_ms: round(faceTrack.delay), relay_to_paint_ms: round(percentile(relay, 0.5)),
      speaking: Boolean(playback && playback.started), face,
      renderer: robotScreen.kind, frame_ms: { p50: round(percentile(cost, 0.5)), p95: round(percentile(cost, 0.95)) },
      dropped_frames: stats.dropped,
      interval_ms: { p50: round(percentile(gaps, 0.5)), p95: round(percentile(gaps, 0.95)) },
    };
    if (robotScreen.missing) message.head_missing = robotScreen.missing;
    if (robotScreen.fallback) message.renderer_note = robotScreen.fallback;
    stats.painted = 0; stats.framesIn = 0; stats.latencies = []; stats.relay = []; stats.frameMs = [];
    stats.intervals = [];
    stats.dropped = 0;
    stats.last = message;
    send(message, false);
    if (debug) {
      debugBox.hidden = false;
      debugBox.textContent = `booth ${canvas.dataset.booth} · ${connected ? "connected" : "reconnecting"}\n`
        + `face ${face} · ${message.fps} fps · in ${message.frames_in}/s\n`
        + `paint latency p50 ${message.paint_latency_ms.p50} p95 ${message.paint_latency_ms.p95} ms\n`
        + `relay->paint ${message.relay_to_paint_ms} ms · rtt ${round(bestRtt)} ms\n`
        + `renderer ${robotScreen.kind} (${robotScreen.source}) · frame ${message.frame_ms.p50}/${message.frame_ms.p95} ms`
        + ` every ${message.interval_ms.p50} ms`
        + ` · dropped ${message.dropped_frames}/s\n`
        + (robotScreen.missing && robotScreen.missing.length ? `head lacks ${robotScreen.missing.length}: ${robotScreen.missing.join(", ")}\n` : "")
        + (stats.note ? "note: " + stats.note : "");
    }
  }

  function note(text) {
    stats.note = text;
    if (debug) console.warn("[display]", text);
  }

  // A click or key unlocks sound in browsers without the autoplay flag; double-click
  // toggles full screen; the wake lock keeps the booth screen on.
  document.addEventListener("pointerdown", unlockAudio);
  document.addEventListener("keydown", unlockAudio);
  document.addEventListener("dblclick", () => {
    if (document.fullscreenElement) document.exitFullscreen(); else document.documentElement.requestFullscreen().catch(() => {});
  });
  if (navigator.wakeLock) navigator.wakeLock.request("screen").catch(() => {});

  window.robotDisplay = Object.freeze({
    state: () => ({ bs: Array.from(state.bs), head: Array.from(state.head), face }),
    geometry: () => geometry,
    connected: () => connected,
    telemetry: () => stats.last || null,
    speaking: () => Boolean(playback && playback.started && !playback.done),
    audioUnlocked: () => audioUnlocked,
    renderer: () => ({ kind: robotScreen.kind, source: robotScreen.source, wanted: robotScreen.wanted,
                       fallback: robotScreen.fallback, missing: robotScreen.missing, ready: robotScreen.ready }),
    head3d: () => robotScreen.head,  // test hook: stills(), screenPoints()
  });

  window.addEventListener("resize", resize);
  resize();
  connect();
  unlockAudio();  // succeeds at once where autoplay is allowed (kiosk flag), else the hint shows
  setInterval(report, 1000);
  setInterval(ping, 5000);
  requestAnimationFrame(frame);
})();
