// The booth's webcam capture page: camera -> MediaPipe face mesh (vendored, served by this
// server) -> landmarks over the WebSocket -> the server -> the booth's worker, which maps
// them to ARKit's blendshapes and the head pose (chameleons/worker/ingest/browser.py).
// Protocol: chameleons/backend/capture/relay.py. window.capturePage exposes the state for
// tests and the curious.
(function () {
  "use strict";
  const root = document.getElementById("capture");
  const $ = (id) => document.getElementById(id);
  const video = $("video");
  const overlay = $("points");
  const select = $("camera");
  const HEADER_BYTES = 40; // 5 little-endian float64: captured, sent, width, height, count
  const STATUS_MS = 1000;
  const HOLD_SECONDS = 4;
  const DARK_LEVEL = 40;

  const state = {
    socket: null, connected: false, worker: null, relayed: 0, sent: 0, noFace: 0,
    lastFace: null, problem: null, brightness: null, camera: "", modelReady: false,
    busy: false, calibration: null, calibrating: false, times: [], stream: null,
  };
  window.capturePage = state;

  function show(id, text, kind) {
    const el = $(id);
    el.textContent = text;
    el.dataset.state = kind;
  }

  // --- the WebSocket ------------------------------------------------------------------------
  function connect() {
    const scheme = location.protocol === "https:" ? "wss:" : "ws:";
    const socket = new WebSocket(scheme + "//" + location.host + root.dataset.wsPath);
    socket.binaryType = "arraybuffer";
    state.socket = socket;
    socket.addEventListener("open", () => {
      state.connected = true;
      sendStatus();
    });
    socket.addEventListener("message", (event) => {
      let message;
      try { message = JSON.parse(event.data); } catch (_) { return; }
      if (message.type === "relay") {
        state.worker = message.worker;
        state.relayed = message.frames;
        if (message.worker) show("worker-state", "receiving the face", "ok");
        else show("worker-state", "no worker of this booth is running: start it", "problem");
      } else if (message.type === "calibration") {
        calibrationAnswer(message);
      }
    });
    socket.addEventListener("close", (event) => {
      state.connected = false;
      state.socket = null;
      if (event.code === 1008) {
        show("worker-state", "this capture link no longer works: ask for the new one", "problem");
        return;
      }
      show("worker-state", "server connection lost: reconnecting…", "problem");
      setTimeout(connect, 1000);
    });
  }

  function send(data) {
    if (state.socket && state.connected && state.socket.bufferedAmount < 256 * 1024) {
      state.socket.send(data);
      return true;
    }
    return false;
  }

  function sendStatus() {
    send(JSON.stringify({ type: "status", brightness: state.brightness, problem: state.problem,
      camera: state.camera }));
  }

  // --- the camera ---------------------------------------------------------------------------
  function cameraProblem(error) {
    const name = error && error.name;
    if (name === "NotAllowedError" || name === "SecurityError")
      return "camera denied: allow this page to use the camera";
    if (name === "NotReadableError" || name === "AbortError")
      return "camera busy: another program is using it; close it and reload";
    if (name === "NotFoundError" || name === "OverconstrainedError")
      return "no camera found: plug one in and reload";
    return "camera error: " + (error && error.message ? error.message : String(error));
  }

  async function listCameras(current) {
    const devices = await navigator.mediaDevices.enumerateDevices();
    const cameras = devices.filter((d) => d.kind === "videoinput");
    select.replaceChildren(...cameras.map((d, i) => {
      const option = document.createElement("option");
      option.value = d.deviceId;
      option.textContent = d.label || "Camera " + (i + 1);
      option.selected = d.deviceId === current;
      return option;
    }));
  }

  async function startCamera(deviceId) {
    if (state.stream) state.stream.getTracks().forEach((t) => t.stop());
    const video640 = { width: { ideal: 640 }, height: { ideal: 480 } };
    const constraints = { audio: false,
      video: deviceId ? { ...video640, deviceId: { exact: deviceId } } : video640 };
    try {
      state.stream = await navigator.mediaDevices.getUserMedia(constraints);
    } catch (error) {
      if (deviceId && error && error.name === "OverconstrainedError") return startCamera();
      state.problem = cameraProblem(error);
      show("camera-state", state.problem, "problem");
      sendStatus();
      return;
    }
    const track = state.stream.getVideoTracks()[0];
    state.camera = track.label;
    state.problem = null;
    const id = track.getSettings().deviceId || deviceId;
    if (id) localStorage.setItem("chameleons.capture.camera", id);
    video.srcObject = state.stream;
    await video.play();
    show("camera-state", state.camera + " (" + video.videoWidth + "x" + video.videoHeight + ")",
      "ok");
    await listCameras(id);
    sendStatus();
    nextFrame();
  }

  select.addEventListener("change", () => startCamera(select.value));

  // --- the face mesh ------------------------------------------------------------------------
  const faceMesh = new FaceMesh({ locateFile: (file) => root.dataset.vendor + file });
  // Irises on (478 points: the eyes' look); the face geometry module stays off (it aborts
  // with refineLandmarks, mediapipe issue 3003): the worker fits the head pose itself.
  faceMesh.setOptions({ maxNumFaces: 1, refineLandmarks: true,
    minDetectionConfidence: 0.5, minTrackingConfidence: 0.5 });
  let pending = null;
  faceMesh.onResults(onResults);

  function nextFrame() {
    if (!state.stream) return;
    if (video.requestVideoFrameCallback) video.requestVideoFrameCallback(onFrame);
    else requestAnimationFrame(() => onFrame(performance.now(), {}));
  }

  async function onFrame(now, meta) {
    if (state.busy || !state.stream) { nextFrame(); return; }
    state.busy = true;
    // The camera's own capture time where the browser gives it, else the frame's arrival.
    pending = { captured: typeof meta.captureTime === "number" ? meta.captureTime : now };
    try {
      await faceMesh.send({ image: video });
      if (!state.modelReady) state.modelReady = true;
    } catch (error) {
      show("face-state", "face tracker failed: " + error, "problem");
    } finally {
      state.busy = false;
      nextFrame();
    }
  }

  function onResults(results) {
    const sent = performance.now();
    const captured = pending ? pending.captured : sent;
    const faces = results.multiFaceLandmarks || [];
    const points = faces[0];
    const width = video.videoWidth, height = video.videoHeight;
    if (!points) {
      state.noFace += 1;
      state.lastFace = null;
      show("face-state", "no face: look into the camera", "problem");
      send(JSON.stringify({ type: "no_face", captured: captured, sent: sent }));
      drawPoints(null);
      return;
    }
    const buffer = new ArrayBuffer(HEADER_BYTES + points.length * 12);
    const view = new DataView(buffer);
    [captured, sent, width, height, points.length].forEach((v, i) => view.setFloat64(i * 8, v, true));
    points.forEach((p, i) => {
      const at = HEADER_BYTES + i * 12;
      view.setFloat32(at, p.x, true);
      view.setFloat32(at + 4, p.y, true);
      view.setFloat32(at + 8, p.z, true);
    });
    if (send(buffer)) {
      state.sent += 1;
      state.times.push(sent);
      while (state.times.length && sent - state.times[0] > 2000) state.times.shift();
    }
    state.lastFace = { points: points.length, eyes: [points[33], points[263]] };
    show("face-state", "face found (" + points.length + " points)", "ok");
    drawPoints(points);
  }

  function drawPoints(points) {
    const ctx = overlay.getContext("2d");
    overlay.width = video.videoWidth || 640;
    overlay.height = video.videoHeight || 480;
    ctx.clearRect(0, 0, overlay.width, overlay.height);
    if (!points || !$("overlay").checked) return;
    ctx.fillStyle = "#39e075";
    for (const p of points) ctx.fillRect(p.x * overlay.width - 1, p.y * overlay.height - 1, 2, 2);
  }

  // --- light and status ---------------------------------------------------------------------
  const probe = document.createElement("canvas");
  probe.width = 32;
  probe.height = 24;
  function measureLight() {
    if (!state.stream || video.readyState < 2) return;
    const ctx = probe.getContext("2d", { willReadFrequently: true });
    ctx.drawImage(video, 0, 0, probe.width, probe.height);
    const data = ctx.getImageData(0, 0, probe.width, probe.height).data;
    let sum = 0;
    for (let i = 0; i < data.length; i += 4)
      sum += 0.299 * data[i] + 0.587 * data[i + 1] + 0.114 * data[i + 2];
    state.brightness = Math.round(sum / (data.length / 4));
    if (state.brightness < DARK_LEVEL && !state.problem)
      show("camera-state", "too dark: light the participant's face", "problem");
  }

  setInterval(() => {
    measureLight();
    sendStatus();
    const n = state.times.length;
    const fps = n > 1 ? (n - 1) * 1000 / (state.times[n - 1] - state.times[0]) : 0;
    $("sent").textContent = String(state.sent);
    $("fps").textContent = fps.toFixed(1);
  }, STATUS_MS);

  // --- the neutral face ---------------------------------------------------------------------
  const button = $("calibrate");
  button.addEventListener("click", () => {
    if (state.calibrating) return;
    state.calibrating = true;
    button.disabled = true;
    send(JSON.stringify({ type: "calibrate", action: "start" }));
  });

  function calibrationAnswer(message) {
    if (message.action === "start") {
      if (message.collecting !== true) return calibrationDone(message);
      let left = HOLD_SECONDS;
      $("countdown").textContent = String(left);
      $("calibrate-help").hidden = false;
      const timer = setInterval(() => {
        left -= 1;
        $("countdown").textContent = String(Math.max(left, 0));
        if (left <= 0) {
          clearInterval(timer);
          send(JSON.stringify({ type: "calibrate", action: "finish" }));
        }
      }, 1000);
      return;
    }
    calibrationDone(message);
  }

  function calibrationDone(message) {
    state.calibrating = false;
    state.calibration = message;
    button.disabled = false;
    $("calibrate-help").hidden = true;
    if (message.calibrated)
      show("calibration-state", "calibrated (" + message.calibration + ", " + message.frames +
        " frames)", "ok");
    else show("calibration-state", "not calibrated: " + (message.problem || "try again"),
      "problem");
  }

  // --- start --------------------------------------------------------------------------------
  connect();
  show("face-state", "loading the face tracker…", "waiting");
  faceMesh.initialize().then(() => {
    state.modelReady = true;
    button.disabled = false;
    show("face-state", "waiting for the camera…", "waiting");
    return startCamera(localStorage.getItem("chameleons.capture.camera") || undefined);
  }).catch((error) => show("face-state", "the face tracker did not load: " + error, "problem"));
})();
