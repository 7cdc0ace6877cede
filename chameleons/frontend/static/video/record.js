// The booth's participant-video page: asks the server every POLL_MS what to record (and
// reads its clock from the answer), films with MediaRecorder in timeslices while a consented
// session runs, and uploads each chunk as it comes, in order, one at a time (a chunk that
// cannot go now waits and is sent again; nothing is skipped). See docs/instruments.md.
(function () {
  "use strict";
  const root = document.getElementById("recorder");
  const api = root.dataset.api;
  const key = decodeURIComponent(location.pathname.split("/").filter(Boolean).pop() || "");
  const timeslice = Number(root.dataset.timeslice) || 2000;
  const POLL_MS = 2000;
  const state = {
    offset: null, bestRtt: Infinity, session: null, audio: false, recorder: null,
    stream: null, video: null, startMs: null, seq: 0, queue: [], uploading: false,
    uploaded: 0, uploadedBytes: 0, refused: 0, stopping: null, gone: false, problem: null,
  };
  window.videoRecorder = state;

  function show(id, text, kind) {
    const node = document.getElementById(id);
    node.textContent = text;
    if (kind) node.dataset.state = kind;
  }

  function counters() {
    show("uploaded", String(state.uploaded));
    show("uploaded-kib", (state.uploadedBytes / 1024).toFixed(0));
    show("pending", String(state.queue.length));
    show("refused", String(state.refused));
  }

  function headers(extra) {
    return Object.assign({ "X-Booth-Key": key }, extra || {});
  }

  // --- what to do now, and the server's clock (NTP-like: the quickest round trip wins) ---
  async function poll() {
    if (state.gone) return;
    const sent = performance.now();
    let answer = null;
    try {
      const response = await fetch(api + "/state", { headers: headers(), cache: "no-store" });
      if (response.status === 404) {
        state.gone = true;
        show("video-state", "this link was replaced or retired: ask for the new one", "problem");
        await stopRecording();
        return;
      }
      answer = await response.json();
    } catch (err) {
      show("video-state", "server unreachable: trying again…", "problem");
    }
    if (answer) {
      const now = performance.now();
      const rtt = now - sent;
      if (rtt <= state.bestRtt * 1.5) {
        state.bestRtt = Math.min(state.bestRtt, rtt);
        state.offset = answer.server_ms - (sent + now) / 2;
        show("clock-state", `offset measured over a ${rtt.toFixed(0)} ms round trip`, "ok");
      }
      await follow(answer);
    }
    setTimeout(poll, POLL_MS);
  }

  async function follow(answer) {
    const recording = state.recorder && state.recorder.state !== "inactive";
    const same = recording && state.session === answer.session_id && state.audio === answer.audio;
    if (answer.record && !same) {
      if (recording) await stopRecording();
      await startRecording(answer);
    } else if (!answer.record && recording) {
      await stopRecording();
    }
    if (state.problem) show("video-state", state.problem, "problem");
    else if (answer.record) show("video-state", `recording session ${answer.session_id}` +
                                 (answer.audio ? " with sound" : " (no sound)"), "ok");
    else show("video-state", `not recording: ${answer.reason}`, "waiting");
  }

  function mimeType(audio) {
    const kinds = audio ? ["video/webm;codecs=vp8,opus", "video/webm;codecs=vp9,opus", "video/webm"]
      : ["video/webm;codecs=vp8", "video/webm;codecs=vp9", "video/webm"];
    return kinds.find((kind) => window.MediaRecorder && MediaRecorder.isTypeSupported(kind));
  }

  // --- recording ------------------------------------------------------------------------
  async function startRecording(answer) {
    state.problem = null;
    const mime = mimeType(answer.audio);
    if (!mime) {
      state.problem = "this browser cannot record WebM video: use Chromium, Chrome, Edge or Firefox";
      return;
    }
    try {
      state.stream = await navigator.mediaDevices.getUserMedia({
        video: { width: { ideal: 640 }, height: { ideal: 480 } }, audio: Boolean(answer.audio),
      });
    } catch (err) {
      state.problem = `camera unavailable (${err.name}): allow the camera and reload`;
      show("camera-state", state.problem, "problem");
      return;
    }
    show("camera-state", state.stream.getVideoTracks()[0].label || "on", "ok");
    const preview = document.getElementById("preview");
    preview.srcObject = state.stream;
    preview.play().catch(() => {});
    const recorder = new MediaRecorder(state.stream, { mimeType: mime, videoBitsPerSecond: 1000000 });
    Object.assign(state, { recorder, session: answer.session_id, audio: Boolean(answer.audio),
                           video: null, seq: 0, queue: [], startMs: null });
    const opened = new Promise((resolve) => { recorder.onstart = resolve; });
    recorder.ondataavailable = (event) => {
      if (!event.data || !event.data.size) return;
      state.queue.push({ video: recorder, seq: state.seq++, blob: event.data,
                         mediaMs: performance.now() - state.startMs });
      counters();
      pump();
    };
    recorder.start(timeslice);
    await opened;
    state.startMs = performance.now();
    recorder.announcing = announce(recorder, mime);
    await recorder.announcing;
  }

  async function announce(recorder, mime) {
    const body = { session_id: state.session, mime_type: mime, audio: state.audio,
                   clock: { start_ms: state.startMs, offset_ms: state.offset || 0,
                            rtt_ms: Number.isFinite(state.bestRtt) ? state.bestRtt : 0 } };
    try {
      const response = await fetch(api + "/videos", {
        method: "POST", headers: headers({ "Content-Type": "application/json" }), body: JSON.stringify(body),
      });
      const data = await response.json();
      if (!response.ok) {
        state.problem = `the server refused the video: ${data.detail}`;
        recorder.failed = true;
        await stopRecording();
        return;
      }
      recorder.videoId = data.video_id;
      if (state.recorder === recorder) state.video = data.video_id;
      pump();
    } catch (err) {
      state.problem = "server unreachable when the video started: trying again";
      recorder.failed = true;
      await stopRecording();
    }
  }

  async function stopRecording() {
    const recorder = state.recorder;
    if (!recorder) return;
    state.recorder = null;
    if (recorder.announcing && !recorder.failed) await recorder.announcing;
    if (recorder.state !== "inactive") {
      const stopped = new Promise((resolve) => { recorder.onstop = resolve; });
      recorder.stop();  // its last chunk comes before its stop event
      await stopped;
    }
    if (state.stream) state.stream.getTracks().forEach((track) => track.stop());
    state.stream = null;
    show("camera-state", "off", "waiting");
    if (!recorder.videoId) {  // the server never took this video: its chunks have nowhere to go
      state.queue = state.queue.filter((item) => item.video !== recorder);
      counters();
    }
    await drained(recorder);
    if (recorder.videoId) {
      await fetch(`${api}/videos/${recorder.videoId}/stop`, { method: "POST", headers: headers() })
        .catch(() => {});
    }
  }

  function drained(recorder) {
    return new Promise((resolve) => {
      const check = () => {
        const left = state.queue.some((item) => item.video === recorder);
        if (!left || !recorder.videoId) resolve(); else setTimeout(check, 200);
      };
      check();
    });
  }

  // --- uploading, in order, one at a time -------------------------------------------------
  async function pump() {
    if (state.uploading) return;
    state.uploading = true;
    try {
      while (state.queue.length && state.queue[0].video.videoId) {
        const item = state.queue[0];
        const url = `${api}/videos/${item.video.videoId}/chunks/${item.seq}?media_ms=${Math.max(0, item.mediaMs).toFixed(0)}`;
        let response = null;
        try {
          response = await fetch(url, { method: "POST", headers: headers({ "Content-Type": "video/webm" }),
                                        body: item.blob });
        } catch (err) {
          show("video-state", "upload failed: trying again…", "problem");
          await new Promise((resolve) => setTimeout(resolve, 1000));
          continue;
        }
        if (response.status >= 500 || response.status === 429) {
          await new Promise((resolve) => setTimeout(resolve, 1000));
          continue;
        }
        const data = await response.json().catch(() => ({}));
        if (response.ok) {
          state.uploaded++;
          state.uploadedBytes += item.blob.size;
        } else if (data.problem !== "duplicate") {  // a duplicate was stored before
          state.refused++;
          state.problem = `a chunk was refused: ${data.detail}`;
        }
        state.queue.shift();
        counters();
      }
    } finally {
      state.uploading = false;
    }
  }

  poll();
})();
