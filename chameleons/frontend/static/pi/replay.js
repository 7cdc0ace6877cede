// The session page's replay (issue 33): the participant's video, the participant's and the
// robot's faces and the timeline, on the session's clock (seconds from its origin, as in the
// .eaf files). The cursor follows the video; clicking the plot or a time in the timeline
// seeks the video there. Data: /pi/sessions/<id>/replay.json.
const section = document.getElementById("replay");
const COLORS = { participant: "#1f77b4", robot: "#e07b00" };

const state = { data: null, span: [0, 1], part: null, cursor: 0, seeks: 0 };
window.replayPage = state;

function el(id) { return document.getElementById(id); }

function spanOf(data) {
  const times = data.events.map((e) => e.t);
  for (const v of data.videos) times.push(v.start_s, v.start_s + v.duration_s);
  for (const stream of Object.values(data.faces.streams)) {
    if (stream.t.length) times.push(stream.t[0], stream.t[stream.t.length - 1]);
  }
  if (!times.length) return [0, 1];
  const lo = Math.min(0, ...times), hi = Math.max(...times);
  return [lo, hi > lo ? hi : lo + 1];
}

// --- the plot ---------------------------------------------------------------------------
function draw() {
  const canvas = el("replay-curves");
  const ratio = window.devicePixelRatio || 1;
  const width = canvas.clientWidth, height = 260;
  if (canvas.width !== Math.round(width * ratio)) {
    canvas.width = Math.round(width * ratio);
    canvas.height = Math.round(height * ratio);
  }
  const g = canvas.getContext("2d");
  g.setTransform(ratio, 0, 0, ratio, 0, 0);
  g.clearRect(0, 0, width, height);
  const [lo, hi] = state.span;
  const x = (t) => ((t - lo) / (hi - lo)) * width;
  const names = state.data.faces.curves, lane = (height - 20) / names.length;
  g.font = "11px system-ui, sans-serif";
  for (const v of state.data.videos) {  // where there is video
    g.fillStyle = "rgba(0, 0, 0, .05)";
    g.fillRect(x(v.start_s), 0, Math.max(1, x(v.start_s + v.duration_s) - x(v.start_s)), height - 20);
  }
  g.strokeStyle = "rgba(0, 0, 0, .12)";
  for (const e of state.data.events) { g.beginPath(); g.moveTo(x(e.t), 0); g.lineTo(x(e.t), height - 20); g.stroke(); }
  names.forEach((name, i) => {
    const top = i * lane;
    g.fillStyle = "#555";
    g.fillText(name, 4, top + 12);
    for (const [stream, color] of Object.entries(COLORS)) {
      const s = state.data.faces.streams[stream];
      if (!s || !s[name]) continue;
      const values = s[name].filter((v) => v !== null);
      if (!values.length) continue;
      let min = Math.min(...values), max = Math.max(...values);
      if (max - min < 1e-6) { min -= 0.5; max += 0.5; }
      g.strokeStyle = color;
      g.beginPath();
      let pen = false;
      s.t.forEach((t, k) => {
        const v = s[name][k];
        if (v === null) { pen = false; return; }
        const y = top + lane - 2 - ((v - min) / (max - min)) * (lane - 16);
        if (pen) g.lineTo(x(t), y); else g.moveTo(x(t), y);
        pen = true;
      });
      g.stroke();
    }
  });
  g.fillStyle = "#555";
  g.fillText(`${(lo + 0).toFixed(0).replace(/^-0$/, "0")} s`, 2, height - 6);
  g.fillText(`${hi.toFixed(0)} s`, width - 40, height - 6);
  g.strokeStyle = "#d62728";
  g.lineWidth = 2;
  g.beginPath(); g.moveTo(x(state.cursor), 0); g.lineTo(x(state.cursor), height); g.stroke();
  g.lineWidth = 1;
}

// --- the cursor and the timeline -----------------------------------------------------------
function moveCursor(t) {
  state.cursor = t;
  el("replay-curves").dataset.cursor = t.toFixed(3);
  el("replay-clock").textContent = `${t.toFixed(1)} s`;
  let current = null;
  for (const e of state.data.events) if (e.t <= t) current = e;
  document.querySelectorAll("#timeline li.replay-now").forEach((li) => {
    li.classList.remove("replay-now"); li.removeAttribute("aria-current");
  });
  if (current) {
    const li = document.querySelector(`#timeline li[data-event-id="${current.id}"]`);
    if (li) { li.classList.add("replay-now"); li.setAttribute("aria-current", "time"); }
    el("replay-event").textContent = `· last event: ${current.kind}`;
  }
  draw();
}

function partAt(t) {
  return state.data.videos.find((v) => t >= v.start_s && t <= v.start_s + Math.max(v.duration_s, 0.001)) || null;
}

function load(part) {
  const video = el("replay-video");
  state.part = part;
  el("replay-part").value = String(part.id);
  if (video.dataset.videoId === String(part.id)) return Promise.resolve();
  video.dataset.videoId = String(part.id);
  video.src = part.url;
  return new Promise((resolve) => video.addEventListener("loadedmetadata", resolve, { once: true }));
}

async function seekTo(t) {
  state.seeks++;
  const part = partAt(t);
  if (part) {
    await load(part);
    el("replay-video").currentTime = Math.max(0, t - part.start_s);
  }
  moveCursor(t);
}

function follow() {
  const video = el("replay-video");
  if (state.part) moveCursor(state.part.start_s + video.currentTime);
  if (!video.paused) requestAnimationFrame(follow);
}

function setUpVideo() {
  const videos = state.data.videos;
  if (!videos.length) { el("replay-none").hidden = false; return; }
  el("replay-player").hidden = false;
  const select = el("replay-part");
  videos.forEach((v, i) => {
    const option = document.createElement("option");
    option.value = String(v.id);
    option.textContent = `Part ${i + 1}: from ${v.start_s.toFixed(1)} s${v.audio ? " (with sound)" : ""}`;
    select.appendChild(option);
  });
  select.hidden = el("replay-part-label").hidden = videos.length < 2;
  select.addEventListener("change", () => {
    const part = videos.find((v) => String(v.id) === select.value);
    if (part) seekTo(part.start_s);
  });
  const video = el("replay-video");
  for (const kind of ["timeupdate", "seeked"]) video.addEventListener(kind, follow);
  video.addEventListener("play", () => requestAnimationFrame(follow));
  load(videos[0]);
}

function setUpTimeline() {
  const byId = new Map(state.data.events.map((e) => [String(e.id), e]));
  document.querySelectorAll("#timeline li[data-event-id]").forEach((li) => {
    const event = byId.get(li.dataset.eventId);
    if (!event) return;
    li.dataset.t = String(event.t);
    const time = li.querySelector("time");
    if (time) time.addEventListener("click", () => seekTo(event.t));
  });
  el("replay-curves").addEventListener("click", (e) => {
    const box = e.currentTarget.getBoundingClientRect();
    const [lo, hi] = state.span;
    seekTo(lo + ((e.clientX - box.left) / box.width) * (hi - lo));
  });
}

async function init() {
  const response = await fetch(section.dataset.replay, { credentials: "same-origin" });
  if (!response.ok) return;
  state.data = await response.json();
  state.span = spanOf(state.data);
  if (state.data.faces.reason) {
    el("replay-faces-note").textContent = state.data.faces.reason;
    el("replay-faces-note").hidden = false;
  }
  setUpVideo();
  setUpTimeline();
  window.addEventListener("resize", draw);
  moveCursor(state.data.videos.length ? state.data.videos[0].start_s : state.span[0]);
  section.dataset.ready = "true";
}

if (section) init();
